//! The ROS 2 messages a bag brings, as serde structs laid out field for field like their
//! `.msg` definitions, so that `cdr` (de)serializes them exactly as ROS 2 writes them
//! (XCDR1 little endian behind the 4-byte encapsulation header).
//!
//! `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` and `tf2_msgs/msg/TFMessage`, with
//! what they contain. The 36-element covariances are 6×6 nested arrays: the same bytes, and
//! serde's arrays stop at 32.

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds since the epoch of the clock; `None` before it.
    pub fn to_ns(&self) -> Option<u64> {
        let sec = u64::try_from(self.sec).ok()?;
        Some(sec * 1_000_000_000 + u64::from(self.nanosec))
    }

    /// The time `ns` nanoseconds after the epoch.
    pub fn from_ns(ns: u64) -> Time {
        Time {
            sec: (ns / 1_000_000_000) as i32,
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LaserScan {
    /// Stamp of the first beam, and the laser's frame.
    pub header: Header,
    /// Angle of the first beam, radians.
    pub angle_min: f32,
    /// Angle of the last beam, radians.
    pub angle_max: f32,
    /// Angle between beams, radians.
    pub angle_increment: f32,
    /// Time between beams, seconds.
    pub time_increment: f32,
    /// Time between scans, seconds.
    pub scan_time: f32,
    /// Shortest valid range, meters.
    pub range_min: f32,
    /// Longest valid range, meters.
    pub range_max: f32,
    /// Ranges, meters.
    pub ranges: Vec<f32>,
    /// Intensities (unused here).
    pub intensities: Vec<f32>,
}

/// `geometry_msgs/msg/Vector3` (and `Point`, the same fields).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion::from_yaw(0.0)
    }
}

impl Quaternion {
    /// The rotation by `yaw_rad` about z.
    pub fn from_yaw(yaw_rad: f64) -> Quaternion {
        let (s, c) = (0.5 * yaw_rad).sin_cos();
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }

    /// The heading about z of this rotation (its yaw in ZYX Euler angles), radians:
    /// `atan2(2(wz + xy), 1 − 2(y² + z²))`.
    pub fn yaw_rad(&self) -> f64 {
        let (x, y, z, w) = (self.x, self.y, self.z, self.w);
        (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position (a `Point`).
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6×6 covariance (x, y, z, roll, pitch, yaw).
    pub covariance: [[f64; 6]; 6],
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity.
    pub linear: Vector3,
    /// Angular velocity.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Row-major 6×6 covariance.
    pub covariance: [[f64; 6]; 6],
}

/// `nav_msgs/msg/Odometry`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the odometry frame.
    pub header: Header,
    /// The robot's frame (`base_link`).
    pub child_frame_id: String,
    /// The robot's pose in the odometry frame.
    pub pose: PoseWithCovariance,
    /// Its velocity.
    pub twist: TwistWithCovariance,
}

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`: `child_frame_id`'s pose in `header.frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage` (what `/tf_static` carries).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quarter_turn_about_z_has_a_yaw_of_pi_over_2() {
        let q = Quaternion::from_yaw(std::f64::consts::FRAC_PI_2);
        assert!((q.z - 0.5f64.sqrt()).abs() < 1e-12 && (q.w - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((q.yaw_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn a_header_is_laid_out_as_ros_2_writes_it() {
        // Encapsulation (CDR_LE), sec, nanosec, then the string: length with its NUL, bytes.
        let h = Header {
            stamp: Time { sec: 1, nanosec: 2 },
            frame_id: "laser".into(),
        };
        let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&h, cdr::Infinite).unwrap();
        assert_eq!(
            bytes,
            [
                0, 1, 0, 0, //
                1, 0, 0, 0, 2, 0, 0, 0, //
                6, 0, 0, 0, b'l', b'a', b's', b'e', b'r', 0
            ]
        );
        assert_eq!(cdr::deserialize::<Header>(&bytes).unwrap(), h);
    }
}
