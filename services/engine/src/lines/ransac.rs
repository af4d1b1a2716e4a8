//! Straight walls in a LiDAR scan by RANSAC (Fischler & Bolles 1981): step 4 of the
//! pipeline, the scan side of the line matching that corrects the heading (eq. 5).
//!
//! Sequential RANSAC over the scan's returns in the robot frame:
//! 1. hypotheses: a line through two points of the remaining set; the first is drawn
//!    uniformly, the second among its neighbours in beam order (±`neighbour_window`
//!    returns; locality-guided sampling as in NAPSAC, Myatt et al. 2002), which makes a
//!    same-wall pair likely even when a wall holds few of the points;
//! 2. consensus: the points within `inlier_distance_m` of the line; the hypothesis with most
//!    inliers wins; the number of hypotheses adapts to the best inlier ratio `w` seen so far,
//!    `N = ln(1 − 0.99) / ln(1 − w)` (the second point is local, so one good draw suffices),
//!    capped by `max_iterations`;
//! 3. refinement: total least squares (PCA) over the inliers — the line through their
//!    centroid along the principal eigenvector of their covariance — then inliers again
//!    for the refined line, twice;
//! 4. segments: the inliers sorted by their abscissa along the line, cut where two neighbours
//!    are farther apart than `gap_m` (so one model does not join two walls that are merely
//!    collinear); each segment with at least `min_segment_points` points spanning at least
//!    `min_segment_length_m` is refitted by TLS and kept;
//! 5. the points of kept segments leave the set (all the model's inliers when no segment was
//!    kept); repeat until fewer than `min_inliers` points remain or `max_lines` are found.
//!
//! Complexity: O(max_lines · max_iterations · n) in the worst case, n returns; typically a
//! few tens of hypotheses per line. Deterministic for a given `Rng` state.

use rand::Rng;
use sketchslam_types::{Point2, Scan};
use std::f64::consts::PI;

/// RANSAC parameters. Lengths in meters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacConfig {
    /// A point is an inlier when its distance to the line is below this. Default 0.05 m
    /// (2.5 σ of the simulator's 2 cm range noise).
    pub inlier_distance_m: f64,
    /// A model needs at least this many inliers; also the stop criterion on the remaining
    /// points. Default 15.
    pub min_inliers: usize,
    /// Hypotheses per line at most. Default 200.
    pub max_iterations: usize,
    /// Hypotheses per line at least (before the adaptive stop may apply). Default 20.
    pub min_iterations: usize,
    /// Lines at most per scan. Default 20.
    pub max_lines: usize,
    /// Two consecutive inliers (along the line) farther apart than this start a new segment.
    /// Default 0.5 m.
    pub gap_m: f64,
    /// A segment needs at least this many points. Default 10.
    pub min_segment_points: usize,
    /// A segment must be at least this long. Default 0.4 m.
    pub min_segment_length_m: f64,
    /// The second sample is drawn within this many returns of the first (in beam order).
    /// Default 20; 0 means uniform sampling of both points.
    pub neighbour_window: usize,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self {
            inlier_distance_m: 0.05,
            min_inliers: 15,
            max_iterations: 200,
            min_iterations: 20,
            max_lines: 20,
            gap_m: 0.5,
            min_segment_points: 10,
            min_segment_length_m: 0.4,
            neighbour_window: 20,
        }
    }
}

/// A straight wall segment found in a scan, robot frame, meters.
///
/// The infinite line is `{p : normal · p = offset}` with `normal = (−sin angle, cos angle)`;
/// the segment runs from `a` to `b` along the direction `(cos angle, sin angle)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScanLine {
    /// First endpoint (smallest abscissa along the direction).
    pub a: Point2,
    /// Second endpoint.
    pub b: Point2,
    /// Direction of the (undirected) line, radians in [0, π).
    pub angle_rad: f64,
    /// Unit normal, `(−sin angle, cos angle)`.
    pub normal: Point2,
    /// Signed distance of the line from the robot: `normal · p` for every `p` on it, meters.
    pub offset: f64,
    /// Number of scan points supporting the segment.
    pub inliers: usize,
}

impl ScanLine {
    /// The segment from `p` to `q` (in either order) supported by `inliers` points; `None`
    /// when the points coincide or are not finite.
    pub fn from_endpoints(p: Point2, q: Point2, inliers: usize) -> Option<ScanLine> {
        let model = Model::through(&p, &q)?;
        let mut line = scan_line(&model, &[p, q])?;
        line.inliers = inliers;
        Some(line)
    }

    /// Length of the segment, meters.
    pub fn length_m(&self) -> f64 {
        self.a.distance(&self.b)
    }

