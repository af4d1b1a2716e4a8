//! Matching a new keyframe against an earlier one: the local map around the older
//! keyframe, correlative search then ICP, and the loop edge's information from the match's
//! score plateau; the match back (the older scan against the newer side's map).
//!
//! Called by [`super::LoopCloser`] for each candidate; what it returns still has to pass
//! the consistency tests ([`crate::back_end::closure_consistency`]) before it enters the
//! graph.

use super::{LoopCloser, LoopClosureConfig, LoopHeadingSigma, MatchedLoop};
use crate::back_end::closure_consistency::{GIVEN_UP_M2, LoopHypothesis, two_way_distance_sq};
use crate::back_end::loop_closure::LoopClosure;
use crate::back_end::pose_graph::Edge;
use crate::scan_matching::correlative::{
    LikelihoodField, SearchWindow, bounding_box, voxel_filter,
};
use crate::scan_matching::icp::{Icp, IcpMode};
use crate::scan_matching::observed_region::{ObservedRegion, View, search_observed};
use nalgebra::Matrix3;
use sketchslam_types::{Point2, Pose2, wrap_angle};

impl LoopCloser {
    /// The local map around keyframe `anchor`: the points of keyframes `lo..=hi` that
    /// `keep` accepts, in `anchor`'s frame, and where each of them looked from (its sensor
    /// position and its points' range in the map).
    fn local_map(
        &self,
        anchor: usize,
        lo: usize,
        hi: usize,
        keep: impl Fn(usize) -> bool,
    ) -> (Vec<Point2>, Vec<(Point2, std::ops::Range<usize>)>) {
        let nodes = self.graph.nodes();
        let at = nodes[anchor];
        let mut local = Vec::new();
        let mut views = Vec::new();
        for k in (lo..=hi.min(nodes.len() - 1)).filter(|&k| keep(k)) {
            let rel = at.between(&nodes[k]);
            let start = local.len();
            local.extend(self.points[k].iter().map(|p| rel.transform_point(p)));
            views.push((rel.position(), start..local.len()));
        }
        (local, views)
    }

    /// Matches keyframe `new` against the local map around `old`: the loop and its edge
    /// when the match is good (not yet in the graph: [`Self::verify`] decides).
    pub(super) fn match_loop(
        &self,
        old: usize,
        new: usize,
        window: &SearchWindow,
    ) -> Option<MatchedLoop> {
        let c = &self.config;
        let nodes = self.graph.nodes();
        let anchor = nodes[old];
        // The local map: `old` and its neighbours on the route, in `old`'s frame, leaving
        // out keyframes too close on the route to `new` (they share its drift).
        let lo = old.saturating_sub(c.local_map_keyframes);
        let hi = (old + c.local_map_keyframes).min(new);
        let (local, views) = self.local_map(old, lo, hi, |k| {
            self.travel_m[new] - self.travel_m[k] >= 0.5 * c.min_travel_m
        });
        let scan = &self.points[new];
        if local.len() < 20 || scan.len() < 20 {
            return None;
        }
        let field = LikelihoodField::new(&local, c.correlative);
        let query = voxel_filter(scan, 2.0 * c.voxel_m);
        let guess = anchor.between(&nodes[new]);
        let mut found = field.search(&query, guess, window)?;
        if found.score < c.min_score {
            return None;
        }
        let observed = if c.score_observed_only {
            let views: Vec<View> = views
                .iter()
                .map(|(sensor, range)| View {
                    sensor: *sensor,
                    points: &local[range.clone()],
                })
                .collect();
            let (lo, hi) = placed_box(&query, &guess, window.linear_m);
            let cell_m = c.correlative.resolution_m * c.correlative.coarse_factor as f64;
            let region = ObservedRegion::new(&views, lo, hi, cell_m);
            let around = Pose2::new(guess.x, guess.y, found.pose.heading_rad);
            let m = search_observed(
                &field,
                &region,
                &query,
                &around,
                window.linear_m,
                c.min_score,
                c.plateau_fraction,
            )?;
            found.pose = m.pose;
            Some(m)
        } else {
            None
        };
        let measurement = self.refined(&local, scan, found.pose);
        let score = field.score(&query, &measurement).max(found.score);
        // In a corridor the match slides along it: the edge's information follows the
        // score plateau, so it holds the position across the corridor and the heading,
        // and leaves the position along it to the sequential edges.
        let plateau = match observed {
            Some(m) => m.covariance,
            None => field.translation_covariance(
                &query,
                &found.pose,
                window.linear_m,
                c.plateau_fraction,
            ),
        };
        let plateau = as_matrix(plateau);
        let sigma_sq = c.loop_sigma_m * c.loop_sigma_m;
        let loop_noise = nalgebra::Matrix2::identity() * sigma_sq;
        let weakest_var = (plateau + loop_noise).symmetric_eigenvalues().max();
        if !weakest_var.is_finite() || weakest_var.sqrt() > c.max_match_sigma_m {
            return None;
        }
        // The consistency tests weigh the match as its plateau claims. The graph edge
        // gives up the weakest direction when the plateau along it is a featureless hump
        // (a corridor seen from its other end): there it pins nothing, and the loops of
        // one pass share its bias, so they must not add up to a pull along the corridor.
        let heading_var = self.heading_variance(&field, &query, &found.pose, window);
        let claimed = loop_information(plateau + loop_noise, measurement.heading_rad, heading_var)?;
        let unpinned = if c.unpin_featureless_direction {
            let placed: Vec<Point2> = query
                .iter()
                .map(|p| found.pose.transform_point(p))
                .collect();
            overlap_driven_direction(plateau, sigma_sq, &local, &placed, c)
        } else {
            None
        };
        let information = match unpinned {
            Some(u) => loop_information(
                plateau + u * u.transpose() * GIVEN_UP_M2 + loop_noise,
                measurement.heading_rad,
                heading_var,
            )?,
            None => claimed,
        };
        let edge = Edge {
            from: old,
            to: new,
            measurement: Pose2::new(
                measurement.x,
                measurement.y,
                wrap_angle(measurement.heading_rad),
            ),
            information,
            huber: Some(c.loop_huber),
        };
        let covariance = claimed.try_inverse()?;
        let hypothesis = LoopHypothesis {
            from: old,
            to: new,
            measurement: edge.measurement,
            covariance: 0.5 * (covariance + covariance.transpose()),
        };
        let closure = LoopClosure {
            from: old,
            to: new,
            score,
            chain_d2: f64::NAN,
            chain_sigma_m: f64::NAN,
            chain_sigma_deg: f64::NAN,
            loop_sigma_deg: f64::NAN,
        };
        Some(MatchedLoop {
            closure,
            hypothesis,
            edge,
        })
    }
}

