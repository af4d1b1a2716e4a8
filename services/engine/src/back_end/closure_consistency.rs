//! Loop-closure consistency: does a matched loop agree with the odometry chain, and with
//! another loop?
//!
//! Sits between the loop matcher ([`super::loop_closure`]) and the pose graph: a scan that
//! matched a place seen long before is only a hypothesis. In a floor of identical rooms or
//! doors in a row the matcher finds look-alikes that score as well as the truth, and one
//! wrong loop optimized into the graph folds a map the front end had right. Two tests, both
//! χ² tests of a 3-dof residual against the uncertainty of what produced it:
//!
//! 1. **Against the chain** ([`prior_distance_sq`]): the loop `Z_ab` (pose of keyframe `b`
//!    in keyframe `a`'s frame) against the graph's current estimate `X_a⁻¹ X_b`:
//!    `e = t2v(Z_ab⁻¹ X_a⁻¹ X_b)`, `d² = eᵀ (Σ_Z + Σ_chain)⁻¹ e`. The chain's covariance
//!    is what the front end's drift along the route from `a` to `b` can explain
//!    ([`chain_variance`]); a loop demanding a larger jump (one room over) is refused.
//! 2. **Against another loop** ([`pair_distance_sq`]), the pairwise test of Mangelson,
//!    Dominic, Eustice, Vasudevan, "Pairwise Consistent Measurement Set Maximization for
//!    Robust Multi-robot Map Merging" (ICRA 2018), eq. (5)–(6): loops `a₁→b₁` and `a₂→b₂`
//!    with the chains `b₁→b₂` and `a₂→a₁` make a cycle, and the loop `a₂→b₂` predicted from
//!    the other, `Ẑ₂ = (X_a₂⁻¹ X_a₁) Z₁ (X_b₁⁻¹ X_b₂)`, must agree with the measured one:
//!    `e = t2v(Z₂⁻¹ Ẑ₂)`. Two wrong matches rarely agree; a right loop seen from two
//!    keyframes always does.
//!
//! 3. **Both ways** ([`two_way_distance_sq`]): the loop matched back — the older
//!    keyframe's scan against the newer one's local map, `Z_r` (pose of `a` in `b`'s frame)
//!    — must undo the loop `Z_f`: `e = t2v(Z_f Z_r) ≈ 0`. A match pulled off the place by
//!    what only one side saw (a scan reaching past its reference, which the likelihood
//!    field scores toward more overlap) is pulled the other way when the roles swap.
//!
//! # What a loop adds
//! A match's covariance is its score plateau's, a Gaussian around the top; along a
//! direction where the plateau is wide (a corridor's axis) the top is not a noisy reading of
//! the place but is set by overlap and clutter, a bias no covariance describes. Where the
//! chain already ties the loop's ends more tightly than the match does — the route since
//! the last loop is short, or ran through a loop that held it — the match tells the graph
//! little along that direction and can only bring its bias. With
//! `LoopClosureConfig::give_up_beyond_chain` the loop gives up each position direction
//! along which its standard deviation exceeds that ratio times the chain's
//! ([`given_up_to_chain`]), in the test against the chain and in the graph's edge alike:
//! a match 1.5 m off along a corridor with σ = 0.5 m there is not tested (nor pulled) along
//! it when the chain since the last loop holds the route to 0.07 m, while the same match
//! after a long unclosed route, where the chain is looser than it, keeps its say. The
//! heading likewise: a loop's heading deviation is not measured but set
//! (`LoopClosureConfig::loop_sigma_rad`, 1°), and matches 1.4–2.8° off pass that test on a
//! good scanner (generated office 43) where the chain since the last loop holds the
//! heading to a fraction of a degree. In the chain tests of later loops it still counts
//! as it claims (they may route through it, it may vouch for them). The rule trusts the
//! chain's claim: where the chain is tighter than the front end's real drift (a long
//! corridor it slides along), a right loop's correction is given up with it.
//!
//! # The chain's covariance
//! Each sequential step `k` (keyframe `k−1 → k`, length `l_k`) adds independent noise of
//! position variance `σ²_k` and heading variance `σ²_θk`, the same figures that weigh the
//! graph's sequential edges: a-priori `σ_k = σ_m + σ_per_m·l_k` and `σ_θk = σ_rad`
//! ([`StepNoise`]), or what the front end measured on that step ([`MeasuredSteps`]). A
//! heading error at step `k` swings the chain's end about keyframe `k`, so to first order
//! the end's position variance is
//!
//! `σ²_pos = Σ_k σ²_k + σ²_θk |p_end − p_k|²`,   `σ²_θ = Σ_k σ²_θk`
//!
//! (isotropic: the direction of the swing is dropped, which errs towards accepting). Cost:
//! O(|to − from|) per chain. Its whole form ([`chain_covariance`], chosen by
//! `LoopClosureConfig::chain_shape`) keeps each step's covariance as the front end gave it
//! (tight across a corridor, loose along it where the scans did not measure the axis) and
//! the swing across the lever only, `Σ_chain = Σ_k G_k Σ_k G_kᵀ`; a route down a corridor
//! and back then has its heading errors swing the loop's end across the corridor, not
//! along it, where look-alike doors in a row lie.
//!
//! Pure: values in, values out.

