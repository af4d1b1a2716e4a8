//! The odometry error over many seeds matches the configured noise and bias:
//! after D meters (radians) the error is N(bias·D, noise²·D), whatever the step size.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_simulator::OdometryConfig;
use sketchslam_simulator::odometry::OdometryModel;
use sketchslam_types::{Pose2, wrap_angle};
use std::f64::consts::PI;

const SEEDS: u64 = 200;

fn config() -> OdometryConfig {
    OdometryConfig {
        rate_hz: 50.0,
        trans_noise: 0.03,
        rot_noise: 0.02,
        trans_bias: 0.02,
        rot_bias: 0.01,
    }
}

fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// Checks the sample mean within 3 standard errors and the sample sd within 15 %
/// (the sd of a 200-sample sd estimate is about 5 %).
fn check(errors: &[f64], bias_total: f64, sd_total: f64, what: &str) {
    let (mean, sd) = mean_sd(errors);
    let se = sd_total / (errors.len() as f64).sqrt();
    assert!(
        (mean - bias_total).abs() < 3.0 * se,
        "{what}: mean error {mean}, expected {bias_total} ± {}",
        3.0 * se
    );
    assert!(
        (sd / sd_total - 1.0).abs() < 0.15,
        "{what}: sd {sd}, expected {sd_total}"
    );
}

/// Dead-reckoned pose after following `truth` poses, seeded with `seed`.
fn drive(seed: u64, truth: &[Pose2]) -> Pose2 {
    let mut m = OdometryModel::new(&config(), ChaCha8Rng::seed_from_u64(seed));
    for w in truth.windows(2) {
        m.step(w[0], w[1]);
    }
    m.pose()
}

#[test]
fn straight_twenty_meters() {
    let d_m: f64 = 20.0;
    for step_m in [0.016, 0.16] {
        let n = (d_m / step_m).round() as usize;
        let truth: Vec<Pose2> = (0..=n)
            .map(|k| Pose2::new(k as f64 * d_m / n as f64, 0.0, 0.0))
            .collect();
        let errors: Vec<f64> = (0..SEEDS)
            .map(|seed| {
                let p = drive(seed, &truth);
                // A straight drive has no rotation, so no heading or lateral error.
                assert_eq!((p.y, p.heading_rad), (0.0, 0.0));
                p.x - d_m
            })
            .collect();
        let c = config();
        check(
            &errors,
            c.trans_bias * d_m,
            c.trans_noise * d_m.sqrt(),
            &format!("20 m in steps of {step_m} m"),
        );
    }
}

#[test]
fn turning_two_full_turns() {
    let angle_rad = 4.0 * PI;
    for n in [800usize, 80] {
        let truth: Vec<Pose2> = (0..=n)
            .map(|k| Pose2::new(0.0, 0.0, k as f64 * angle_rad / n as f64))
            .collect();
        let errors: Vec<f64> = (0..SEEDS)
            .map(|seed| {
                let p = drive(1000 + seed, &truth);
                assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12);
                // The truth ends where it started: heading 0.
                wrap_angle(p.heading_rad)
            })
            .collect();
        let c = config();
        check(
            &errors,
            c.rot_bias * angle_rad,
            c.rot_noise * angle_rad.sqrt(),
            &format!("4π in {n} steps"),
        );
    }
}