impl LoopCloser {
    /// Test 3 of [`crate::back_end::closure_consistency`]: the older keyframe's scan
    /// matched against the local map of the newer one and the `4 · local_map_keyframes`
    /// keyframes before it (twice what a local map spans, since the newer side has no
    /// keyframes after it), from the loop's inverse, in the same `window`; true when that
    /// match scores and undoes the loop within `consistency_chi2`.
    pub(super) fn matches_back(&self, found: &MatchedLoop, window: &SearchWindow) -> bool {
        let c = &self.config;
        let (old, new) = (found.hypothesis.from, found.hypothesis.to);
        let lo = new.saturating_sub(4 * c.local_map_keyframes);
        // Keyframes near `old` on the route share its view: they stay out.
        let (local, _) = self.local_map(new, lo, new, |k| {
            self.travel_m[k] - self.travel_m[old] >= 0.5 * c.min_travel_m
        });
        let scan = &self.points[old];
        // A newer side that saw too little of the older keyframe's view to match it back
        // refuses the loop, as a match back that scores too low does.
        if local.len() < 20 || scan.len() < 20 {
            return false;
        }
        let field = LikelihoodField::new(&local, c.correlative);
        let query = voxel_filter(scan, 2.0 * c.voxel_m);
        let guess = found.hypothesis.measurement.inverse();
        let Some(back) = field.search(&query, guess, window) else {
            return false;
        };
        if back.score < c.min_score {
            return false;
        }
        let reverse = self.refined(&local, scan, back.pose);
        let plateau = as_matrix(field.translation_covariance(
            &query,
            &back.pose,
            window.linear_m,
            c.plateau_fraction,
        ));
        let loop_noise = nalgebra::Matrix2::identity() * (c.loop_sigma_m * c.loop_sigma_m);
        let heading_var = self.heading_variance(&field, &query, &back.pose, window);
        let Some(reverse_cov) =
            loop_information(plateau + loop_noise, reverse.heading_rad, heading_var)
                .and_then(|info| info.try_inverse())
        else {
            return false;
        };
        let d2 = two_way_distance_sq(
            &found.hypothesis.measurement,
            &found.hypothesis.covariance,
            &reverse,
            &reverse_cov,
        );
        d2 <= c.consistency_chi2
    }

