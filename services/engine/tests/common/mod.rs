//! Helpers the engine's integration tests share: worlds of straight wall segments and the
//! exact ray cast against them, from which the tests make hand-checkable scans.

#![allow(dead_code)]

use sketchslam_types::Point2;

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
