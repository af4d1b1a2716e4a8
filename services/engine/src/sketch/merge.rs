//! Merging of collinear line fragments into one line per drawn wall.
//!
//! Last stage of line extraction, after the progressive probabilistic Hough transform
//! ([`super::hough`]). A wall drawn by hand is wavy or slightly bent, and a transform that
//! looks for straight runs of pixels breaks it into several fragments whose directions differ
//! by a few degrees and whose centre lines are offset by the wave's amplitude. Two segments
//! `A` (the longer) and `B` are the same wall when
//!
//! - their undirected directions differ by at most `angle_tol_rad`;
//! - along `A`'s direction, the intervals they cover overlap or leave a gap of at most
//!   `gap_tol_px`;
//! - and either they lie *side by side or in line*: both endpoints of `B` within
//!   `offset_tol_px` of `A`'s supporting line and all four endpoints within `offset_tol_px`
//!   of the merged line;
//! - or they join *end to end*, as the pieces of a wavy stroke do — with a direction
//!   difference up to `3.5 · angle_tol_rad`, since such pieces zig-zag: an endpoint of one within
//!   `gap_tol_px` of an endpoint of the other, an overlap of at most `offset_tol_px`, and all
//!   four endpoints within `max(offset_tol_px, rel_offset_tol · L)` of the merged line of
//!   length `L` — a band that grows with the wall, as the tremor of a long stroke does. A
//!   hairpin (two strokes joined at one end, running back side by side) overlaps and is
//!   not merged; a jog (two parallel walls joined by a short perpendicular one) has its
//!   ends farther apart than the gap tolerance when the jog is longer than it.
//!
//! The merged line goes through the length-weighted centroid of the two midpoints, along the
//! length-weighted mean direction (averaged as doubled angles `2θ`, since lines are
//! undirected), and spans the projections of all four endpoints. Merging repeats, longest
//! segments first, until no pair qualifies: `O(n²)` per round and at most `n` rounds, `O(n³)`
//! for `n` fragments in the worst case — `n` is a few hundred at most for a drawing.

use sketchslam_types::Point2;

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
        if n > 0.0 {
            (dx / n, dy / n)
        } else {
            (1.0, 0.0)
        }
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
    /// For fragments joined end to end (a wavy wall), the largest distance of an endpoint
    /// to the merged line as a fraction of the merged length, when above `offset_tol_px`.
    pub rel_offset_tol: f64,
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

