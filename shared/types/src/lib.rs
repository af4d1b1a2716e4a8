//! Types shared by every sketchslam process: plane geometry (`Pose2`, `Point2`), the
//! iceoryx2 payloads a robot driver publishes (`ScanHeader` over a `[f32]` slice of
//! ranges, `Odometry`), their owned in-process twin (`Scan`), the service names, and the
//! `t,x,y,theta` CSV of trajectories and truths ([`trajectory_csv`]).
//!
//! Units are in the names: lengths in meters (`_m`), angles in radians (`_rad`), stamps
//! in nanoseconds of the publisher's clock (`stamp_ns`).

pub mod geometry;
pub mod messages;
pub mod names;
pub mod sketch_trajectory_csv;
pub mod trajectory_csv;

pub use geometry::{Point2, Pose2, wrap_angle, wrap_half_pi};
pub use messages::{Odometry, Scan, ScanHeader, SensorEvent};
pub use names::{DEFAULT_PREFIX, ServiceNames, Topic};
pub use trajectory_csv::StampedPose;
