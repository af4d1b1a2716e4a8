//! SE(2) pose-graph optimization: the back-end that closes loops.
//!
//! Place in the pipeline: scan matching produces constraints between robot poses —
//! sequential ones (scan k+1 against scan k or the local map) and loop closures (a scan
//! against a place seen long before). They become the edges of a graph whose nodes are the
//! poses; this module moves the nodes to agree best with all edges, after which the mapper
//! re-anchors its trajectory and rebuilds its grid from the optimized poses.
//!
//! Formulation (Grisetti, Kümmerle, Stachniss, Burgard, "A Tutorial on Graph-Based SLAM",
//! IEEE ITS Magazine 2010). Node `X_i = (t_i, θ_i)`, edge `i → j` with measurement
//! `Z_ij = (t_ij, θ_ij)` and information `Ω_ij`; the error is
//!
//! `e_ij = t2v(Z_ij⁻¹ (X_i⁻¹ X_j)) = [R_ijᵀ (R_iᵀ (t_j − t_i) − t_ij); θ_j − θ_i − θ_ij]`
//!
//! (angle wrapped to (−π, π]), with Jacobians with respect to `X_i` and `X_j`
//!
//! `A_ij = [−R_ijᵀ R_iᵀ, R_ijᵀ (∂R_iᵀ/∂θ_i)(t_j − t_i); 0 0 −1]`,
//! `B_ij = [R_ijᵀ R_iᵀ, 0; 0 0 1]`.
//!
//! Gauss–Newton minimizes `F = Σ ρ(e_ijᵀ Ω_ij e_ij)`: each iteration linearizes every edge,
//! accumulates the block-sparse normal equations `H Δx = −b` (`H_ii += A_ijᵀ Ω A_ij`,
//! `H_ij = A_ijᵀ Ω B_ij`, `H_jj += B_ijᵀ Ω B_ij`, `b_i += A_ijᵀ Ω e_ij`,
//! `b_j += B_ijᵀ Ω e_ij`), solves them and sets `x ← x + Δx`, headings wrapped. Node 0 is
//! held fixed: it is the gauge, the map frame's origin. Robust edges use the Huber kernel on
//! the Mahalanobis distance `d = √(eᵀΩe)` — `ρ = d²` for `d ≤ k`, `2kd − k²` beyond — by
//! iteratively reweighted least squares: `Ω ← w Ω` with `w = min(1, k/d)`.
//!
//! The linear system is solved by conjugate gradient, `H` multiplied edge by edge (no dense
//! matrix), preconditioned with each node's diagonal block (block Jacobi, the default) or
//! with the odometry chain: the block-tridiagonal part of `H` (every node's diagonal block
//! and the blocks between consecutive nodes) factored exactly in O(n), so CG only has the
//! loop edges left to resolve (subgraph preconditioning, Dellaert et al., IROS 2010; see
//! `Preconditioner`). Cost: O(n + m) memory and O((n + m) · CG iterations) time per
//! Gauss–Newton iteration, n nodes and m edges. Block Jacobi needs about one CG iteration
//! per node a correction has to travel, so on long routes its capped steps stop far from
//! the optimum (an 800-node corridor walked out and back: 7.5 m RMS off after 10 × 500
//! iterations; the chain: 4 Gauss–Newton iterations, at the optimum, 10× less time). Why
//! block Jacobi is still the default: [`Preconditioning::BlockJacobi`].

use crate::EngineError;
use nalgebra::{Matrix3, Vector3};
use sketchslam_types::{Pose2, wrap_angle};

/// A step may raise chi2 by at most this factor; a larger rise is undone and ends the run.
const MAX_CHI2_GROWTH: f64 = 1.5;

/// A constraint between two nodes: what a scan matcher measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// Index of the node whose frame the measurement is expressed in.
    pub from: usize,
    /// Index of the measured node.
    pub to: usize,
    /// Pose of `to` in the frame of `from` (what a scan matcher measured).
    pub measurement: Pose2,
    /// Information matrix (inverse covariance) of the measurement in (x, y, heading) order.
    pub information: Matrix3<f64>,
    /// Huber kernel width on the Mahalanobis distance sqrt(eᵀΩe); None = plain least squares.
    pub huber: Option<f64>,
}

impl Edge {
    /// A plain least-squares edge (no robust kernel).
    pub fn new(from: usize, to: usize, measurement: Pose2, information: Matrix3<f64>) -> Self {
        let huber = None;
        Self {
            from,
            to,
            measurement,
            information,
            huber,
        }
    }