/// True when `long` and `short` (the shorter one) lie side by side or in line: the same
/// wall found twice, or split by a gap.
pub fn same_wall(long: &Segment, short: &Segment, tol: &MergeTolerances) -> bool {
    let (u, v) = (long.direction(), short.direction());
    let angle_rad = (u.0 * v.0 + u.1 * v.1).abs().min(1.0).acos();
    if angle_rad > tol.angle_tol_rad {
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
    if (lo - len).max(-hi) > tol.gap_tol_px {
        return false;
    }
    let m = merged(long, short);
    [long.a, long.b, short.a, short.b]
        .iter()
        .all(|p| line_distance(&m, p) <= tol.offset_tol_px)
}

/// How much wider the angle tolerance is between consecutive pieces of one stroke: the
/// pieces of a wavy stroke zig-zag by more than whole walls differ.
const CHAIN_ANGLE_FACTOR: f64 = 3.5;

/// Largest angle between a fragment's direction and the step to the next fragment's end:
/// a wave's crest steps sideways by less, a jog between parallel walls by about 90°.
const LINK_ANGLE_MAX_RAD: f64 = std::f64::consts::FRAC_PI_3;

/// Joins fragments that continue each other end to end into chains, splits each chain
/// where it bends (Douglas–Peucker with a length-relative tolerance) and returns one
/// segment per straight piece. See the module docs.
///
/// Two ends link when they are within `gap_tol_px`, or within `3 · gap_tol_px` and
/// `drawn(p, q)` says the stroke runs between them (a wave's crest, whose pixels the Hough
/// transform left to no segment, rather than a door left open in a wall), and the step
/// from one end to the other is within 60° of both fragments' directions (a crest, not a
/// jog between two parallel walls).
pub fn merge_chains(
    segments: Vec<Segment>,
    tol: &MergeTolerances,
    drawn: &dyn Fn(Point2, Point2) -> bool,
) -> Vec<Segment> {
    let n = segments.len();
    // Endpoint e of segment i is 2i + e (e = 0 for `a`, 1 for `b`).
    let point = |k: usize| {
        if k.is_multiple_of(2) {
            segments[k / 2].a
        } else {
            segments[k / 2].b
        }
    };
    // Unit direction pointing out of the segment through endpoint k.
    let outward = |k: usize| {
        let (dx, dy) = segments[k / 2].direction();
        if k.is_multiple_of(2) {
            (-dx, -dy)
        } else {
            (dx, dy)
        }
    };
    let cos_max = (tol.angle_tol_rad * CHAIN_ANGLE_FACTOR)
        .min(std::f64::consts::FRAC_PI_2)
        .cos();
    let mut candidates = Vec::new();
    for k in 0..2 * n {
        for l in (k + 1)..2 * n {
            if k / 2 == l / 2 {
                continue;
            }
            let d = point(k).distance(&point(l));
            // The stroke goes on: out of one segment, into the other.
            let (ok, ol) = (outward(k), outward(l));
            let cos = -(ok.0 * ol.0 + ok.1 * ol.1);
            // The step from one end to the other goes on in the stroke's direction too
            // (a crest), not across it (a jog between two parallel walls).
            let link_ok = d <= tol.offset_tol_px || {
                let (pk, pl) = (point(k), point(l));
                let (lx, ly) = ((pl.x - pk.x) / d, (pl.y - pk.y) / d);
                let cos_link = LINK_ANGLE_MAX_RAD.cos();
                ok.0 * lx + ok.1 * ly >= cos_link && -(ol.0 * lx + ol.1 * ly) >= cos_link
            };
            if cos >= cos_max
                && link_ok
                && (d <= tol.gap_tol_px || (d <= 3.0 * tol.gap_tol_px && drawn(point(k), point(l))))
            {
                candidates.push((d / tol.gap_tol_px.max(1e-9) + (1.0 - cos), k, l));
            }
        }
    }
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut link = vec![usize::MAX; 2 * n];
    // Union–find over segments: no cycles.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for &(_, k, l) in &candidates {
        if link[k] != usize::MAX || link[l] != usize::MAX {
            continue;
        }
        let (rk, rl) = (root(&mut parent, k / 2), root(&mut parent, l / 2));
        if rk == rl {
            continue;
        }
        parent[rk] = rl;
        link[k] = l;
        link[l] = k;
    }
    // Walk each chain from a free end.
    let mut used = vec![false; n];
    let mut out = Vec::new();
    for start in 0..2 * n {
        if used[start / 2] || link[start] != usize::MAX {
            continue;
        }
        let mut chain = Vec::new(); // (segment, entered through endpoint)
        let mut k = start;
        loop {
            used[k / 2] = true;
            chain.push(k);
            let exit = k ^ 1;
            let next = link[exit];
            if next == usize::MAX || used[next / 2] {
                break;
            }
            k = next;
        }
        split_chain(&segments, &chain, tol, &mut out);
    }
    out
}

