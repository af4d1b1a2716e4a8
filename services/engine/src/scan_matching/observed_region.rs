//! Where a reference looked, and a match scored only there: the correlative search's
//! answer re-placed by the points its reference could have confirmed.
//!
//! Sits after the correlative search of a loop match ([`crate::back_end::loop_closure`]),
//! before ICP refines it. The search's score ([`super::correlative`]) is the mean
//! likelihood of *all* scan points, and a point where the reference never looked scores 0.
//! When the scan reaches beyond its reference — a corridor revisited in the other
//! direction: each pass looked ahead, along the corridor, with a blind cone behind — every
//! shift toward more overlap wins, and along a featureless corridor the top of the score
//! sits where the two views overlap most, not where the scan was taken (measured on
//! paper-env2's dead ends and the CSAIL log: 0.1–1.8 m off, the truth 15 % below the top).
//!
//! Model. A reference view k (its sensor at s_k, its points) saw along a bearing when it
//! has a return there: the cells before the return are free, the return's a wall, those
//! behind it hidden by it — all three tell something about a point placed there. Along a
//! bearing it looked at and got no return (out of range), it saw free space as far as its
//! farthest return r_k; in its blind cone (the widest run of bearings without a return,
//! when it spans 45° or more) it saw nothing. A point placed where no view saw holds no
//! evidence and is left out:
//!
//! ```text
//! seen(c) ⇔ ∃k: |c − s_k| ≤ reach_k(∠(c − s_k)),   reach_k = ∞ (return) | r_k (none) | 0 (blind)
//! S_obs(x) = Σ_{i: seen(xpᵢ)} L(xpᵢ) / |{i: seen(xpᵢ)}|
//! ```
//!
//! with bins of one degree (a gap of up to two bins between returns counts as a return, so
//! a coarse scan has no holes). `S_obs` is flat where the plain score only grows with
//! overlap, and peaks on what both views saw. It is searched over the window's
//! translations at the correlative heading, among poses that would pass as a match by
//! their plain score and place enough points where the reference looked; the match is the
//! middle of its plateau, and the plateau gives the translation covariance, as
//! [`super::correlative::LikelihoodField::translation_covariance`] does for the plain score.
//! Used by `LoopClosureConfig::score_observed_only` (off by default: measured, see there).
//!
//! Cost: the region is O(cells · views) bearings (cells of `cell_m`); a search is
//! O(w² · n) for w² shifts and n points.

use super::correlative::{LikelihoodField, bounding_box, plateau_spread};
use sketchslam_types::{Point2, Pose2};

/// A pose is only re-placed where it puts at least this many points where the reference
/// looked: fewer are too few to average.
pub const MIN_SEEN_POINTS: usize = 20;

/// Bearing bins of a view: one degree.
const BINS: usize = 360;

/// A run of bins without a return this wide (45°) is the scanner's blind cone, not an
/// open direction: 270° and 180° scanners leave 90° and 180°.
const BLIND_CONE_BINS: usize = 45;

/// One scan of the reference: its sensor's position and its points, in the reference frame.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// Where the sensor stood.
    pub sensor: Point2,
    /// What it saw.
    pub points: &'a [Point2],
}

/// The cells some view of the reference saw along (free, wall or hidden behind a wall).
#[derive(Debug, Clone)]
pub struct ObservedRegion {
    origin: Point2,
    cell_m: f64,
    width: usize,
    height: usize,
    seen: Vec<bool>,
}

impl ObservedRegion {
    /// The region of `views`, on cells of `cell_m` covering `views` and the box
    /// `[lo, hi]` (where the queries will land); outside it nothing counts as seen.
    pub fn new(views: &[View], lo: Point2, hi: Point2, cell_m: f64) -> Self {
        let cell_m = cell_m.max(0.01);
        let covered = [lo, hi].into_iter().chain(
            views
                .iter()
                .flat_map(|v| v.points.iter().copied().chain(std::iter::once(v.sensor))),
        );
        let Some((lo, hi)) = bounding_box(covered) else {
            return Self {
                origin: Point2::new(0.0, 0.0),
                cell_m,
                width: 0,
                height: 0,
                seen: Vec::new(),
            };
        };
        let origin = Point2::new(lo.x - cell_m, lo.y - cell_m);
        let width = ((hi.x - lo.x) / cell_m).ceil() as usize + 3;
        let height = ((hi.y - lo.y) / cell_m).ceil() as usize + 3;
        let mut seen = vec![false; width * height];
        for v in views {
            let reach = reach_by_bearing(v);
            for (y, row) in seen.chunks_mut(width).enumerate() {
                let cy = origin.y + (y as f64 + 0.5) * cell_m - v.sensor.y;
                for (x, cell) in row.iter_mut().enumerate() {
                    if *cell {
                        continue;
                    }
                    let cx = origin.x + (x as f64 + 0.5) * cell_m - v.sensor.x;
                    let d_sq = cx * cx + cy * cy;
                    let r = reach[bin_of(cy.atan2(cx))];
                    *cell = d_sq <= cell_m * cell_m || d_sq <= r * r;
                }
            }
        }
        Self {
            origin,
            cell_m,
            width,
            height,
            seen,
        }
    }