    /// The same edge with a Huber kernel of width `k` (a Mahalanobis distance, unitless).
    pub fn with_huber(self, k: f64) -> Self {
        Self {
            huber: Some(k),
            ..self
        }
    }

    /// `e_ij = t2v(Z_ij⁻¹ (X_i⁻¹ X_j))` for node poses `xi`, `xj`. O(1).
    pub fn error(&self, xi: &Pose2, xj: &Pose2) -> Vector3<f64> {
        let d = self.measurement.inverse().compose(&xi.between(xj));
        let dtheta = xj.heading_rad - xi.heading_rad - self.measurement.heading_rad;
        Vector3::new(d.x, d.y, wrap_angle(dtheta))
    }

    /// `(A_ij, B_ij)`, the Jacobians of [`Self::error`] with respect to `X_i` and `X_j`. O(1).
    fn jacobians(&self, xi: &Pose2, xj: &Pose2) -> (Matrix3<f64>, Matrix3<f64>) {
        // R_ijᵀ R_iᵀ = R(−(θ_i + θ_ij)); with d = R_iᵀ (t_j − t_i), the rotation column of
        // A_ij is R_ijᵀ (∂R_iᵀ/∂θ_i)(t_j − t_i) = R_ijᵀ (d_y, −d_x).
        let (s, c) = (xi.heading_rad + self.measurement.heading_rad).sin_cos();
        let d = xi.inverse_transform_point(&xj.position());
        let (sz, cz) = self.measurement.heading_rad.sin_cos();
        let (ax, ay) = (cz * d.y - sz * d.x, -sz * d.y - cz * d.x);
        let a = Matrix3::new(-c, -s, ax, s, -c, ay, 0.0, 0.0, -1.0);
        (a, Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0))
    }

    /// IRLS weight and robust cost `ρ` of the error `e`.
    fn weight_and_cost(&self, e: &Vector3<f64>) -> (f64, f64) {
        let s = e.dot(&(self.information * e));
        match self.huber {
            Some(k) if s.sqrt() > k => (k / s.sqrt(), 2.0 * k * s.sqrt() - k * k),
            _ => (1.0, s),
        }
    }
}

/// Parameters of [`PoseGraph::optimize`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimizeConfig {
    /// Gauss–Newton iterations at most. Default 10.
    pub max_iterations: usize,
    /// Converged when the largest step component (m or rad) is below this. Default 1e-4.
    pub tolerance: f64,
    /// Conjugate-gradient iterations at most per linear solve. Default 500.
    pub cg_max_iterations: usize,
    /// CG stops when ‖r‖ ≤ cg_tolerance · ‖b‖ (relative residual). Default 1e-8.
    pub cg_tolerance: f64,
    /// How each CG solve is preconditioned. Default [`Preconditioning::BlockJacobi`]
    /// (see there why).
    pub preconditioning: Preconditioning,
}

/// How [`PoseGraph::optimize`] preconditions the conjugate-gradient solve of each
/// Gauss–Newton step (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preconditioning {
    /// The odometry chain's block-tridiagonal part of `H`, factored exactly: CG has only
    /// the loop edges left to resolve, and each step reaches the Gauss–Newton step.
    Chain,
    /// Each node's 3×3 diagonal block alone: about one CG iteration per node a correction
    /// must travel, so on long routes the capped steps stop short of the optimum and leave
    /// a loop's correction near its newest node. Still the default (2026-12-06): the
    /// engine was tuned on it, and with the chain its worst world is worse. Measured
    /// (`graph`, release, in-process, 30 generated worlds, map error median / p90 / worst,
    /// completeness worst): block Jacobi 0.014 / 0.046 / 0.073, 0.888; chain 0.011 / 0.042
    /// / 0.143, 0.543 (good corridor 26: the keyframe ICP slides 2.7 m toward a dead end
    /// after turning round there, where block Jacobi's run slid 0.4 m and a loop took it
    /// out; the right loops that come later bend the route around the slide — a draw of
    /// the front end, not of the solver; README "Generated worlds"); paper-env2 0.034 →
    /// 0.006 m. With the loop heading read from the match (2026-12-07) the chain mends
    /// `sketch` on school (0.097 → 0.024 m: block Jacobi's unfinished solve had bent it)
    /// but breaks CSAIL on two frame turns of five (0.228, 0.101 m): an exact solve
    /// carries a wrong loop across the route where this one kept it local.
    #[default]
    BlockJacobi,
}

