//! What a robot driver publishes: LiDAR scans and dead-reckoned odometry.
//!
//! Over iceoryx2 a scan is a `ScanHeader` user header over a `[f32]` slice of ranges that lives
//! in the shared-memory sample itself; `Odometry` is a fixed payload. Both are `#[repr(C)]`
//! and, with the `zero-copy` feature the transport turns on, `ZeroCopySend`: no pointers, no
//! heap. Inside a process the same data travels as the owned `Scan`, and a time-ordered stream
//! of both as `SensorEvent`.
//!
//! Conventions follow ROS `sensor_msgs/LaserScan`: beam `i` points at
//! `angle_min_rad + i·angle_increment_rad` in the robot frame (counter-clockwise from the
//! heading); a range that is not finite, below `range_min_m` or at/above `range_max_m` is
//! "no return".

use crate::geometry::Point2;
#[cfg(feature = "zero-copy")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// The fixed part of a LiDAR scan; the ranges follow as the sample's `[f32]` payload.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("sketchslam::ScanHeader")
)]
#[repr(C)]
pub struct ScanHeader {
    /// Sequence number of this scan for its robot, from 0, without gaps at the publisher.
    pub sequence: u64,
    /// Time of the scan, nanoseconds of the publisher's clock.
    pub stamp_ns: u64,
    /// Angle of the first beam in the robot frame, radians (counter-clockwise from heading).
    pub angle_min_rad: f32,
    /// Angle between consecutive beams, radians.
    pub angle_increment_rad: f32,
    /// Shortest valid range, meters.
    pub range_min_m: f32,
    /// Range cap, meters: a reading at or beyond it is no return.
    pub range_max_m: f32,
    /// Number of ranges in the payload slice.
    pub beam_count: u32,
}

/// The robot's dead-reckoned pose as a wheel-odometry driver reports it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(
    feature = "zero-copy",
    derive(ZeroCopySend),
    type_name("sketchslam::Odometry")
)]
#[repr(C)]
pub struct Odometry {
    /// Sequence number of this message for its robot, from 0.
    pub sequence: u64,
    /// Time of the reading, nanoseconds of the publisher's clock.
    pub stamp_ns: u64,
    /// Dead-reckoned x in the odometry frame, meters.
    pub x_m: f64,
    /// Dead-reckoned y in the odometry frame, meters.
    pub y_m: f64,
    /// Dead-reckoned heading in the odometry frame, radians.
    pub theta_rad: f64,
}

impl Odometry {
    /// The odometry reading as a pose.
    pub fn pose(&self) -> crate::Pose2 {
        crate::Pose2::new(self.x_m, self.y_m, self.theta_rad)
    }
}

impl ScanHeader {
    /// The bearings the scan covers, radians: one beam's increment per beam (a 360-beam
    /// scanner 1° apart covers the full turn, a 361-beam one 0.5° apart 180.5°). O(1).
    pub fn field_of_view_rad(&self) -> f64 {
        f64::from(self.angle_increment_rad).abs() * f64::from(self.beam_count)
    }
}

/// A scan owned in process memory: the header and its ranges in meters.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Scan {
    /// The fixed fields; `header.beam_count == ranges_m.len()`.
    pub header: ScanHeader,
    /// One range per beam, meters; non-finite means no return.
    pub ranges_m: Vec<f32>,
}

impl Scan {
    /// A scan of `ranges_m.len()` beams spread evenly over `fov_rad` centred on the
    /// heading (first beam at `−fov/2`, last at `+fov/2`), sequence and stamp 0.
    pub fn centred(fov_rad: f64, range_min_m: f32, range_max_m: f32, ranges_m: Vec<f32>) -> Scan {
        let n = ranges_m.len();
        Scan {
            header: ScanHeader {
                angle_min_rad: (-fov_rad / 2.0) as f32,
                angle_increment_rad: (fov_rad / (n.max(2) - 1) as f64) as f32,
                range_min_m,
                range_max_m,
                beam_count: n as u32,
                ..Default::default()
            },
            ranges_m,
        }
    }

    /// The scan's range cap in meters, or `fallback_m` when the header's is not a positive
    /// finite number (a driver that leaves it unset).
    pub fn range_max_m_or(&self, fallback_m: f64) -> f64 {
        let r = self.header.range_max_m as f64;
        if r.is_finite() && r > 0.0 {
            r
        } else {
            fallback_m
        }
    }

    /// Angle of beam `i` in the robot frame, radians.
    pub fn beam_angle_rad(&self, i: usize) -> f64 {
        self.header.angle_min_rad as f64 + i as f64 * self.header.angle_increment_rad as f64
    }

    /// True when beam `i`'s range is a real return (finite and inside the sensor's limits).
    pub fn is_return(&self, i: usize) -> bool {
        let r = self.ranges_m[i];
        r.is_finite() && r >= self.header.range_min_m && r < self.header.range_max_m && r > 0.0
    }

    /// The returns as points in the robot frame, meters, with their beam index.
    pub fn points(&self) -> impl Iterator<Item = (usize, Point2)> + '_ {
        (0..self.ranges_m.len())
            .filter(|&i| self.is_return(i))
            .map(move |i| {
                let a = self.beam_angle_rad(i);
                let r = self.ranges_m[i] as f64;
                (i, Point2::new(r * a.cos(), r * a.sin()))
            })
    }
}

/// One message of a robot's time-ordered sensor stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SensorEvent {
    /// A wheel-odometry reading.
    Odometry(Odometry),
    /// A LiDAR scan.
    Scan(Scan),
}

impl SensorEvent {
    /// The event's stamp, nanoseconds.
    pub fn stamp_ns(&self) -> u64 {
        match self {
            SensorEvent::Odometry(o) => o.stamp_ns,
            SensorEvent::Scan(s) => s.header.stamp_ns,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_skip_no_returns() {
        let scan = Scan {
            header: ScanHeader {
                angle_min_rad: -std::f32::consts::FRAC_PI_2,
                angle_increment_rad: std::f32::consts::FRAC_PI_2,
                range_min_m: 0.1,
                range_max_m: 10.0,
                beam_count: 5,
                ..Default::default()
            },
            ranges_m: vec![1.0, f32::NAN, 2.0, 10.0, f32::INFINITY],
        };
        let pts: Vec<_> = scan.points().collect();
        assert_eq!(pts.len(), 2);
        assert!((pts[0].1.y + 1.0).abs() < 1e-6 && pts[0].1.x.abs() < 1e-6);
        assert!((pts[1].1.y - 2.0).abs() < 1e-6 && pts[1].1.x.abs() < 1e-6);
    }

    #[test]
    fn the_field_of_view_is_one_increment_per_beam() {
        let header = |beams: u32, step_deg: f32| ScanHeader {
            angle_increment_rad: step_deg.to_radians(),
            beam_count: beams,
            ..Default::default()
        };
        let deg = |h: ScanHeader| h.field_of_view_rad().to_degrees();
        assert!((deg(header(360, 1.0)) - 360.0).abs() < 1e-3);
        assert!((deg(header(361, 0.5)) - 180.5).abs() < 1e-3);
        // A scan listed clockwise covers as much.
        assert!((deg(header(361, -0.5)) - 180.5).abs() < 1e-3);
    }
}
