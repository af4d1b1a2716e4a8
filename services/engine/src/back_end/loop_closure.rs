//! Loop closure: keyframes, the constraints between them, and the pose graph they make.
//!
//! Sits behind the `sketch` method's per-scan front end (MCL on the drawing, eq. 5
//! heading, eq. 6 ICP): the front end's poses are good over a few metres, but every
//! small error of scan matching adds up, and on a long route (the Intel Lab log, a loop
//! through a building) the map's far ends no longer agree. The drawing bounds the
//! heading; the position needs a second view of the same place.
//!
//! Every `keyframe_distance_m` of travel (or turn of `keyframe_angle_rad`) the front end's pose
//! becomes a node of a [`PoseGraph`] with a sequential edge from the previous keyframe (their
//! relative pose as the front end saw it). Each new keyframe is then matched against the
//! earlier keyframes it could be revisiting — near its estimate, but at least `min_travel_m` of
//! route behind — by correlative search ([`crate::scan_matching::correlative`], the window
//! covers the drift) and point-to-line ICP against a local map of the candidate and its
//! neighbours. A match that scores well enough adds a loop edge with a Huber kernel (a wrong
//! match in a look-alike corridor is down-weighted, not obeyed), and the graph is optimized.
//! The mapper then re-anchors its trajectory and rebuilds its grid on the optimized keyframes.
//!
//! Pure: values in, values out.

use crate::back_end::pose_graph::{Edge, OptimizeConfig, PoseGraph};
use crate::scan_matching::correlative::{
    CorrelativeConfig, LikelihoodField, SearchWindow, voxel_filter,
};
use crate::scan_matching::icp::{Icp, IcpConfig, IcpMode};
use nalgebra::Matrix3;
use sketchslam_types::{Point2, Pose2, wrap_angle};

/// Settings of the loop-closure back end.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopClosureConfig {
    /// A new keyframe after this much travel, meters...
    pub keyframe_distance_m: f64,
    /// ...or this much turn, radians.
    pub keyframe_angle_rad: f64,
    /// Route length between two keyframes before a match between them is a loop, meters.
    pub min_travel_m: f64,
    /// Candidate keyframes lie within this distance of the new keyframe's estimate, meters
    /// (plus however much the search window has grown beyond `window.linear_m`).
    pub search_radius_m: f64,
    /// Candidates tried per new keyframe, nearest first.
    pub max_candidates: usize,
    /// Keyframes on each side of a candidate that join its local map.
    pub local_map_keyframes: usize,
    /// Correlative search window around the estimate, right after a loop closed.
    pub window: SearchWindow,
    /// The window's linear half-width grows by this share of the route travelled since
    /// the last loop closed: the front end's drift grows with distance, and a window
    /// narrower than the drift finds no match at all, m/m.
    pub window_growth_per_m: f64,
    /// The window's linear half-width stops growing here, meters (the search's cost
    /// grows with its area).
    pub max_window_m: f64,
    /// Likelihood field of the correlative search.
    pub correlative: CorrelativeConfig,
    /// Least mean likelihood (0..1) of an accepted loop match.
    pub min_score: f64,
    /// Translations scoring at least this share of the best make up a match's
    /// uncertainty region ([`LikelihoodField::translation_covariance`]).
    pub plateau_fraction: f64,
    /// A match whose uncertainty region is wider than this (standard deviation along its
    /// weakest direction) pins nothing down and is dropped, meters.
    pub max_match_sigma_m: f64,
    /// ICP refining a loop match.
    pub icp: IcpConfig,
    /// Standard deviation of a sequential edge: this plus `sequential_sigma_per_m` per
    /// meter of the step, meters.
    pub sequential_sigma_m: f64,
    /// Growth of the sequential sigma per meter travelled.
    pub sequential_sigma_per_m: f64,
    /// Heading standard deviation of a sequential edge, radians.
    pub sequential_sigma_rad: f64,
    /// Standard deviation of a loop edge, meters.
    pub loop_sigma_m: f64,
    /// Heading standard deviation of a loop edge, radians.
    pub loop_sigma_rad: f64,
    /// Huber width of loop edges on the Mahalanobis distance.
    pub loop_huber: f64,
    /// Standard deviation of a keyframe's heading prior from the drawing's wall
    /// directions ([`crate::lines::wall_directions`]), radians; `None` leaves priors out. Off
    /// by default: measured on the Intel Lab, whose drawings' two directions are 94.7°
    /// and 96.5° apart and whose real walls curve, the priors bent the map (relations
    /// 0.136 → 0.910 m with person-1).
    pub heading_prior_sigma_rad: Option<f64>,
    /// Huber width of heading priors on the Mahalanobis distance.
    pub heading_prior_huber: f64,
    /// With heading priors pending, the graph is optimized every this many keyframes.
    pub optimize_every_keyframes: usize,
    /// Keyframe points are thinned to one per square of this side, meters.
    pub voxel_m: f64,
    /// Gauss–Newton settings.
    pub optimize: OptimizeConfig,
}

