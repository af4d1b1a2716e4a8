//! RANSAC lines of simulated scans, sketch ↔ scan correspondence and the heading correction
//! of eq. (5).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_engine::lines::matching::{
    HeadingAggregate, MatchConfig, heading_correction, match_lines, sketch_line_in_robot_frame,
};
use sketchslam_engine::lines::ransac::{RansacConfig, ScanLine, extract_lines, extract_scan_lines};
use sketchslam_engine::sketch::{SketchLine, SketchPose};
use sketchslam_types::wrap_half_pi;
use sketchslam_types::{Point2, Pose2, Scan};
use std::f64::consts::PI;

mod common;
use common::{Seg, scan_270, seg};

fn simulate(walls: &[Seg], pose: &Pose2, noise_m: f64, rng: &mut ChaCha8Rng) -> Scan {
    scan_270(walls, pose, noise_m, 30.0, rng)
}

/// Undirected angle of a world wall seen from `pose`, in [0, π).
fn wall_angle_in_robot(w: &Seg, pose: &Pose2) -> f64 {
    let a = (w.1.y - w.0.y).atan2(w.1.x - w.0.x) - pose.heading_rad;
    a.rem_euclid(PI)
}

/// Checks every line lies on some wall and every wall in `must_find` is found.
fn check_lines(lines: &[ScanLine], walls: &[Seg], must_find: &[usize], pose: &Pose2) {
    let on_wall = |l: &ScanLine, w: &Seg| {
        let (a, b) = (pose.transform_point(&l.a), pose.transform_point(&l.b));
        let (ex, ey) = (w.1.x - w.0.x, w.1.y - w.0.y);
        let len = ex.hypot(ey);
        let d = |p: Point2| ((p.x - w.0.x) * ey - (p.y - w.0.y) * ex).abs() / len;
        let da = wrap_half_pi(l.angle_rad - wall_angle_in_robot(w, pose)).abs();
        d(a) < 0.1 && d(b) < 0.1 && da < 1f64.to_radians()
    };
    for l in lines {
        assert!(
            walls.iter().any(|w| on_wall(l, w)),
            "line {l:?} lies on no wall"
        );
        assert!((0.0..PI).contains(&l.angle_rad));
        let n = l.normal;
        assert!((n.x * l.a.x + n.y * l.a.y - l.offset).abs() < 1e-9);
    }
    for &k in must_find {
        assert!(
            lines
                .iter()
                .any(|l| on_wall(l, &walls[k]) && l.length_m() > 2.0),
            "wall {k} {:?} not found among {lines:#?}",
            walls[k]
        );
    }
}

#[test]
fn corridor_two_walls() {
    let walls = [seg(-60.0, 1.0, 60.0, 1.0), seg(-60.0, -1.2, 60.0, -1.2)];
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for pose in [Pose2::new(0.0, 0.0, 0.0), Pose2::new(3.0, 0.4, 0.35)] {
        let scan = simulate(&walls, &pose, 0.02, &mut rng);
        let lines = extract_scan_lines(&scan, &RansacConfig::default(), &mut rng);
        check_lines(&lines, &walls, &[0, 1], &pose);
        // The two best supported lines are the two walls, near the robot.
        assert!(lines.len() >= 2);
        let mut by_support = lines.clone();
        by_support.sort_by_key(|l| std::cmp::Reverse(l.inliers));
        let offs: Vec<f64> = by_support[..2].iter().map(|l| l.offset.abs()).collect();
        assert!(offs.iter().all(|o| *o < 1.8), "offsets {offs:?}");
    }
}

