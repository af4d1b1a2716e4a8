//! The sketchslam HTTP API.
