//! The metric map: where every corrected scan ends up.
//!
//! Last stage of a scan's pipeline:
//! - [`grid`]: the growing log-odds occupancy grid;
//! - [`ros_export`]: the grid as ROS `map_server` files (`map.pgm` + `map.yaml`), PNG and
//!   messages, and the one rule that reads such a map back into occupied points.

pub mod grid;
pub mod ros_export;
