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
//! relative pose as the front end saw it, weighed by the covariance the front end reported
//! for the scans between them: [`SequentialNoise`]). Each new keyframe is then matched against the
//! earlier keyframes it could be revisiting — near its estimate, but at least `min_travel_m` of
//! route behind — by correlative search ([`crate::scan_matching::correlative`], the window
//! covers the drift) and point-to-line ICP against a local map of the candidate and its
//! neighbours. A match that scores well enough adds a loop edge with a Huber kernel (a wrong
//! match in a look-alike corridor is down-weighted, not obeyed), and the graph is optimized.
//! The edge holds what the score plateau pins: where the plateau is wider than the
//! likelihood kernel along one direction, no feature lies on it there, and where the scan
//! also reaches beyond the reference along it (a corridor seen from its other end), its
//! top is set by overlap, not by the place, and the edge can give that direction up
//! (`overlap_driven_direction`; off by default, see
//! `LoopClosureConfig::unpin_featureless_direction`), or the match can be re-placed by its
//! score over what the reference looked at only ([`crate::scan_matching::observed_region`];
//! off by default, see `LoopClosureConfig::score_observed_only`).
//! The mapper then re-anchors its trajectory and rebuilds its grid on the optimized keyframes.
//!
//! Files: this one holds the keyframes, the consistency gate and the graph; `config` the
//! settings with what each default was measured against; `loop_match` the matching of a
//! keyframe against an earlier one and the loop edge's information.
//!
//! Pure: values in, values out.

use crate::back_end::closure_consistency::{
    ChainVariance, LoopHypothesis, MeasuredSteps, StepNoise, StepVariance, chain_covariance,
    chain_variance, given_up_to_chain, pair_distance_sq, prior_distance_sq, prior_distance_sq_full,
    swing, to_frame, widest_m2,
};
use crate::back_end::pose_graph::{Edge, PoseGraph};
use crate::scan_matching::correlative::{SearchWindow, voxel_filter};
use nalgebra::Matrix3;
use sketchslam_types::{Point2, Pose2, wrap_angle};

mod config;
mod loop_match;

pub use config::{ChainShape, LoopClosureConfig, LoopHeadingSigma, SequentialNoise};

/// A loop edge the back end added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopClosure {
    /// The earlier keyframe.
    pub from: usize,
    /// The new keyframe.
    pub to: usize,
    /// Mean likelihood of the match, 0..1.
    pub score: f64,
    /// The chain test's squared Mahalanobis distance when the loop was verified
    /// ([`crate::back_end::closure_consistency::prior_distance_sq`], against
    /// `consistency_chi2`); NaN before it was.
    pub chain_d2: f64,
    /// The standard deviation the chain between the loop's ends was given in that test,
    /// meters (position, widest direction; [`ChainVariance`]); NaN before it was.
    pub chain_sigma_m: f64,
    /// The chain's heading deviation in that test, degrees; NaN before it was.
    pub chain_sigma_deg: f64,
    /// The heading deviation the loop itself claimed in that test (its edge's, before any
    /// direction was given up), degrees; NaN before it was.
    pub loop_sigma_deg: f64,
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
    /// Variance of the sequential step ending at each keyframe, as the consistency tests
    /// read it (entry 0: none).
    steps: Vec<ChainVariance>,
    /// The whole covariance (map axes) of the sequential step ending at each keyframe, as
    /// the test against the chain reads it with [`ChainShape::Full`] (entry 0: zero).
    step_covariances: Vec<Matrix3<f64>>,
    /// Loops in the graph, and (same index) what their consistency tests need.
    closures: Vec<LoopClosure>,
    loops: Vec<LoopHypothesis>,
    /// Matched loops waiting for others to agree with them.
    pending: Vec<MatchedLoop>,
    /// Matched loops refused by a consistency test, timed out, or taken out again.
    rejected: usize,
    /// Heading priors added since the last optimization.
    pending_priors: usize,
}

/// A loop the matcher found: what it reports, what the tests read, and its graph edge.
#[derive(Debug, Clone, Copy)]
struct MatchedLoop {
    closure: LoopClosure,
    hypothesis: LoopHypothesis,
    edge: Edge,
}

impl LoopCloser {
    /// Bytes on the heap: keyframe points, route lengths, loops and the pose graph
    /// (capacities). O(keyframes).
    pub fn heap_bytes(&self) -> usize {
        use crate::heap::vec_bytes;
        self.points.iter().map(vec_bytes).sum::<usize>()
            + vec_bytes(&self.points)
            + vec_bytes(&self.travel_m)
            + vec_bytes(&self.steps)
            + vec_bytes(&self.step_covariances)
            + vec_bytes(&self.closures)
            + vec_bytes(&self.loops)
            + vec_bytes(&self.pending)
            + self.graph.heap_bytes()
    }