use nalgebra::{Matrix3, Vector3};
use sketchslam_types::{Point2, Pose2, wrap_angle};

/// A matched loop, not yet in the graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopHypothesis {
    /// The earlier keyframe.
    pub from: usize,
    /// The newer keyframe.
    pub to: usize,
    /// Pose of `to` in the frame of `from`, as the matcher found it.
    pub measurement: Pose2,
    /// Covariance of the measurement's error `t2v(Z⁻¹ X_from⁻¹ X_to)` in (x, y, heading),
    /// the inverse of the loop edge's information.
    pub covariance: Matrix3<f64>,
}

/// Noise of one sequential step of the front end (the graph's sequential edges).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepNoise {
    /// Position standard deviation of a step, meters...
    pub sigma_m: f64,
    /// ...plus this much per meter of the step.
    pub sigma_per_m: f64,
    /// Heading standard deviation of a step, radians.
    pub sigma_rad: f64,
}

/// Variance of a chain's end as seen from its start (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainVariance {
    /// Position variance (isotropic), m².
    pub position_m2: f64,
    /// Heading variance, rad².
    pub heading_rad2: f64,
}

impl ChainVariance {
    /// No uncertainty.
    pub const ZERO: ChainVariance = ChainVariance {
        position_m2: 0.0,
        heading_rad2: 0.0,
    };

    /// The sum of two independent chains.
    pub fn plus(self, other: ChainVariance) -> ChainVariance {
        ChainVariance {
            position_m2: self.position_m2 + other.position_m2,
            heading_rad2: self.heading_rad2 + other.heading_rad2,
        }
    }

    /// As a diagonal (x, y, heading) covariance.
    fn matrix(&self) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::new(
            self.position_m2,
            self.position_m2,
            self.heading_rad2,
        ))
    }
}

/// The noise of each sequential step, as [`chain_variance`] reads it: the a-priori model
/// ([`StepNoise`]) or what the front end measured per step ([`MeasuredSteps`]).
pub trait StepVariance {
    /// Position variance (isotropic) and heading variance of step `k` (keyframe `k − 1 → k`),
    /// `step_m` long.
    fn step(&self, k: usize, step_m: f64) -> ChainVariance;

    /// Step `k`'s whole (x, y, heading) covariance, translation on the map's axes, as
    /// [`chain_covariance`] reads it: by default the isotropic [`StepVariance::step`] as a
    /// diagonal.
    fn step_covariance(&self, k: usize, step_m: f64) -> Matrix3<f64> {
        self.step(k, step_m).matrix()
    }
}

impl StepNoise {
    /// Position standard deviation of a step `step_m` long: `σ_m + σ_per_m · l`.
    pub fn position_sigma_m(&self, step_m: f64) -> f64 {
        self.sigma_m + self.sigma_per_m * step_m
    }
}

impl StepVariance for StepNoise {
    fn step(&self, _k: usize, step_m: f64) -> ChainVariance {
        let sigma_m = self.position_sigma_m(step_m);
        ChainVariance {
            position_m2: sigma_m * sigma_m,
            heading_rad2: self.sigma_rad * self.sigma_rad,
        }
    }
}

/// Each step's variance as the front end measured it, indexed by the step's newer
/// keyframe (entry 0 unused); a step beyond the slice falls back to `model`.
#[derive(Debug, Clone, Copy)]
pub struct MeasuredSteps<'a> {
    /// Variance of step `k` at index `k`.
    pub steps: &'a [ChainVariance],
    /// Whole covariance of step `k` at index `k` (map axes); a step beyond this slice
    /// falls back to `steps`' isotropic figure.
    pub covariances: &'a [Matrix3<f64>],
    /// For steps not measured.
    pub model: StepNoise,
}

