//! ICP knows what it does not know: in a featureless 60 m corridor the normal matrix is
//! nearly singular along the axis, that axis is reported, and the pose keeps the odometry's
//! prediction along it instead of ICP's slide; in a room every direction is measured.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_engine::scan_matching::correlative::voxel_filter;
use sketchslam_engine::scan_matching::icp::{Icp, IcpConfig, IcpMode, IcpResult};
use sketchslam_engine::scan_matching::motion_prior::{
    DEFAULT_MIN_POINTS, Held, hold_unmeasured_directions,
};
use sketchslam_types::{Point2, Pose2};

mod common;
use common::{Seg, scan_270, seg};

/// A 270°, 1 081-beam scan with 2 cm noise and a range cap, robot frame points.
fn scan_points(walls: &[Seg], pose: &Pose2, max_range_m: f64, rng: &mut ChaCha8Rng) -> Vec<Point2> {
    scan_270(walls, pose, 0.02, max_range_m, rng)
        .points()
        .map(|(_, p)| p)
        .collect()
}

/// A 60 m corridor 2.4 m wide along x, closed at both ends.
fn corridor() -> Vec<Seg> {
    vec![
        seg(0.0, 0.0, 60.0, 0.0),
        seg(0.0, 2.4, 60.0, 2.4),
        seg(0.0, 0.0, 0.0, 2.4),
        seg(60.0, 0.0, 60.0, 2.4),
    ]
}

/// A 10 × 8 m room with a box and a slanted wall: every direction is measured.
fn room() -> Vec<Seg> {
    vec![
        seg(25.0, -3.0, 35.0, -3.0),
        seg(35.0, -3.0, 35.0, 5.0),
        seg(35.0, 5.0, 25.0, 5.0),
        seg(25.0, 5.0, 25.0, -3.0),
        seg(31.0, 2.0, 32.0, 2.0),
        seg(32.0, 2.0, 32.0, 2.8),
        seg(32.0, 2.8, 31.0, 2.8),
        seg(31.0, 2.8, 31.0, 2.0),
        seg(26.0, -1.0, 28.0, -2.5),
    ]
}

/// The reference a submap gives (`IcpReference::Submap`): the scans of the last meter of
/// route, every 20 cm, thinned to one point per 5 cm square. The scan at `truth`, 4 cm past
/// the last of them, is aligned from a `guess` 10 cm off along x and 8 cm across, and the
/// directions the scan does not measure are held at the guess (the odometry's prediction).
/// Returns the ICP result, the guess and the held pose.
fn match_from_a_bad_guess(walls: &[Seg], seed: u64) -> (IcpResult, Pose2, Held) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = Pose2::new(30.04, 1.2, 0.0);
    let mut reference = Vec::new();
    for k in 0..5 {
        let at = Pose2::new(29.2 + 0.2 * k as f64, 1.2, 0.0);
        let points = scan_points(walls, &at, 30.0, &mut rng);
        reference.extend(points.iter().map(|p| at.transform_point(p)));
    }
    let reference = voxel_filter(&reference, 0.05);
    let icp = Icp::new(&reference, IcpConfig::default());
    let source = scan_points(walls, &truth, 30.0, &mut rng);
    let guess = Pose2::new(truth.x + 0.10, truth.y + 0.08, 0.0);
    let result = icp.align(&source, guess, IcpMode::Full);
    // Along a corridor the damped steps creep and may use up the iterations: convergence is
    // not asked, a finite pose and its normal matrix are.
    assert!(
        result.pose.is_finite() && result.inliers > 100,
        "{result:?}"
    );
    let held = hold_unmeasured_directions(&result, &guess, DEFAULT_MIN_POINTS);
    (result, guess, held)
}

#[test]
fn a_featureless_corridor_reports_its_axis_and_keeps_the_odometry_along_it() {
    for seed in 0..5 {
        let (result, guess, held) = match_from_a_bad_guess(&corridor(), seed);
        // The weakest direction is the corridor's axis, far weaker than across it and
        // below the bound: not measured.
        let (axis, weakest) = result.weakest_direction();
        let strongest = result
            .normal_matrix
            .fixed_view::<2, 2>(0, 0)
            .into_owned()
            .symmetric_eigenvalues()
            .max();
        assert!(axis.x.abs() > 0.99, "seed {seed}: axis {axis:?}");
        assert!(
            weakest < DEFAULT_MIN_POINTS && weakest < 0.05 * strongest,
            "seed {seed}: {weakest} vs {strongest}"
        );
        assert_eq!(held.directions, 1, "seed {seed}");
        // Across the corridor the scan decides (the truth, y = 1.2); along it the
        // odometry's guess stands, wherever ICP slid to.
        let pose = held.pose;
        assert!((pose.y - 1.2).abs() < 0.01, "seed {seed}: {pose:?}");
        assert!(
            (pose.x - guess.x).abs() < 0.005,
            "seed {seed}: {pose:?} from {guess:?}, ICP {:?}",
            result.pose
        );
        assert!(
            pose.heading_rad.abs() < 0.2f64.to_radians(),
            "seed {seed}: {pose:?}"
        );
    }
}

#[test]
fn in_a_room_the_scan_decides_every_direction() {
    for seed in 0..5 {
        let (result, _, held) = match_from_a_bad_guess(&room(), seed);
        let (_, weakest) = result.weakest_direction();
        assert!(weakest > 5.0 * DEFAULT_MIN_POINTS, "seed {seed}: {weakest}");
        assert_eq!(held.directions, 0, "seed {seed}");
        let pose = held.pose;
        assert!(
            (pose.x - 30.04).abs() < 0.01 && (pose.y - 1.2).abs() < 0.01,
            "seed {seed}: {pose:?}"
        );
    }
}