impl Default for LoopClosureConfig {
    fn default() -> Self {
        Self {
            keyframe_distance_m: 0.5,
            keyframe_angle_rad: 20f64.to_radians(),
            min_travel_m: 8.0,
            search_radius_m: 4.0,
            max_candidates: 1,
            local_map_keyframes: 4,
            window: SearchWindow {
                linear_m: 1.5,
                angular_rad: 12f64.to_radians(),
            },
            window_growth_per_m: 0.1,
            max_window_m: 3.0,
            correlative: CorrelativeConfig::default(),
            min_score: 0.6,
            plateau_fraction: 0.95,
            max_match_sigma_m: 0.5,
            icp: IcpConfig::default(),
            sequential_sigma_m: 0.02,
            sequential_sigma_per_m: 0.02,
            sequential_sigma_rad: 0.5f64.to_radians(),
            loop_sigma_m: 0.05,
            loop_sigma_rad: 1f64.to_radians(),
            loop_huber: 2.0,
            heading_prior_sigma_rad: None,
            heading_prior_huber: 2.0,
            optimize_every_keyframes: 10,
            voxel_m: 0.05,
            optimize: OptimizeConfig::default(),
        }
    }
}

/// A loop edge the back end added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopClosure {
    /// The earlier keyframe.
    pub from: usize,
    /// The new keyframe.
    pub to: usize,
    /// Mean likelihood of the match, 0..1.
    pub score: f64,
}

/// What adding a keyframe did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyframeOutcome {
    /// The keyframe's node index.
    pub index: usize,
    /// True when a loop was closed and the graph optimized: every keyframe may have moved.
    pub optimized: bool,
}

/// The keyframes, their points and the pose graph.
#[derive(Debug, Clone)]
pub struct LoopCloser {
    config: LoopClosureConfig,
    graph: PoseGraph,
    /// Scan points of each keyframe, robot frame, thinned.
    points: Vec<Vec<Point2>>,
    /// Route length at each keyframe, meters.
    travel_m: Vec<f64>,
    closures: Vec<LoopClosure>,
    /// Heading priors added since the last optimization.
    pending_priors: usize,
}

impl LoopCloser {
    /// An empty back end.
    pub fn new(config: LoopClosureConfig) -> Self {
        Self {
            config,
            graph: PoseGraph::new(),
            points: Vec::new(),
            travel_m: Vec::new(),
            closures: Vec::new(),
            pending_priors: 0,
        }
    }

    /// True when `pose` (map frame) is far enough from the last keyframe to be a new one.
    pub fn wants_keyframe(&self, pose: &Pose2) -> bool {
        match self.graph.nodes().last() {
            None => true,
            Some(last) => {
                let step = last.between(pose);
                step.position().norm() >= self.config.keyframe_distance_m
                    || step.heading_rad.abs() >= self.config.keyframe_angle_rad
            }
        }
    }

    /// True when keyframes take heading priors from the drawing.
    pub fn uses_heading_priors(&self) -> bool {
        self.config.heading_prior_sigma_rad.is_some()
    }

    /// Keyframe poses, map frame (optimized where loops were closed).
    pub fn poses(&self) -> &[Pose2] {
        self.graph.nodes()
    }

    /// The loops closed so far.
    pub fn closures(&self) -> &[LoopClosure] {
        &self.closures
    }