    /// An empty back end.
    pub fn new(config: LoopClosureConfig) -> Self {
        Self {
            config,
            graph: PoseGraph::new(),
            points: Vec::new(),
            travel_m: Vec::new(),
            steps: Vec::new(),
            step_covariances: Vec::new(),
            closures: Vec::new(),
            loops: Vec::new(),
            pending: Vec::new(),
            rejected: 0,
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

    /// Each keyframe's scan points, robot frame, thinned (same order as [`Self::poses`]).
    pub fn keyframe_points(&self) -> &[Vec<Point2>] {
        &self.points
    }

    /// The loops closed so far.
    pub fn closures(&self) -> &[LoopClosure] {
        &self.closures
    }

    /// The loop edges in the graph now, with the measurements they hold (a loop taken out
    /// again after optimization is not among them).
    pub fn loops(&self) -> &[LoopHypothesis] {
        &self.loops
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
        self.add_keyframe_with_step(pose, points, heading_prior_rad, None)
    }

    /// [`LoopCloser::add_keyframe`], with the front end's covariance of the step from the
    /// previous keyframe (x, y, heading; translation on the map's axes), which weighs the
    /// sequential edge under [`SequentialNoise::FrontEnd`].
    pub fn add_keyframe_with_step(
        &mut self,
        pose: Pose2,
        points: &[Point2],
        heading_prior_rad: Option<f64>,
        step_covariance: Option<Matrix3<f64>>,
    ) -> KeyframeOutcome {
        let c = &self.config;
        let thinned = voxel_filter(points, c.voxel_m);
        let index = self.graph.add_node(pose);
        let (travel, step_variance, step_covariance) = match index.checked_sub(1) {
            Some(prev) => {
                let prev_pose = self.graph.nodes()[prev];
                let step = prev_pose.between(&pose);
                let length_m = step.position().norm();
                let measured = step_covariance
                    .filter(|_| c.sequential_noise == SequentialNoise::FrontEnd)
                    .and_then(|cov| {
                        let (information, variance) = measured_step(&cov, pose.heading_rad)?;
                        Some((information, variance, cov))
                    });
                let (information, variance, covariance) = match measured {
                    Some(m) => m,
                    None => {
                        let model = self.a_priori_noise();
                        (
                            information(model.position_sigma_m(length_m), model.sigma_rad),
                            model.step(index, length_m),
                            model.step_covariance(index, length_m),
                        )
                    }
                };
                let edge = Edge {
                    from: prev,
                    to: index,
                    measurement: step,
                    information,
                    huber: None,
                };
                // The pose is finite (the mapper refuses others), so the edge is valid.
                let _ = self.graph.add_edge(edge);
                (self.travel_m[prev] + length_m, variance, covariance)
            }
            None => (0.0, ChainVariance::ZERO, Matrix3::zeros()),
        };
        self.points.push(thinned);
        self.travel_m.push(travel);
        self.steps.push(step_variance);
        self.step_covariances.push(step_covariance);
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
            if let Some(found) = self.match_loop(candidate, index, &window) {
                if self.config.two_way_check && !self.matches_back(&found, &window) {
                    self.rejected += 1;
                    continue;
                }
                closed |= self.verify(found, index);
            }
        }
        self.expire_pending(index);
        let periodic = self.pending_priors > 0
            && index.is_multiple_of(self.config.optimize_every_keyframes.max(1));
        let optimized = closed || periodic;
        if optimized {
            let config = self.config.optimize;
            self.graph.optimize(&config);
            self.pending_priors = 0;
            self.drop_disagreeing_loops();
        }
        KeyframeOutcome { index, optimized }
    }

    /// Matched loops refused so far: by a consistency test, for want of agreement within
    /// `pending_keyframes`, or taken out of the graph after an optimization.
    pub fn rejected(&self) -> usize {
        self.rejected
    }

    /// The sequential edges' a-priori noise (`sequential_sigma_*`).
    fn a_priori_noise(&self) -> StepNoise {
        StepNoise {
            sigma_m: self.config.sequential_sigma_m,
            sigma_per_m: self.config.sequential_sigma_per_m,
            sigma_rad: self.config.sequential_sigma_rad,
        }
    }

    /// The sequential edges' noise, as the consistency tests read it.
    fn step_noise(&self) -> MeasuredSteps<'_> {
        MeasuredSteps {
            steps: &self.steps,
            covariances: &self.step_covariances,
            model: self.a_priori_noise(),
        }
    }

    /// What the route can have drifted between keyframes `from` (older) and `to`: along the
    /// chain from `from`, or from the newest of the last few loops in the graph that are
    /// older than `to` (that loop tied the route to the old part of the map), whichever is
    /// tighter.
    fn drift_since(&self, from: usize, to: usize) -> ChainVariance {
        let nodes = self.graph.nodes();
        let noise = self.step_noise();
        let direct = chain_variance(nodes, from, to, &noise, nodes[to].position());
        let through_loops = self.loops_before(to).map(|l| {
            let own = ChainVariance {
                position_m2: l.covariance[(0, 0)].max(l.covariance[(1, 1)]),
                heading_rad2: l.covariance[(2, 2)],
            };
            let new = chain_variance(nodes, l.to, to, &noise, nodes[to].position());
            let old = chain_variance(nodes, l.from, from, &noise, nodes[from].position());
            own.plus(new).plus(old)
        });
        tightest(direct, through_loops, |v| v.position_m2)
    }

    /// The last few loops in the graph older than keyframe `to`, newest first: the routes
    /// [`Self::drift_since`] may take instead of the chain.
    fn loops_before(&self, to: usize) -> impl Iterator<Item = &LoopHypothesis> {
        self.loops.iter().rev().take(5).filter(move |l| l.to < to)
    }

    /// [`Self::drift_since`] with the chain's whole covariance (map axes,
    /// [`chain_covariance`]): along the chain, or through one of the last few loops — that
    /// loop's own covariance carried onto the map and swung about its newer end, plus the
    /// chains from its ends to `from` and `to` — whichever is tighter in its widest
    /// direction.
    fn drift_since_full(&self, from: usize, to: usize) -> Matrix3<f64> {
        let nodes = self.graph.nodes();
        let noise = self.step_noise();
        let end = nodes[to].position();
        let direct = chain_covariance(nodes, from, to, &noise, end);
        let through_loops = self.loops_before(to).map(|l| {
            let onto_map = to_frame(nodes[l.to].heading_rad).transpose();
            let g = swing(nodes[l.to].position(), end);
            let own = g * onto_map * l.covariance * onto_map.transpose() * g.transpose();
            let new = chain_covariance(nodes, l.to, to, &noise, end);
            let old = chain_covariance(nodes, l.from, from, &noise, nodes[from].position());
            own + new + old
        });
        tightest(direct, through_loops, widest_m2)
    }

