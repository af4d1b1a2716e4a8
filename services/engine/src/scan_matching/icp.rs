//! Point-to-line ICP: step 5 of the pipeline (eq. 6, the position correction with the
//! heading held from eq. 5) and the `icp` baseline (the paper's "conventional ICP-SLAM":
//! frame-to-frame or scan-to-map ICP seeded by odometry, full SE(2)).
//!
//! Reference: points `q_j` (the previous frame's returns, or cells of the map built so far, see
//! [`OccupancyGrid::occupied_points_near`]) in a k-d tree (kiddo `ImmutableKdTree`), each with
//! a normal `n_j` from PCA over its `normal_neighbours` nearest neighbours (the eigenvector of
//! the smallest eigenvalue of their covariance; neighbourhoods that are not line-like, with
//! `λ_min / λ_max > max_normal_eigen_ratio`, get no normal and are never matched).
//!
//! Alignment of source points `p_i` (robot frame) to find the pose `x = (t, θ)` of the robot
//! in the reference frame minimises (eq. 6)
//!
//! `E(t, θ) = Σ_i ρ( n_jᵢ · (R(θ) p_i + t − q_jᵢ) )`
//!
//! with `q_jᵢ` the nearest reference point of the transformed `p_i` and ρ the Huber loss.
//! Each iteration: nearest neighbours (O(n log m)), correspondences farther than the gate
//! dropped, one Gauss-Newton step on the linearised residuals
//! `r_i + J_i δ`, `J_i = [n_x, n_y, n · (R(θ + π/2) p_i)]` (the last column only in
//! [`IcpMode::Full`]) solved by a damped 3×3 / 2×2 normal-equation system with iteratively
//! reweighted Huber weights. The gate shrinks geometrically from `max_correspondence_m` to
//! `min_correspondence_m` (factor `gate_shrink` per iteration); convergence when the step is
//! below `convergence_translation_m` and `convergence_rotation_rad` with the gate at its
//! floor (or after `max_iterations`). Degenerate directions (a corridor) are held near the
//! initial guess by the small damping term.
//!
//! Cost: building O(m log m + m·k log m); aligning O(iterations · n log m).

use crate::mapping::grid::OccupancyGrid;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{Matrix2, Vector2};
use sketchslam_types::{Point2, Pose2};
use std::num::NonZero;

/// ICP parameters. Lengths in meters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcpConfig {
    /// Iterations at most. Default 40.
    pub max_iterations: usize,
    /// Correspondence gate at the first iteration, meters. Default 1.0.
    pub max_correspondence_m: f64,
    /// Floor of the shrinking gate, meters. Default 0.2.
    pub min_correspondence_m: f64,
    /// Gate factor per iteration (0 < f ≤ 1). Default 0.75.
    pub gate_shrink: f64,
    /// Huber threshold on the point-to-line residual, meters. Default 0.05.
    pub huber_m: f64,
    /// Neighbours (the point included) for a reference normal. Default 8.
    pub normal_neighbours: usize,
    /// Neighbours farther than this from the point do not enter its normal. Default 0.5 m.
    pub normal_radius_m: f64,
    /// A reference point whose neighbourhood has `λ_min / λ_max` above this has no normal.
    /// Default 0.3.
    pub max_normal_eigen_ratio: f64,
    /// Stop when the translation step is below this (and the rotation step below its
    /// threshold). Default 1e-4 m.
    pub convergence_translation_m: f64,
    /// Rotation step threshold, radians. Default 1e-5.
    pub convergence_rotation_rad: f64,
    /// Fewer correspondences than this: no update, the result is not converged. Default 10.
    pub min_inliers: usize,
}

impl Default for IcpConfig {
    fn default() -> Self {
        Self {
            max_iterations: 40,
            max_correspondence_m: 1.0,
            min_correspondence_m: 0.2,
            gate_shrink: 0.75,
            huber_m: 0.05,
            normal_neighbours: 8,
            normal_radius_m: 0.5,
            max_normal_eigen_ratio: 0.3,
            convergence_translation_m: 1e-4,
            convergence_rotation_rad: 1e-5,
            min_inliers: 10,
        }
    }
}

/// Which parameters ICP estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IcpMode {
    /// Only the translation; the heading of the initial pose is held (eq. 6 after eq. 5).
    TranslationOnly,
    /// Translation and heading (the ICP baseline).
    Full,
}