    /// Adds a keyframe at the front end's `pose` (map frame, consistent with the graph's
    /// current poses) with its scan `points` (robot frame) and, when the drawing gave one,
    /// a prior on its map heading; tries to close loops from it and optimizes the graph
    /// when one closes (or every `optimize_every_keyframes` with priors pending).
    pub fn add_keyframe(
        &mut self,
        pose: Pose2,
        points: &[Point2],
        heading_prior_rad: Option<f64>,
    ) -> KeyframeOutcome {
        let c = &self.config;
        let thinned = voxel_filter(points, c.voxel_m);
        let index = self.graph.add_node(pose);
        let travel = match index.checked_sub(1) {
            Some(prev) => {
                let prev_pose = self.graph.nodes()[prev];
                let step = prev_pose.between(&pose);
                let length_m = step.position().norm();
                let sigma_m = c.sequential_sigma_m + c.sequential_sigma_per_m * length_m;
                let edge = Edge {
                    from: prev,
                    to: index,
                    measurement: step,
                    information: information(sigma_m, c.sequential_sigma_rad),
                    huber: None,
                };
                // The pose is finite (the mapper refuses others), so the edge is valid.
                let _ = self.graph.add_edge(edge);
                self.travel_m[prev] + length_m
            }
            None => 0.0,
        };
        self.points.push(thinned);
        self.travel_m.push(travel);
        let prior = heading_prior_rad.zip(c.heading_prior_sigma_rad);
        if let Some((heading, sigma_rad)) = prior.filter(|(h, _)| h.is_finite() && index > 0) {
            // A heading-only edge from the fixed node 0: e = θ_i − θ_0 − (h − θ_0), its
            // position part carries no information (a negligible weight keeps Ω definite).
            let origin = self.graph.nodes()[0];
            let rel = origin.between(&pose);
            let sr = sigma_rad.max(1e-5);
            let edge = Edge {
                from: 0,
                to: index,
                measurement: Pose2::new(rel.x, rel.y, wrap_angle(heading - origin.heading_rad)),
                information: Matrix3::from_diagonal(&nalgebra::Vector3::new(
                    1e-9,
                    1e-9,
                    1.0 / (sr * sr),
                )),
                huber: Some(c.heading_prior_huber),
            };
            if self.graph.add_edge(edge).is_ok() {
                self.pending_priors += 1;
            }
        }

        let mut closed = false;
        let window = self.window(index);
        for candidate in self.candidates(index, &window) {
            if let Some(closure) = self.try_close(candidate, index, &window) {
                self.closures.push(closure);
                closed = true;
            }
        }
        let periodic = self.pending_priors > 0
            && index.is_multiple_of(self.config.optimize_every_keyframes.max(1));
        let optimized = closed || periodic;
        if optimized {
            let config = self.config.optimize;
            self.graph.optimize(&config);
            self.pending_priors = 0;
        }
        KeyframeOutcome { index, optimized }
    }

    /// The correlative search window for keyframe `new`: `window` widened by
    /// `window_growth_per_m` of the route since the last closure, up to `max_window_m`.
    fn window(&self, new: usize) -> SearchWindow {
        let c = &self.config;
        // Route length at the last closure: that of its newer keyframe.
        let closed_at_m = self.closures.last().map_or(0.0, |c| self.travel_m[c.to]);
        let since_m = (self.travel_m[new] - closed_at_m).max(0.0);
        let grown_m = c.window.linear_m + c.window_growth_per_m.max(0.0) * since_m;
        SearchWindow {
            linear_m: grown_m.min(c.max_window_m.max(c.window.linear_m)),
            angular_rad: c.window.angular_rad,
        }
    }

    /// Earlier keyframes `new` may be revisiting: near its estimate (within the search
    /// radius widened as much as `window` is) and far enough behind on the route, nearest
    /// first.
    fn candidates(&self, new: usize, window: &SearchWindow) -> Vec<usize> {
        let c = &self.config;
        let at = self.graph.nodes()[new].position();
        let radius_m = c.search_radius_m + (window.linear_m - c.window.linear_m).max(0.0);
        let mut near: Vec<(f64, usize)> = (0..new)
            .filter(|&i| self.travel_m[new] - self.travel_m[i] >= c.min_travel_m)
            .map(|i| (self.graph.nodes()[i].position().distance(&at), i))
            .filter(|(d, _)| *d <= radius_m)
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        near.into_iter()
            .take(c.max_candidates)
            .map(|(_, i)| i)
            .collect()
    }