    /// The consistency tests of [`closure_consistency`] on a matched loop: refused when the
    /// chain cannot explain it; into the graph with every waiting loop that agrees with it
    /// once `min_consistent_loops` agree (or one loop already in the graph near it does);
    /// otherwise it waits. True when loops entered the graph.
    fn verify(&mut self, mut found: MatchedLoop, now: usize) -> bool {
        let c = &self.config;
        let nodes = self.graph.nodes();
        let noise = self.step_noise();
        let h = &found.hypothesis;
        let chain = self.drift_since(h.from, h.to);
        // The directions where the chain knows more than the match: neither tested against
        // the chain nor pulled along in the graph (the pairwise tests below still weigh
        // the match as it claims).
        let given_up = c.give_up_beyond_chain.map_or(Matrix3::zeros(), |ratio| {
            given_up_to_chain(&h.covariance, chain, ratio)
        });
        let tested = LoopHypothesis {
            covariance: h.covariance + given_up,
            ..*h
        };
        let (d2, chain_m2, chain_rad2) = match c.chain_shape {
            ChainShape::Isotropic => (
                prior_distance_sq(nodes, &tested, chain),
                chain.position_m2,
                chain.heading_rad2,
            ),
            ChainShape::Full => {
                let full = self.drift_since_full(h.from, h.to);
                (
                    prior_distance_sq_full(nodes, &tested, &full),
                    widest_m2(&full),
                    full[(2, 2)],
                )
            }
        };
        // A NaN distance (a singular covariance) is refused too.
        if d2.is_nan() || d2 > c.consistency_chi2 {
            self.rejected += 1;
            return false;
        }
        found.closure.chain_d2 = d2;
        found.closure.chain_sigma_m = chain_m2.max(0.0).sqrt();
        found.closure.chain_sigma_deg = chain_rad2.max(0.0).sqrt().to_degrees();
        found.closure.loop_sigma_deg = h.covariance[(2, 2)].max(0.0).sqrt().to_degrees();
        let agree = |a: &LoopHypothesis, b: &LoopHypothesis| {
            pair_distance_sq(nodes, a, b, &noise) <= c.consistency_chi2
        };
        let recent = |l: &LoopHypothesis| now.saturating_sub(l.to) <= c.pending_keyframes;
        // Two matches against overlapping local maps share the reference's bias (a slide
        // along a corridor grows slowly from one keyframe to the next): with
        // `independent_vouching`, only a loop whose reference shares no keyframe with this
        // one's local map vouches for it.
        let independent = |l: &LoopHypothesis| {
            !c.independent_vouching || l.from.abs_diff(h.from) > 2 * c.local_map_keyframes
        };
        let mut group = vec![*h];
        let vouched = self
            .loops
            .iter()
            .rev()
            .filter(|l| recent(l) && independent(l))
            .any(|l| agree(h, l));
        let mut members = Vec::new();
        for (i, p) in self.pending.iter().enumerate().rev() {
            if group.iter().all(|g| agree(g, &p.hypothesis)) {
                group.push(p.hypothesis);
                members.push(i);
            }
        }
        if given_up != Matrix3::zeros() {
            let info = found
                .edge
                .information
                .try_inverse()
                .and_then(|cov| (cov + given_up).try_inverse());
            let Some(info) = info else {
                self.rejected += 1;
                return false;
            };
            found.edge.information = 0.5 * (info + info.transpose());
        }
        let needed = if vouched {
            1
        } else {
            c.min_consistent_loops.max(1)
        };
        if group.len() < needed {
            self.pending.push(found);
            return false;
        }
        // `members` holds pending indices in descending order: removing them one by one
        // leaves the others' indices valid.
        let mut entering: Vec<MatchedLoop> = members
            .into_iter()
            .map(|i| self.pending.remove(i))
            .collect();
        entering.push(found);
        entering.sort_by_key(|m| m.closure.to);
        let mut entered = false;
        for m in entering {
            if self.graph.add_edge(m.edge).is_ok() {
                self.closures.push(m.closure);
                self.loops.push(m.hypothesis);
                entered = true;
            }
        }
        entered
    }

    /// Waiting loops that found no agreement within `pending_keyframes` are rejected.
    fn expire_pending(&mut self, now: usize) {
        let limit = self.config.pending_keyframes;
        let before = self.pending.len();
        self.pending
            .retain(|p| now.saturating_sub(p.closure.to) <= limit);
        self.rejected += before - self.pending.len();
    }

