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

/// The squared Mahalanobis distance of each seed's match error (translation) under the
/// covariance ICP reports for it, with `prior_m2` along the directions not measured.
fn match_error_mahalanobis(walls: &[Seg], prior_m2: f64) -> Vec<(f64, nalgebra::Matrix2<f64>)> {
    (0..20)
        .map(|seed| {
            let (result, _, _) = match_from_a_bad_guess(walls, 100 + seed);
            let (cov, _) = result.covariance(DEFAULT_MIN_POINTS, prior_m2);
            let e = nalgebra::Vector2::new(result.pose.x - 30.04, result.pose.y - 1.2);
            (e.dot(&(cov.try_inverse().unwrap() * e)), cov)
        })
        .collect()
}

#[test]
fn the_reported_covariance_is_the_size_of_the_error_in_a_room_and_the_prior_along_a_corridor() {
    // In the room every direction is measured: rms² H⁻¹ alone. Over 20 seeds the mean
    // squared Mahalanobis distance of the error would be χ²(2)'s mean, 2, for a calibrated
    // covariance. ICP's first-order covariance is optimistic where the residuals are
    // correlated: here the reference is made of scans as noisy as the query, and several
    // returns share one reference point and its normal (11.7 measured, 2026-12-04; 8.7
    // with each return weighted by how many share its reference point). Asked: the right
    // order of magnitude, within a factor of ten either way.
    let room = match_error_mahalanobis(&room(), 0.01);
    let mean = room.iter().map(|(d2, _)| d2).sum::<f64>() / room.len() as f64;
    eprintln!(
        "room: mean squared Mahalanobis {mean:.2}, σ_x {:.4} m",
        room[0].1[(0, 0)].sqrt()
    );
    assert!((0.2..20.0).contains(&mean), "{mean}");
    assert!(room.iter().all(|(_, c)| c[(0, 0)] < 1e-4), "{room:?}");
    // Along the corridor's axis the prior (0.1 m)² stands; across it ICP's own few mm.
    for (_, cov) in match_error_mahalanobis(&corridor(), 0.01) {
        assert!(cov[(0, 0)] >= 0.0099, "{cov}");
        assert!(cov[(1, 1)] < 1e-4, "{cov}");
    }
}
