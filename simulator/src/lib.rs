//! The sensor simulator: it owns the truth (world, robot motion, sensor and odometry
//! models) and publishes only what a real robot driver would, over iceoryx2.
//!
//! Pipeline: [`scenario`] loads a scenario folder (its TOML read by `toml_file`, shared
//! with datasets); [`world`] holds the truth grid and casts
//! rays; [`motion`] is the true trajectory; [`odometry`] and [`lidar`] are the sensor
//! models; [`simulation`] streams their messages in stamp order; [`truth`] writes the true
//! poses; [`render`] draws a scenario; [`generate`] writes whole scenario folders (floor,
//! route, sensors, hand-drawn sketches) from a seed. Real data: [`dataset`] loads a dataset folder,
//! [`carmen`] parses its CARMEN log and [`replay`] streams it like a simulation.

pub mod carmen;
pub mod dataset;
pub mod error;
pub mod generate;
pub mod lidar;
pub mod motion;
pub mod odometry;
pub mod publish;
pub mod render;
pub mod replay;
pub mod rosbag;
pub mod scenario;
pub mod simulation;
mod toml_file;
pub mod truth;
pub mod world;

pub use error::{GenerateError, SimError};
pub use scenario::{LidarConfig, OdometryConfig, RobotConfig, Scenario, SketchConfig, WorldConfig};
pub use simulation::{SimStep, Simulation};
pub use world::World;