    /// A loop edge's heading variance, rad², as `loop_heading` asks
    /// ([`LoopHeadingSigma`]): `loop_sigma_rad²`, or the match's own — the heading plateau
    /// of `query` at `top` ([`LikelihoodField::heading_variance`], within the search's
    /// angular window) plus the loop's position noise `loop_sigma_m` at the points' rms
    /// range, as the translation's plateau gets `loop_sigma_m²` — or the smaller of both.
    fn heading_variance(
        &self,
        field: &LikelihoodField,
        query: &[Point2],
        top: &Pose2,
        window: &SearchWindow,
    ) -> f64 {
        let c = &self.config;
        let set = c.loop_sigma_rad.max(1e-5).powi(2);
        let measured = || {
            let range_sq_m2 =
                query.iter().map(|p| p.norm().powi(2)).sum::<f64>() / query.len().max(1) as f64;
            let lever_rad2 = c.loop_sigma_m.powi(2) / range_sq_m2.max(c.loop_sigma_m.powi(2));
            field.heading_variance(query, top, window.angular_rad, c.plateau_fraction) + lever_rad2
        };
        match c.loop_heading {
            LoopHeadingSigma::Set => set,
            LoopHeadingSigma::Plateau => measured(),
            LoopHeadingSigma::PlateauWithinSet => measured().min(set),
        }
    }

    /// `found` refined by point-to-line ICP of `scan` against `local`, when ICP converges
    /// near it (within the correlative search's resolution and 2°); `found` otherwise.
    fn refined(&self, local: &[Point2], scan: &[Point2], found: Pose2) -> Pose2 {
        let c = &self.config;
        let refined = Icp::new(local, c.icp).align(scan, found, IcpMode::Full);
        let moved = found.between(&refined.pose);
        let agrees = refined.converged
            && refined.pose.is_finite()
            && moved.position().norm() < 2.0 * c.correlative.resolution_m + 0.05
            && moved.heading_rad.abs() < 2f64.to_radians();
        if agrees { refined.pose } else { found }
    }
}

/// A plateau's covariance as [`LikelihoodField::translation_covariance`] gives it (rows
/// of x and y), as a matrix.
fn as_matrix(c: [[f64; 2]; 2]) -> nalgebra::Matrix2<f64> {
    nalgebra::Matrix2::new(c[0][0], c[0][1], c[1][0], c[1][1])
}

/// The box the finite `points` cover when placed at `guess` (and `guess` itself), widened
/// by `margin_m`.
fn placed_box(points: &[Point2], guess: &Pose2, margin_m: f64) -> (Point2, Point2) {
    let placed = points.iter().map(|p| guess.transform_point(p));
    let (lo, hi) = bounding_box(std::iter::once(guess.position()).chain(placed))
        .unwrap_or((guess.position(), guess.position()));
    let m = margin_m.max(0.0);
    (
        Point2::new(lo.x - m, lo.y - m),
        Point2::new(hi.x + m, hi.y + m),
    )
}

/// A loop edge's information from its translation covariance `cov_xy` (m², in `old`'s
/// frame, as the plateau is) and its heading variance `heading_var_rad2`; the edge's error
/// is in the frame of the measurement (rotated by its `heading_rad`). `None` when `cov_xy`
/// is singular.
fn loop_information(
    cov_xy: nalgebra::Matrix2<f64>,
    heading_rad: f64,
    heading_var_rad2: f64,
) -> Option<Matrix3<f64>> {
    let info_xy = cov_xy.try_inverse()?;
    let (sin, cos) = heading_rad.sin_cos();
    let r = nalgebra::Matrix2::new(cos, -sin, sin, cos);
    let info_xy = r.transpose() * info_xy * r;
    let info_xy = 0.5 * (info_xy + info_xy.transpose());
    let mut information = Matrix3::zeros();
    information.fixed_view_mut::<2, 2>(0, 0).copy_from(&info_xy);
    information[(2, 2)] = 1.0 / heading_var_rad2.max(1e-10);
    Some(information)
}

/// The plateau's weakest direction (unit vector, `old`'s frame) when the match does not pin
/// it: the plateau is wider there than the likelihood kernel, and the scan `placed` at the
/// match reaches beyond the `reference` along it further than the loop claims to be sure
/// (`√(λ_weak + loop_var_m2)`). `None` when the match holds.
///
/// Why: a feature (a door jamb, a corner, a pillar) seen through the field
/// `exp(−d²/2σ²)` makes a score peak about σ wide, whose top within 95 % of the best is
/// ±0.32σ (a uniform σ of ≈ 0.2σ, one cell's rounding added). A top flatter than σ itself
/// has no feature on it: it is the hump of a corridor or a long wall. Where the scan also
/// reaches beyond the reference along it, the score rises with how much of the scan
/// overlaps the reference, not with where the scan belongs, and the top is pulled toward
/// more overlap by up to that reach: two passes of a corridor in opposite directions see
/// different stretches of it. Measured on paper-env2's dead-end spurs (plateau σ
/// 0.27–0.32 m, off the truth by 0.10–1.08 m) and on the MIT CSAIL log (plateau σ
/// 0.19–0.49 m, 0.3–1.8 m from the chain's estimate, against 0.03–0.07 m and ≤ 0.05 m for
/// 96 of its 111 matches). The loops of one pass share that bias, so their information
/// along the corridor must not add up; across it and in heading they hold. Where the scan
/// lies within the reference (a revisit in the same direction, a 360° scanner), sliding
/// it along the plateau changes no overlap and the plateau is kept as it is.
fn overlap_driven_direction(
    plateau: nalgebra::Matrix2<f64>,
    loop_var_m2: f64,
    reference: &[Point2],
    placed: &[Point2],
    c: &LoopClosureConfig,
) -> Option<nalgebra::Vector2<f64>> {
    let eigen = nalgebra::SymmetricEigen::new(plateau);
    let weak = eigen.eigenvalues.imax();
    let weak_var_m2 = eigen.eigenvalues[weak].max(0.0);
    if weak_var_m2.sqrt() <= c.correlative.sigma_m {
        return None;
    }
    let u = eigen.eigenvectors.column(weak).into_owned();
    let reach_m = outreach_m(reference, placed, (u[0], u[1]));
    (reach_m > (weak_var_m2 + loop_var_m2).sqrt()).then_some(u)
}

