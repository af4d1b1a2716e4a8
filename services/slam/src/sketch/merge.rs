//! Merging of collinear line fragments into one line per drawn wall.
//!
//! Last stage of line extraction, after the progressive probabilistic Hough transform
//! ([`super::hough`]). A wall drawn by hand is wavy or slightly bent, and a transform that
//! looks for straight runs of pixels breaks it into several fragments whose directions differ
//! by a few degrees and whose centre lines are offset by the wave's amplitude. Two segments
//! `A` (the longer) and `B` are the same wall when
//!
//! - their undirected directions differ by at most `angle_tol_rad`;
//! - both endpoints of `B` lie within `offset_tol_px` of `A`'s supporting line (and, for
//!   symmetry, `A`'s endpoints within `offset_tol_px` of the merged line — checked through
//!   the merged result's residual);
//! - along `A`'s direction, the intervals they cover overlap or leave a gap of at most
//!   `gap_tol_px`.
//!
//! The merged line goes through the length-weighted centroid of the two midpoints, along the
//! length-weighted mean direction (averaged as doubled angles `2θ`, since lines are
//! undirected), and spans the projections of all four endpoints. Merging repeats, longest
//! segments first, until no pair qualifies: `O(n²)` per round and at most `n` rounds, `O(n³)`
//! for `n` fragments in the worst case — `n` is a few hundred at most for a drawing.

use sketchslam_shared::Point2;

/// A line segment in pixel coordinates with the amount of stroke that supports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// First endpoint, `(u, v)` pixels.
    pub a: Point2,
    /// Second endpoint, `(u, v)` pixels.
    pub b: Point2,
}

impl Segment {
    /// Length, pixels.
    pub fn length_px(&self) -> f64 {
        self.a.distance(&self.b)
    }

    /// Unit direction from `a` to `b` (`(1, 0)` for a degenerate segment).
    pub fn direction(&self) -> (f64, f64) {
        let (dx, dy) = (self.b.x - self.a.x, self.b.y - self.a.y);
        let n = dx.hypot(dy);
        if n > 0.0 { (dx / n, dy / n) } else { (1.0, 0.0) }
    }

    /// Midpoint.
    pub fn midpoint(&self) -> Point2 {
        Point2::new(0.5 * (self.a.x + self.b.x), 0.5 * (self.a.y + self.b.y))
    }
}

/// Tolerances of [`merge_collinear`], in pixels and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergeTolerances {
    /// Largest direction difference, radians.
    pub angle_tol_rad: f64,
    /// Largest perpendicular distance of an endpoint to the other line, pixels.
    pub offset_tol_px: f64,
    /// Largest gap bridged along the line, pixels.
    pub gap_tol_px: f64,
}

/// Perpendicular distance from `p` to the infinite line through `s`.
fn line_distance(s: &Segment, p: &Point2) -> f64 {
    let (dx, dy) = s.direction();
    ((p.x - s.a.x) * dy - (p.y - s.a.y) * dx).abs()
}

/// The single segment covering `a` and `b` (see the module docs).
pub fn merged(a: &Segment, b: &Segment) -> Segment {
    let (la, lb) = (a.length_px().max(1e-9), b.length_px().max(1e-9));
    let (ua, ub) = (a.direction(), b.direction());
    // Doubled-angle mean: (cos 2θ, sin 2θ) = (c² − s², 2cs).
    let c2 = la * (ua.0 * ua.0 - ua.1 * ua.1) + lb * (ub.0 * ub.0 - ub.1 * ub.1);
    let s2 = la * (2.0 * ua.0 * ua.1) + lb * (2.0 * ub.0 * ub.1);
    let theta = 0.5 * s2.atan2(c2);
    let (dx, dy) = (theta.cos(), theta.sin());
    let (ma, mb) = (a.midpoint(), b.midpoint());
    let centre = Point2::new(
        (la * ma.x + lb * mb.x) / (la + lb),
        (la * ma.y + lb * mb.y) / (la + lb),
    );
    let (mut t_min, mut t_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in [a.a, a.b, b.a, b.b] {
        let t = (p.x - centre.x) * dx + (p.y - centre.y) * dy;
        t_min = t_min.min(t);
        t_max = t_max.max(t);
    }
    Segment {
        a: Point2::new(centre.x + t_min * dx, centre.y + t_min * dy),
        b: Point2::new(centre.x + t_max * dx, centre.y + t_max * dy),
    }
}

/// True when `long` and `short` (the shorter one) are fragments of one wall.
pub fn same_wall(long: &Segment, short: &Segment, tol: &MergeTolerances) -> bool {
    let (u, v) = (long.direction(), short.direction());
    let cos = (u.0 * v.0 + u.1 * v.1).abs().min(1.0);
    if cos.acos() > tol.angle_tol_rad {
        return false;
    }
    if line_distance(long, &short.a) > tol.offset_tol_px
        || line_distance(long, &short.b) > tol.offset_tol_px
    {
        return false;
    }
    let len = long.length_px();
    let t = |p: &Point2| (p.x - long.a.x) * u.0 + (p.y - long.a.y) * u.1;
    let (t0, t1) = (t(&short.a), t(&short.b));
    let (lo, hi) = (t0.min(t1), t0.max(t1));
    let gap = (lo - len).max(-hi).max(0.0);
    if gap > tol.gap_tol_px {
        return false;
    }
    // The merged line must still pass close to every endpoint of both.
    let m = merged(long, short);
    [long.a, long.b, short.a, short.b]
        .iter()
        .all(|p| line_distance(&m, p) <= tol.offset_tol_px)
}

/// Merges collinear fragments until no pair qualifies (see the module docs). Order of the
/// output: longest first.
pub fn merge_collinear(mut segments: Vec<Segment>, tol: &MergeTolerances) -> Vec<Segment> {
    loop {
        segments.sort_by(|a, b| b.length_px().total_cmp(&a.length_px()));
        let mut changed = false;
        let mut i = 0;
        while i < segments.len() {
            let mut j = i + 1;
            while j < segments.len() {
                if same_wall(&segments[i], &segments[j], tol) {
                    segments[i] = merged(&segments[i], &segments[j]);
                    segments.remove(j);
                    changed = true;
                    j = i + 1;
                } else {
                    j += 1;
                }
            }
            i += 1;
        }
        if !changed {
            return segments;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
        Segment {
            a: Point2::new(ax, ay),
            b: Point2::new(bx, by),
        }
    }

    const TOL: MergeTolerances = MergeTolerances {
        angle_tol_rad: 0.1,
        offset_tol_px: 4.0,
        gap_tol_px: 8.0,
    };

    #[test]
    fn wavy_fragments_become_one() {
        let out = merge_collinear(
            vec![
                seg(0.0, 0.0, 50.0, 2.0),
                seg(52.0, 2.0, 100.0, -1.0),
                seg(105.0, -1.0, 150.0, 1.0),
            ],
            &TOL,
        );
        assert_eq!(out.len(), 1);
        assert!((out[0].length_px() - 150.0).abs() < 1.0);
    }

    #[test]
    fn parallel_walls_and_far_collinear_walls_stay_apart() {
        let out = merge_collinear(
            vec![
                seg(0.0, 0.0, 100.0, 0.0),
                seg(0.0, 20.0, 100.0, 20.0),
                seg(130.0, 0.0, 200.0, 0.0),
                seg(50.0, -40.0, 50.0, 40.0),
            ],
            &TOL,
        );
        assert_eq!(out.len(), 4);
    }
}
