//! The LiDAR model: `beams` rays over the field of view, cast in the truth world, with
//! Gaussian range noise.
//!
//! [`crate::simulation::Simulation`] calls [`Lidar::scan`] at every scan stamp with the
//! true pose and wraps the ranges with [`Lidar::header`] into a `Scan` message, laid out as
//! ROS `sensor_msgs/LaserScan`: beam `i` points at `angle_min + i·increment` from the
//! heading, `angle_min = −fov/2`, `increment = fov/(beams − 1)`. A beam whose wall is beyond
//! `max_range` reports `+inf` (no return). The beam angles are computed from the header's
//! `f32` fields, exactly as a subscriber will, so the casting and the reading agree.
//!
//! Cost: `beams` exact ray casts ([`World::cast`]), each O(range / resolution).

use crate::scenario::LidarConfig;
use crate::world::World;
use rand::Rng;
use rand_distr::StandardNormal;
use sketchslam_types::{Pose2, ScanHeader};

/// The shortest range the scanner reports, meters.
pub const RANGE_MIN_M: f64 = 0.05;

/// A LiDAR with a fixed beam layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Lidar {
    beams: usize,
    angle_min_rad: f32,
    angle_increment_rad: f32,
    max_range_m: f64,
    range_noise_m: f64,
    /// The scanner's pose in the robot frame.
    mount: Pose2,
}

impl Lidar {
    /// The scanner of `config` (expected validated: at least 2 beams).
    pub fn new(config: &LidarConfig) -> Lidar {
        let beams = config.beams.max(2);
        Lidar {
            beams,
            angle_min_rad: (-config.fov_rad / 2.0) as f32,
            angle_increment_rad: (config.fov_rad / (beams - 1) as f64) as f32,
            max_range_m: config.max_range_m,
            range_noise_m: config.range_noise_m,
            mount: config.mount,
        }
    }

    /// The scanner's pose when the robot is at `robot`: the rays of a scan start there.
    pub fn sensor_pose(&self, robot: Pose2) -> Pose2 {
        robot.compose(&self.mount)
    }

    /// Number of beams per scan.
    pub fn beams(&self) -> usize {
        self.beams
    }

    /// The range cap, meters.
    pub fn max_range_m(&self) -> f64 {
        self.max_range_m
    }

    /// Angle of beam `i` in the robot frame, radians (from the header's `f32` values).
    pub fn beam_angle_rad(&self, i: usize) -> f64 {
        self.angle_min_rad as f64 + i as f64 * self.angle_increment_rad as f64
    }

    /// The header of scan number `sequence` taken at `stamp_ns`.
    pub fn header(&self, sequence: u64, stamp_ns: u64) -> ScanHeader {
        ScanHeader {
            sequence,
            stamp_ns,
            angle_min_rad: self.angle_min_rad,
            angle_increment_rad: self.angle_increment_rad,
            range_min_m: RANGE_MIN_M as f32,
            range_max_m: self.max_range_m as f32,
            beam_count: self.beams as u32,
        }
    }

    /// One scan with the robot at the true `pose` (the rays from the scanner's pose on it,
    /// [`Lidar::sensor_pose`]): per beam the exact distance to the first wall plus
    /// `N(0, range_noise²)`, clamped at 0; `+inf` when the wall is beyond `max_range` or the
    /// noisy reading reaches it. Draws one standard normal per beam with a return.
    pub fn scan<R: Rng + ?Sized>(&self, world: &World, pose: Pose2, rng: &mut R) -> Vec<f32> {
        let pose = self.sensor_pose(pose);
        let origin = pose.position();
        (0..self.beams)
            .map(|i| {
                let angle_rad = pose.heading_rad + self.beam_angle_rad(i);
                match world.cast(origin, angle_rad, self.max_range_m) {
                    None => f32::INFINITY,
                    Some(range_m) => {
                        let z: f64 = rng.sample(StandardNormal);
                        let noisy_m = (range_m + self.range_noise_m * z).max(0.0);
                        if noisy_m >= self.max_range_m {
                            f32::INFINITY
                        } else {
                            noisy_m as f32
                        }
                    }
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn layout_and_no_return() {
        let config = LidarConfig {
            rate_hz: 10.0,
            fov_rad: std::f64::consts::PI,
            beams: 3,
            max_range_m: 3.0,
            range_noise_m: 0.0,
            mount: Pose2::IDENTITY,
        };
        let lidar = Lidar::new(&config);
        let h = lidar.header(4, 7);
        assert_eq!((h.sequence, h.stamp_ns, h.beam_count), (4, 7, 3));
        assert!((lidar.beam_angle_rad(2) - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
        // A 10x1 corridor of 1 m cells, open except the border: beams right, up, left.
        let world = World::from_walls(10, 1, 1.0, vec![false; 10]).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let r = lidar.scan(
            &world,
            Pose2::new(1.5, 0.5, std::f64::consts::FRAC_PI_2),
            &mut rng,
        );
        // Right-hand beam (−90° from +y) looks along +x: 8.5 m > 3 m cap → no return.
        assert_eq!(r[0], f32::INFINITY);
        assert!((r[1] - 0.5).abs() < 1e-6);
        assert!((r[2] - 1.5).abs() < 1e-6);
    }
}