impl Default for OptimizeConfig {
    fn default() -> Self {
        let (max_iterations, tolerance) = (10, 1e-4);
        let (cg_max_iterations, cg_tolerance) = (500, 1e-8);
        Self {
            max_iterations,
            tolerance,
            cg_max_iterations,
            cg_tolerance,
            preconditioning: Preconditioning::default(),
        }
    }
}

/// What [`PoseGraph::optimize`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimizeReport {
    /// Gauss–Newton iterations run (an undone one included).
    pub iterations: usize,
    /// [`PoseGraph::chi2`] before.
    pub initial_chi2: f64,
    /// [`PoseGraph::chi2`] after.
    pub final_chi2: f64,
    /// True when the last step was below the tolerance (or there was nothing to optimize).
    pub converged: bool,
}

/// A graph of 2D poses (nodes, in the map frame) and relative-pose constraints (edges).
#[derive(Debug, Clone, Default)]
pub struct PoseGraph {
    nodes: Vec<Pose2>,
    edges: Vec<Edge>,
}

/// `H Δx = −b` in block form: a 3×3 diagonal block per node and one off-diagonal block
/// `H_ij` per edge (`H_ji = H_ijᵀ`).
struct NormalEquations {
    diag: Vec<Matrix3<f64>>,
    off: Vec<Matrix3<f64>>,
    b: Vec<Vector3<f64>>,
}

impl NormalEquations {
    /// `y = H x` on the free nodes (zero on the others), `H` applied edge by edge. O(n + m).
    fn multiply(&self, edges: &[Edge], free: &[bool], x: &[Vector3<f64>], y: &mut [Vector3<f64>]) {
        for k in 0..self.diag.len() {
            y[k] = if free[k] {
                self.diag[k] * x[k]
            } else {
                Vector3::zeros()
            };
        }
        for (e, h) in edges.iter().zip(&self.off) {
            if free[e.from] {
                y[e.from] += h * x[e.to];
            }
            if free[e.to] {
                y[e.to] += h.tr_mul(&x[e.from]);
            }
        }
    }
}

fn dot(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    a.iter().zip(b).map(|(u, v)| u.dot(v)).sum()
}

impl PoseGraph {
    /// Bytes on the heap of its nodes and edges (capacities).
    pub fn heap_bytes(&self) -> usize {
        crate::heap::vec_bytes(&self.nodes) + crate::heap::vec_bytes(&self.edges)
    }

    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a node (a pose in the map frame) and returns its index; node 0 stays fixed.
    pub fn add_node(&mut self, pose: Pose2) -> usize {
        self.nodes.push(pose);
        self.nodes.len() - 1
    }

    /// Adds an edge and returns its index. Refused: an endpoint that is not a node, a
    /// self-loop, a non-finite measurement, an information matrix that is not finite,
    /// symmetric and positive definite, a Huber width that is not finite and positive.
    pub fn add_edge(&mut self, edge: Edge) -> Result<usize, EngineError> {
        let (n, info, z) = (self.nodes.len(), &edge.information, &edge.measurement);
        let (from, to) = (edge.from, edge.to);
        let finite = info.iter().all(|v| v.is_finite());
        let symmetric = (info - info.transpose()).amax() <= 1e-9 * info.amax();
        let huber_ok = edge.huber.is_none_or(|k| k.is_finite() && k > 0.0);
        let refuse = |name, reason: String| Err(EngineError::InvalidParameter { name, reason });
        if from.max(to) >= n {
            return refuse("edge", format!("{from} → {to} with {n} nodes"));
        } else if from == to {
            return refuse("edge", format!("self-loop on node {to}"));
        } else if !z.is_finite() {
            return refuse("edge.measurement", format!("not finite: {z:?}"));
        } else if !finite || !symmetric || info.cholesky().is_none() {
            return refuse("edge.information", format!("not finite SPD: {info:?}"));
        } else if !huber_ok {
            return refuse("edge.huber", format!("{:?}: not finite > 0", edge.huber));
        }
        self.edges.push(edge);
        Ok(self.edges.len() - 1)
    }