    /// Whether a view saw along the cell holding `p`.
    pub fn contains(&self, p: Point2) -> bool {
        let x = ((p.x - self.origin.x) / self.cell_m).floor();
        let y = ((p.y - self.origin.y) / self.cell_m).floor();
        x >= 0.0
            && y >= 0.0
            && (x as usize) < self.width
            && (y as usize) < self.height
            && self.seen[y as usize * self.width + x as usize]
    }
}

/// The bearing bin of an angle in (−π, π].
fn bin_of(angle_rad: f64) -> usize {
    let u = (angle_rad + std::f64::consts::PI) / std::f64::consts::TAU;
    ((u * BINS as f64).floor() as usize).min(BINS - 1)
}

/// How far `view` saw along each bearing bin, meters: without limit where a return lies
/// (free before it, wall, hidden behind); as far as its farthest return where the scan
/// looked and got none (out of range: free that far); nowhere in its blind cone, the
/// widest run of bins without a return when it spans [`BLIND_CONE_BINS`] or more (a 360°
/// scanner has none). A gap of up to two bins between returns is a sparse scan (one
/// degree per beam, or points thinned by a voxel filter) and counts as a return.
fn reach_by_bearing(view: &View) -> Vec<f64> {
    let mut bins = vec![false; BINS];
    let mut farthest_m: f64 = 0.0;
    for p in view.points {
        let (dx, dy) = (p.x - view.sensor.x, p.y - view.sensor.y);
        if dx.is_finite() && dy.is_finite() && (dx != 0.0 || dy != 0.0) {
            bins[bin_of(dy.atan2(dx))] = true;
            farthest_m = farthest_m.max(dx.hypot(dy));
        }
    }
    let at = |i: usize, d: isize| bins[(i as isize + d).rem_euclid(BINS as isize) as usize];
    let returns: Vec<bool> = (0..BINS)
        .map(|i| bins[i] || ((at(i, -1) || at(i, -2)) && (at(i, 1) || at(i, 2))))
        .collect();
    let mut reach: Vec<f64> = returns
        .iter()
        .map(|&r| if r { f64::INFINITY } else { farthest_m })
        .collect();
    let Some(start) = returns.iter().position(|&r| r) else {
        return vec![0.0; BINS];
    };
    // The widest run without a return, walking the circle from a return.
    let (mut widest, mut run) = ((0, 0), (0, 0));
    for k in 1..=BINS {
        let i = (start + k) % BINS;
        if returns[i] {
            run = (0, 0);
        } else {
            run = (if run.1 == 0 { i } else { run.0 }, run.1 + 1);
            if run.1 > widest.1 {
                widest = run;
            }
        }
    }
    if widest.1 >= BLIND_CONE_BINS {
        for k in 0..widest.1 {
            reach[(widest.0 + k) % BINS] = 0.0;
        }
    }
    reach
}

/// A match re-placed by the score over the observed region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservedMatch {
    /// Pose of the scan in the reference frame: the mean of the plateau's translations, at
    /// the search's heading. On a sharp peak that is the peak; on a flat stretch (nothing
    /// both views saw pins it) it is the stretch's middle, and `covariance` says how long
    /// the stretch is, where the plateau's best cell would be an arbitrary point of it.
    pub pose: Pose2,
    /// The best `S_obs`: the mean likelihood of the points placed where the reference looked.
    pub score: f64,
    /// Covariance (m², x then y) of the translations whose `S_obs` reaches `fraction` of
    /// the best, plus one cell's own variance r²/12.
    pub covariance: [[f64; 2]; 2],
}

