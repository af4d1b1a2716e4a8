//! `GET /v1/sessions/{id}/map`: the map as ROS 2's `nav_msgs/msg/OccupancyGrid`, field for
//! field, so that a bridge (rosbridge, foxglove, a few lines of `rclpy`) can publish the JSON
//! as it comes.
//!
//! ```text
//! std_msgs/Header header            stamp (builtin_interfaces/Time), frame_id
//! nav_msgs/MapMetaData info         map_load_time, resolution, width, height,
//!                                   origin (geometry_msgs/Pose: position, orientation)
//! int8[] data                       row-major from the origin's row: -1 unknown, 0..100
//! ```
//!
//! The planar origin `(x, y, θ)` is a pose with `z = 0` and the quaternion of a turn by θ
//! about +z: `(x, y, z, w) = (0, 0, sin θ/2, cos θ/2)`.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// ROS 2 `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ToSchema)]
pub struct RosTime {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds past `sec`, in [0, 10⁹).
    pub nanosec: u32,
}

impl RosTime {
    /// The time `stamp_ns` nanoseconds after the clock's zero (saturating at `i32::MAX` s).
    pub fn from_ns(stamp_ns: u64) -> Self {
        Self {
            sec: i32::try_from(stamp_ns / 1_000_000_000).unwrap_or(i32::MAX),
            nanosec: (stamp_ns % 1_000_000_000) as u32,
        }
    }
}

/// ROS `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RosHeader {
    /// The sensor time of the last scan fused into the map.
    pub stamp: RosTime,
    /// The frame the grid lies in: `map`.
    pub frame_id: String,
}

/// ROS `geometry_msgs/msg/Point`, meters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RosPoint {
    /// Meters.
    pub x: f64,
    /// Meters.
    pub y: f64,
    /// Meters (0 for a floor map).
    pub z: f64,
}

/// ROS `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RosQuaternion {
    /// `x`.
    pub x: f64,
    /// `y`.
    pub y: f64,
    /// `z`.
    pub z: f64,
    /// `w`.
    pub w: f64,
}

impl RosQuaternion {
    /// A turn by `yaw_rad` about +z: `(0, 0, sin(yaw/2), cos(yaw/2))`.
    pub fn from_yaw(yaw_rad: f64) -> Self {
        let (s, c) = (yaw_rad / 2.0).sin_cos();
        Self {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }

    /// The turn about +z of a quaternion with `x = y = 0`: `2 atan2(z, w)`, in (-π, π].
    pub fn yaw_rad(&self) -> f64 {
        let yaw = 2.0 * self.z.atan2(self.w);
        sketchslam_types::wrap_angle(yaw)
    }
}

/// ROS `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RosPose {
    /// Where.
    pub position: RosPoint,
    /// Which way.
    pub orientation: RosQuaternion,
}

impl RosPose {
    /// A pose in the plane: `(x, y)` meters at `z = 0`, turned by `yaw_rad` about +z.
    pub fn planar(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Self {
            position: RosPoint {
                x: x_m,
                y: y_m,
                z: 0.0,
            },
            orientation: RosQuaternion::from_yaw(yaw_rad),
        }
    }
}

/// ROS `nav_msgs/msg/MapMetaData`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct MapMetaData {
    /// When the map was built: the same time as the header's stamp.
    pub map_load_time: RosTime,
    /// Meters per cell.
    pub resolution: f64,
    /// Cells along the origin's x.
    pub width: u32,
    /// Cells along the origin's y.
    pub height: u32,
    /// The map-frame pose of cell (0, 0)'s outer corner.
    pub origin: RosPose,
}

/// `GET /v1/sessions/{id}/map`: ROS 2 `nav_msgs/msg/OccupancyGrid`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct OccupancyGridResponse {
    /// Stamp and frame.
    pub header: RosHeader,
    /// Size, resolution and origin.
    pub info: MapMetaData,
    /// Row-major from the row at `origin` (lowest y) upwards: -1 unknown, 0..100 occupancy.
    pub data: Vec<i8>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_2, PI};

    #[test]
    fn a_quarter_turn_is_the_half_angle_quaternion_about_z() {
        // Worked by hand: θ = π/2 → (0, 0, sin π/4, cos π/4) = (0, 0, 1/√2, 1/√2).
        let q = RosQuaternion::from_yaw(FRAC_PI_2);
        assert!(q.x == 0.0 && q.y == 0.0);
        assert!((q.z - FRAC_1_SQRT_2).abs() < 1e-15 && (q.w - FRAC_1_SQRT_2).abs() < 1e-15);
        // No turn is the identity; a half turn is (0, 0, 1, 0).
        assert_eq!(
            RosQuaternion::from_yaw(0.0),
            RosQuaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0
            }
        );
        let half = RosQuaternion::from_yaw(PI);
        assert!((half.z - 1.0).abs() < 1e-15 && half.w.abs() < 1e-15);
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            assert!(
                (RosQuaternion::from_yaw(yaw).yaw_rad() - yaw).abs() < 1e-12,
                "{yaw}"
            );
        }
    }

    #[test]
    fn a_stamp_splits_into_seconds_and_nanoseconds() {
        assert_eq!(
            RosTime::from_ns(12_345_678_901),
            RosTime {
                sec: 12,
                nanosec: 345_678_901
            }
        );
        assert_eq!(RosTime::from_ns(u64::MAX).sec, i32::MAX);
    }

    #[test]
    fn the_json_has_the_ros_field_names() {
        let grid = OccupancyGridResponse {
            header: RosHeader {
                stamp: RosTime::from_ns(1_500_000_000),
                frame_id: "map".into(),
            },
            info: MapMetaData {
                map_load_time: RosTime::from_ns(1_500_000_000),
                resolution: 0.05,
                width: 2,
                height: 1,
                origin: RosPose::planar(-1.0, 2.0, 0.0),
            },
            data: vec![-1, 100],
        };
        let json = serde_json::to_value(&grid).unwrap();
        assert_eq!(json["header"]["frame_id"], "map");
        assert_eq!(json["header"]["stamp"]["sec"], 1);
        assert_eq!(json["header"]["stamp"]["nanosec"], 500_000_000);
        assert_eq!(json["info"]["origin"]["position"]["x"], -1.0);
        assert_eq!(json["info"]["origin"]["orientation"]["w"], 1.0);
        assert_eq!(json["info"]["width"], 2);
        assert_eq!(json["data"], serde_json::json!([-1, 100]));
    }
}