impl StepVariance for MeasuredSteps<'_> {
    fn step(&self, k: usize, step_m: f64) -> ChainVariance {
        match self.steps.get(k) {
            Some(v) => *v,
            None => self.model.step(k, step_m),
        }
    }

    fn step_covariance(&self, k: usize, step_m: f64) -> Matrix3<f64> {
        match self.covariances.get(k) {
            Some(c) => *c,
            None => self.step(k, step_m).matrix(),
        }
    }
}

/// The variance the sequential steps between keyframes `a` and `b` (either order) add to
/// a point at `lever_end` carried along them: the module doc's sum over the steps
/// `min(a, b) + 1 ..= max(a, b)`, with `nodes` the keyframes' current estimates and each
/// step's own position and heading variance from `noise`. O(|b − a|).
pub fn chain_variance(
    nodes: &[Pose2],
    a: usize,
    b: usize,
    noise: &dyn StepVariance,
    lever_end: Point2,
) -> ChainVariance {
    let (lo, hi) = (a.min(b), a.max(b).min(nodes.len().saturating_sub(1)));
    let mut v = ChainVariance::ZERO;
    for k in lo + 1..=hi {
        let p = nodes[k].position();
        let step = noise.step(k, p.distance(&nodes[k - 1].position()));
        let lever_m = lever_end.distance(&p);
        v.position_m2 += step.position_m2 + step.heading_rad2 * lever_m * lever_m;
        v.heading_rad2 += step.heading_rad2;
    }
    v
}

/// The whole covariance (x, y, heading; map axes) of the end of the chain between
/// keyframes `a` and `b` (either order) at `lever_end`, the anisotropic form of
/// [`chain_variance`] (module doc, "The chain's covariance"): a step's error `δ_k =
/// (δx, δy, δθ)` moves keyframe `k` by `(δx, δy)` and turns the rest of the chain about
/// it, so it moves the end by `G_k δ_k`, `G_k = [[1, 0, −(y_end − y_k)], [0, 1, x_end −
/// x_k], [0, 0, 1]]` (first order), and
///
/// `Σ_chain = Σ_k G_k Σ_k G_kᵀ`
///
/// with `Σ_k` the step's own ([`StepVariance::step_covariance`]). A chain down a corridor
/// and back keeps what each step's scans pinned: its heading errors swing the end across
/// the corridor, not along it, and its steps' along-axis variance is only what the
/// front end left unmeasured there. O(|b − a|).
pub fn chain_covariance(
    nodes: &[Pose2],
    a: usize,
    b: usize,
    noise: &dyn StepVariance,
    lever_end: Point2,
) -> Matrix3<f64> {
    let (lo, hi) = (a.min(b), a.max(b).min(nodes.len().saturating_sub(1)));
    let mut sum = Matrix3::zeros();
    for k in lo + 1..=hi {
        let p = nodes[k].position();
        let step = noise.step_covariance(k, p.distance(&nodes[k - 1].position()));
        let g = swing(p, lever_end);
        sum += g * step * g.transpose();
    }
    sum
}

/// `G` of [`chain_covariance`]: a small `(δx, δy, δθ)` at `pivot` moves a point at `end`
/// by `(δx − δθ (y_end − y_pivot), δy + δθ (x_end − x_pivot))` and turns it by `δθ`.
pub fn swing(pivot: Point2, end: Point2) -> Matrix3<f64> {
    Matrix3::new(
        1.0,
        0.0,
        -(end.y - pivot.y),
        0.0,
        1.0,
        end.x - pivot.x,
        0.0,
        0.0,
        1.0,
    )
}

/// The largest position variance of a whole (x, y, heading) covariance, m²: its 2×2
/// block's larger eigenvalue. O(1).
pub fn widest_m2(covariance: &Matrix3<f64>) -> f64 {
    covariance
        .fixed_view::<2, 2>(0, 0)
        .into_owned()
        .symmetric_eigenvalues()
        .max()
}

/// `t2v(Z⁻¹ · actual)`: how far `actual` is from the measurement `z`, in `z`'s frame, the
/// heading wrapped.
fn residual(z: &Pose2, actual: &Pose2) -> Vector3<f64> {
    let d = z.inverse().compose(actual);
    Vector3::new(d.x, d.y, wrap_angle(actual.heading_rad - z.heading_rad))
}