/// The plateau of `S_obs` of `points` over the translations within ±`radius_m` of `around`
/// (at its heading, on the field's cells) — those reaching `fraction` of the best — among
/// the translations whose plain score is at least `min_plain_score` (each would pass as a
/// match by itself: the overlap supports it) and that place at least [`MIN_SEEN_POINTS`]
/// points in `region` and at least a quarter as many as the translation that places most
/// there (a mean over fewer is a lottery); `None` when none qualifies. O((2·radius/r)² · n).
pub fn search_observed(
    field: &LikelihoodField,
    region: &ObservedRegion,
    points: &[Point2],
    around: &Pose2,
    radius_m: f64,
    min_plain_score: f64,
    fraction: f64,
) -> Option<ObservedMatch> {
    let res = field.config().resolution_m;
    let placed: Vec<Point2> = points
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .map(|p| around.transform_point(p))
        .collect();
    if placed.is_empty() {
        return None;
    }
    let reach = (radius_m.max(0.0) / res).ceil() as i64;
    let mut grid = Vec::with_capacity(((2 * reach + 1) * (2 * reach + 1)) as usize);
    for iy in -reach..=reach {
        for ix in -reach..=reach {
            let (dx, dy) = (ix as f64 * res, iy as f64 * res);
            let (mut plain, mut sum, mut seen) = (0.0, 0.0, 0usize);
            for p in &placed {
                let q = Point2::new(p.x + dx, p.y + dy);
                let l = field.likelihood(q);
                plain += l;
                if region.contains(q) {
                    sum += l;
                    seen += 1;
                }
            }
            grid.push((dx, dy, plain, sum, seen));
        }
    }
    let most_seen = grid.iter().map(|g| g.4).max().unwrap_or(0);
    let least_seen = MIN_SEEN_POINTS.max(most_seen.div_ceil(4));
    let least_plain = min_plain_score * placed.len() as f64;
    let candidates: Vec<(f64, f64, f64)> = grid
        .into_iter()
        .filter(|g| g.2 >= least_plain && g.4 >= least_seen)
        .map(|(dx, dy, _, sum, seen)| (dx, dy, sum / seen as f64))
        .collect();
    let best = candidates
        .iter()
        .copied()
        .max_by(|a, b| a.2.total_cmp(&b.2))?;
    // The plateau of S_obs, as `translation_covariance` takes it of the plain score.
    let threshold = fraction * best.2;
    let near: Vec<(f64, f64)> = candidates
        .iter()
        .filter(|c| c.2 >= threshold)
        .map(|c| (c.0, c.1))
        .collect();
    let ((mx, my), covariance) = plateau_spread(&near, res);
    Some(ObservedMatch {
        pose: Pose2::new(around.x + mx, around.y + my, around.heading_rad),
        score: best.2,
        covariance,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan_matching::correlative::tests::{corridor, door_frames};
    use crate::scan_matching::correlative::{CorrelativeConfig, SearchWindow};

    /// The corridor tests' cells: the corridor's 24 m and the window's reach around it.
    const CORRIDOR_BOX: (Point2, Point2) = (Point2::new(-16.0, -4.0), Point2::new(16.0, 4.0));

    /// The region seen by one view from the origin, on 0.2 m cells covering `[lo, hi]`.
    fn seen_from_origin(points: &[Point2], (lo, hi): (Point2, Point2)) -> ObservedRegion {
        let view = View {
            sensor: Point2::new(0.0, 0.0),
            points,
        };
        ObservedRegion::new(&[view], lo, hi, 0.2)
    }

    #[test]
    fn a_view_sees_ahead_of_it_and_not_into_its_blind_cone() {
        // A sensor at the origin with returns from bearings −135°..135° (a 270° scan) on a
        // circle of 5 m: ahead, beside and behind the returns are seen (free, wall,
        // hidden); straight behind (the 90° blind cone) is not.
        let points: Vec<Point2> = (-135..=135)
            .map(|d| {
                let a = (d as f64).to_radians();
                Point2::new(5.0 * a.cos(), 5.0 * a.sin())
            })
            .collect();
        let cells = (Point2::new(-20.0, -20.0), Point2::new(20.0, 20.0));
        let region = seen_from_origin(&points, cells);
        assert!(region.contains(Point2::new(2.0, 0.0)), "free, ahead");
        assert!(region.contains(Point2::new(5.0, 0.0)), "the wall");
        assert!(region.contains(Point2::new(12.0, 3.0)), "hidden behind it");
        assert!(region.contains(Point2::new(0.0, -4.0)), "beside");
        assert!(
            !region.contains(Point2::new(-3.0, 0.5)),
            "behind, in the blind cone"
        );
        assert!(!region.contains(Point2::new(-10.0, -5.0)), "bearing −153°");
        assert!(
            !region.contains(Point2::new(40.0, 0.0)),
            "outside the cells"
        );
        // Bearings 10°..30° got no return (out of range): free as far as the farthest
        // return (5 m), unseen beyond.
        let open: Vec<Point2> = points
            .iter()
            .copied()
            .filter(|p| !(10.0..=30.0).contains(&p.y.atan2(p.x).to_degrees()))
            .collect();
        let region = seen_from_origin(&open, cells);
        let at = |d: f64, r: f64| Point2::new(r * d.to_radians().cos(), r * d.to_radians().sin());
        assert!(region.contains(at(20.0, 3.0)), "free within range");
        assert!(!region.contains(at(20.0, 8.0)), "beyond the range");
        assert!(region.contains(at(40.0, 8.0)), "hidden behind a return");
        // One missing return between two is no hole.
        let holed: Vec<Point2> = points.iter().copied().step_by(2).collect();
        let region = seen_from_origin(&holed, cells);
        assert!((-130..=130).all(|d| {
            let a = (d as f64 + 0.5).to_radians();
            region.contains(Point2::new(8.0 * a.cos(), 8.0 * a.sin()))
        }));
    }

    #[test]
    fn an_opposite_pass_is_placed_on_the_door_both_saw_not_on_the_overlap() {
        // The reference looked east from x = 0 along a corridor with door frames at
        // x = 0.5 and 9: it saw x ≥ −1 (walls 1 m aside at bearings up to 135°), out to
        // 12 m. The scan looked west from x = 0 and saw x ≤ 1 out to −12 m, and the frame
        // at 0.5. The plain score grows as the scan slides east over what the reference
        // saw (its walls west of −1 m score 0 at the truth) and its top is metres east;
        // over the seen region only, the walls score alike everywhere and the frame at
        // 0.5 m, which both views saw, holds the scan at the truth.
        let mut reference = corridor(-1.0, 12.0);
        reference.extend(door_frames(&[0.5, 9.0]));
        let mut scan = corridor(-12.0, 1.0);
        scan.extend(door_frames(&[0.5]));
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        let window = SearchWindow {
            linear_m: 3.0,
            angular_rad: 0.0,
        };
        let plain = field.search(&scan, Pose2::IDENTITY, &window).unwrap();
        assert!(plain.pose.x > 1.5, "plain top {:?}", plain.pose);
        let region = seen_from_origin(&reference, CORRIDOR_BOX);
        let around = Pose2::new(1.0, 0.0, plain.pose.heading_rad);
        let m = search_observed(&field, &region, &scan, &around, 3.0, 0.0, 0.95).unwrap();
        let off_m = m.pose.x - 0.0;
        assert!(off_m.abs() < 0.1, "re-placed at {:?}", m.pose);
        assert!(m.pose.y.abs() < 0.06, "{:?}", m.pose);
        assert!(m.score > 0.8, "{}", m.score);
        assert!(m.covariance[0][0].sqrt() < 0.15, "{:?}", m.covariance);
    }

    #[test]
    fn only_poses_that_would_pass_on_their_own_are_placed() {
        // The opposite pass again: at the truth the plain score is low (most of the scan
        // lies where the reference never looked). Asking every candidate to reach a plain
        // score above the truth's keeps the answer among the poses the overlap supports.
        let mut reference = corridor(-1.0, 12.0);
        reference.extend(door_frames(&[0.5, 9.0]));
        let mut scan = corridor(-12.0, 1.0);
        scan.extend(door_frames(&[0.5]));
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        let region = seen_from_origin(&reference, CORRIDOR_BOX);
        let at_truth = field.score(&scan, &Pose2::IDENTITY);
        let least = at_truth + 0.05;
        let around = Pose2::new(1.0, 0.0, 0.0);
        let m = search_observed(&field, &region, &scan, &around, 3.0, least, 0.95).unwrap();
        assert!(m.pose.x > 0.2, "{:?}", m.pose);
        // Every pose of its plateau passed, so the plateau's middle lies between them.
        assert!(field.score(&scan, &m.pose) > at_truth, "{:?}", m.pose);
        assert!(
            search_observed(&field, &region, &scan, &around, 3.0, 0.99, 0.95).is_none(),
            "no pose explains 99 % of the scan"
        );
    }

    #[test]
    fn without_a_feature_both_saw_the_plateau_spans_the_corridor() {
        // The same passes with no frame in the overlap: nothing pins the scan along the
        // corridor, and S_obs says so (σ along ≫ the kernel) instead of a top at the
        // overlap.
        let reference = corridor(-1.0, 12.0);
        let scan = corridor(-12.0, 1.0);
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        let region = seen_from_origin(&reference, CORRIDOR_BOX);
        let top = Pose2::new(1.0, 0.0, 0.0);
        let m = search_observed(&field, &region, &scan, &top, 3.0, 0.0, 0.95).unwrap();
        assert!(m.covariance[0][0].sqrt() > 0.5, "{:?}", m.covariance);
        assert!(m.covariance[1][1].sqrt() < 0.1, "{:?}", m.covariance);
    }

    #[test]
    fn a_scan_the_reference_never_saw_is_not_placed() {
        let reference = corridor(-1.0, 12.0);
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        let region = ObservedRegion::new(&[], Point2::new(-5.0, -5.0), Point2::new(5.0, 5.0), 0.2);
        let scan = corridor(-3.0, 3.0);
        assert!(
            search_observed(&field, &region, &scan, &Pose2::IDENTITY, 1.0, 0.0, 0.95).is_none()
        );
    }
}