/// The outcome of [`Icp::align`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcpResult {
    /// The estimated pose of the source frame in the reference frame.
    pub pose: Pose2,
    /// Iterations run.
    pub iterations: usize,
    /// Correspondences within the final gate.
    pub inliers: usize,
    /// RMS point-to-line residual of those correspondences at `pose`, meters.
    pub rms_m: f64,
    /// True when the step fell below the convergence thresholds.
    pub converged: bool,
    /// `H = Σ_i w_i J_i J_iᵀ` at `pose` over the final correspondences (Huber weights
    /// `w_i`, Jacobians of the module doc; the heading row and column are zero in
    /// [`IcpMode::TranslationOnly`]), unit m⁻²·m² = 1: the number of points, weighted, that
    /// pin each direction down. With independent residuals of standard deviation σ the
    /// pose's covariance is `σ² H⁻¹`, so a direction along which `H` is small — a
    /// corridor's axis — is one the scan does not measure ([`IcpResult::weakest_direction`]).
    pub normal_matrix: nalgebra::Matrix3<f64>,
}

impl IcpResult {
    /// The translation direction the match constrains least (unit vector, reference frame)
    /// and `H`'s eigenvalue along it (weighted points; module doc of the field
    /// [`IcpResult::normal_matrix`]). O(1).
    pub fn weakest_direction(&self) -> (Point2, f64) {
        let h = self.normal_matrix.fixed_view::<2, 2>(0, 0).into_owned();
        let eig = h.symmetric_eigen();
        let k = if eig.eigenvalues[0] <= eig.eigenvalues[1] {
            0
        } else {
            1
        };
        let v = eig.eigenvectors.column(k);
        (Point2::new(v[0], v[1]), eig.eigenvalues[k].max(0.0))
    }

    /// The translation directions the match does not measure: the unit eigenvectors of
    /// `H`'s translation block whose eigenvalue is below `min_points` (weighted returns; a
    /// corridor's axis), in eigen-decomposition order. None when the scan pins both down,
    /// both in open space. O(1).
    pub fn unmeasured_directions(
        &self,
        min_points: f64,
    ) -> impl Iterator<Item = Vector2<f64>> + Clone {
        let h = self.normal_matrix.fixed_view::<2, 2>(0, 0).into_owned();
        let eig = h.symmetric_eigen();
        (0..2)
            .filter(move |&k| eig.eigenvalues[k] < min_points)
            .map(move |k| eig.eigenvectors.column(k).into_owned())
    }

    /// The projector onto [`IcpResult::unmeasured_directions`]: `Σ v vᵀ` over them (zero
    /// when the scan pins both down, the identity in open space). The odometry's share of
    /// [`IcpResult::covariance`] is this times its variance. O(1).
    pub fn unmeasured_projector(&self, min_points: f64) -> Matrix2<f64> {
        self.unmeasured_directions(min_points)
            .fold(Matrix2::zeros(), |p, v| p + v * v.transpose())
    }

    /// The pose's covariance under independent residuals of the converged RMS,
    /// `Σ = rms² H⁻¹` in (x, y, heading), translation in the reference frame (Censi, "An
    /// accurate closed-form estimate of ICP's covariance", ICRA 2007, takes this as the
    /// first term; it underestimates where the residuals are correlated). Each
    /// translation eigen-direction of `H` with eigenvalue below `min_points` (a
    /// corridor's axis: module doc of [`super::motion_prior`]) is not measured and gets at
    /// least `unmeasured_m2` (the caller's prior along it, say the odometry's). The
    /// heading variance is `None` in [`IcpMode::TranslationOnly`] (the heading was held,
    /// `H`'s heading row is zero) and when `H` is singular there. O(1).
    pub fn covariance(&self, min_points: f64, unmeasured_m2: f64) -> (Matrix2<f64>, Option<f64>) {
        let rms2 = self.rms_m * self.rms_m;
        let h = &self.normal_matrix;
        let h_tt = h.fixed_view::<2, 2>(0, 0).into_owned();
        let eig = h_tt.symmetric_eigen();
        let measured = eig.eigenvalues.iter().all(|&l| l >= min_points);
        let full = if h[(2, 2)] > 0.0 && measured {
            h.try_inverse()
                .filter(|inv| inv[(2, 2)].is_finite() && inv[(2, 2)] > 0.0)
        } else {
            None
        };
        if let Some(inv) = full {
            // Heading and translation estimated together: the marginal of each.
            return (
                rms2 * inv.fixed_view::<2, 2>(0, 0).into_owned(),
                Some(rms2 * inv[(2, 2)]),
            );
        }
        let mut cov = Matrix2::zeros();
        for k in 0..2 {
            let v = eig.eigenvectors.column(k).into_owned();
            let l = eig.eigenvalues[k];
            let var = if l >= min_points {
                rms2 / l
            } else if l > 0.0 {
                (rms2 / l).max(unmeasured_m2)
            } else {
                unmeasured_m2
            };
            cov += var * v * v.transpose();
        }
        // The heading's own information, the translation held: a lower bound of its variance
        // (the coupling is dropped with the unmeasured directions).
        let heading = (h[(2, 2)] > 0.0).then(|| rms2 / h[(2, 2)]);
        (cov, heading)
    }
}

