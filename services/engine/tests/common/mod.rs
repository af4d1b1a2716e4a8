//! Helpers the engine's integration tests share: worlds of straight wall segments and the
//! exact ray cast against them, and the noisy 270° scans the tests make from them.

#![allow(dead_code)]

use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sketchslam_engine::sketch::SketchLine;
use sketchslam_types::{Point2, Pose2, Scan};

/// A wall from one point to another, meters.
pub type Seg = (Point2, Point2);

/// The wall from `(ax, ay)` to `(bx, by)`.
pub fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Seg {
    (Point2::new(ax, ay), Point2::new(bx, by))
}

/// Distance along the ray `o + t·(cos a, sin a)` to the nearest wall (∞ when none): the
/// ray–segment intersection `o + t d = p + s (q − p)` solved by Cramer's rule, `t > 0` and
/// `0 ≤ s ≤ 1`. O(walls).
pub fn cast(walls: &[Seg], o: Point2, a: f64) -> f64 {
    let (dy, dx) = a.sin_cos();
    let mut best = f64::INFINITY;
    for (p, q) in walls {
        let (ex, ey) = (q.x - p.x, q.y - p.y);
        let den = dx * ey - dy * ex;
        if den.abs() < 1e-12 {
            continue;
        }
        let (wx, wy) = (p.x - o.x, p.y - o.y);
        let t = (wx * ey - wy * ex) / den;
        let s = (wx * dy - wy * dx) / den;
        if t > 1e-9 && (0.0..=1.0).contains(&s) {
            best = best.min(t);
        }
    }
    best
}

/// A 270°, 1 081-beam scan of `walls` from `pose`: each beam's exact range ([`cast`]) plus
/// Gaussian noise of `noise_m`, no return beyond `max_range_m` (the scan's range cap).
pub fn scan_270(
    walls: &[Seg],
    pose: &Pose2,
    noise_m: f64,
    max_range_m: f64,
    rng: &mut ChaCha8Rng,
) -> Scan {
    let beams = 1081;
    let fov = 270f64.to_radians();
    let inc = fov / (beams - 1) as f64;
    let noise = Normal::new(0.0, noise_m.max(1e-12)).unwrap();
    let ranges_m = (0..beams)
        .map(|i| {
            let r = cast(
                walls,
                pose.position(),
                pose.heading_rad - fov / 2.0 + i as f64 * inc,
            );
            if r.is_finite() && r < max_range_m {
                (r + noise.sample(rng)) as f32
            } else {
                f32::INFINITY
            }
        })
        .collect();
    Scan::centred(fov, 0.05, max_range_m as f32, ranges_m)
}

/// The lines a person drew of `walls` (meters) through `drawn` (meters → drawing frame
/// `(u, −v)` pixels), each wall split where it crosses `x = kink_x_m`, where the drawing's
/// proportions change: a drawn line is straight only on either side of the kink.
pub fn drawn_lines(
    walls: &[Seg],
    kink_x_m: f64,
    drawn: impl Fn(Point2) -> Point2,
) -> Vec<SketchLine> {
    let mut lines = Vec::new();
    for &(a, b) in walls {
        let mut cuts = vec![a];
        if (a.x - kink_x_m) * (b.x - kink_x_m) < 0.0 {
            let t = (kink_x_m - a.x) / (b.x - a.x);
            cuts.push(Point2::new(kink_x_m, a.y + t * (b.y - a.y)));
        }
        cuts.push(b);
        for w in cuts.windows(2) {
            let (da, db) = (drawn(w[0]), drawn(w[1]));
            let index = lines.len();
            lines.push(SketchLine::new(
                index,
                Point2::new(da.x, -da.y),
                Point2::new(db.x, -db.y),
            ));
        }
    }
    lines
}

/// An 8 × 5 m room with a 2 × 1 m alcove off its north wall and a pillar: nothing in it
/// repeats under a turn.
pub fn alcove_room() -> Vec<Seg> {
    vec![
        seg(0.0, 0.0, 8.0, 0.0),
        seg(8.0, 0.0, 8.0, 5.0),
        seg(8.0, 5.0, 5.0, 5.0),
        seg(5.0, 5.0, 5.0, 6.0),
        seg(5.0, 6.0, 3.0, 6.0),
        seg(3.0, 6.0, 3.0, 5.0),
        seg(3.0, 5.0, 0.0, 5.0),
        seg(0.0, 5.0, 0.0, 0.0),
        seg(6.0, 1.0, 6.4, 1.0),
        seg(6.4, 1.0, 6.4, 1.4),
        seg(6.4, 1.4, 6.0, 1.4),
        seg(6.0, 1.4, 6.0, 1.0),
    ]
}