    /// Removes the first edge for which `matches` holds and returns it. O(m).
    pub fn remove_edge_where(&mut self, matches: impl Fn(&Edge) -> bool) -> Option<Edge> {
        let i = self.edges.iter().position(matches)?;
        Some(self.edges.remove(i))
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when the graph has no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The node poses, by index.
    pub fn nodes(&self) -> &[Pose2] {
        &self.nodes
    }

    /// The pose of node `i`, if it exists.
    pub fn node(&self, i: usize) -> Option<Pose2> {
        self.nodes.get(i).copied()
    }

    /// Replaces the pose of node `i`; an index out of range is ignored.
    pub fn set_node(&mut self, i: usize, pose: Pose2) {
        if let Some(node) = self.nodes.get_mut(i) {
            *node = pose;
        }
    }

    /// The edges, by index.
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// The objective `Σ ρ(e_ijᵀ Ω_ij e_ij)`, ρ the identity or Huber's (module doc). O(m).
    pub fn chi2(&self) -> f64 {
        let error = |e: &Edge| e.error(&self.nodes[e.from], &self.nodes[e.to]);
        self.edges
            .iter()
            .map(|e| e.weight_and_cost(&error(e)).1)
            .sum()
    }

    /// Gauss–Newton (IRLS for Huber edges) with node 0 fixed, see the module doc. Stops at
    /// convergence, after `max_iterations`, or when a step makes chi2 non-finite or raises
    /// it by more than half (the step is then undone and `converged` is false).
    /// O(max_iterations · (n + m) · cg_max_iterations).
    pub fn optimize(&mut self, config: &OptimizeConfig) -> OptimizeReport {
        let mut chi2 = self.chi2();
        let converged = self.nodes.len() < 2 || self.edges.is_empty();
        let mut report = OptimizeReport {
            iterations: 0,
            initial_chi2: chi2,
            final_chi2: chi2,
            converged,
        };
        if converged || !chi2.is_finite() {
            return report;
        }
        while report.iterations < config.max_iterations {
            report.iterations += 1;
            let step = solve_pcg(&self.linearize(), &self.edges, config);
            let previous = self.nodes.clone();
            for (x, d) in self.nodes.iter_mut().zip(&step) {
                *x = Pose2::new(x.x + d.x, x.y + d.y, x.heading_rad + d.z);
            }
            let new_chi2 = self.chi2();
            if !(new_chi2.is_finite() && new_chi2 <= MAX_CHI2_GROWTH * chi2 + 1e-12) {
                self.nodes = previous;
                break;
            }
            chi2 = new_chi2;
            if step.iter().all(|d| d.amax() < config.tolerance) {
                report.converged = true;
                break;
            }
        }
        report.final_chi2 = chi2;
        report
    }

    /// The block normal equations at the current nodes, IRLS weights included. O(n + m).
    fn linearize(&self) -> NormalEquations {
        let n = self.nodes.len();
        let (mut diag, mut b) = (vec![Matrix3::zeros(); n], vec![Vector3::zeros(); n]);
        let mut off = Vec::with_capacity(self.edges.len());
        for edge in &self.edges {
            let (xi, xj) = (&self.nodes[edge.from], &self.nodes[edge.to]);
            let e = edge.error(xi, xj);
            let omega = edge.information * edge.weight_and_cost(&e).0;
            let (a, bj) = edge.jacobians(xi, xj);
            let (at_omega, bt_omega) = (a.transpose() * omega, bj.transpose() * omega);
            diag[edge.from] += at_omega * a;
            diag[edge.to] += bt_omega * bj;
            off.push(at_omega * bj);
            b[edge.from] += at_omega * e;
            b[edge.to] += bt_omega * e;
        }
        NormalEquations { diag, off, b }
    }
}

/// The preconditioner `M⁻¹` of [`solve_pcg`]: the odometry chain's block-tridiagonal part
/// of `H` factored exactly, or block Jacobi where that factorization fails.
///
/// `M` keeps every diagonal block `H_kk` (loop and prior edges included) and the
/// off-diagonal blocks `H_{k−1,k}` of the edges between consecutive nodes; `M` is a sum of
/// positive semi-definite terms (whole chain edges, the diagonal parts of the others), so it
/// is SPD once node 0 is fixed. It is factored as `M = L S Lᵀ`, `L` unit lower block
/// bidiagonal: `S_k = H_kk − U_kᵀ S_{k−1}⁻¹ U_k` with `U_k = H_{k−1,k}`, and
/// `L_{k,k−1} = U_kᵀ S_{k−1}⁻¹`. Applying `M⁻¹` is one forward and one backward sweep.
/// Cost O(n) to factor and to apply (3×3 blocks).
///
/// This is subgraph preconditioning (Dellaert, Carlson, Ila, Ni, Thorpe, "Subgraph-
/// preconditioned conjugate gradients for large scale SLAM", IROS 2010) with the odometry
/// chain as the subgraph: `H − M` has rank at most 3 per loop edge, so CG converges in as
/// many iterations as the loops need, not as the chain is long (block Jacobi: about one
/// iteration per node a correction must travel; module doc).
enum Preconditioner {
    Chain {
        /// `S_k⁻¹`, zero on fixed nodes.
        s_inv: Vec<Matrix3<f64>>,
        /// `U_k = H_{k−1,k}` (zero when node k−1 or k is fixed or no chain edge joins them).
        upper: Vec<Matrix3<f64>>,
    },
    Jacobi(Vec<Matrix3<f64>>),
}

impl Preconditioner {
    /// `inverse[k]`: `H_kk⁻¹` of each free node, `None` on fixed ones.
    fn new(
        sys: &NormalEquations,
        edges: &[Edge],
        inverse: &[Option<Matrix3<f64>>],
        kind: Preconditioning,
    ) -> Self {
        if kind == Preconditioning::BlockJacobi {
            return Self::jacobi(inverse);
        }
        let free = |k: usize| inverse[k].is_some();
        let n = sys.diag.len();
        let mut upper = vec![Matrix3::zeros(); n];
        for (e, h) in edges.iter().zip(&sys.off) {
            let (lo, hi) = (e.from.min(e.to), e.from.max(e.to));
            if hi == lo + 1 && free(lo) && free(hi) {
                // H_{from,to} = off; H_{lo,hi} is off or its transpose.
                upper[hi] += if e.from == lo { *h } else { h.transpose() };
            }
        }
        let mut s_inv = vec![Matrix3::zeros(); n];
        for k in 0..n {
            if !free(k) {
                continue;
            }
            let mut s = sys.diag[k];
            if k > 0 && free(k - 1) {
                s -= upper[k].transpose() * s_inv[k - 1] * upper[k];
            }
            match s.cholesky() {
                Some(c) => s_inv[k] = c.inverse(),
                None => return Self::jacobi(inverse),
            }
        }
        if s_inv.iter().all(|m| m.iter().all(|v| v.is_finite())) {
            Self::Chain { s_inv, upper }
        } else {
            Self::jacobi(inverse)
        }
    }

