//! The generated scenario's sensors: a good LiDAR and odometry (like `paper-env1`) or a
//! cheap robot's (like `school`), varied a little by seed within a physical range.
//!
//! Values are rounded so that `scenario.toml` reads like a hand-written one.

use super::LidarGrade;
use crate::scenario::{LidarConfig, OdometryConfig};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

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
pub fn pick(grade: LidarGrade, rng: &mut ChaCha8Rng) -> (LidarConfig, OdometryConfig) {
    let sign = |rng: &mut ChaCha8Rng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    match grade {
        LidarGrade::Good => (
            LidarConfig {
                rate_hz: 20.0,
                fov_rad: 270f64.to_radians(),
                beams: 1081,
                max_range_m: round(rng.random_range(30.0..50.0), 0),
                range_noise_m: 0.02,
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
            let beams = [180, 240, 270, 360][rng.random_range(0..4)];
            (
                LidarConfig {
                    rate_hz: 10.0,
                    fov_rad: 360f64.to_radians(),
                    beams,
                    max_range_m: round(rng.random_range(8.0..12.0), 0),
                    range_noise_m: 0.03,
                },
                OdometryConfig {
                    rate_hz: 50.0,
                    trans_noise: 0.05,
                    rot_noise: 0.05,
                    trans_bias: 0.03,
                    rot_bias: 0.02,
                },
            )
        }
    }
}
