//! Point-to-line ICP (eq. 6): known shifts and rotations of synthetic scans come back.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_engine::mapping::grid::{GridConfig, OccupancyGrid};
use sketchslam_engine::scan_matching::icp::{Icp, IcpConfig, IcpMode};
use sketchslam_types::{Point2, Pose2, Scan};

mod common;
use common::{Seg, scan_270, seg};

/// A room with a box, a slanted wall and a pillar: no degenerate direction.
fn world() -> Vec<Seg> {
    vec![
        seg(-5.0, -4.0, 5.0, -4.0),
        seg(5.0, -4.0, 5.0, 4.0),
        seg(5.0, 4.0, -5.0, 4.0),
        seg(-5.0, 4.0, -5.0, -4.0),
        seg(1.0, 1.0, 2.0, 1.0),
        seg(2.0, 1.0, 2.0, 1.8),
        seg(2.0, 1.8, 1.0, 1.8),
        seg(1.0, 1.8, 1.0, 1.0),
        seg(-4.0, -2.0, -2.0, -3.5),
        seg(-2.0, 2.5, -1.7, 2.5),
        seg(-1.7, 2.5, -1.7, 2.8),
    ]
}

fn simulate(pose: &Pose2, noise_m: f64, rng: &mut ChaCha8Rng) -> Scan {
    scan_270(&world(), pose, noise_m, 30.0, rng)
}

fn points(scan: &Scan) -> Vec<Point2> {
    scan.points().map(|(_, p)| p).collect()
}

fn assert_pose(got: &Pose2, want: &Pose2, tol_m: f64, tol_deg: f64) {
    let e = want.between(got);
    assert!(
        e.x.hypot(e.y) < tol_m && e.heading_rad.abs().to_degrees() < tol_deg,
        "got {got:?}, want {want:?}"
    );
}

#[test]
fn translation_only_recovers_a_shift() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let a = Pose2::new(-0.5, -0.3, 0.4);
    let b = Pose2::new(-0.2, -0.55, 0.4);
    let reference = points(&simulate(&a, 0.01, &mut rng));
    let source = points(&simulate(&b, 0.01, &mut rng));
    let icp = Icp::new(&reference, IcpConfig::default());
    assert!(icp.points_with_normal() > reference.len() / 2);
    let want = a.between(&b);
    // Seeded with zero translation, the right heading.
    let r = icp.align(
        &source,
        Pose2::new(0.0, 0.0, want.heading_rad),
        IcpMode::TranslationOnly,
    );
    assert!(r.converged, "{r:?}");
    assert_eq!(r.pose.heading_rad, want.heading_rad);
    assert_pose(&r.pose, &want, 0.01, 0.2);
    assert!(r.rms_m < 0.03 && r.inliers > 500, "{r:?}");
}

#[test]
fn full_recovers_rotation_and_shift() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let a = Pose2::new(0.0, 0.0, 0.0);
    let b = a.compose(&Pose2::new(0.25, -0.15, 5f64.to_radians()));
    let reference = points(&simulate(&a, 0.01, &mut rng));
    let source = points(&simulate(&b, 0.01, &mut rng));
    let icp = Icp::new(&reference, IcpConfig::default());
    let r = icp.align(&source, Pose2::IDENTITY, IcpMode::Full);
    assert!(r.converged, "{r:?}");
    assert_pose(&r.pose, &a.between(&b), 0.01, 0.2);
    // Seeded by a noisy odometry guess instead.
    let guess = a.between(&b).compose(&Pose2::new(0.1, 0.08, -0.04));
    let r = icp.align(&source, guess, IcpMode::Full);
    assert_pose(&r.pose, &a.between(&b), 0.01, 0.2);
}

#[test]
fn scan_to_map_against_grid_reference() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut grid = OccupancyGrid::new(GridConfig::default());
    for p in [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(-2.0, 1.0, 2.0),
        Pose2::new(3.0, -2.0, -2.2),
    ] {
        grid.insert_scan(&p, &simulate(&p, 0.01, &mut rng));
    }
    let truth = Pose2::new(0.6, -0.9, 1.0);
    let source = points(&simulate(&truth, 0.01, &mut rng));
    let reference = grid.occupied_points_near(truth.position(), 30.0);
    let icp = Icp::new(&reference, IcpConfig::default());
    let guess = truth.compose(&Pose2::new(-0.15, 0.1, 0.03));
    let r = icp.align(&source, guess, IcpMode::Full);
    // Cell centres quantise the reference: a few centimetres.
    assert_pose(&r.pose, &truth, 0.03, 0.5);
    let r = icp.align(
        &source,
        Pose2::new(guess.x, guess.y, truth.heading_rad),
        IcpMode::TranslationOnly,
    );
    assert_pose(&r.pose, &truth, 0.03, 0.01);
}

#[test]
fn degenerate_inputs_return_the_initial_pose() {
    let init = Pose2::new(1.0, 2.0, 0.3);
    let empty = Icp::new(&[], IcpConfig::default());
    assert!(empty.is_empty());
    let r = empty.align(&[Point2::new(1.0, 1.0)], init, IcpMode::Full);
    assert_eq!(r.pose, init);
    assert!(!r.converged);
    let nan = Icp::new(&[Point2::new(f64::NAN, 0.0); 5], IcpConfig::default());
    assert!(nan.is_empty());
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let pts = points(&simulate(&Pose2::IDENTITY, 0.0, &mut rng));
    let icp = Icp::new(&pts, IcpConfig::default());
    let r = icp.align(&[], init, IcpMode::Full);
    assert_eq!(r.pose, init);
    let r = icp.align(&pts, Pose2::new(f64::NAN, 0.0, 0.0), IcpMode::Full);
    assert!(!r.converged);
    // Bad config values fall back to defaults instead of misbehaving.
    let icp = Icp::new(
        &pts,
        IcpConfig {
            gate_shrink: f64::NAN,
            huber_m: -1.0,
            ..IcpConfig::default()
        },
    );
    let r = icp.align(&pts, Pose2::new(0.05, 0.0, 0.0), IcpMode::Full);
    assert_pose(&r.pose, &Pose2::IDENTITY, 0.005, 0.1);
}