    /// After an optimization: the loop edge that disagrees most with the optimized graph,
    /// if its squared Mahalanobis error is above `residual_chi2` times the graph's variance
    /// factor ([`variance_factor`]), is taken out and the graph optimized again (a few rounds
    /// at most: each removal changes the others).
    fn drop_disagreeing_loops(&mut self) {
        const ROUNDS: usize = 3;
        let Some(bound) = self.config.residual_chi2 else {
            return;
        };
        for _ in 0..ROUNDS {
            let nodes = self.graph.nodes();
            let d2: Vec<f64> = self
                .loops
                .iter()
                .map(|l| {
                    let e = Edge::new(l.from, l.to, l.measurement, Matrix3::identity());
                    let r = e.error(&nodes[l.from], &nodes[l.to]);
                    l.covariance
                        .try_inverse()
                        .map_or(f64::INFINITY, |info| r.dot(&(info * r)))
                })
                .collect();
            let scaled = bound * variance_factor(&d2);
            let worst = d2
                .iter()
                .copied()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(&b.1));
            let Some((i, _)) = worst.filter(|(_, d2)| *d2 > scaled) else {
                return;
            };
            let l = self.loops.remove(i);
            self.closures.remove(i);
            self.graph.remove_edge_where(|e| {
                e.from == l.from && e.to == l.to && e.measurement == l.measurement
            });
            self.rejected += 1;
            let config = self.config.optimize;
            self.graph.optimize(&config);
        }
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
        if c.plausible_first {
            let match_m2 = c.loop_sigma_m * c.loop_sigma_m;
            let mut keyed: Vec<(f64, usize)> = near
                .iter()
                .map(|&(d, i)| (d * d / (self.drift_since(i, new).position_m2 + match_m2), i))
                .collect();
            keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
            near = keyed;
        } else {
            near.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        near.into_iter()
            .take(c.max_candidates)
            .map(|(_, i)| i)
            .collect()
    }
}

/// Median of χ² with 3 degrees of freedom.
const CHI2_3_MEDIAN: f64 = 2.366;

/// The a-posteriori variance factor of the loop edges, estimated robustly: the median of
/// their squared Mahalanobis errors `d2` after optimization over the median of χ²(3), and
/// never below 1. When the front end drifts more than the sequential edges' a-priori noise
/// says (a cheap scanner, a log with one scan a second), every right loop strains against
/// the chain and its `d²` grows with that ratio; a wrong loop stands out against the typical
/// one, not against the a-priori model (Förstner and Wrobel, *Photogrammetric Computer
/// Vision*, 2016, §4.2.3: the variance factor `σ̂₀² = Ω/R`, here with the median in place of
/// the mean so the loops being tested do not set their own bound). O(n log n).
fn variance_factor(d2: &[f64]) -> f64 {
    let mut finite: Vec<f64> = d2.iter().copied().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return 1.0;
    }
    finite.sort_by(f64::total_cmp);
    let n = finite.len();
    let median = if n % 2 == 1 {
        finite[n / 2]
    } else {
        0.5 * (finite[n / 2 - 1] + finite[n / 2])
    };
    (median / CHI2_3_MEDIAN).max(1.0)
}

/// A sequential edge's information and the step's variance for the consistency tests,
/// from the front end's covariance `cov` of the step (translation on the map's axes). The
/// edge's error `t2v(Z⁻¹ X_i⁻¹ X_j)` lies in the newer keyframe's frame (heading
/// `heading_rad`): with `T = diag(R(θ_j)ᵀ, 1)`, `Ω = (T Σ Tᵀ)⁻¹`. The consistency tests
/// take the position's widest direction (their variance is isotropic). `None` when `cov`
/// is not a covariance. O(1).
fn measured_step(cov: &Matrix3<f64>, heading_rad: f64) -> Option<(Matrix3<f64>, ChainVariance)> {
    if !cov.iter().all(|v| v.is_finite()) {
        return None;
    }
    let t = to_frame(heading_rad);
    // A floor far below any real step's noise keeps Ω finite for a noise-free match.
    let floor = Matrix3::from_diagonal(&nalgebra::Vector3::new(1e-10, 1e-10, 1e-12));
    let rotated = t * cov * t.transpose() + floor;
    let information = rotated.try_inverse()?;
    let position_m2 = widest_m2(cov);
    let variance = ChainVariance {
        position_m2,
        heading_rad2: cov[(2, 2)],
    };
    (position_m2 >= 0.0 && variance.heading_rad2 >= 0.0).then_some((information, variance))
}