/// Douglas–Peucker over a chain's vertices (its start, the junctions, its end) with the
/// tolerance `max(offset_tol, rel_offset_tol · L)` for a piece of length `L`; each piece
/// becomes the [`merged`] segment of its fragments. `chain[i]` is the endpoint through which
/// fragment `chain[i] / 2` is entered.
fn split_chain(
    segments: &[Segment],
    chain: &[usize],
    tol: &MergeTolerances,
    out: &mut Vec<Segment>,
) {
    let entry = |k: usize| {
        if k.is_multiple_of(2) {
            segments[k / 2].a
        } else {
            segments[k / 2].b
        }
    };
    let exit = |k: usize| entry(k ^ 1);
    // Vertex i is where fragment i starts; vertex len is the chain's end.
    let vertex = |i: usize| -> Point2 {
        if i == 0 {
            entry(chain[0])
        } else if i == chain.len() {
            exit(chain[chain.len() - 1])
        } else {
            let (p, q) = (exit(chain[i - 1]), entry(chain[i]));
            Point2::new(0.5 * (p.x + q.x), 0.5 * (p.y + q.y))
        }
    };
    let mut stack = vec![(0usize, chain.len())];
    let mut pieces = Vec::new();
    while let Some((i, j)) = stack.pop() {
        let chord = Segment {
            a: vertex(i),
            b: vertex(j),
        };
        let length: f64 = (i..j).map(|f| segments[chain[f] / 2].length_px()).sum();
        let eps = tol.offset_tol_px.max(tol.rel_offset_tol * length);
        let worst = (i + 1..j)
            .map(|v| (line_distance(&chord, &vertex(v)), v))
            .fold((0.0, i), |a, b| if b.0 > a.0 { b } else { a });
        if j - i > 1 && (worst.0 > eps || chord.length_px() < 1e-9) {
            stack.push((worst.1, j));
            stack.push((i, worst.1));
        } else {
            pieces.push((i, j));
        }
    }
    pieces.sort_unstable();
    for (i, j) in pieces {
        let mut s = segments[chain[i] / 2];
        for f in i + 1..j {
            s = merged(&s, &segments[chain[f] / 2]);
        }
        out.push(s);
    }
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

/// Extends or trims line ends onto the lines they meet at a corner.
///
/// The Hough transform removes the pixels of a line's corridor when it finds the line, so
/// a wall found later stops a corridor's width short of the corner it shares with an
/// earlier one (and thinning shortens free ends by half a stroke). For each end `E` of a
/// segment and each other segment at more than 30° to it, the intersection `X` of the two
/// supporting lines replaces `E` when `|EX| ≤ snap_px` and `X` lies within `snap_px` of the
/// other segment. `O(n²)` for `n` segments.
pub fn snap_corners(segments: &mut [Segment], snap_px: f64) {
    let min_sin = 30f64.to_radians().sin();
    for i in 0..segments.len() {
        for end in 0..2 {
            let mut best: Option<(f64, Point2)> = None;
            for j in 0..segments.len() {
                if i == j {
                    continue;
                }
                let (si, sj) = (segments[i], segments[j]);
                let ((ux, uy), (vx, vy)) = (si.direction(), sj.direction());
                let cross = ux * vy - uy * vx;
                if cross.abs() < min_sin {
                    continue;
                }
                // si.a + t u = sj.a + r v.
                let (wx, wy) = (sj.a.x - si.a.x, sj.a.y - si.a.y);
                let t = (wx * vy - wy * vx) / cross;
                let x = Point2::new(si.a.x + t * ux, si.a.y + t * uy);
                let e = if end == 0 { si.a } else { si.b };
                let d = e.distance(&x);
                let r = (x.x - sj.a.x) * vx + (x.y - sj.a.y) * vy;
                let outside = (-r).max(r - sj.length_px()).max(0.0);
                // Snapping must not flip or collapse the segment.
                let other = if end == 0 { si.b } else { si.a };
                if d <= snap_px
                    && outside <= snap_px
                    && other.distance(&x) > 0.5 * si.length_px()
                    && best.is_none_or(|(bd, _)| d < bd)
                {
                    best = Some((d, x));
                }
            }
            if let Some((_, x)) = best {
                if end == 0 {
                    segments[i].a = x;
                } else {
                    segments[i].b = x;
                }
            }
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
        rel_offset_tol: 0.04,
    };

    #[test]
    fn wavy_fragments_become_one() {
        let out = merge_chains(
            vec![
                seg(0.0, 0.0, 50.0, 6.0),
                seg(52.0, 6.0, 100.0, -1.0),
                seg(105.0, -1.0, 150.0, 4.0),
            ],
            &TOL,
            &|_, _| true,
        );
        assert_eq!(out.len(), 1);
        assert!((out[0].length_px() - 150.0).abs() < 1.0);
    }

    #[test]
    fn corners_jogs_and_hairpins_are_not_chained() {
        let out = merge_chains(
            vec![
                // An L corner.
                seg(0.0, 0.0, 100.0, 0.0),
                seg(100.0, 0.0, 100.0, 100.0),
                // A jog: parallel walls 20 px apart joined by a short wall.
                seg(200.0, 0.0, 300.0, 0.0),
                seg(300.0, 20.0, 400.0, 20.0),
                // A hairpin.
                seg(0.0, 200.0, 100.0, 200.0),
                seg(100.0, 206.0, 0.0, 206.0),
            ],
            &TOL,
            &|_, _| true,
        );
        assert_eq!(out.len(), 6);
    }

    #[test]
    fn corners_are_closed() {
        let mut s = vec![seg(0.0, 0.0, 100.0, 0.0), seg(103.0, 4.0, 103.0, 80.0)];
        snap_corners(&mut s, 6.0);
        assert!(s[0].b.distance(&Point2::new(103.0, 0.0)) < 1e-9);
        assert!(s[1].a.distance(&Point2::new(103.0, 0.0)) < 1e-9);
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
