//! The sketchslam mapping engine: the method of Akiba et al., "Indoor SLAM based on line
//! observation probability using a hand-drawn map", as pure functions over values.
//!
//! One folder per stage of the pipeline (see `docs/architecture.md` for the per-scan flow
//! and the paper's equations mapped to functions):
//! - [`sketch`]: the uploaded drawing becomes stroke pixels and numbered lines (once, at
//!   upload), and a distance field rays are cast on;
//! - [`localization`]: MCL on the drawing with a per-particle scale (eq. 1–3), its failure
//!   detection and recovery (section 3.2), the line observation probability (eq. 4);
//! - [`lines`]: RANSAC walls of a scan, their matching to the drawing's lines and the heading
//!   correction (eq. 5), the drawing's dominant wall directions;
//! - [`scan_matching`]: point-to-line ICP (eq. 6) and correlative scan matching;
//! - [`mapping`]: the occupancy grid and its ROS `map_server` export;
//! - [`back_end`]: keyframes, loop closure and the SE(2) pose graph;
//! - [`registration`]: the warp from the map onto the drawing, fitted to the map's walls;
//! - [`mapper`]: one session's pipeline, the front end per scan and the back end per
//!   keyframe, and the `odometry` / `icp` baselines.
//!
//! Nothing here does I/O, spawns threads or reads clocks: random draws take an `Rng`, and
//! the crate's `Cargo.toml` holds no async runtime, transport, logging or CLI dependency.

pub mod back_end;
pub mod error;
mod heap;
pub mod lines;
pub mod localization;
pub mod mapper;
pub mod mapping;
pub mod registration;
pub mod scan_matching;
pub mod sketch;

pub use error::EngineError;