/// The candidate with the smallest `widest` position variance, `first` on a tie. O(n).
fn tightest<T>(first: T, others: impl Iterator<Item = T>, widest: impl Fn(&T) -> f64) -> T {
    others.fold(
        first,
        |best, v| if widest(&v) < widest(&best) { v } else { best },
    )
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
    use crate::back_end::pose_graph::OptimizeConfig;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn a_measured_step_is_weighed_in_the_newer_keyframes_frame() {
        // Loose along the map's x (a corridor along x), tight across; the keyframe faces
        // +y, so the map's x is its −y: the edge's error is loose in its y.
        let cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.01, 1e-4, 1e-6));
        let (info, variance) = measured_step(&cov, FRAC_PI_2).unwrap();
        assert!((info[(0, 0)] - 1e4).abs() < 1e-2, "{info}");
        assert!((info[(1, 1)] - 100.0).abs() < 1e-4, "{info}");
        assert!((info[(2, 2)] - 1e6).abs() < 2.0, "{info}");
        assert!(info[(0, 1)].abs() < 1e-6, "{info}");
        // The consistency tests take the widest direction.
        assert_eq!(variance.position_m2, 0.01);
        assert_eq!(variance.heading_rad2, 1e-6);
        assert!(measured_step(&(cov * f64::NAN), 0.0).is_none());
    }

    #[test]
    fn the_front_end_weighs_the_sequential_edges_when_asked() {
        let step = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.01, 1e-4, 1e-6));
        let edge_information = |noise: SequentialNoise| {
            let mut lc = LoopCloser::new(LoopClosureConfig {
                sequential_noise: noise,
                ..LoopClosureConfig::default()
            });
            lc.add_keyframe_with_step(Pose2::IDENTITY, &[], None, None);
            lc.add_keyframe_with_step(Pose2::new(0.5, 0.0, 0.0), &[], None, Some(step));
            // Without a covariance from the front end, the a-priori figures.
            lc.add_keyframe_with_step(Pose2::new(1.0, 0.0, 0.0), &[], None, None);
            let edges = lc.graph.edges();
            let whole = lc.step_covariances.clone();
            (
                edges[0].information,
                edges[1].information,
                lc.steps.clone(),
                whole,
            )
        };
        // 0.02 + 0.02·0.5 = 0.03 m and 0.5°, whatever the front end saw.
        let a_priori = information(0.03, 0.5f64.to_radians());
        let (first, second, _, _) = edge_information(SequentialNoise::APriori);
        assert!((first - a_priori).norm() < 1e-6 && (second - a_priori).norm() < 1e-6);
        let (first, second, steps, whole) = edge_information(SequentialNoise::FrontEnd);
        assert!((first[(0, 0)] - 100.0).abs() < 1e-4 && (first[(1, 1)] - 1e4).abs() < 1e-2);
        assert!((second - a_priori).norm() < 1e-6);
        assert_eq!(steps[1].position_m2, 0.01);
        assert!((steps[2].position_m2 - 0.03f64.powi(2)).abs() < 1e-12);
        // The whole covariance as the front end gave it (map axes), the a-priori diagonal
        // where it gave none.
        assert_eq!(whole[1], step);
        let diagonal = Matrix3::from_diagonal(&nalgebra::Vector3::new(
            0.0009,
            0.0009,
            0.5f64.to_radians().powi(2),
        ));
        assert!((whole[2] - diagonal).norm() < 1e-12, "{}", whole[2]);
    }

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
        drifted_return_is_closed(LoopClosureConfig {
            min_travel_m: 5.0,
            ..LoopClosureConfig::default()
        });
    }

    #[test]
    fn a_drifted_return_is_closed_by_the_observed_score_too() {
        // The room is closed, so every view saw around it: the observed score agrees with
        // the plain one and the loop closes the same.
        drifted_return_is_closed(LoopClosureConfig {
            min_travel_m: 5.0,
            score_observed_only: true,
            ..LoopClosureConfig::default()
        });
    }

    #[test]
    fn a_drifted_return_is_closed_with_the_two_way_check_too() {
        // The return sees the room the start saw: the loop matches back and closes.
        drifted_return_is_closed(LoopClosureConfig {
            min_travel_m: 5.0,
            two_way_check: true,
            ..LoopClosureConfig::default()
        });
    }

    #[test]
    fn a_drifted_return_is_closed_against_the_whole_chain_too() {
        // The route's drift fits the chain's whole covariance as it fits the isotropic
        // one: the loops close, and each keeps the chain's widest deviation.
        drifted_return_is_closed(LoopClosureConfig {
            min_travel_m: 5.0,
            chain_shape: ChainShape::Full,
            ..LoopClosureConfig::default()
        });
    }

    #[test]
    fn a_drifted_return_is_closed_with_the_heading_from_the_plateau_too() {
        // The room's walls pin each match's heading: the loops close as with a set degree.
        for loop_heading in [
            LoopHeadingSigma::Plateau,
            LoopHeadingSigma::PlateauWithinSet,
        ] {
            drifted_return_is_closed(LoopClosureConfig {
                min_travel_m: 5.0,
                loop_heading,
                ..LoopClosureConfig::default()
            });
        }
    }

    #[test]
    fn a_loop_matches_back_and_one_pulled_aside_does_not() {
        // Around the room to the start, without trying any loop on the way (no
        // candidates), then the return matched against the start by hand.
        let mut lc = LoopCloser::new(LoopClosureConfig {
            min_travel_m: 5.0,
            max_candidates: 0,
            ..LoopClosureConfig::default()
        });
        let mut truth: Vec<Pose2> = (0..16)
            .map(|i| Pose2::new(2.0 + 0.5 * i as f64, 1.2, 0.0))
            .collect();
        truth.extend((0..8).map(|i| Pose2::new(9.0, 1.2 + 0.5 * i as f64, FRAC_PI_2)));
        truth.extend((0..16).map(|i| Pose2::new(9.0 - 0.5 * i as f64, 4.8, PI)));
        truth.extend((0..8).map(|i| Pose2::new(1.5, 4.8 - 0.5 * i as f64, -FRAC_PI_2)));
        truth.push(Pose2::new(2.1, 1.2, 0.05));
        for t in &truth {
            lc.add_keyframe(*t, &view(t), None);
        }
        let last = truth.len() - 1;
        let window = lc.config.window;
        let found = lc
            .match_loop(0, last, &window)
            .expect("the return matches the start");
        assert!(lc.matches_back(&found, &window));
        // The same loop claimed 0.5 m along the room: matched back, the room says where
        // the start really is, and the round trip is 0.5 m off.
        let mut aside = found;
        let z = found.hypothesis.measurement;
        aside.hypothesis.measurement = Pose2::new(z.x + 0.5, z.y, z.heading_rad);
        assert!(!lc.matches_back(&aside, &window));
    }

    /// The robot drives a loop around the pillar; the front end's estimate drifts by
    /// 0.2° of heading per keyframe, so it returns to its start about 10° and 1 m off;
    /// `config`'s loop closure must close it and correct the return within 0.1 m.
    fn drifted_return_is_closed(config: LoopClosureConfig) {
        let loop_heading = config.loop_heading;
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
        // Each loop keeps the chain test it passed: within the bound, over a chain that
        // was given some drift.
        let chi2 = LoopClosureConfig::default().consistency_chi2;
        for c in lc.closures() {
            assert!((0.0..=chi2).contains(&c.chain_d2), "{c:?}");
            // The loop's heading deviation (the set 1° unless read from the match), and a
            // chain that drifted some in heading.
            if loop_heading == LoopHeadingSigma::Set {
                assert!((c.loop_sigma_deg - 1.0).abs() < 1e-9, "{c:?}");
            }
            assert!(
                c.loop_sigma_deg > 0.0 && c.loop_sigma_deg.is_finite(),
                "{c:?}"
            );
            assert!(
                c.chain_sigma_deg > 0.0 && c.chain_sigma_deg.is_finite(),
                "{c:?}"
            );
            assert!(
                c.chain_sigma_m > 0.0 && c.chain_sigma_m.is_finite(),
                "{c:?}"
            );
        }
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

    /// A corridor walked out along y = 0 and back along y = 0.2, keyframes every 0.5 m
    /// (no scan points: the matcher never fires, the tests hand the loops in).
    fn out_and_back() -> LoopCloser {
        let mut lc = LoopCloser::new(LoopClosureConfig::default());
        for i in 0..40 {
            lc.add_keyframe(Pose2::new(0.5 * i as f64, 0.0, 0.0), &[], None);
        }
        for i in 0..40 {
            let pose = Pose2::new(19.5 - 0.5 * i as f64, 0.2, std::f64::consts::PI);
            lc.add_keyframe(pose, &[], None);
        }
        lc
    }

    /// The loop keyframe `to` (on the way back) → the keyframe `from` on the way out
    /// `offset_m` ahead of the true one (a look-alike room), as the matcher reports it.
    fn offered(lc: &LoopCloser, from: usize, to: usize, offset_m: f64) -> MatchedLoop {
        let nodes = lc.graph.nodes();
        // The truth: `to` seen from `from`, as the (exact) estimates say; a look-alike
        // match puts it `offset_m` further along the corridor.
        let truth = nodes[from].between(&nodes[to]);
        let z = Pose2::new(truth.x - offset_m, truth.y, truth.heading_rad);
        let information = information(0.05, 1f64.to_radians());
        let covariance = information.try_inverse().unwrap();
        MatchedLoop {
            closure: LoopClosure {
                from,
                to,
                score: 0.9,
                chain_d2: f64::NAN,
                chain_sigma_m: f64::NAN,
                chain_sigma_deg: f64::NAN,
                loop_sigma_deg: f64::NAN,
            },
            hypothesis: LoopHypothesis {
                from,
                to,
                measurement: z,
                covariance,
            },
            edge: Edge {
                from,
                to,
                measurement: z,
                information,
                huber: Some(2.0),
            },
        }
    }

    #[test]
    fn a_look_alike_room_one_pitch_over_is_rejected_against_the_chain() {
        // Keyframe 60 (x = 9.5 on the way back) matched the room 4 m further on, as a
        // row of identical rooms allows: the route since (10 m back and forth) cannot
        // have drifted 4 m, so the loop never enters the graph.
        let mut lc = out_and_back();
        let wrong = offered(&lc, 19, 60, 4.0);
        assert!(!lc.verify(wrong, 60));
        assert_eq!(lc.rejected(), 1);
        assert!(lc.closures().is_empty() && lc.pending.is_empty());
    }

    #[test]
    fn a_look_alike_a_door_over_passes_the_isotropic_chain_and_not_the_whole_one() {
        // Keyframe 60 matched keyframe 19 0.9 m further along the corridor. The chain
        // 19 → 60 (41 a-priori steps of 0.03 m and 0.5°, out to x = 19.5 and back) has
        // position variance 41 · 0.03² ≈ 0.037 m² on its own, and its headings swing the end
        // across the corridor by Σ (0.5°)² · lever² ≈ 0.11 m² more (levers 0.5–10 m along
        // x). Isotropic, that swing counts along the corridor too: d² ≈ 0.81 / 0.15 ≈ 5.5,
        // inside the bound; with the chain's whole covariance the axis keeps 0.037 m²:
        // d² ≈ 0.81 / 0.04 ≈ 20, refused.
        let mut lc = out_and_back();
        let d2 = |lc: &LoopCloser| lc.closures.last().map_or(f64::NAN, |c| c.chain_d2);
        lc.config.min_consistent_loops = 1;
        assert!(lc.verify(offered(&lc, 19, 60, 0.9), 60));
        assert!((4.0..7.0).contains(&d2(&lc)), "{}", d2(&lc));
        let mut lc = out_and_back();
        lc.config.min_consistent_loops = 1;
        lc.config.chain_shape = ChainShape::Full;
        assert!(!lc.verify(offered(&lc, 19, 60, 0.9), 60));
        assert_eq!(lc.rejected(), 1);
        // The same match where it belongs passes the whole chain.
        assert!(lc.verify(offered(&lc, 19, 60, 0.0), 60));
        assert!(d2(&lc) < 1e-6, "{}", d2(&lc));
    }

    #[test]
    fn a_right_loop_waits_for_agreement_and_enters_with_it() {
        let mut lc = out_and_back();
        // One match alone only waits...
        assert!(!lc.verify(offered(&lc, 19, 60, 0.0), 60));
        assert_eq!(lc.pending.len(), 1);
        // ...a second, from another keyframe, agrees but two are not yet enough...
        assert!(!lc.verify(offered(&lc, 17, 62, 0.0), 62));
        // ...a look-alike in between agrees with neither and waits on its own...
        assert!(!lc.verify(offered(&lc, 16, 63, 1.0), 63));
        assert_eq!(lc.pending.len(), 3);
        // ...and the third right one brings the two others in with it.
        assert!(lc.verify(offered(&lc, 15, 64, 0.0), 64));
        let entered: Vec<(usize, usize)> = lc.closures().iter().map(|c| (c.from, c.to)).collect();
        assert_eq!(entered, vec![(19, 60), (17, 62), (15, 64)]);
        // Once loops are in, one more that agrees with them enters at once.
        assert!(lc.verify(offered(&lc, 13, 66, 0.0), 66));
        assert_eq!(lc.closures().len(), 4);
        // The look-alike, never agreed with, times out.
        lc.expire_pending(63 + LoopClosureConfig::default().pending_keyframes + 1);
        assert!(lc.pending.is_empty());
        assert_eq!(lc.rejected(), 1);
    }

    #[test]
    fn a_loop_looser_than_the_chain_pulls_nothing_along_what_it_gives_up() {
        // Three right loops tie the way back to the way out; then keyframe 66 matches a
        // corridor view 1.5 m along the axis with σ 0.5 m there (a wide plateau), 0.05 m
        // across, 1°. As it claims itself it passes (d² ≈ 1.5² / 0.25 ≈ 9 < 11.34) and
        // pulls the graph along the corridor; given up beyond the chain (which the loops
        // hold to about their own 0.05 m), it enters holding only what it measures.
        let moved_m = |give_up: Option<f64>| {
            let mut lc = out_and_back();
            lc.config.give_up_beyond_chain = give_up;
            for (from, to) in [(19, 60), (17, 62), (15, 64)] {
                lc.verify(offered(&lc, from, to, 0.0), to);
            }
            lc.graph.optimize(&lc.config.optimize);
            let before = lc.graph.nodes()[66];
            let mut slid = offered(&lc, 13, 66, 1.5);
            let cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(
                0.25,
                0.0025,
                1f64.to_radians().powi(2),
            ));
            slid.hypothesis.covariance = cov;
            slid.edge.information = cov.try_inverse().unwrap();
            assert!(lc.verify(slid, 66), "{give_up:?}");
            lc.graph.optimize(&lc.config.optimize);
            before.between(&lc.graph.nodes()[66]).position().norm()
        };
        let claimed_m = moved_m(None);
        let given_up_m = moved_m(Some(1.0));
        assert!(claimed_m > 0.01, "{claimed_m}");
        assert!(given_up_m < 0.001, "{given_up_m}");
    }

    #[test]
    fn only_a_loop_against_another_stretch_of_the_old_pass_vouches_when_asked() {
        let mut lc = out_and_back();
        lc.config.independent_vouching = true;
        for (from, to) in [(19, 60), (17, 62), (15, 64)] {
            lc.verify(offered(&lc, from, to, 0.0), to);
        }
        assert_eq!(lc.closures().len(), 3);
        // Against keyframe 13, whose local map (9..=17) overlaps those of 15, 17 and 19:
        // no vouching, it waits for agreement of its own.
        assert!(!lc.verify(offered(&lc, 13, 66, 0.0), 66));
        assert_eq!(lc.pending.len(), 1);
        // Against keyframe 5, ten keyframes from the nearest reference in the graph: one
        // agreeing loop is enough, and it brings the waiting one in with it.
        assert!(lc.verify(offered(&lc, 5, 74, 0.0), 74));
        assert_eq!(lc.closures().len(), 5);
        assert!(lc.pending.is_empty());
    }

    #[test]
    fn a_loop_the_optimized_graph_disagrees_with_is_taken_out_again() {
        let mut lc = out_and_back();
        lc.config.residual_chi2 = Some(16.27);
        for (from, to) in [(19, 60), (17, 62), (15, 64)] {
            lc.verify(offered(&lc, from, to, 0.0), to);
        }
        assert_eq!(lc.closures().len(), 3);
        // A look-alike 2 m off forced into the graph beside them (as a looser test once
        // let through): after optimizing, it disagrees with the rest and leaves.
        let wrong = offered(&lc, 11, 68, 2.0);
        lc.graph.add_edge(wrong.edge).unwrap();
        lc.closures.push(wrong.closure);
        lc.loops.push(wrong.hypothesis);
        lc.graph.optimize(&OptimizeConfig::default());
        lc.drop_disagreeing_loops();
        let left: Vec<(usize, usize)> = lc.closures().iter().map(|c| (c.from, c.to)).collect();
        assert_eq!(left, vec![(19, 60), (17, 62), (15, 64)]);
        assert_eq!(lc.rejected(), 1);
        assert_eq!(lc.graph.edges().len(), 79 + 3);
        // The right loops hold the straight corridor where it was.
        assert!(lc.poses()[68].position().distance(&Point2::new(5.5, 0.2)) < 0.05);
    }

    #[test]
    fn a_long_unclosed_pass_is_tried_before_a_nearer_one_tied_by_a_short_chain() {
        // An old pass along y = 0, a 30 m excursion north and back, a recent pass along
        // y = 1 (back west), a 10 m detour north and back, and a new keyframe at (5, 0.6):
        // 0.4 m from the recent pass, 0.6 m from the old one, whose chain is four times as
        // long. Nearest first tries the recent pass; `plausible_first` the old one.
        use std::f64::consts::{FRAC_PI_2, PI};
        let mut route = Vec::new();
        route.extend((0..20).map(|i| Pose2::new(0.5 * i as f64, 0.0, 0.0)));
        route.extend((1..=30).map(|j| Pose2::new(10.0, 0.5 * j as f64, FRAC_PI_2)));
        route.extend(
            (0..30)
                .rev()
                .map(|j| Pose2::new(10.0, 0.5 * j as f64, -FRAC_PI_2)),
        );
        route.extend((0..=20).map(|k| Pose2::new(10.0 - 0.5 * k as f64, 1.0, PI)));
        route.extend((1..=10).map(|m| Pose2::new(0.0, 1.0 + 0.5 * m as f64, FRAC_PI_2)));
        route.extend(
            (0..10)
                .rev()
                .map(|m| Pose2::new(0.0, 1.0 + 0.5 * m as f64, -FRAC_PI_2)),
        );
        route.extend((1..=10).map(|n| Pose2::new(0.5 * n as f64, 0.6, 0.0)));
        for plausible_first in [false, true] {
            let mut lc = LoopCloser::new(LoopClosureConfig {
                plausible_first,
                ..LoopClosureConfig::default()
            });
            for pose in &route {
                lc.graph.add_node(*pose);
                let n = lc.graph.nodes().len();
                let travel = match n {
                    1 => 0.0,
                    _ => {
                        let step = lc.graph.nodes()[n - 2]
                            .position()
                            .distance(&pose.position());
                        lc.travel_m[n - 2] + step
                    }
                };
                lc.travel_m.push(travel);
                lc.points.push(Vec::new());
            }
            let new = route.len() - 1;
            let window = lc.config.window;
            let first = lc.candidates(new, &window)[0];
            let y = lc.poses()[first].y;
            if plausible_first {
                assert_eq!(y, 0.0, "the old pass (y = 0), got keyframe {first}");
            } else {
                assert_eq!(y, 1.0, "the recent pass (y = 1), got keyframe {first}");
            }
        }
    }

    #[test]
    fn the_variance_factor_is_the_median_strain_over_that_of_chi2() {
        // Medians 2 and 4.732 = 2 · 2.366 (χ²(3)'s median): 1 (never below) and 2.
        assert_eq!(variance_factor(&[1.0, 2.0, 3.0]), 1.0);
        assert!((variance_factor(&[100.0, 4.0, 4.732]) - 2.0).abs() < 1e-9);
        // No loop, or none finite: the a-priori model stands.
        assert_eq!(variance_factor(&[]), 1.0);
        assert_eq!(variance_factor(&[f64::INFINITY]), 1.0);
    }

    #[test]
    fn right_loops_straining_a_chain_that_drifted_more_than_its_model_all_stay() {
        // The way back drifted sideways 12 mm per keyframe (0.47 m at its end), six times
        // what the sequential edges' model (2 mm and 0.03° a step) lets a straight
        // corridor bend or turn:
        // every right loop then strains alike, several above the a-priori bound. None is
        // taken out, and a look-alike 1 m over among them still is.
        let mut lc = LoopCloser::new(LoopClosureConfig {
            residual_chi2: Some(16.27),
            sequential_sigma_m: 0.002,
            sequential_sigma_per_m: 0.0,
            sequential_sigma_rad: 0.0005,
            ..LoopClosureConfig::default()
        });
        for i in 0..40 {
            lc.add_keyframe(Pose2::new(0.5 * i as f64, 0.0, 0.0), &[], None);
        }
        for i in 0..40 {
            let drift_m = 0.012 * i as f64;
            let pose = Pose2::new(19.5 - 0.5 * i as f64, 0.2 + drift_m, std::f64::consts::PI);
            lc.add_keyframe(pose, &[], None);
        }
        let right = |lc: &LoopCloser, from: usize, to: usize| {
            // The truth: the way back runs at y = 0.2, straight.
            let truth_to = Pose2::new(19.5 - 0.5 * (to - 40) as f64, 0.2, std::f64::consts::PI);
            let truth_from = Pose2::new(0.5 * from as f64, 0.0, 0.0);
            let mut m = offered(lc, from, to, 0.0);
            let z = truth_from.between(&truth_to);
            let information = information(0.01, 0.2f64.to_radians());
            m.hypothesis.measurement = z;
            m.hypothesis.covariance = information.try_inverse().unwrap();
            m.edge.measurement = z;
            m.edge.information = information;
            m
        };
        let put = |lc: &mut LoopCloser, m: MatchedLoop| {
            lc.graph.add_edge(m.edge).unwrap();
            lc.closures.push(m.closure);
            lc.loops.push(m.hypothesis);
        };
        for (from, to) in [
            (37, 42),
            (31, 48),
            (25, 54),
            (19, 60),
            (13, 66),
            (7, 72),
            (1, 78),
        ] {
            let m = right(&lc, from, to);
            put(&mut lc, m);
        }
        lc.graph.optimize(&OptimizeConfig::default());
        let strain = |lc: &LoopCloser| -> Vec<f64> {
            let nodes = lc.graph.nodes();
            lc.loops
                .iter()
                .map(|l| {
                    let e = Edge::new(l.from, l.to, l.measurement, Matrix3::identity());
                    let r = e.error(&nodes[l.from], &nodes[l.to]);
                    r.dot(&(l.covariance.try_inverse().unwrap() * r))
                })
                .collect()
        };
        let d2 = strain(&lc);
        assert!(
            d2.iter().any(|&d| d > 16.27),
            "the setup must strain a right loop beyond the a-priori bound: {d2:?}"
        );
        lc.drop_disagreeing_loops();
        assert_eq!(lc.closures().len(), 7, "strain {d2:?}");
        assert_eq!(lc.rejected(), 0);
        // A look-alike a meter along the corridor stands out against that strain.
        let mut wrong = right(&lc, 16, 63);
        let z = Pose2::new(
            wrong.edge.measurement.x - 1.0,
            wrong.edge.measurement.y,
            wrong.edge.measurement.heading_rad,
        );
        wrong.edge.measurement = z;
        wrong.hypothesis.measurement = z;
        put(&mut lc, wrong);
        lc.graph.optimize(&OptimizeConfig::default());
        lc.drop_disagreeing_loops();
        assert_eq!(lc.rejected(), 1, "strain {:?}", strain(&lc));
        assert!(lc.closures().iter().all(|c| c.from != 16));
    }
}