    /// Midpoint of the segment.
    pub fn midpoint(&self) -> Point2 {
        Point2::new(0.5 * (self.a.x + self.b.x), 0.5 * (self.a.y + self.b.y))
    }

    /// Unit direction `(cos angle, sin angle)`.
    pub fn direction(&self) -> Point2 {
        Point2::new(self.angle_rad.cos(), self.angle_rad.sin())
    }

    /// Signed distance of `p` from the infinite line, meters.
    pub fn signed_distance(&self, p: &Point2) -> f64 {
        self.normal.x * p.x + self.normal.y * p.y - self.offset
    }
}

/// An infinite line `n · p = c` with unit `n`.
#[derive(Debug, Clone, Copy)]
struct Model {
    n: Point2,
    c: f64,
}

impl Model {
    fn through(p: &Point2, q: &Point2) -> Option<Model> {
        let (dx, dy) = (q.x - p.x, q.y - p.y);
        let len = dx.hypot(dy);
        if len.is_nan() || len <= 1e-9 {
            return None;
        }
        let n = Point2::new(-dy / len, dx / len);
        Some(Model {
            n,
            c: n.x * p.x + n.y * p.y,
        })
    }

    fn distance(&self, p: &Point2) -> f64 {
        (self.n.x * p.x + self.n.y * p.y - self.c).abs()
    }
}