/// A reference point set prepared for alignment: k-d tree and normals, built once.
#[derive(Debug, Clone)]
pub struct Icp {
    config: IcpConfig,
    points: Vec<Point2>,
    /// Unit normal per point, `None` when its neighbourhood is not line-like.
    normals: Vec<Option<Point2>>,
    tree: Option<ImmutableKdTree<f64, 2>>,
}

/// Normal of the points `nb` (PCA): the eigenvector of the smaller eigenvalue of their
/// covariance, with the eigenvalue ratio `λ_min / λ_max`.
fn pca_normal(nb: &[Point2]) -> Option<(Point2, f64)> {
    if nb.len() < 3 {
        return None;
    }
    let n = nb.len() as f64;
    let (mx, my) = nb.iter().fold((0.0, 0.0), |(a, b), p| (a + p.x, b + p.y));
    let (mx, my) = (mx / n, my / n);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in nb {
        let (dx, dy) = (p.x - mx, p.y - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    let half_tr = 0.5 * (sxx + syy);
    let disc = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let (l_max, l_min) = (half_tr + disc, half_tr - disc);
    if l_max.is_nan() || l_max <= 1e-18 {
        return None;
    }
    let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    Some((Point2::new(-phi.sin(), phi.cos()), l_min.max(0.0) / l_max))
}

impl Icp {
    /// Prepares `reference_points` (non-finite ones dropped): k-d tree and normals.
    /// Unusable configuration fields fall back to their defaults.
    pub fn new(reference_points: &[Point2], config: IcpConfig) -> Self {
        let config = sanitize(config);
        let points: Vec<Point2> = reference_points
            .iter()
            .copied()
            .filter(|p| p.x.is_finite() && p.y.is_finite() && p.x.abs() < 1e9 && p.y.abs() < 1e9)
            .collect();
        if points.is_empty() {
            return Self {
                config,
                points,
                normals: Vec::new(),
                tree: None,
            };
        }
        let coords: Vec<[f64; 2]> = points.iter().map(|p| [p.x, p.y]).collect();
        let tree: ImmutableKdTree<f64, 2> = ImmutableKdTree::new_from_slice(&coords);
        let k = NonZero::new(config.normal_neighbours.max(3)).unwrap_or(NonZero::<usize>::MIN);
        let r2 = config.normal_radius_m * config.normal_radius_m;
        let mut nb = Vec::with_capacity(k.get());
        let normals = coords
            .iter()
            .map(|c| {
                nb.clear();
                for n in tree.nearest_n::<SquaredEuclidean>(c, k) {
                    if n.distance <= r2 {
                        nb.push(points[n.item as usize]);
                    }
                }
                pca_normal(&nb)
                    .filter(|(_, ratio)| *ratio <= config.max_normal_eigen_ratio)
                    .map(|(n, _)| n)
            })
            .collect();
        Self {
            config,
            points,
            normals,
            tree: Some(tree),
        }
    }

    /// A scan-to-map reference from the map built so far:
    /// [`OccupancyGrid::occupied_points_near`].
    pub fn from_grid(
        grid: &OccupancyGrid,
        center: Point2,
        radius_m: f64,
        config: IcpConfig,
    ) -> Self {
        Self::new(&grid.occupied_points_near(center, radius_m), config)
    }

    /// The configuration in use.
    pub fn config(&self) -> &IcpConfig {
        &self.config
    }

    /// The reference points (the finite ones it was given), in their order.
    pub fn points(&self) -> &[Point2] {
        &self.points
    }

    /// Unit normal of each reference point (same order as [`Icp::points`]), `None` where
    /// its neighbourhood is not line-like. Unoriented: its sign is arbitrary.
    pub fn normals(&self) -> &[Option<Point2>] {
        &self.normals
    }

    /// Number of reference points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there is no reference point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Number of reference points that have a normal (can be matched).
    pub fn points_with_normal(&self) -> usize {
        self.normals.iter().filter(|n| n.is_some()).count()
    }

    /// Aligns `points` (source frame, e.g. robot-frame scan returns) to the reference,
    /// starting from `initial` (the source frame's pose in the reference frame); see the
    /// module docs. Never fails: with no usable reference or too few correspondences the
    /// initial pose comes back with `converged = false`. Non-finite source points are
    /// ignored; a non-finite `initial` is returned unchanged.
    pub fn align(&self, points: &[Point2], initial: Pose2, mode: IcpMode) -> IcpResult {
        let c = &self.config;
        let mut result = IcpResult {
            pose: initial,
            iterations: 0,
            inliers: 0,
            rms_m: f64::NAN,
            converged: false,
            normal_matrix: nalgebra::Matrix3::zeros(),
        };
        let Some(tree) = &self.tree else {
            return result;
        };
        if !initial.is_finite() {
            return result;
        }
        let src: Vec<Point2> = points
            .iter()
            .copied()
            .filter(|p| p.x.is_finite() && p.y.is_finite() && p.x.abs() < 1e9 && p.y.abs() < 1e9)
            .collect();
        let (mut tx, mut ty, mut th) = (initial.x, initial.y, initial.heading_rad);
        let mut gate = c.max_correspondence_m;
        let mut pairs: Vec<(Point2, Point2, Point2)> = Vec::with_capacity(src.len());
        for it in 0..c.max_iterations {
            result.iterations = it + 1;
            self.correspondences(tree, &src, tx, ty, th, gate, &mut pairs);
            if pairs.len() < c.min_inliers {
                break;
            }
            let Some((dx, dy, dth)) = gauss_newton_step(&pairs, (tx, ty, th), c.huber_m, mode)
            else {
                break;
            };
            tx += dx;
            ty += dy;
            th += dth;
            let at_floor = gate <= c.min_correspondence_m;
            gate = (gate * c.gate_shrink).max(c.min_correspondence_m);
            if dx.hypot(dy) < c.convergence_translation_m
                && dth.abs() < c.convergence_rotation_rad
                && at_floor
            {
                result.converged = true;
                break;
            }
        }
        // Final statistics at the final pose and gate.
        self.correspondences(tree, &src, tx, ty, th, gate, &mut pairs);
        result.pose = Pose2::new(tx, ty, th);
        result.inliers = pairs.len();
        if !pairs.is_empty() {
            let (s, co) = th.sin_cos();
            let ss: f64 = pairs
                .iter()
                .map(|(p, q, n)| {
                    let x = Point2::new(co * p.x - s * p.y + tx, s * p.x + co * p.y + ty);
                    let r = n.x * (x.x - q.x) + n.y * (x.y - q.y);
                    r * r
                })
                .sum();
            result.rms_m = (ss / pairs.len() as f64).sqrt();
            result.normal_matrix = normal_equations(&pairs, (tx, ty, th), c.huber_m, mode).0;
        }
        result
    }

    /// Fills `pairs` with (source point, reference point, reference normal) for the source
    /// points whose nearest reference point (after the transform) is within `gate` and has
    /// a normal.
    #[allow(clippy::too_many_arguments)]
    fn correspondences(
        &self,
        tree: &ImmutableKdTree<f64, 2>,
        src: &[Point2],
        tx: f64,
        ty: f64,
        th: f64,
        gate: f64,
        pairs: &mut Vec<(Point2, Point2, Point2)>,
    ) {
        pairs.clear();
        let (s, c) = th.sin_cos();
        let g2 = gate * gate;
        for p in src {
            let x = [c * p.x - s * p.y + tx, s * p.x + c * p.y + ty];
            let nn = tree.nearest_one::<SquaredEuclidean>(&x);
            if nn.distance > g2 {
                continue;
            }
            let j = nn.item as usize;
            if let (Some(q), Some(Some(n))) = (self.points.get(j), self.normals.get(j)) {
                pairs.push((*p, *q, *n));
            }
        }
    }
}

/// The Huber-weighted (IRLS) normal equations `(H, g) = (Σ w J Jᵀ, Σ w r J)` of the
/// point-to-line residuals `r = n · (R(θ) p + t − q)` at the pose `(tx, ty, th)`; the
/// heading row and column are zero in translation-only mode. O(n).
fn normal_equations(
    pairs: &[(Point2, Point2, Point2)],
    (tx, ty, th): (f64, f64, f64),
    huber_m: f64,
    mode: IcpMode,
) -> (nalgebra::Matrix3<f64>, nalgebra::Vector3<f64>) {
    let (s, c) = th.sin_cos();
    let mut h = nalgebra::Matrix3::<f64>::zeros();
    let mut g = nalgebra::Vector3::<f64>::zeros();
    for (p, q, n) in pairs {
        let rp = Point2::new(c * p.x - s * p.y, s * p.x + c * p.y);
        // Eq. (6): the point-to-line residual.
        let r = n.x * (rp.x + tx - q.x) + n.y * (rp.y + ty - q.y);
        // ∂(R p)/∂θ = R(θ + π/2) p = (−(Rp)_y, (Rp)_x).
        let j = nalgebra::Vector3::new(n.x, n.y, n.x * -rp.y + n.y * rp.x);
        let w = if r.abs() <= huber_m {
            1.0
        } else {
            huber_m / r.abs()
        };
        h += w * j * j.transpose();
        g += w * r * j;
    }
    if mode == IcpMode::TranslationOnly {
        for i in 0..3 {
            h[(2, i)] = 0.0;
            h[(i, 2)] = 0.0;
        }
        g[2] = 0.0;
    }
    (h, g)
}

/// One damped Gauss-Newton step on [`normal_equations`] at the pose `(tx, ty, th)`;
/// returns `(δx, δy, δθ)` (δθ = 0 in translation-only mode). `None` when the system cannot
/// be solved.
fn gauss_newton_step(
    pairs: &[(Point2, Point2, Point2)],
    pose: (f64, f64, f64),
    huber_m: f64,
    mode: IcpMode,
) -> Option<(f64, f64, f64)> {
    let (h, g) = normal_equations(pairs, pose, huber_m, mode);
    // Small Levenberg damping keeps unobservable directions (a corridor's axis) near the
    // current estimate instead of making the system singular.
    let damping = 1e-6 * (h[(0, 0)] + h[(1, 1)]).max(1e-9);
    let step = match mode {
        IcpMode::TranslationOnly => {
            let h2 = nalgebra::Matrix2::new(
                h[(0, 0)] + damping,
                h[(0, 1)],
                h[(1, 0)],
                h[(1, 1)] + damping,
            );
            let d = h2.cholesky()?.solve(&nalgebra::Vector2::new(-g[0], -g[1]));
            (d[0], d[1], 0.0)
        }
        IcpMode::Full => {
            let mut h3 = h;
            for i in 0..3 {
                h3[(i, i)] += damping;
            }
            let d = h3.cholesky()?.solve(&(-g));
            (d[0], d[1], d[2])
        }
    };
    (step.0.is_finite() && step.1.is_finite() && step.2.is_finite()).then_some(step)
}

fn sanitize(c: IcpConfig) -> IcpConfig {
    let d = IcpConfig::default();
    let pos = |v: f64, def: f64| if v.is_finite() && v > 0.0 { v } else { def };
    let min_gate = pos(c.min_correspondence_m, d.min_correspondence_m);
    IcpConfig {
        max_iterations: c.max_iterations,
        max_correspondence_m: pos(c.max_correspondence_m, d.max_correspondence_m).max(min_gate),
        min_correspondence_m: min_gate,
        gate_shrink: if c.gate_shrink > 0.0 && c.gate_shrink <= 1.0 {
            c.gate_shrink
        } else {
            d.gate_shrink
        },
        huber_m: pos(c.huber_m, d.huber_m),
        normal_neighbours: c.normal_neighbours.clamp(3, 64),
        normal_radius_m: pos(c.normal_radius_m, d.normal_radius_m),
        max_normal_eigen_ratio: if c.max_normal_eigen_ratio.is_finite() {
            c.max_normal_eigen_ratio.clamp(0.0, 1.0)
        } else {
            d.max_normal_eigen_ratio
        },
        convergence_translation_m: pos(c.convergence_translation_m, d.convergence_translation_m),
        convergence_rotation_rad: pos(c.convergence_rotation_rad, d.convergence_rotation_rad),
        min_inliers: c.min_inliers.max(3),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    fn result(h: Vector3<f64>, rms_m: f64) -> IcpResult {
        IcpResult {
            pose: Pose2::IDENTITY,
            iterations: 5,
            inliers: 100,
            rms_m,
            converged: true,
            normal_matrix: Matrix3::from_diagonal(&h),
        }
    }

    #[test]
    fn covariance_of_a_room_is_rms_squared_over_the_normal_matrix() {
        // 100 returns face x, 400 face y, heading information 50: rms 2 cm gives
        // σ²_x = 4e-4 / 100, σ²_y = 4e-4 / 400, σ²_θ = 4e-4 / 50.
        let (xy, heading) = result(Vector3::new(100.0, 400.0, 50.0), 0.02).covariance(20.0, 0.01);
        assert!((xy[(0, 0)] - 4e-6).abs() < 1e-15 && (xy[(1, 1)] - 1e-6).abs() < 1e-15);
        assert!(xy[(0, 1)].abs() < 1e-15);
        assert!((heading.unwrap() - 8e-6).abs() < 1e-15);
    }

    #[test]
    fn an_unmeasured_direction_gets_the_prior_and_a_held_heading_none() {
        // A corridor along x: 3 returns face x. Along x the prior 0.01 m² (it exceeds
        // 4e-4 / 3); across, 4e-4 / 500; the heading from its own information, 4e-4 / 100.
        let (xy, heading) = result(Vector3::new(3.0, 500.0, 100.0), 0.02).covariance(20.0, 0.01);
        assert!((xy[(0, 0)] - 0.01).abs() < 1e-12 && (xy[(1, 1)] - 8e-7).abs() < 1e-15);
        assert!((heading.unwrap() - 4e-6).abs() < 1e-15);
        // A prior below what ICP itself claims does not tighten it: 4e-4 / 3.
        let (xy, _) = result(Vector3::new(3.0, 500.0, 100.0), 0.02).covariance(20.0, 1e-6);
        assert!((xy[(0, 0)] - 4e-4 / 3.0).abs() < 1e-15);
        // Translation only: the heading row is zero, nothing is known of the heading.
        let (_, heading) = result(Vector3::new(100.0, 400.0, 0.0), 0.02).covariance(20.0, 0.01);
        assert_eq!(heading, None);
    }

    #[test]
    fn unmeasured_projector_picks_the_weak_axes() {
        // A room: nothing unmeasured. A corridor along x: the x axis. Open space: both.
        let p = result(Vector3::new(100.0, 400.0, 50.0), 0.02).unmeasured_projector(20.0);
        assert_eq!(p, Matrix2::zeros());
        let p = result(Vector3::new(3.0, 500.0, 100.0), 0.02).unmeasured_projector(20.0);
        assert!(
            (p - Matrix2::new(1.0, 0.0, 0.0, 0.0)).abs().max() < 1e-12,
            "{p}"
        );
        let p = result(Vector3::new(3.0, 5.0, 100.0), 0.02).unmeasured_projector(20.0);
        assert!((p - Matrix2::identity()).abs().max() < 1e-12, "{p}");
        // A corridor at 45°: 3 returns face (1, 1)/√2, 500 face (1, −1)/√2: the former.
        let mut r = result(Vector3::new(0.0, 0.0, 100.0), 0.02);
        let weak = nalgebra::Vector2::new(1.0, 1.0) / 2f64.sqrt();
        let strong = nalgebra::Vector2::new(1.0, -1.0) / 2f64.sqrt();
        let h = weak * weak.transpose() * 3.0 + strong * strong.transpose() * 500.0;
        r.normal_matrix.fixed_view_mut::<2, 2>(0, 0).copy_from(&h);
        let p = r.unmeasured_projector(20.0);
        assert!((p - weak * weak.transpose()).abs().max() < 1e-12, "{p}");
    }
}