/// `eᵀ Σ⁻¹ e`; infinite when `Σ` is not invertible.
fn mahalanobis_sq(e: &Vector3<f64>, cov: &Matrix3<f64>) -> f64 {
    match cov.try_inverse() {
        Some(info) => e.dot(&(info * e)),
        None => f64::INFINITY,
    }
}

/// Variance put on a position direction a loop gives up, m²: (100 m)², nothing next to
/// any chain's (no pull, no say in a test), yet finite, so the tests' inverses stay
/// defined. Also what `unpin_featureless_direction` puts on a featureless direction.
pub const GIVEN_UP_M2: f64 = 1e4;
/// Variance put on a heading a loop gives up, rad².
pub const GIVEN_UP_RAD2: f64 = 1e4;

/// What a loop knows beyond the chain it closes (module doc, "What a loop adds"): the
/// variance to add to the loop's covariance so that it gives up each direction of its
/// position along which its standard deviation is above `ratio` times the chain's
/// (`chain`'s isotropic position variance), and its heading when that is. Zero when the
/// loop is tighter than that everywhere. `covariance` in the loop's error frame, as
/// [`LoopHypothesis::covariance`]; the position's directions are its 2×2 block's
/// eigenvectors. O(1).
pub fn given_up_to_chain(
    covariance: &Matrix3<f64>,
    chain: ChainVariance,
    ratio: f64,
) -> Matrix3<f64> {
    let bound_m2 = ratio * ratio * chain.position_m2.max(0.0);
    let eigen = covariance
        .fixed_view::<2, 2>(0, 0)
        .into_owned()
        .symmetric_eigen();
    let mut added_xy = nalgebra::Matrix2::zeros();
    for (i, &var_m2) in eigen.eigenvalues.iter().enumerate() {
        if var_m2 > bound_m2 {
            let u = eigen.eigenvectors.column(i);
            added_xy += u * u.transpose() * GIVEN_UP_M2;
        }
    }
    let mut added = Matrix3::zeros();
    added.fixed_view_mut::<2, 2>(0, 0).copy_from(&added_xy);
    if covariance[(2, 2)] > ratio * ratio * chain.heading_rad2.max(0.0) {
        added[(2, 2)] = GIVEN_UP_RAD2;
    }
    added
}

/// Test 1 of the module doc: the squared Mahalanobis distance between the loop and the
/// graph's estimate, under the loop's covariance plus `chain` (what the route between the
/// loop's ends can have drifted). Compare with a χ² quantile of 3 degrees of freedom. O(1).
pub fn prior_distance_sq(nodes: &[Pose2], loop_: &LoopHypothesis, chain: ChainVariance) -> f64 {
    let estimate = nodes[loop_.from].between(&nodes[loop_.to]);
    let e = residual(&loop_.measurement, &estimate);
    mahalanobis_sq(&e, &(loop_.covariance + chain.matrix()))
}

/// Test 1 with the chain's whole covariance `chain_map` (map axes, [`chain_covariance`]):
/// the residual `t2v(Z⁻¹ X_a⁻¹ X_b)` moves by `R(θ_b)ᵀ δp` when `X_b` moves by `δp` on the
/// map (to first order, `θ_a + θ_Z ≈ θ_b`), so `d² = eᵀ (Σ_Z + T Σ_chain Tᵀ)⁻¹ e` with `T =
/// diag(R(θ_b)ᵀ, 1)`. O(1).
pub fn prior_distance_sq_full(
    nodes: &[Pose2],
    loop_: &LoopHypothesis,
    chain_map: &Matrix3<f64>,
) -> f64 {
    let estimate = nodes[loop_.from].between(&nodes[loop_.to]);
    let e = residual(&loop_.measurement, &estimate);
    let t = to_frame(nodes[loop_.to].heading_rad);
    mahalanobis_sq(&e, &(loop_.covariance + t * chain_map * t.transpose()))
}

/// `diag(R(θ)ᵀ, 1)`: map axes into the axes of a frame turned by `heading_rad`.
pub fn to_frame(heading_rad: f64) -> Matrix3<f64> {
    let (s, c) = heading_rad.sin_cos();
    Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0)
}