    /// Matches keyframe `new` against the local map around `old`; the closure when the
    /// match is good, after adding its edge.
    fn try_close(&mut self, old: usize, new: usize, window: &SearchWindow) -> Option<LoopClosure> {
        let c = &self.config;
        let nodes = self.graph.nodes();
        let anchor = nodes[old];
        // The local map: `old` and its neighbours on the route, in `old`'s frame, leaving
        // out keyframes too close on the route to `new` (they share its drift).
        let lo = old.saturating_sub(c.local_map_keyframes);
        let hi = (old + c.local_map_keyframes).min(new);
        let mut local = Vec::new();
        for ((node, points), travel_m) in nodes
            .iter()
            .zip(&self.points)
            .zip(&self.travel_m)
            .take(hi + 1)
            .skip(lo)
        {
            if self.travel_m[new] - travel_m < 0.5 * c.min_travel_m {
                continue;
            }
            let rel = anchor.between(node);
            local.extend(points.iter().map(|p| rel.transform_point(p)));
        }
        let scan = &self.points[new];
        if local.len() < 20 || scan.len() < 20 {
            return None;
        }
        let field = LikelihoodField::new(&local, c.correlative);
        let query = voxel_filter(scan, 2.0 * c.voxel_m);
        let guess = anchor.between(&nodes[new]);
        let found = field.search(&query, guess, window)?;
        if found.score < c.min_score {
            return None;
        }
        let refined = Icp::new(&local, c.icp).align(scan, found.pose, IcpMode::Full);
        let moved = found.pose.between(&refined.pose);
        let agrees = refined.converged
            && refined.pose.is_finite()
            && moved.position().norm() < 2.0 * c.correlative.resolution_m + 0.05
            && moved.heading_rad.abs() < 2f64.to_radians();
        let measurement = if agrees { refined.pose } else { found.pose };
        let score = field.score(&query, &measurement).max(found.score);
        // In a corridor the match slides along it: the edge's information follows the
        // score plateau, so it holds the position across the corridor and the heading,
        // and leaves the position along it to the sequential edges.
        let plateau =
            field.translation_covariance(&query, &found.pose, window.linear_m, c.plateau_fraction);
        let sigma_sq = c.loop_sigma_m * c.loop_sigma_m;
        let cov = nalgebra::Matrix2::new(
            plateau[0][0] + sigma_sq,
            plateau[0][1],
            plateau[1][0],
            plateau[1][1] + sigma_sq,
        );
        let weakest_var = cov.symmetric_eigenvalues().max();
        if !weakest_var.is_finite() || weakest_var.sqrt() > c.max_match_sigma_m {
            return None;
        }
        let info_xy = cov.try_inverse()?;
        // The measurement is expressed in `old`'s frame, as is the plateau; the edge's
        // error is in the frame of the measurement (rotated by its heading).
        let (sin, cos) = measurement.heading_rad.sin_cos();
        let r = nalgebra::Matrix2::new(cos, -sin, sin, cos);
        let info_xy = r.transpose() * info_xy * r;
        let info_xy = 0.5 * (info_xy + info_xy.transpose());
        let sr = c.loop_sigma_rad.max(1e-5);
        let mut information = Matrix3::zeros();
        information.fixed_view_mut::<2, 2>(0, 0).copy_from(&info_xy);
        information[(2, 2)] = 1.0 / (sr * sr);
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
        self.graph.add_edge(edge).ok()?;
        Some(LoopClosure {
            from: old,
            to: new,
            score,
        })
    }
}

