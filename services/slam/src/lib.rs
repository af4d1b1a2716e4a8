//! The sketchslam mapping engine: the method of Akiba et al., "Indoor SLAM based on line
//! observation probability using a hand-drawn map", as pure functions over values.
//!
//! Pipeline for one scan of a `sketch` session:
//! 1. [`sketch`]: the uploaded drawing becomes stroke pixels and numbered lines (once);
//! 2. MCL on the sketch with a per-particle scale localizes the robot on the drawing;
//! 3. the line observation probability (eq. 4) picks the sketch lines really seen;
//! 4. RANSAC lines of the scan are matched to them and correct the heading (eq. 5);
//! 5. point-to-line ICP corrects the position (eq. 6);
//! 6. the scan is fused into the occupancy grid.
//!
//! Nothing here does I/O, spawns threads or reads clocks: random draws take an `Rng`.

pub mod correlative;
pub mod error;
pub mod grid;
pub mod grid_export;
pub mod icp;
pub mod line_match;
pub mod line_observation;
pub mod loop_closure;
pub mod mapper;
pub mod mcl;
pub mod pose_graph;
pub mod ransac;
pub mod recovery;
pub mod runtime;
pub mod sketch;
pub mod wall_directions;

pub use error::EngineError;