/// Test 2 of the module doc: the squared Mahalanobis distance between loop `second` and
/// its prediction from loop `first` through the chains between their ends (the graph's
/// current estimates, with [`chain_variance`]'s uncertainty). Symmetric in the sense that
/// matters: the newer loop is predicted from the older. O(|Δto| + |Δfrom|).
pub fn pair_distance_sq(
    nodes: &[Pose2],
    first: &LoopHypothesis,
    second: &LoopHypothesis,
    noise: &dyn StepVariance,
) -> f64 {
    let (c1, c2) = if first.to <= second.to {
        (first, second)
    } else {
        (second, first)
    };
    let (a1, b1, a2, b2) = (c1.from, c1.to, c2.from, c2.to);
    // Ẑ₂ = (X_a₂⁻¹ X_a₁) Z₁ (X_b₁⁻¹ X_b₂)
    let predicted = nodes[a2]
        .between(&nodes[a1])
        .compose(&c1.measurement)
        .compose(&nodes[b1].between(&nodes[b2]));
    let e = residual(&c2.measurement, &predicted);
    // Z₁'s own uncertainty at b₂: its position part (widest direction) and its heading
    // swinging the chain b₁ → b₂ about b₁.
    let c1_pos = widest_m2(&c1.covariance).max(0.0);
    let c1_rad2 = c1.covariance[(2, 2)].max(0.0);
    let swing_m = nodes[b2].position().distance(&nodes[b1].position());
    let first_loop = ChainVariance {
        position_m2: c1_pos + c1_rad2 * swing_m * swing_m,
        heading_rad2: c1_rad2,
    };
    // The new chain ends at b₂; the old chain's end is carried to where b₂ is in the old
    // part of the map, near a₂.
    let new_chain = chain_variance(nodes, b1, b2, noise, nodes[b2].position());
    let old_chain = chain_variance(nodes, a1, a2, noise, nodes[a2].position());
    let cov = c2.covariance + first_loop.plus(new_chain).plus(old_chain).matrix();
    mahalanobis_sq(&e, &cov)
}

/// The adjoint of `t`: `t · Exp(δ) · t⁻¹ = Exp(Ad(t) δ)` for a small `δ = (x, y, θ)`,
/// `Ad(t) = [[R, (t_y, −t_x)ᵀ], [0, 0, 1]]`.
fn adjoint(t: &Pose2) -> Matrix3<f64> {
    let (s, c) = t.heading_rad.sin_cos();
    Matrix3::new(c, -s, t.y, s, c, -t.x, 0.0, 0.0, 1.0)
}