    fn jacobi(inverse: &[Option<Matrix3<f64>>]) -> Self {
        Self::Jacobi(
            inverse
                .iter()
                .map(|m| m.unwrap_or_else(Matrix3::zeros))
                .collect(),
        )
    }

    /// `z = M⁻¹ r`.
    fn apply(&self, r: &[Vector3<f64>], z: &mut [Vector3<f64>]) {
        match self {
            Self::Jacobi(inv) => z.iter_mut().zip(inv.iter().zip(r)).for_each(|(z, (m, r))| {
                *z = m * r;
            }),
            Self::Chain { s_inv, upper } => {
                let n = r.len();
                // Forward: y_k = r_k − U_kᵀ S_{k−1}⁻¹ y_{k−1} (z holds y).
                for k in 0..n {
                    z[k] = r[k];
                    if k > 0 {
                        let carried = upper[k].tr_mul(&(s_inv[k - 1] * z[k - 1]));
                        z[k] -= carried;
                    }
                }
                // Backward: z_k = S_k⁻¹ (y_k − U_{k+1} z_{k+1}).
                for k in (0..n).rev() {
                    let mut y = z[k];
                    if k + 1 < n {
                        y -= upper[k + 1] * z[k + 1];
                    }
                    z[k] = s_inv[k] * y;
                }
            }
        }
    }
}

/// Solves `H Δx = −b` by conjugate gradient preconditioned as `config` says
/// ([`Preconditioner`]), multiplying by `H` edge by edge. Node 0 and nodes with a singular
/// diagonal block (unconstrained) keep `Δ = 0`. O((n + m) · iterations).
fn solve_pcg(sys: &NormalEquations, edges: &[Edge], config: &OptimizeConfig) -> Vec<Vector3<f64>> {
    let n = sys.diag.len();
    let zero = Vector3::<f64>::zeros();
    // Fixed nodes stay out of the Krylov space: node 0, and nodes nothing constrains.
    let inverse: Vec<Option<Matrix3<f64>>> = (0..n)
        .map(|k| {
            let m = sys.diag[k].try_inverse()?;
            (k > 0 && m.iter().all(|v| v.is_finite())).then_some(m)
        })
        .collect();
    let free: Vec<bool> = inverse.iter().map(Option::is_some).collect();
    let precond = Preconditioner::new(sys, edges, &inverse, config.preconditioning);
    let mul = |x: &[Vector3<f64>], y: &mut [Vector3<f64>]| sys.multiply(edges, &free, x, y);
    let mut r: Vec<Vector3<f64>> = (0..n)
        .map(|k| if free[k] { -sys.b[k] } else { zero })
        .collect();
    let threshold = config.cg_tolerance * dot(&r, &r).sqrt();
    let mut z = vec![zero; n];
    precond.apply(&r, &mut z);
    let (mut x, mut p, mut hp) = (vec![zero; n], z.clone(), vec![zero; n]);
    let mut rz = dot(&r, &z);
    for _ in 0..config.cg_max_iterations {
        let residual = dot(&r, &r).sqrt();
        if residual <= threshold || residual.is_nan() {
            break;
        }
        mul(&p, &mut hp);
        let php = dot(&p, &hp);
        if php <= 0.0 || php.is_nan() {
            break;
        }
        let alpha = rz / php;
        for k in 0..n {
            x[k] += alpha * p[k];
            r[k] -= alpha * hp[k];
        }
        precond.apply(&r, &mut z);
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz;
        rz = rz_next;
        for k in 0..n {
            p[k] = z[k] + beta * p[k];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use std::f64::consts::{FRAC_PI_2, PI};

    fn info(v: f64) -> Matrix3<f64> {
        Matrix3::identity() * v
    }

    /// A graph whose nodes integrate the odometry steps `odo` from `start`, with an edge per
    /// step (information `omega`) and the `extra` edges.
    fn odometry_graph(
        start: Pose2,
        odo: &[Pose2],
        omega: Matrix3<f64>,
        extra: &[Edge],
    ) -> PoseGraph {
        let mut g = PoseGraph::new();
        g.add_node(start);
        for (k, step) in odo.iter().enumerate() {
            g.add_node(g.nodes[k].compose(step));
            g.add_edge(Edge::new(k, k + 1, *step, omega)).unwrap();
        }
        extra.iter().for_each(|e| _ = g.add_edge(*e).unwrap());
        g
    }

    fn steps(truth: &[Pose2], bias_rad: f64) -> Vec<Pose2> {
        let step = |w: &[Pose2]| w[0].between(&w[1]);
        let biased = |s: Pose2| Pose2::new(s.x, s.y, s.heading_rad + bias_rad);
        truth.windows(2).map(step).map(biased).collect()
    }

    fn max_error_m(nodes: &[Pose2], truth: &[Pose2]) -> f64 {
        let dist = |(a, b): (&Pose2, &Pose2)| a.position().distance(&b.position());
        nodes.iter().zip(truth).map(dist).fold(0.0, f64::max)
    }

    /// A 4 m square walked counter-clockwise from the origin, a node per meter (16 nodes);
    /// a corner node already faces the next side: node 4 is (4, 0, π/2).
    fn square_truth() -> Vec<Pose2> {
        let starts = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)];
        let dirs = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)];
        let pose = |(side, along): (usize, f64)| {
            let ((sx, sy), (dx, dy)) = (starts[side], dirs[side]);
            Pose2::new(sx + along * dx, sy + along * dy, side as f64 * FRAC_PI_2)
        };
        (0..16).map(|k| pose((k / 4, (k % 4) as f64))).collect()
    }

    #[test]
    fn consistent_chain_is_left_unchanged() {
        let truth = square_truth();
        let mut g = odometry_graph(truth[0], &steps(&truth, 0.0), info(100.0), &[]);
        assert!(g.chi2() < 1e-20 && max_error_m(g.nodes(), &truth) < 1e-12);
        let before = g.nodes().to_vec();
        let report = g.optimize(&OptimizeConfig::default());
        assert!(report.converged && report.final_chi2 < 1e-20, "{report:?}");
        for (a, b) in g.nodes().iter().zip(&before) {
            let moved = (a.x - b.x).abs().max((a.y - b.y).abs());
            assert!(moved.max(wrap_angle(a.heading_rad - b.heading_rad).abs()) < 1e-12);
        }
    }

    #[test]
    fn square_loop_with_heading_bias_is_closed() {
        // 15 odometry steps each turning 2° too much (30° at the end, > 1 m off), weak; the
        // loop edge 15 → 0 is the truth (1 m ahead, a quarter turn left), strong.
        let truth = square_truth();
        let closure = Edge::new(15, 0, Pose2::new(1.0, 0.0, FRAC_PI_2), info(1e4));
        let odo = steps(&truth, 2f64.to_radians());
        let mut g = odometry_graph(truth[0], &odo, info(10.0), &[closure]);
        assert!(max_error_m(g.nodes(), &truth) > 1.0);
        let report = g.optimize(&OptimizeConfig::default());
        assert!(report.converged, "{report:?}");
        assert!(report.final_chi2 < 0.01 * report.initial_chi2, "{report:?}");
        assert_eq!(g.node(0), Some(truth[0]));
        let error_m = max_error_m(g.nodes(), &truth);
        assert!(error_m < 0.03, "max error {error_m} m");
        let end_rad = g.nodes[15].heading_rad - truth[15].heading_rad;
        assert!(wrap_angle(end_rad).abs() < 0.2f64.to_radians());
    }

    /// Exact sequential and loop edges (σ 1 cm, 0.01 rad) and a loop edge 12 → 4 shifted
    /// 3 m, all with kernel `huber`; start from odometry turning 1° too much per step.
    /// Returns the max error after optimization.
    fn outlier_error_m(huber: Option<f64>) -> f64 {
        let truth = square_truth();
        let loop_edge = |(i, j): (usize, usize)| {
            let mut z = truth[i].between(&truth[j]);
            z.x += if (i, j) == (12, 4) { 3.0 } else { 0.0 };
            Edge::new(i, j, z, info(1e4))
        };
        let pairs = [(15, 0), (12, 0), (8, 4), (11, 3), (12, 4)];
        let loops: Vec<Edge> = pairs.into_iter().map(loop_edge).collect();
        let mut g = odometry_graph(truth[0], &steps(&truth, 0.0), info(1e4), &loops);
        g.edges.iter_mut().for_each(|e| e.huber = huber);
        let odo = steps(&truth, 1f64.to_radians());
        g.nodes = odometry_graph(truth[0], &odo, info(1.0), &[]).nodes;
        let report = g.optimize(&OptimizeConfig {
            max_iterations: 50,
            ..Default::default()
        });
        assert!(report.final_chi2 < report.initial_chi2, "{report:?}");
        max_error_m(g.nodes(), &truth)
    }

    #[test]
    fn huber_resists_a_wrong_loop_closure() {
        let (robust_m, plain_m) = (outlier_error_m(Some(1.0)), outlier_error_m(None));
        assert!(robust_m < 0.1, "with Huber: {robust_m} m");
        assert!(plain_m > 1.0, "plain least squares: {plain_m} m");
    }

    #[test]
    fn bad_input_is_refused() {
        let mut g = odometry_graph(
            Pose2::IDENTITY,
            &[Pose2::new(1.0, 0.0, 0.0)],
            info(1.0),
            &[],
        );
        let good = g.edges[0];
        let spoil: [fn(&mut Edge); 7] = [
            |e| e.to = 2,
            |e| e.from = 1,
            |e| e.measurement.x = f64::NAN,
            |e| e.information[(2, 2)] = f64::INFINITY,
            |e| e.information[(0, 1)] = 0.5,
            |e| e.information = -e.information,
            |e| e.huber = Some(f64::NAN),
        ];
        for f in spoil {
            let mut edge = good;
            f(&mut edge);
            let refused = matches!(g.add_edge(edge), Err(EngineError::InvalidParameter { .. }));
            assert!(refused, "{edge:?}");
        }
        assert_eq!(g.edges().len(), 1);
        assert_eq!(g.add_edge(good.with_huber(1.0)).unwrap(), 1);
        g.set_node(7, Pose2::IDENTITY);
        assert_eq!((g.len(), g.node(7)), (2, None));
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let (xi, xj) = (Pose2::new(0.3, -1.2, 2.5), Pose2::new(2.0, 0.7, -2.9));
        let edge = Edge::new(0, 1, Pose2::new(1.1, 0.4, 3.0), info(1.0));
        let (a, b) = edge.jacobians(&xi, &xj);
        let h = 1e-6;
        for k in 0..3 {
            let mut dv = Vector3::zeros();
            dv[k] = h;
            let shift = |p: &Pose2, s: f64| {
                Pose2::new(p.x + s * dv.x, p.y + s * dv.y, p.heading_rad + s * dv.z)
            };
            let num_a = (edge.error(&shift(&xi, 1.0), &xj) - edge.error(&shift(&xi, -1.0), &xj))
                / (2.0 * h);
            let num_b = (edge.error(&xi, &shift(&xj, 1.0)) - edge.error(&xi, &shift(&xj, -1.0)))
                / (2.0 * h);
            assert!((num_a - a.column(k)).amax() < 1e-8 && (num_b - b.column(k)).amax() < 1e-8);
        }
    }

    #[test]
    fn thousand_node_circle_converges() {
        // Two laps of a 10 m radius circle, 500 nodes a lap; odometry with σ 1 cm / 0.002 rad
        // noise and a 5e-4 rad/step heading bias; a loop edge every 50 nodes between laps.
        let (sigma_m, sigma_rad) = (0.01, 0.002);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let circle = |k: usize| {
            let phi = 2.0 * PI * k as f64 / 500.0;
            Pose2::new(10.0 * phi.sin(), 10.0 * (1.0 - phi.cos()), phi)
        };
        let truth: Vec<Pose2> = (0..1000).map(circle).collect();
        let mut noise = |sigma: f64| sigma * Distribution::<f64>::sample(&StandardNormal, &mut rng);
        let mut odo = steps(&truth, 5e-4);
        for z in &mut odo {
            *z = Pose2::new(
                z.x + noise(sigma_m),
                z.y + noise(sigma_m),
                z.heading_rad + noise(sigma_rad),
            );
        }
        let omega =
            Matrix3::from_diagonal(&Vector3::new(sigma_m, sigma_m, sigma_rad).map(|s| s.powi(-2)));
        let loops: Vec<Edge> = (0..500)
            .step_by(50)
            .map(|i| Edge::new(i + 500, i, Pose2::IDENTITY, omega))
            .collect();
        let mut g = odometry_graph(truth[0], &odo, omega, &loops);
        assert!(max_error_m(g.nodes(), &truth) > 3.0);
        let report = g.optimize(&OptimizeConfig {
            max_iterations: 30,
            ..Default::default()
        });
        assert!(report.converged, "{report:?}");
        assert!(report.final_chi2 < 1e-3 * report.initial_chi2, "{report:?}");
        let error_m = max_error_m(g.nodes(), &truth);
        assert!(error_m < 0.3, "max error {error_m} m");
    }

    /// A corridor walked out and back, 2 × 300 nodes 0.25 m apart, lanes 1 m apart; every
    /// edge exact (odometry and a loop every 10 nodes back to the node beside it), the nodes
    /// placed by integrating the steps with a 1 mrad/step heading bias. The optimum is the
    /// truth.
    fn out_and_back_graph() -> (PoseGraph, Vec<Pose2>) {
        let leg = 300;
        let out = (0..leg).map(|k| Pose2::new(0.25 * k as f64, 0.0, 0.0));
        let back = (0..leg).map(|k| Pose2::new(0.25 * (leg - 1 - k) as f64, 1.0, PI));
        let truth: Vec<Pose2> = out.chain(back).collect();
        let omega = Matrix3::from_diagonal(&Vector3::new(1e4, 1e4, 1e5));
        let mut g = odometry_graph(truth[0], &steps(&truth, 1e-3), omega, &[]);
        for (k, pose) in truth.iter().enumerate().skip(1) {
            let exact = truth[k - 1].between(pose);
            g.edges[k - 1].measurement = exact;
        }
        for k in (leg..2 * leg).step_by(10) {
            let j = 2 * leg - 1 - k;
            let exact = truth[j].between(&truth[k]);
            g.add_edge(Edge::new(j, k, exact, omega)).unwrap();
        }
        (g, truth)
    }

    #[test]
    fn a_long_out_and_back_corridor_reaches_its_optimum_with_the_chain() {
        let (mut g, truth) = out_and_back_graph();
        assert!(max_error_m(g.nodes(), &truth) > 10.0);
        let report = g.optimize(&OptimizeConfig {
            preconditioning: Preconditioning::Chain,
            ..Default::default()
        });
        assert!(report.converged, "{report:?}");
        let error_m = max_error_m(g.nodes(), &truth);
        // Block Jacobi left this graph meters off after the same 10 × 500 iterations.
        assert!(error_m < 1e-3, "max error {error_m} m ({report:?})");
    }

    #[test]
    fn the_chain_preconditioner_solves_a_chain_alone_in_one_cg_iteration() {
        // Without loops M = H: one preconditioned CG step is the exact Gauss–Newton step.
        let (mut g, truth) = out_and_back_graph();
        g.edges.truncate(truth.len() - 1);
        let sys = g.linearize();
        let one = OptimizeConfig {
            cg_max_iterations: 1,
            preconditioning: Preconditioning::Chain,
            ..Default::default()
        };
        let step = solve_pcg(&sys, &g.edges, &one);
        // H Δx = −b on every node but the fixed node 0.
        let free: Vec<bool> = (0..truth.len()).map(|k| k > 0).collect();
        let mut h_step = vec![Vector3::zeros(); truth.len()];
        sys.multiply(&g.edges, &free, &step, &mut h_step);
        let scale = sys.b.iter().map(|b| b.amax()).fold(0.0, f64::max);
        for (k, (hx, b)) in h_step.iter().zip(&sys.b).enumerate().skip(1) {
            assert!((hx + b).amax() < 1e-9 * scale, "node {k}: {hx:?} vs {b:?}");
        }
    }
}