#[test]
fn t_junction_three_walls() {
    // Stem along x (walls y = ±1 up to x = 5), crossing corridor x ∈ [5, 7].
    let walls = [
        seg(-60.0, 1.0, 5.0, 1.0),
        seg(-60.0, -1.0, 5.0, -1.0),
        seg(7.0, -30.0, 7.0, 30.0),
        seg(5.0, 1.0, 5.0, 30.0),
        seg(5.0, -1.0, 5.0, -30.0),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let pose = Pose2::new(0.0, 0.0, 0.0);
    let scan = simulate(&walls, &pose, 0.02, &mut rng);
    let lines = extract_scan_lines(&scan, &RansacConfig::default(), &mut rng);
    check_lines(&lines, &walls, &[0, 1, 2], &pose);
    let across = lines
        .iter()
        .find(|l| (l.angle_rad - PI / 2.0).abs() < 1f64.to_radians())
        .unwrap();
    assert!((across.offset.abs() - 7.0).abs() < 0.05);
}

#[test]
fn deterministic_for_a_seed_and_nan_is_no_return() {
    let walls = [seg(-60.0, 1.0, 60.0, 1.0), seg(-60.0, -1.2, 60.0, -1.2)];
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut scan = simulate(&walls, &Pose2::new(0.0, 0.0, 0.0), 0.02, &mut rng);
    for r in scan.ranges_m.iter_mut().step_by(7) {
        *r = f32::NAN;
    }
    let a = extract_scan_lines(
        &scan,
        &RansacConfig::default(),
        &mut ChaCha8Rng::seed_from_u64(9),
    );
    let b = extract_scan_lines(
        &scan,
        &RansacConfig::default(),
        &mut ChaCha8Rng::seed_from_u64(9),
    );
    assert_eq!(a, b);
    assert!(a.iter().all(|l| l.a.x.is_finite() && l.b.y.is_finite()));
    assert!(a.len() >= 2);
    let pts = [Point2::new(f64::INFINITY, 1.0), Point2::new(0.0, f64::NAN)];
    assert!(extract_lines(&pts, &RansacConfig::default(), &mut rng).is_empty());
}

/// Sketch pixels of a metric point in the sketch frame (`x = u·s`, `y = −v·s`).
fn px(p: Point2, s: f64) -> Point2 {
    Point2::new(p.x / s, -p.y / s)
}

#[test]
fn heading_correction_recovers_a_known_offset() {
    let s = 0.05;
    // Walls in the sketch's metric frame.
    let walls = [
        seg(0.0, -20.0, 30.0, -20.0),
        seg(0.0, -10.0, 12.0, -10.0),
        seg(0.0, -20.0, 0.0, -10.0),
        seg(14.0, -20.0, 14.0, -14.0),
        seg(20.0, -13.0, 26.0, -17.0),
    ];
    let sketch: Vec<SketchLine> = walls
        .iter()
        .enumerate()
        .map(|(i, w)| SketchLine::new(i, px(w.0, s), px(w.1, s)))
        .collect();
    let est = SketchPose {
        u_px: 6.0 / s,
        v_px: 15.0 / s,
        heading_rad: 0.3,
        meters_per_pixel: s,
    };
    let delta = 4f64.to_radians();
    // The robot really faces 0.3 + δ and stands 0.2 m off the estimate.
    let truth = Pose2::new(6.2, -15.1, 0.3 + delta);
    let mut scan_lines: Vec<ScanLine> = walls
        .iter()
        .map(|w| {
            ScanLine::from_endpoints(
                truth.inverse_transform_point(&w.0),
                truth.inverse_transform_point(&w.1),
                100,
            )
            .unwrap()
        })
        .collect();
    // A spurious line at 45° to everything, right across the first wall's midpoint.
    let (a, b) = sketch_line_in_robot_frame(&sketch[1], &est);
    let m = Point2::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
    let dir = (b.y - a.y).atan2(b.x - a.x) + PI / 4.0;
    let (sd, cd) = dir.sin_cos();
    scan_lines.push(
        ScanLine::from_endpoints(
            Point2::new(m.x - cd, m.y - sd),
            Point2::new(m.x + cd, m.y + sd),
            50,
        )
        .unwrap(),
    );
    let matches = match_lines(&sketch, &est, &scan_lines, &MatchConfig::default());
    assert_eq!(matches.len(), walls.len(), "{matches:#?}");
    for m in &matches {
        assert_eq!(m.sketch_index, m.scan_index);
        assert!(m.scan_index != walls.len(), "the 45° line was matched");
    }
    for agg in [
        HeadingAggregate::Mean,
        HeadingAggregate::Median,
        HeadingAggregate::InlierMean {
            tolerance_rad: 0.05,
        },
    ] {
        let d = heading_correction(&matches, agg).unwrap();
        assert!((d - delta).abs() < 1e-9, "{agg:?}: {d} vs {delta}");
    }
    // Corrected heading = estimate + Δθ = truth.
    let d = heading_correction(&matches, HeadingAggregate::Mean).unwrap();
    assert!((est.heading_rad + d - truth.heading_rad).abs() < 1e-9);
    assert_eq!(heading_correction(&[], HeadingAggregate::Mean), None);
}

#[test]
fn correspondence_rejects_wrong_angle_and_far_lines() {
    let s = 0.1;
    let sketch = vec![SketchLine::new(
        0,
        px(Point2::new(-5.0, 1.0), s),
        px(Point2::new(5.0, 1.0), s),
    )];
    let est = SketchPose {
        u_px: 0.0,
        v_px: 0.0,
        heading_rad: 0.0,
        meters_per_pixel: s,
    };
    let cfg = MatchConfig::default();
    let line = |a: (f64, f64), b: (f64, f64)| {
        ScanLine::from_endpoints(Point2::new(a.0, a.1), Point2::new(b.0, b.1), 30).unwrap()
    };
    // 20° off: rejected; 3° off: accepted; parallel but 4 m away: rejected.
    let at = |deg: f64| {
        let (sn, c) = deg.to_radians().sin_cos();
        line((-2.0 * c, 1.0 - 2.0 * sn), (2.0 * c, 1.0 + 2.0 * sn))
    };
    assert!(match_lines(&sketch, &est, &[at(20.0)], &cfg).is_empty());
    let ok = match_lines(&sketch, &est, &[at(-3.0)], &cfg);
    assert_eq!(ok.len(), 1);
    assert!((ok[0].angle_diff_rad - 3f64.to_radians()).abs() < 1e-9);
    // Undirected: the same line given in reverse is still 3° off, not 183°.
    let rev = {
        let l = at(-3.0);
        ScanLine::from_endpoints(l.b, l.a, 30).unwrap()
    };
    assert_eq!(match_lines(&sketch, &est, &[rev], &cfg).len(), 1);
    assert!(match_lines(&sketch, &est, &[line((-2.0, 5.0), (2.0, 5.0))], &cfg).is_empty());
    // Past the sketch segment's end by more than the overhang: rejected.
    assert!(match_lines(&sketch, &est, &[line((10.0, 1.0), (12.0, 1.0))], &cfg).is_empty());
}

#[test]
fn ransac_then_heading_end_to_end() {
    // A room drawn exactly; the robot's heading estimate is 3° off.
    let s = 0.05;
    let walls = [
        seg(-5.0, -4.0, 5.0, -4.0),
        seg(5.0, -4.0, 5.0, 4.0),
        seg(5.0, 4.0, -5.0, 4.0),
        seg(-5.0, 4.0, -5.0, -4.0),
        seg(1.0, 1.0, 3.0, 1.0),
    ];
    let sketch: Vec<SketchLine> = walls
        .iter()
        .enumerate()
        .map(|(i, w)| SketchLine::new(i, px(w.0, s), px(w.1, s)))
        .collect();
    let truth = Pose2::new(-1.0, -0.5, 0.7);
    let delta = -3f64.to_radians();
    let est = SketchPose {
        u_px: truth.x / s,
        v_px: -truth.y / s,
        heading_rad: truth.heading_rad - delta,
        meters_per_pixel: s,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let scan = simulate(&walls, &truth, 0.02, &mut rng);
    let lines = extract_scan_lines(&scan, &RansacConfig::default(), &mut rng);
    let matches = match_lines(&sketch, &est, &lines, &MatchConfig::default());
    assert!(matches.len() >= 4);
    let d = heading_correction(&matches, HeadingAggregate::Mean).unwrap();
    assert!(
        (d - delta).abs() < 0.2f64.to_radians(),
        "{} vs {}",
        d,
        delta
    );
}