/// How far the `placed` points reach beyond the `reference` along the unit direction `u`,
/// at either end, meters (0 when they lie within it): the extents are the 2nd and 98th
/// percentiles of the points' projections on `u`, so a few stray returns do not count.
/// O(n log n).
fn outreach_m(reference: &[Point2], placed: &[Point2], u: (f64, f64)) -> f64 {
    let extent = |points: &[Point2]| {
        let mut along: Vec<f64> = points
            .iter()
            .map(|p| p.x * u.0 + p.y * u.1)
            .filter(|a| a.is_finite())
            .collect();
        if along.is_empty() {
            return None;
        }
        along.sort_by(f64::total_cmp);
        let at = |q: f64| along[((along.len() - 1) as f64 * q).round() as usize];
        Some((at(0.02), at(0.98)))
    };
    match (extent(reference), extent(placed)) {
        (Some((r_lo, r_hi)), Some((s_lo, s_hi))) => (s_hi - r_hi).max(r_lo - s_lo).max(0.0),
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outreach_counts_what_lies_beyond_the_reference_along_a_direction() {
        // A reference along x from 0 to 10 m, a scan from 6 to 16 m: 6 m beyond along x
        // (the 2nd/98th percentiles of 101 evenly spread points sit 0.2 m in from either
        // end of both, so the reach is still 6 m), nothing beyond along y.
        let line = |x0: f64| -> Vec<Point2> {
            (0..=100)
                .map(|i| Point2::new(x0 + 0.1 * i as f64, 0.0))
                .collect()
        };
        let (reference, scan) = (line(0.0), line(6.0));
        assert!((outreach_m(&reference, &scan, (1.0, 0.0)) - 6.0).abs() < 1e-9);
        assert!(outreach_m(&reference, &scan, (0.0, 1.0)).abs() < 1e-12);
        // A scan inside the reference reaches nowhere.
        assert_eq!(outreach_m(&reference, &line(2.0)[..50], (1.0, 0.0)), 0.0);
    }

    #[test]
    fn a_hump_the_scan_overhangs_gives_up_its_weak_direction_only() {
        // A corridor along (cos 30°, sin 30°): the plateau 0.3 m along it (wider than the
        // 0.1 m kernel), 0.02 m across.
        let c = LoopClosureConfig::default();
        let (cos, sin) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let r = nalgebra::Matrix2::new(cos, -sin, sin, cos);
        let hump = r * nalgebra::Matrix2::new(0.09, 0.0, 0.0, 0.0004) * r.transpose();
        let along = |d: f64| Point2::new(d * cos, d * sin);
        let reference: Vec<Point2> = (0..=100).map(|i| along(0.1 * i as f64)).collect();
        // The scan reaches 4 m beyond the reference: the direction is given up...
        let overhang: Vec<Point2> = (0..=100).map(|i| along(4.0 + 0.1 * i as f64)).collect();
        let u = overlap_driven_direction(hump, 0.0025, &reference, &overhang, &c).unwrap();
        assert!((u[0] * cos + u[1] * sin).abs() > 1.0 - 1e-9, "{u:?}");
        // ...one within it is not (sliding it changes no overlap)...
        let inside: Vec<Point2> = (20..=80).map(|i| along(0.1 * i as f64)).collect();
        assert!(overlap_driven_direction(hump, 0.0025, &reference, &inside, &c).is_none());
        // ...nor is a door jamb's top, 0.06 m along, whatever the overhang.
        let jamb = r * nalgebra::Matrix2::new(0.0036, 0.0, 0.0, 0.0004) * r.transpose();
        assert!(overlap_driven_direction(jamb, 0.0025, &reference, &overhang, &c).is_none());
    }
}
