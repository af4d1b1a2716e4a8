//! The keyframe ICP's hold judged over a stretch (`MapperConfig::icp_hold_over_stretch`,
//! off by default): along a corridor's axis, which a handful of door-jamb returns barely
//! measure, ICP's pose is kept within k σ of the odometry dead-reckoned since the last scan
//! ICP placed in every direction, σ the odometry model's error over that stretch. Hand-made
//! corridor, exact ray cast, seeded noise.
//!
//! The two cases are the hold's purpose and its price stated as tests: a slide the wheels
//! cannot have made (the robot pushed along the corridor while they stand) is cut to the
//! window, and a correction the wheels' error allows (a 10 % long odometry over 2 m) stands.

mod common;

use common::{scan_270, seg};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_engine::mapper::{Mapper, MapperConfig, Method};
use sketchslam_types::{Odometry, Pose2};

/// A corridor 2 m wide along x, far longer than the scanner's 30 m, with one door recess
/// 1 m wide and 0.1 m deep in its north wall at x = 1…2 m: its two jambs are the only
/// returns facing the axis (a few, below the 20 that measure a direction).
fn corridor_with_a_recess() -> Vec<common::Seg> {
    vec![
        seg(-50.0, 0.0, 50.0, 0.0),
        seg(-50.0, 2.0, 1.0, 2.0),
        seg(1.0, 2.0, 1.0, 2.1),
        seg(1.0, 2.1, 2.0, 2.1),
        seg(2.0, 2.1, 2.0, 2.0),
        seg(2.0, 2.0, 50.0, 2.0),
    ]
}

/// Six scans standing at (0, 1), then `steps` scans along x, the k-th from `truth_x_m(k)`
/// while the odometry reports `odom_x_m(k)`; the last scan's map x (the map frame is the
/// start's).
fn last_x(
    config: MapperConfig,
    steps: u64,
    truth_x_m: impl Fn(u64) -> f64,
    odom_x_m: impl Fn(u64) -> f64,
) -> f64 {
    let walls = corridor_with_a_recess();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut mapper = Mapper::new(Method::Graph, None, config).unwrap();
    let mut publish = |k: u64, truth_m: f64, odom_m: f64| {
        mapper.on_odometry(&Odometry {
            sequence: k,
            stamp_ns: k * 100_000_000,
            x_m: odom_m,
            y_m: 0.0,
            theta_rad: 0.0,
        });
        let mut scan = scan_270(&walls, &Pose2::new(truth_m, 1.0, 0.0), 0.01, 30.0, &mut rng);
        scan.header.stamp_ns = k * 100_000_000;
        mapper.on_scan(&scan);
    };
    for k in 0..6 {
        publish(k, 0.0, 0.0);
    }
    for k in 1..=steps {
        publish(5 + k, truth_x_m(k), odom_x_m(k));
    }
    mapper.pose().map.x
}

/// Loop closure off (the front end alone), the hold at 20 returns and `k` sigmas over the
/// stretch when `k` is given.
fn config(k: Option<f64>) -> MapperConfig {
    MapperConfig {
        loop_closure: None,
        icp_min_constraining_points: k.map(|_| 20.0),
        icp_hold_beyond_sigmas: k,
        icp_hold_over_stretch: k.is_some(),
        ..MapperConfig::default()
    }
}

#[test]
fn a_slide_the_wheels_cannot_have_made_is_cut_to_their_error() {
    // Pushed 3 cm per scan along the corridor, 0.3 m in all, while the wheels stand: the
    // jambs' few returns drag ICP along; over a stretch of no travel the odometry's error
    // is nil, and the pose stays where the wheels say.
    let pushed = |k: u64| 0.03 * k as f64;
    let open = last_x(config(None), 10, pushed, |_| 0.0);
    let held = last_x(config(Some(3.0)), 10, pushed, |_| 0.0);
    assert!(open > 0.15, "ICP alone follows the jambs: {open}");
    assert!(held.abs() < 0.01, "held {held}");
}

#[test]
fn a_correction_within_the_wheels_error_over_the_stretch_stands() {
    // Driven 0.1 m per scan, 1 m in all, the wheels reporting 10 % more: over 1 m of
    // stretch the window is 3 · 0.1 · 1 m = 0.3 m, so ICP's 0.1 m correction stands as
    // it does without the hold.
    let driven = |k: u64| 0.1 * k as f64;
    let long = |k: u64| 0.11 * k as f64;
    let open = last_x(config(None), 10, driven, long);
    let held = last_x(config(Some(3.0)), 10, driven, long);
    assert!((open - 1.0).abs() < 0.03, "ICP alone: {open}");
    assert!((held - open).abs() < 0.005, "held {held} against {open}");
}
