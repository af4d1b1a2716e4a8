//! The generated scenario's sensors: a good LiDAR and odometry (like `paper-env1`) or a
//! cheap robot's (like `school`), varied by seed within the range of real scanners, so the
//! engine is exercised on every kind of sensor without retuning.
//!
//! Values are rounded so that `scenario.toml` reads like a hand-written one.

use super::LidarGrade;
use crate::scenario::{LidarConfig, OdometryConfig};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Pose2;

/// `v` rounded to `digits` decimals.
fn round(v: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (v * k).round() / k
}

/// A value `nominal · (1 ± up to 50 %)`, sign kept.
fn vary(nominal: f64, rng: &mut ChaCha8Rng) -> f64 {
    nominal * rng.random_range(0.5..1.5)
}

/// The LiDAR and odometry models for `grade`.
///
/// - `good`: a 270° scanner of 1 081 beams at 20 or 40 Hz seeing 30–50 m (SICK TiM/LMS,
///   Hokuyo UST class), good odometry varied ±50 %;
/// - `cheap`: a 180°, 240°, 270° or 360° scanner of 0.5–1.5° steps at 5–15 Hz seeing 5.6–12 m
///   (Hokuyo URG, RPLIDAR class), worn odometry.
pub fn pick(grade: LidarGrade, rng: &mut ChaCha8Rng) -> (LidarConfig, OdometryConfig) {
    let sign = |rng: &mut ChaCha8Rng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    match grade {
        LidarGrade::Good => (
            LidarConfig {
                rate_hz: [20.0, 40.0][rng.random_range(0..2)],
                fov_rad: 270f64.to_radians(),
                beams: 1081,
                max_range_m: round(rng.random_range(30.0..50.0), 0),
                range_noise_m: 0.02,
                mount: Pose2::IDENTITY,
            },
            OdometryConfig {
                rate_hz: 50.0,
                trans_noise: round(vary(0.03, rng), 3),
                rot_noise: round(vary(0.02, rng), 3),
                trans_bias: round(sign(rng) * vary(0.02, rng), 3),
                rot_bias: round(sign(rng) * vary(0.01, rng), 3),
            },
        ),
        LidarGrade::Cheap => {
            let fov_deg: f64 = [180.0, 240.0, 270.0, 360.0][rng.random_range(0..4)];
            let step_deg = [0.5, 1.0, 1.5][rng.random_range(0..3)];
            // A closed circle has no beam at 360°; an open fan has both ends.
            let beams = if fov_deg == 360.0 {
                (fov_deg / step_deg) as usize
            } else {
                (fov_deg / step_deg) as usize + 1
            };
            let max_range_m = if rng.random_bool(0.25) {
                5.6
            } else {
                round(rng.random_range(8.0..12.0), 0)
            };
            (
                LidarConfig {
                    rate_hz: [5.0, 8.0, 10.0, 15.0][rng.random_range(0..4)],
                    fov_rad: fov_deg.to_radians(),
                    beams,
                    max_range_m,
                    range_noise_m: 0.03,
                    mount: Pose2::IDENTITY,
                },
                OdometryConfig {
                    rate_hz: 50.0,
                    trans_noise: 0.05,
                    rot_noise: 0.05,
                    trans_bias: round(sign(rng) * vary(0.03, rng), 3),
                    rot_bias: round(sign(rng) * vary(0.02, rng), 3),
                },
            )
        }
    }
}
