//! Evaluation and multi-process test support for sketchslam.