/// Test 3 of the module doc: the squared Mahalanobis distance of `e = t2v(Z_f Z_r)` from
/// zero, for a loop `forward` (pose of the newer keyframe in the older's frame) and its
/// match back `reverse` (the older in the newer's), each with the covariance of its error
/// in its own frame (`Z · Exp(δ)`). Since `Z_f Exp(δ_f) Z_r Exp(δ_r) = Z_f Z_r Exp(Ad(Z_r⁻¹)
/// δ_f) Exp(δ_r)`, `Σ_e = Ad(Z_r⁻¹) Σ_f Ad(Z_r⁻¹)ᵀ + Σ_r`. Compare with a χ² quantile of 3
/// degrees of freedom. O(1).
pub fn two_way_distance_sq(
    forward: &Pose2,
    forward_cov: &Matrix3<f64>,
    reverse: &Pose2,
    reverse_cov: &Matrix3<f64>,
) -> f64 {
    let round_trip = forward.compose(reverse);
    let e = Vector3::new(
        round_trip.x,
        round_trip.y,
        wrap_angle(round_trip.heading_rad),
    );
    let ad = adjoint(&reverse.inverse());
    mahalanobis_sq(&e, &(ad * forward_cov * ad.transpose() + reverse_cov))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    const NOISE: StepNoise = StepNoise {
        sigma_m: 0.02,
        sigma_per_m: 0.0,
        sigma_rad: 0.01,
    };

    fn straight(n: usize) -> Vec<Pose2> {
        (0..n).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect()
    }

    fn loop_(from: usize, to: usize, z: Pose2, sigma_m: f64, sigma_rad: f64) -> LoopHypothesis {
        LoopHypothesis {
            from,
            to,
            measurement: z,
            covariance: Matrix3::from_diagonal(&Vector3::new(
                sigma_m * sigma_m,
                sigma_m * sigma_m,
                sigma_rad * sigma_rad,
            )),
        }
    }

    #[test]
    fn a_loop_gives_up_only_the_directions_the_chain_knows_better() {
        // A corridor loop along (cos 30°, sin 30°): σ 0.5 m along it, 0.06 m across, 1°.
        let (s, c) = 30f64.to_radians().sin_cos();
        let r = nalgebra::Matrix2::new(c, -s, s, c);
        let xy = r * nalgebra::Matrix2::new(0.25, 0.0, 0.0, 0.0036) * r.transpose();
        let mut cov = Matrix3::zeros();
        cov.fixed_view_mut::<2, 2>(0, 0).copy_from(&xy);
        cov[(2, 2)] = 1f64.to_radians().powi(2);
        let chain = |sigma_m: f64| ChainVariance {
            position_m2: sigma_m * sigma_m,
            heading_rad2: 1e-4,
        };
        // A chain of 0.07 m and 0.57° (1e-4 rad²): the axis (0.5 > 0.07) and the heading
        // (1° > 0.57°) are given up, across (0.06 < 0.07) is kept.
        let added = given_up_to_chain(&cov, chain(0.07), 1.0);
        let along = nalgebra::Vector3::new(c, s, 0.0);
        let across = nalgebra::Vector3::new(-s, c, 0.0);
        assert!(
            (along.dot(&(added * along)) - GIVEN_UP_M2).abs() < 1e-6,
            "{added}"
        );
        assert!(across.dot(&(added * across)).abs() < 1e-6, "{added}");
        assert_eq!(added[(2, 2)], GIVEN_UP_RAD2);
        // A chain of 1 m and 2° (a long unclosed route): nothing given up; of 0.05 m:
        // both position directions.
        let loose = ChainVariance {
            position_m2: 1.0,
            heading_rad2: 2f64.to_radians().powi(2),
        };
        assert_eq!(given_up_to_chain(&cov, loose, 1.0), Matrix3::zeros());
        let both = given_up_to_chain(&cov, chain(0.05), 1.0);
        assert!((both.fixed_view::<2, 2>(0, 0).trace() - 2.0 * GIVEN_UP_M2).abs() < 1e-6);
        // The ratio scales the chain: 0.5 m and 1° against 8 × 0.07 m and 8 × 0.57° are
        // kept.
        assert_eq!(given_up_to_chain(&cov, chain(0.07), 8.0), Matrix3::zeros());
        // The test against the chain on a loop 1.5 m off along the axis: as the loop
        // claims itself, d² = 1.5² / (0.25 + 0.07²) ≈ 8.8, inside the 99 % bound of 11.34
        // (the chain's 0.07 m says it is 21 σ off); with the axis given up, d² ≈ 0 — the
        // axis is no longer the loop's to say.
        let nodes = vec![Pose2::IDENTITY, Pose2::new(0.0, 0.0, 0.0)];
        let off = LoopHypothesis {
            from: 0,
            to: 1,
            measurement: Pose2::new(1.5 * c, 1.5 * s, 0.0),
            covariance: cov,
        };
        let claimed = prior_distance_sq(&nodes, &off, chain(0.07));
        assert!((claimed - 2.25 / (0.25 + 0.0049)).abs() < 1e-6, "{claimed}");
        let given_up = LoopHypothesis {
            covariance: cov + added,
            ..off
        };
        assert!(prior_distance_sq(&nodes, &given_up, chain(0.07)) < 1e-3);
        // Across the axis it still speaks: 0.3 m off across is refused.
        let aside = LoopHypothesis {
            measurement: Pose2::new(-0.3 * s, 0.3 * c, 0.0),
            ..given_up
        };
        let d2 = prior_distance_sq(&nodes, &aside, chain(0.07));
        assert!((d2 - 0.09 / (0.0036 + 0.0049)).abs() < 1e-3, "{d2}");
    }

    #[test]
    fn chain_variance_by_hand() {
        // Three unit steps along x, ending at x = 3: position variance
        // 3·0.02² + 0.01²·(2² + 1² + 0²) = 0.0012 + 0.0005; heading 3·0.01².
        let nodes = straight(4);
        let v = chain_variance(&nodes, 0, 3, &NOISE, nodes[3].position());
        assert!((v.position_m2 - 0.0017).abs() < 1e-12, "{v:?}");
        assert!((v.heading_rad2 - 0.0003).abs() < 1e-12, "{v:?}");
        // The order of the ends does not matter, and an empty chain adds nothing.
        assert_eq!(chain_variance(&nodes, 3, 0, &NOISE, nodes[3].position()), v);
        assert_eq!(
            chain_variance(&nodes, 2, 2, &NOISE, Point2::new(0.0, 0.0)),
            ChainVariance::ZERO
        );
    }

    #[test]
    fn measured_steps_replace_the_model_where_given() {
        // Steps 1 and 2 measured, step 3 beyond the slice: the model's 0.02² and 0.01².
        let steps = [
            ChainVariance::ZERO,
            ChainVariance {
                position_m2: 1e-4,
                heading_rad2: 4e-4,
            },
            ChainVariance {
                position_m2: 9e-4,
                heading_rad2: 0.0,
            },
        ];
        let measured = MeasuredSteps {
            steps: &steps,
            covariances: &[],
            model: NOISE,
        };
        let nodes = straight(4);
        // Levers to x = 3: 2, 1 and 0 m. Position 1e-4 + 4e-4·2² + 9e-4 + 0 + 0.02² + 1e-4·0,
        // heading 4e-4 + 0 + 1e-4.
        let v = chain_variance(&nodes, 0, 3, &measured, nodes[3].position());
        assert!((v.position_m2 - 0.003).abs() < 1e-12, "{v:?}");
        assert!((v.heading_rad2 - 0.0005).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn a_loop_that_agrees_with_the_chain_passes_and_one_a_room_over_does_not() {
        let nodes = straight(11);
        let chain = chain_variance(&nodes, 0, 10, &NOISE, nodes[10].position());
        // The estimate says keyframe 10 is 10 m ahead of keyframe 0.
        let right = loop_(0, 10, Pose2::new(10.05, 0.02, 0.005), 0.05, 0.02);
        let d_right = prior_distance_sq(&nodes, &right, chain);
        // Residual (−0.05, −0.02, −0.005) against σ² = 0.05² + 0.0075 (pos), 0.02² + 0.001.
        let pos_var = 0.0025 + chain.position_m2;
        let head_var = 0.0004 + chain.heading_rad2;
        let by_hand = (0.05f64.powi(2) + 0.02f64.powi(2)) / pos_var + 0.005f64.powi(2) / head_var;
        assert!((d_right - by_hand).abs() < 1e-3, "{d_right} vs {by_hand}");
        assert!(d_right < 11.34);
        let room_over = loop_(0, 10, Pose2::new(15.0, 0.0, 0.0), 0.05, 0.02);
        assert!(prior_distance_sq(&nodes, &room_over, chain) > 100.0);
    }

    #[test]
    fn two_views_of_one_loop_agree_and_a_look_alike_does_not() {
        // A route along x and back along y = 0.1: keyframes 10.. revisit 9..0.
        let mut nodes = straight(10);
        for i in 0..10 {
            nodes.push(Pose2::new(9.0 - i as f64, 0.1, std::f64::consts::PI));
        }
        // The truth: keyframe 12 (at x = 7) sees keyframe 7 from 0.1 m to its left,
        // turned half a turn; keyframe 14 (x = 5) sees keyframe 5 the same way.
        let z = Pose2::new(0.0, 0.1, std::f64::consts::PI);
        let a = loop_(7, 12, z, 0.05, 0.02);
        let b = loop_(5, 14, z, 0.05, 0.02);
        assert!(pair_distance_sq(&nodes, &a, &b, &NOISE) < 1.0);
        assert!(pair_distance_sq(&nodes, &b, &a, &NOISE) < 1.0);
        // A look-alike: keyframe 14 matched keyframe 2 as if it were there (3 m off).
        let wrong = loop_(2, 14, z, 0.05, 0.02);
        assert!(pair_distance_sq(&nodes, &a, &wrong, &NOISE) > 100.0);
    }

    #[test]
    fn a_loop_matched_back_agrees_and_one_pulled_aside_does_not() {
        let cov = Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, 1e-4));
        let forward = Pose2::new(2.0, 0.0, 0.0);
        // The exact inverse: no residual.
        let back = forward.inverse();
        assert!(two_way_distance_sq(&forward, &cov, &back, &cov) < 1e-20);
        // Matched back 0.3 m aside: e = (0, 0.3, 0). With Z_r⁻¹ = (2, −0.3, 0),
        // Ad = [[1, 0, −0.3], [0, 1, −2], [0, 0, 1]], Σ_e = Ad Σ Adᵀ + Σ =
        // [[0.020009, 6e-5, −3e-5], [6e-5, 0.0204, −2e-4], [−3e-5, −2e-4, 2e-4]]:
        // eᵀ Σ_e⁻¹ e = 4.4555 (0.09 / 0.0204 = 4.41 without the heading's share).
        let aside = Pose2::new(-2.0, 0.3, 0.0);
        let d2 = two_way_distance_sq(&forward, &cov, &aside, &cov);
        assert!((d2 - 4.455455).abs() < 1e-5, "{d2}");
        // 1 m aside is far outside what the two matches' noise explains.
        let far = Pose2::new(-2.0, 1.0, 0.0);
        assert!(two_way_distance_sq(&forward, &cov, &far, &cov) > 11.34);
        // A turned loop: forward (1, 0, 90°) and back its inverse (0, 1, −90°).
        let turned = Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        let d2 = two_way_distance_sq(&turned, &cov, &turned.inverse(), &cov);
        assert!(d2 < 1e-20, "{d2}");
    }

    #[test]
    fn a_corridors_chain_by_hand_is_loose_along_and_tight_across() {
        // Three unit steps along x, each loose along the corridor (0.2 m) and tight across
        // (0.01 m) and in heading (0.01 rad); end at x = 3, levers 2, 1, 0 m. G_k moves
        // the heading's error onto y only: xx = 3·0.04, yy = 3·1e-4 + 1e-4·(2² + 1² + 0²),
        // yθ = 1e-4·(2 + 1 + 0), θθ = 3·1e-4, no xy or xθ.
        let step = Matrix3::from_diagonal(&Vector3::new(0.04, 1e-4, 1e-4));
        let covariances = [Matrix3::zeros(), step, step, step];
        let measured = MeasuredSteps {
            steps: &[],
            covariances: &covariances,
            model: NOISE,
        };
        let mut nodes = straight(4);
        let full = chain_covariance(&nodes, 0, 3, &measured, nodes[3].position());
        let expected = Matrix3::new(0.12, 0.0, 0.0, 0.0, 8e-4, 3e-4, 0.0, 3e-4, 3e-4);
        assert!((full - expected).abs().max() < 1e-12, "{full}");
        assert!((widest_m2(&full) - 0.12).abs() < 1e-12);
        // The same steps without covariances: the isotropic figures as a diagonal.
        let by_model = chain_covariance(&nodes, 0, 3, &NOISE, nodes[3].position());
        let v = chain_variance(&nodes, 0, 3, &NOISE, nodes[3].position());
        assert!(
            (by_model[(0, 0)] - 3.0 * 0.0004).abs() < 1e-12,
            "{by_model}"
        );
        assert!((by_model[(0, 0)] + by_model[(1, 1)] - 2.0 * 0.0012 - 5e-4).abs() < 1e-12);
        assert!((by_model[(2, 2)] - v.heading_rad2).abs() < 1e-12);

        // The loop's end faces up the page (heading 90°): the map's x is its frame's −y.
        nodes[3].heading_rad = FRAC_PI_2;
        let cov = Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, 1e-4));
        let isotropic = ChainVariance {
            position_m2: widest_m2(&full) + 1e-4 * 5.0,
            heading_rad2: 3e-4,
        };
        // 0.3 m off along the corridor (map x): d² = 0.09 / (0.01 + 0.12) either way.
        let along = LoopHypothesis {
            from: 0,
            to: 3,
            measurement: Pose2::new(3.3, 0.0, FRAC_PI_2),
            covariance: cov,
        };
        let d2 = prior_distance_sq_full(&nodes, &along, &full);
        assert!((d2 - 0.09 / 0.13).abs() < 1e-9, "{d2}");
        // 0.3 m off across it (map y): the isotropic chain lets it pass at d² ≈ 0.69; the
        // whole one, tight across and its heading coupled to y, holds it to
        // 0.09 · 4e-4 / (0.0108 · 4e-4 − (3e-4)²) ≈ 8.51.
        let across = LoopHypothesis {
            measurement: Pose2::new(3.0, 0.3, FRAC_PI_2),
            ..along
        };
        let d2 = prior_distance_sq_full(&nodes, &across, &full);
        let hand = 0.09 * 4e-4 / (0.0108 * 4e-4 - 9e-8);
        assert!((d2 - hand).abs() < 1e-9, "{d2} {hand}");
        let loose = prior_distance_sq(&nodes, &across, isotropic);
        assert!((loose - 0.09 / (0.01 + 0.1205)).abs() < 1e-9, "{loose}");
    }
}
