//! ROS 2 bags as a robot's stream: `simulator replay BAG.mcap` publishes a rosbag2 MCAP
//! recording (`sensor_msgs/msg/LaserScan` and `nav_msgs/msg/Odometry`, CDR-encoded as ROS 2
//! writes them) like a simulation, stamps from the messages' headers. No ROS installation:
//! the `mcap` crate reads the container (chunks compressed with zstd or lz4 too) and `cdr`
//! the messages ([`messages`]).
//!
//! The LiDAR's mounting pose comes from `/tf_static` when the bag has it: the chain of
//! transforms from the robot's frame (`--base-frame`, else the odometry's
//! `child_frame_id`, else `base_link`) to the scans' `frame_id`, flattened to x, y, yaw.
//! The scan stream has no field for it, so [`BagStream::lidar_mount`] is for the session
//! request (`lidar_mount`), which the replay prints.
//!
//! [`write_bag`] is the other way, for tests and for turning a simulation into a bag.

pub mod messages;
mod reader;
mod writer;

pub use reader::{mount_from_tf, read_bag};
pub use writer::write_bag;

use std::path::Path;

use sketchslam_types::{Pose2, SensorEvent};

use crate::error::SimError;

/// Where a bag keeps what the service needs.
#[derive(Debug, Clone, PartialEq)]
pub struct BagTopics {
    /// The `LaserScan` topic.
    pub scan: String,
    /// The `Odometry` topic.
    pub odom: String,
    /// The robot's frame; `None`: the odometry's `child_frame_id`, else `base_link`.
    pub base_frame: Option<String>,
}

impl Default for BagTopics {
    fn default() -> Self {
        BagTopics {
            scan: "/scan".into(),
            odom: "/odom".into(),
            base_frame: None,
        }
    }
}

/// The robot's stream read from a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct BagStream {
    /// Scans and odometry in stamp order, numbered from 0 per topic.
    pub events: Vec<SensorEvent>,
    /// Scans among them.
    pub scans: u64,
    /// The LiDAR's pose on the robot from `/tf_static`, when the bag has the chain.
    pub lidar_mount: Option<Pose2>,
    /// The scans' `frame_id`.
    pub laser_frame: Option<String>,
    /// Messages on the two topics that could not be used (a stamp before the epoch).
    pub skipped: usize,
}

/// The first bytes of every MCAP file.
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// The message types read and written, as their schemas name them.
const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
const ODOMETRY: &str = "nav_msgs/msg/Odometry";
const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";
const TF_STATIC: &str = "/tf_static";
/// Frames followed from the laser up to the robot before giving up (a cycle).
const MAX_TF_HOPS: usize = 32;

/// A [`SimError::Bag`] about `file`.
fn bag_error(file: &Path, message: impl Into<String>) -> SimError {
    SimError::Bag {
        file: file.to_path_buf(),
        message: message.into(),
    }
}