/// Diagonal information matrix of independent x, y (sigma_m) and heading (sigma_rad).
fn information(sigma_m: f64, sigma_rad: f64) -> Matrix3<f64> {
    let (sm, sr) = (sigma_m.max(1e-4), sigma_rad.max(1e-5));
    Matrix3::from_diagonal(&nalgebra::Vector3::new(
        1.0 / (sm * sm),
        1.0 / (sm * sm),
        1.0 / (sr * sr),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a robot at `pose` sees of a 10 × 6 m room with an inner pillar, as points
    /// every 5 cm of wall within 8 m (no occlusion: enough for matching tests).
    fn view(pose: &Pose2) -> Vec<Point2> {
        let walls = [
            ((0.0, 0.0), (10.0, 0.0)),
            ((10.0, 0.0), (10.0, 6.0)),
            ((10.0, 6.0), (0.0, 6.0)),
            ((0.0, 6.0), (0.0, 0.0)),
            ((4.0, 2.5), (6.0, 2.5)),
            ((6.0, 2.5), (6.0, 3.5)),
        ];
        let mut pts = Vec::new();
        for ((ax, ay), (bx, by)) in walls {
            let n = f64::hypot(bx - ax, by - ay) / 0.05;
            for i in 0..=n as usize {
                let t = i as f64 / n;
                let w = Point2::new(ax + t * (bx - ax), ay + t * (by - ay));
                if w.distance(&pose.position()) < 8.0 {
                    pts.push(pose.inverse_transform_point(&w));
                }
            }
        }
        pts
    }

    #[test]
    fn keyframes_follow_travel_and_turn() {
        let lc = LoopCloser::new(LoopClosureConfig::default());
        assert!(lc.wants_keyframe(&Pose2::IDENTITY));
        let mut lc = lc;
        lc.add_keyframe(Pose2::IDENTITY, &view(&Pose2::new(1.0, 1.0, 0.0)), None);
        assert!(!lc.wants_keyframe(&Pose2::new(0.3, 0.0, 0.0)));
        assert!(lc.wants_keyframe(&Pose2::new(0.6, 0.0, 0.0)));
        assert!(lc.wants_keyframe(&Pose2::new(0.0, 0.0, 0.5)));
    }

    #[test]
    fn a_drifted_return_to_the_start_is_closed_and_corrected() {
        // The robot drives a loop around the pillar; the front end's estimate drifts by
        // 0.2° of heading per keyframe, so it returns to its start about 10° and 1 m off.
        let config = LoopClosureConfig {
            min_travel_m: 5.0,
            ..LoopClosureConfig::default()
        };
        let mut lc = LoopCloser::new(config);
        let mut truth = Vec::new();
        for i in 0..16 {
            truth.push(Pose2::new(2.0 + 0.5 * i as f64, 1.2, 0.0));
        }
        for i in 0..8 {
            truth.push(Pose2::new(
                9.0,
                1.2 + 0.5 * i as f64,
                std::f64::consts::FRAC_PI_2,
            ));
        }
        for i in 0..16 {
            truth.push(Pose2::new(9.0 - 0.5 * i as f64, 4.8, std::f64::consts::PI));
        }
        for i in 0..8 {
            truth.push(Pose2::new(
                1.5,
                4.8 - 0.5 * i as f64,
                -std::f64::consts::FRAC_PI_2,
            ));
        }
        truth.push(Pose2::new(2.0, 1.2, 0.0));
        let start = truth[0];
        let mut estimate = Pose2::new(0.0, 0.0, 0.0);
        let mut closed_at = None;
        for (k, t) in truth.iter().enumerate() {
            if k > 0 {
                let step = truth[k - 1].between(t);
                let drifted = Pose2::new(step.x, step.y, step.heading_rad + 0.2f64.to_radians());
                // Keep the front end on the graph's (possibly optimized) last node.
                estimate = lc.poses()[k - 1].compose(&drifted);
            }
            let out = lc.add_keyframe(estimate, &view(t), None);
            if out.optimized && closed_at.is_none() {
                closed_at = Some(k);
                // The route since the last closure starts again: the window is the narrow one.
                assert_eq!(lc.window(k).linear_m, 1.5);
            }
        }
        assert!(closed_at.is_some(), "no loop closed");
        // Every keyframe's pose relative to the start agrees with the truth.
        let last = lc.poses()[truth.len() - 1];
        let expected = start.between(truth.last().unwrap());
        let got = lc.poses()[0].between(&last);
        assert!(
            got.position().distance(&expected.position()) < 0.1,
            "{got:?} vs {expected:?}"
        );
        assert!(lc.closures().iter().all(|c| c.score >= 0.6));
    }

    #[test]
    fn the_search_window_grows_with_the_route_since_the_last_closure() {
        // Keyframes every 0.5 m along a 10 m room, no loop: the window widens by 10 % of
        // the route (1.5 m + 0.1 × 4.5 m after 9 steps) and stops at 3 m.
        let mut lc = LoopCloser::new(LoopClosureConfig::default());
        for i in 0..10 {
            let p = Pose2::new(2.0 + 0.5 * i as f64, 1.2, 0.0);
            lc.add_keyframe(Pose2::new(0.5 * i as f64, 0.0, 0.0), &view(&p), None);
        }
        assert!(lc.closures().is_empty());
        assert!((lc.window(0).linear_m - 1.5).abs() < 1e-12);
        assert!((lc.window(9).linear_m - 1.95).abs() < 1e-12);
        for i in 10..40 {
            let p = Pose2::new(2.0 + 0.2 * i as f64, 1.2, 0.0);
            lc.add_keyframe(Pose2::new(0.5 * i as f64, 0.0, 0.0), &view(&p), None);
        }
        assert_eq!(lc.window(39).linear_m, 3.0);
        assert!(lc.window(39).angular_rad == LoopClosureConfig::default().window.angular_rad);
    }

    #[test]
    fn nothing_is_closed_before_the_route_is_long_enough() {
        let mut lc = LoopCloser::new(LoopClosureConfig::default());
        for i in 0..10 {
            let p = Pose2::new(2.0 + 0.5 * i as f64, 1.2, 0.0);
            let out = lc.add_keyframe(Pose2::new(0.5 * i as f64, 0.0, 0.0), &view(&p), None);
            assert!(!out.optimized);
        }
        assert!(lc.closures().is_empty());
    }
}