/// Total least squares line through `pts` (PCA): centroid and principal direction.
/// `None` for fewer than two distinct points.
fn fit_tls(pts: &[Point2]) -> Option<Model> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(sx, sy), p| (sx + p.x, sy + p.y));
    let (mx, my) = (mx / n, my / n);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in pts {
        let (dx, dy) = (p.x - mx, p.y - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    if (sxx + syy).is_nan() || sxx + syy <= 1e-18 {
        return None;
    }
    // Principal direction of the 2×2 covariance: φ = ½·atan2(2 sxy, sxx − syy).
    let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let nrm = Point2::new(-phi.sin(), phi.cos());
    Some(Model {
        n: nrm,
        c: nrm.x * mx + nrm.y * my,
    })
}

/// Builds the [`ScanLine`] of a refitted segment.
fn scan_line(model: &Model, pts: &[Point2]) -> Option<ScanLine> {
    // Direction d = (n_y, −n_x) rotated so that the angle lands in [0, π).
    let mut angle = (-model.n.x).atan2(model.n.y);
    if angle < 0.0 {
        angle += PI;
    }
    if angle >= PI {
        angle -= PI;
    }
    let d = Point2::new(angle.cos(), angle.sin());
    let normal = Point2::new(-d.y, d.x);
    let offset = if normal.x * model.n.x + normal.y * model.n.y >= 0.0 {
        model.c
    } else {
        -model.c
    };
    let (mut tmin, mut tmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in pts {
        let t = d.x * p.x + d.y * p.y;
        tmin = tmin.min(t);
        tmax = tmax.max(t);
    }
    if tmax.is_nan() || tmin.is_nan() || tmax < tmin {
        return None;
    }
    let on = |t: f64| Point2::new(normal.x * offset + d.x * t, normal.y * offset + d.y * t);
    Some(ScanLine {
        a: on(tmin),
        b: on(tmax),
        angle_rad: angle,
        normal,
        offset,
        inliers: pts.len(),
    })
}

/// The returns of `scan` as robot-frame points (non-finite and out-of-limits ranges are no
/// return), then [`extract_lines`].
pub fn extract_scan_lines(scan: &Scan, config: &RansacConfig, rng: &mut impl Rng) -> Vec<ScanLine> {
    let pts: Vec<Point2> = scan.points().map(|(_, p)| p).collect();
    extract_lines(&pts, config, rng)
}

/// Sequential RANSAC line extraction (see the module docs) over robot-frame points given
/// in beam order. Non-finite points are ignored. Lines come out in the order found (most
/// supported model first).
pub fn extract_lines(
    points: &[Point2],
    config: &RansacConfig,
    rng: &mut impl Rng,
) -> Vec<ScanLine> {
    let mut remaining: Vec<Point2> = points
        .iter()
        .copied()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .collect();
    let min_inliers = config.min_inliers.max(2);
    let thr = if config.inlier_distance_m.is_finite() && config.inlier_distance_m > 0.0 {
        config.inlier_distance_m
    } else {
        RansacConfig::default().inlier_distance_m
    };
    let mut lines = Vec::new();
    // Each round removes points, but bound the rounds anyway.
    let mut rounds = 0usize;
    while remaining.len() >= min_inliers
        && lines.len() < config.max_lines
        && rounds < 4 * config.max_lines.max(1)
    {
        rounds += 1;
        let Some(model) = best_model(&remaining, thr, config, rng) else {
            break;
        };
        // Refine by TLS over the inliers, twice.
        let mut model = model;
        let mut inlier_mask: Vec<bool> =
            remaining.iter().map(|p| model.distance(p) < thr).collect();
        for _ in 0..2 {
            let pts: Vec<Point2> = remaining
                .iter()
                .zip(&inlier_mask)
                .filter(|(_, m)| **m)
                .map(|(p, _)| *p)
                .collect();
            if let Some(m) = fit_tls(&pts) {
                model = m;
                inlier_mask = remaining.iter().map(|p| model.distance(p) < thr).collect();
            }
        }
        let count = inlier_mask.iter().filter(|m| **m).count();
        if count < min_inliers {
            break;
        }
        // Split the inliers into contiguous segments along the line.
        let d = Point2::new(model.n.y, -model.n.x);
        let mut along: Vec<(f64, usize)> = remaining
            .iter()
            .enumerate()
            .filter(|(i, _)| inlier_mask[*i])
            .map(|(i, p)| (d.x * p.x + d.y * p.y, i))
            .collect();
        along.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut remove = vec![false; remaining.len()];
        let mut kept_any = false;
        let mut start = 0;
        for k in 1..=along.len() {
            let cut = k == along.len() || along[k].0 - along[k - 1].0 > config.gap_m;
            if !cut {
                continue;
            }
            let seg = &along[start..k];
            start = k;
            let span = seg.last().map_or(0.0, |l| l.0) - seg.first().map_or(0.0, |f| f.0);
            if seg.len() < config.min_segment_points.max(2) || span < config.min_segment_length_m {
                continue;
            }
            let pts: Vec<Point2> = seg.iter().map(|&(_, i)| remaining[i]).collect();
            if let Some(line) = fit_tls(&pts).and_then(|m| scan_line(&m, &pts)) {
                if lines.len() < config.max_lines {
                    lines.push(line);
                }
                kept_any = true;
                for &(_, i) in seg {
                    remove[i] = true;
                }
            }
        }
        if !kept_any {
            remove = inlier_mask;
        }
        let mut i = 0;
        remaining.retain(|_| {
            let keep = !remove[i];
            i += 1;
            keep
        });
    }
    lines
}

/// The hypothesis with most inliers among adaptively many two-point samples.
fn best_model(
    pts: &[Point2],
    thr: f64,
    config: &RansacConfig,
    rng: &mut impl Rng,
) -> Option<Model> {
    let n = pts.len();
    if n < 2 {
        return None;
    }
    let mut best: Option<(usize, Model)> = None;
    let mut needed = config.max_iterations.max(1);
    let mut it = 0;
    while it < needed.max(config.min_iterations.min(config.max_iterations)) {
        it += 1;
        let i = rng.random_range(0..n);
        let j = if config.neighbour_window > 0 {
            let lo = i.saturating_sub(config.neighbour_window);
            let hi = (i + config.neighbour_window).min(n - 1);
            rng.random_range(lo..=hi)
        } else {
            rng.random_range(0..n)
        };
        if i == j {
            continue;
        }
        let Some(m) = Model::through(&pts[i], &pts[j]) else {
            continue;
        };
        let count = pts.iter().filter(|p| m.distance(p) < thr).count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            best = Some((count, m));
            // Adaptive stop: N = ln(1 − 0.99) / ln(1 − w).
            let w = count as f64 / n as f64;
            if w >= 1.0 {
                needed = 0;
            } else if w > 0.0 {
                let est = ((1.0f64 - 0.99).ln() / (1.0 - w).ln()).ceil();
                needed = needed.min(est.max(1.0) as usize);
            }
        }
        if it >= config.max_iterations {
            break;
        }
    }
    best.map(|(_, m)| m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn tls_of_a_vertical_line() {
        let pts: Vec<Point2> = (0..10).map(|i| Point2::new(2.0, i as f64 * 0.1)).collect();
        let m = fit_tls(&pts).unwrap();
        let l = scan_line(&m, &pts).unwrap();
        assert!((l.angle_rad - PI / 2.0).abs() < 1e-9);
        assert!((l.signed_distance(&Point2::new(2.0, 5.0))).abs() < 1e-9);
        assert!((l.length_m() - 0.9).abs() < 1e-9);
    }

    #[test]
    fn garbage_gives_nothing() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let pts = vec![Point2::new(f64::NAN, 0.0); 100];
        assert!(extract_lines(&pts, &RansacConfig::default(), &mut rng).is_empty());
        let same = vec![Point2::new(1.0, 1.0); 100];
        assert!(extract_lines(&same, &RansacConfig::default(), &mut rng).is_empty());
        assert!(extract_lines(&[], &RansacConfig::default(), &mut rng).is_empty());
    }
}
