//! A global start for the warp's fit ([`super::fit`]): the similarity (and stretch of the
//! two axes) that lays the most wall points on drawn lines of their direction, searched over
//! everything the prior's uncertainty allows, so the fit's Gauss–Newton does not settle a
//! room over when the scale guess is 30 % off on a floor of same-size rooms.
//!
//! Sits inside [`super::fit::fit_warp`], before its similarity stage. Candidates are taken
//! about the map's origin (the marked start) relative to the prior `S₀`: the floor's first
//! wall axis scaled by `s₀ e^(u+v)`, its second by `s₀ e^(u−v)` (the axes at `α`, the map's
//! walls' dominant direction, `¼ atan2(Σ sin 4nᵢ, Σ cos 4nᵢ)` over their normals `nᵢ`: a
//! person draws a floor too long along its walls, and the map's own axes lie wherever the
//! robot started), turned by `θ₀ + φ`, shifted by `t₀ + s₀ d`
//! (`d` meters), over `|u| ≤ k σ_u`, `|φ| ≤ k σ_φ`, `|d_x|, |d_y| ≤ k σ_d`, `|v| ≤ k σ_v`
//! (`k = search_sigmas`; σ_u, σ_φ, σ_d the prior's `scale_error`, `rotation_error_rad`,
//! `translation_error_m`, σ_v the drawing's `proportion_error`). Each is scored
//!
//! `J(c) = ln( (1/n) Σ_i max(0, 1 − (D_b(i)(W_c(p_i)) / τ)²) )
//!         − ½ (u²/σ_u² + v²/σ_v² + φ²/σ_φ² + |d|²/σ_d²)`
//!
//! the log of the share of wall points on a drawn line (a truncated quadratic, TLS's
//! kernel: 1 on a line, 0 beyond `τ` = the fit's last gate `gate_m`) plus the prior's log
//! density, so a start mark and scale guess that are right still win. `D_b` is the distance
//! to the nearest drawn line whose normal is within `direction_tolerance_rad` (plus at most
//! a bin) of the point's wall normal turned by `θ₀ + φ`: one field per direction bin, the
//! drawn lines rasterized once onto cells of a quarter of the gate, read O(1) per point.
//! (τ is the last gate, not wider: on a floor of 4 m rooms a 3 m kernel scores a room over
//! about as well as the truth, and the prior then wins.)
//!
//! Steps: (1) the rotations, from the wall directions alone (the map's wall normals against
//! a histogram of the drawn lines' normals, local maxima of its log share minus the prior
//! term over `|φ| ≤ k σ_φ`, the best two); (2) about each, a grid over `(u, φ ± one step, d)`
//! at steps that move the farthest wall point by half the gate (every k-th point, at most
//! `COARSE_POINTS`); (3) from its best local maxima a pattern search over `(u, φ, d)`
//! (3⁴ neighbours) halving the steps twice; (4) for the best four, the first and the second axis'
//! scale and translation in turn over grids of `(v, d)` (coordinate ascent, twice). The
//! search returns the stretched and the unstretched maxima, best first, one per maximum.
//!
//! Cost: O(L · (ℓ + r) · r / c²) to rasterize (L lines of length ℓ, reach r = τ, cell c);
//! O(n) per candidate; `(2kσ_u / Δu) · 6 · (2kσ_d / Δd)²` candidates on the grid (Δ from
//! the gate over the floor's radius: about 10⁵ on a 40 m floor, 10⁸ lookups), tenths of a
//! second.

use super::fit::{FitConfig, Segment, WallPoint, bounds};
use super::warp::{ControlGrid, Similarity, Warp};
use sketchslam_types::Point2;
use std::f64::consts::PI;

/// At most this many wall points are scored (every k-th of the map's, evenly).
const MAX_POINTS: usize = 3000;
/// At most this many of them on the coarse grid (its τ, the start gate, is wide).
const COARSE_POINTS: usize = 1000;
/// Direction bins per half turn for each direction tolerance: a point pairs with lines
/// within the tolerance plus at most a bin's width of its wall's direction.
const BINS_PER_TOLERANCE: f64 = 2.0;
/// Local maxima of the grid refined.
const SEEDS: usize = 12;
/// The best refined maxima whose axes are let scale apart (each costs a grid over two
/// axes' scale and translation with every point).
const STRETCHED: usize = 4;
/// Rotations (local maxima of the wall directions' match) searched.
const ROTATIONS: usize = 2;
/// Step of the rotations tried against the wall directions, radians.
const ROTATION_STEP_RAD: f64 = 0.25 * PI / 180.0;
/// How far a drawn wall's direction spreads in the match of directions, radians (a
/// drawing's wall directions are right within a few degrees; a mapped wall's PCA normal
/// within one or two).
const DIRECTION_KERNEL_RAD: f64 = 2.0 * PI / 180.0;

/// Per direction bin, the distance (pixels, drawing frame) from each cell's centre to the
/// nearest drawn line of that bin's direction, truncated at `reach_px`.
pub(super) struct DirectionField {
    origin_px: Point2,
    cell_px: f64,
    columns: usize,
    rows: usize,
    bins: usize,
    bin_rad: f64,
    /// The truncation.
    reach_px: f64,
    distance_px: Vec<f32>,
}

/// A line's or a wall's normal as an angle in [0, π).
fn normal_angle(n: Point2) -> f64 {
    n.y.atan2(n.x).rem_euclid(PI)
}

/// `R(α) diag(f_a, f_b) R(−α) q`: `q` scaled by `f_a` along the axis at `α` (given as its
/// sine and cosine) and by `f_b` across it. The search's stretch along the walls' axes.
fn along_axes(q: Point2, (sin_a, cos_a): (f64, f64), f_a: f64, f_b: f64) -> Point2 {
    let (qa, qb) = (
        f_a * (cos_a * q.x + sin_a * q.y),
        f_b * (-sin_a * q.x + cos_a * q.y),
    );
    Point2::new(cos_a * qa - sin_a * qb, sin_a * qa + cos_a * qb)
}

impl DirectionField {
    /// Rasterizes `segments` (drawing frame, pixels); `tolerance_rad` the direction
    /// tolerance, `cell_px` the cell, `reach_px` the truncation. `None` when empty.
    pub(super) fn new(
        segments: &[Segment],
        tolerance_rad: f64,
        cell_px: f64,
        reach_px: f64,
    ) -> Option<Self> {
        if segments.is_empty() || !(cell_px > 0.0 && reach_px > 0.0) {
            return None;
        }
        let tolerance_rad = tolerance_rad.clamp(1e-3, PI / 2.0);
        let bins = ((BINS_PER_TOLERANCE * PI / tolerance_rad).ceil() as usize).clamp(1, 180);
        let bin_rad = PI / bins as f64;
        let (lo, hi) = bounds(segments.iter().flat_map(|s| [s.a, s.b]));
        let origin_px = Point2::new(lo.x - reach_px, lo.y - reach_px);
        let columns = (((hi.x - lo.x + 2.0 * reach_px) / cell_px).ceil() as usize + 1).min(8192);
        let rows = (((hi.y - lo.y + 2.0 * reach_px) / cell_px).ceil() as usize + 1).min(8192);
        let mut distance_px = vec![reach_px as f32; bins * columns * rows];
        for s in segments {
            let angle = normal_angle(s.normal);
            let (x0, x1) = (s.a.x.min(s.b.x) - reach_px, s.a.x.max(s.b.x) + reach_px);
            let (y0, y1) = (s.a.y.min(s.b.y) - reach_px, s.a.y.max(s.b.y) + reach_px);
            let cell = |v: f64, o: f64, n: usize| {
                (((v - o) / cell_px).floor().max(0.0) as usize).min(n - 1)
            };
            let (i0, i1) = (
                cell(x0, origin_px.x, columns),
                cell(x1, origin_px.x, columns),
            );
            let (j0, j1) = (cell(y0, origin_px.y, rows), cell(y1, origin_px.y, rows));
            for bin in 0..bins {
                // The bin's angles [bin·w, (bin+1)·w) against the line's, circularly mod π.
                let centre = (bin as f64 + 0.5) * bin_rad;
                let off = (angle - centre).rem_euclid(PI);
                if off.min(PI - off) > tolerance_rad + 0.5 * bin_rad {
                    continue;
                }
                let plane = &mut distance_px[bin * columns * rows..(bin + 1) * columns * rows];
                for j in j0..=j1 {
                    let y = origin_px.y + (j as f64 + 0.5) * cell_px;
                    for i in i0..=i1 {
                        let p = Point2::new(origin_px.x + (i as f64 + 0.5) * cell_px, y);
                        let d = p.distance(&s.foot(p)) as f32;
                        let c = &mut plane[j * columns + i];
                        if d < *c {
                            *c = d;
                        }
                    }
                }
            }
        }
        Some(Self {
            origin_px,
            cell_px,
            columns,
            rows,
            bins,
            bin_rad,
            reach_px,
            distance_px,
        })
    }

    /// The field the fit scores with ([`super::fit`]'s search and region search): the
    /// fit's direction tolerance, cells of a quarter of its last gate, truncated at the
    /// gate; `s0` the prior's pixels per meter.
    pub(super) fn for_fit(segments: &[Segment], config: &FitConfig, s0: f64) -> Option<Self> {
        let gate_px = config.gate_m.max(1e-3) * s0;
        Self::new(
            segments,
            config.direction_tolerance_rad,
            0.25 * gate_px,
            gate_px,
        )
    }

    /// The distance from `w` (drawing frame, pixels) to the nearest drawn line whose normal
    /// is within the tolerance of `normal_rad`, at most the reach.
    pub(super) fn distance_px(&self, w: Point2, normal_rad: f64) -> f64 {
        let fx = (w.x - self.origin_px.x) / self.cell_px;
        let fy = (w.y - self.origin_px.y) / self.cell_px;
        if !(fx >= 0.0 && fy >= 0.0) {
            return self.reach_px;
        }
        let (i, j) = (fx as usize, fy as usize);
        if i >= self.columns || j >= self.rows {
            return self.reach_px;
        }
        let bin = ((normal_rad.rem_euclid(PI) / self.bin_rad) as usize).min(self.bins - 1);
        f64::from(self.distance_px[(bin * self.rows + j) * self.columns + i])
    }
}

/// A candidate start: `(u, φ, d_x, d_y)` of the module doc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Candidate {
    /// Log scale against the prior's (the mean of the two axes').
    pub u: f64,
    /// Half the log of the drawing's scale along the floor's first wall axis over its scale
    /// along the second: the first is scaled by `e^(u+v)`, the second by `e^(u−v)`.
    pub v: f64,
    /// The floor's first wall axis in the map frame, radians (the map's walls' dominant
    /// direction: a person draws a floor too long or too short along its walls, not along
    /// the map's axes, which are wherever the robot started).
    pub axes_rad: f64,
    /// Rotation against the prior's, radians.
    pub phi_rad: f64,
    /// Translation against the prior's, meters at the prior's scale.
    pub d_m: Point2,
    /// The module doc's `J` at the last `τ` it was scored with.
    pub objective: f64,
}

impl Candidate {
    /// The similarity it stands for.
    pub(super) fn similarity(&self, prior: &Similarity) -> Similarity {
        let s0 = prior.scale_px_per_m();
        Similarity::new(
            s0 * self.u.exp(),
            prior.rotation_rad() + self.phi_rad,
            Point2::new(prior.t.x + s0 * self.d_m.x, prior.t.y + s0 * self.d_m.y),
        )
    }
}

impl Candidate {
    /// The warp it stands for on `grid` (the similarity of scale `s₀ e^u`, the two axes'
    /// stretch `±v` in the offsets; exact on a grid of one cell, the stretch being linear).
    pub(super) fn warp(&self, prior: &Similarity, grid: ControlGrid) -> Warp {
        let similarity = self.similarity(prior);
        let (sin, cos) = similarity.rotation_rad().sin_cos();
        let (sin_a, cos_a) = self.axes_rad.sin_cos();
        let s = similarity.scale_px_per_m();
        let (ex, ey) = (self.v.exp() - 1.0, (-self.v).exp() - 1.0);
        let mut warp = Warp::rigid(similarity, grid);
        for (k, o) in warp.offsets.iter_mut().enumerate() {
            let q = Point2::new(
                grid.origin.x + (k % grid.columns) as f64 * grid.spacing_m,
                grid.origin.y + (k / grid.columns) as f64 * grid.spacing_m,
            );
            // s R(θ) R(α) diag(e^v − 1, e^−v − 1) R(−α) q: the stretch along the walls'
            // axes, turned with the similarity.
            let d = along_axes(q, (sin_a, cos_a), s * ex, s * ey);
            *o = Point2::new(cos * d.x - sin * d.y, sin * d.x + cos * d.y);
        }
        warp
    }
}

/// Scores candidates: the module doc's `J`.
struct Scorer<'a> {
    points: Vec<(Point2, f64)>,
    field: &'a DirectionField,
    prior: Similarity,
    sigma_u: f64,
    sigma_v: f64,
    sigma_phi_rad: f64,
    sigma_d_m: f64,
    /// The floor's first wall axis in the map frame ([`Candidate::axes_rad`]).
    axes_rad: f64,
}

impl Scorer<'_> {
    /// `J` of `(u, φ)` at every translation of `ds` (meters), `τ` pixels, from every
    /// `stride`-th point.
    fn score_translations(
        &self,
        u: f64,
        phi_rad: f64,
        ds: &[Point2],
        tau_px: f64,
        stride: usize,
    ) -> Vec<f64> {
        self.score_stretched(u, 0.0, phi_rad, ds, tau_px, stride)
    }

    /// `J` of `(u, v, φ)` at every translation of `ds` (meters), `τ` pixels, from every
    /// `stride`-th point: the walls' first axis scaled by `e^(u+v)`, the second by `e^(u−v)`,
    /// before the turn.
    fn score_stretched(
        &self,
        u: f64,
        v: f64,
        phi_rad: f64,
        ds: &[Point2],
        tau_px: f64,
        stride: usize,
    ) -> Vec<f64> {
        let field = self.field;
        let (sx, sy) = (
            self.prior.scale_px_per_m() * (u + v).exp(),
            self.prior.scale_px_per_m() * (u - v).exp(),
        );
        let theta = self.prior.rotation_rad() + phi_rad;
        let (sin, cos) = theta.sin_cos();
        let (sin_a, cos_a) = self.axes_rad.sin_cos();
        let inv_cell = 1.0 / field.cell_px;
        let plane = field.columns * field.rows;
        // The points turned and scaled once, in cells of the field, with their bin's plane.
        let turned: Vec<(f64, f64, usize)> = self
            .points
            .iter()
            .step_by(stride.max(1))
            .map(|(p, n)| {
                let bin =
                    (((n + theta).rem_euclid(PI) / field.bin_rad) as usize).min(field.bins - 1);
                // Stretched along the walls' axes, then turned.
                let q = along_axes(*p, (sin_a, cos_a), sx, sy);
                (
                    (cos * q.x - sin * q.y + self.prior.t.x - field.origin_px.x) * inv_cell,
                    (sin * q.x + cos * q.y + self.prior.t.y - field.origin_px.y) * inv_cell,
                    bin * plane,
                )
            })
            .collect();
        let inv_tau2 = 1.0 / (tau_px * tau_px);
        let s0 = self.prior.scale_px_per_m();
        let prior_term = 0.5
            * ((u / self.sigma_u).powi(2)
                + (v / self.sigma_v).powi(2)
                + (phi_rad / self.sigma_phi_rad).powi(2));
        let (columns, rows) = (field.columns as f64, field.rows as f64);
        ds.iter()
            .map(|d| {
                let (sx, sy) = (s0 * d.x * inv_cell, s0 * d.y * inv_cell);
                let sum: f64 = turned
                    .iter()
                    .map(|&(x, y, base)| {
                        let (fx, fy) = (x + sx, y + sy);
                        if !(fx >= 0.0 && fy >= 0.0 && fx < columns && fy < rows) {
                            return 0.0;
                        }
                        let k = base + fy as usize * field.columns + fx as usize;
                        let dist = f64::from(field.distance_px[k]);
                        (1.0 - dist * dist * inv_tau2).max(0.0)
                    })
                    .sum();
                let share = sum / turned.len().max(1) as f64;
                share.max(1e-9).ln()
                    - prior_term
                    - 0.5 * (d.x * d.x + d.y * d.y) / (self.sigma_d_m * self.sigma_d_m)
            })
            .collect()
    }
}

/// Values `−span..=span` by `step` (centred on 0, at least the centre).
fn steps(span: f64, step: f64) -> Vec<f64> {
    if !(span > 0.0 && step > 0.0) {
        return vec![0.0];
    }
    let k = (span / step).ceil() as i64;
    (-k..=k)
        .map(|i| i as f64 * span / k.max(1) as f64)
        .collect()
}

/// The rotations (against the prior's, radians) at which the map's wall directions best
/// match the drawing's, best first, at most `ROTATIONS`: the local maxima over
/// `|φ| ≤ span_rad` of `ln( (1/n) Σ_i h(α_i + θ₀ + φ) ) − ½ φ² / σ_φ²`, `h` the drawn lines'
/// normal directions weighted by length (a triangle of `kernel_rad` each way, scaled to a
/// peak of 1), `α_i` the wall points' normals. O(L / step + n · span / step).
fn rotations(
    points: &[(Point2, f64)],
    segments: &[Segment],
    theta0_rad: f64,
    span_rad: f64,
    sigma_rad: f64,
) -> Vec<f64> {
    let bins = (PI / ROTATION_STEP_RAD).round() as usize;
    let step = PI / bins as f64;
    let reach = (DIRECTION_KERNEL_RAD / step).ceil() as i64;
    let mut h = vec![0.0; bins];
    for s in segments {
        let len = s.a.distance(&s.b);
        let at = normal_angle(s.normal) / step;
        for k in -reach..=reach {
            let b = (at.floor() as i64 + k).rem_euclid(bins as i64) as usize;
            let off = ((b as f64 + 0.5) - at)
                .abs()
                .min(bins as f64 - ((b as f64 + 0.5) - at).abs());
            h[b] += len * (1.0 - off * step / DIRECTION_KERNEL_RAD).max(0.0);
        }
    }
    let peak = h.iter().copied().fold(0.0, f64::max);
    if peak <= 0.0 || !peak.is_finite() || points.is_empty() {
        return vec![0.0];
    }
    let phis = steps(span_rad, step);
    let j: Vec<f64> = phis
        .iter()
        .map(|&phi| {
            let sum: f64 = points
                .iter()
                .map(|(_, n)| {
                    let b = ((n + theta0_rad + phi).rem_euclid(PI) / step) as usize;
                    h[b.min(bins - 1)] / peak
                })
                .sum();
            (sum / points.len() as f64).max(1e-9).ln() - 0.5 * (phi / sigma_rad).powi(2)
        })
        .collect();
    let mut maxima: Vec<(f64, f64)> = (0..phis.len())
        .filter(|&k| (k == 0 || j[k - 1] < j[k]) && (k + 1 == phis.len() || j[k + 1] <= j[k]))
        .map(|k| (j[k], phis[k]))
        .collect();
    maxima.sort_by(|x, y| y.0.total_cmp(&x.0));
    maxima.truncate(ROTATIONS);
    maxima.into_iter().map(|(_, phi)| phi).collect()
}

/// Lets `seed`'s two axes scale apart: coordinate ascent of `J`, x's scale and translation
/// over a grid of `(u + v, d_x)` (`|v| ≤ k σ_v`, `d_x` within `k σ_d` of the prior's), then
/// y's, twice; steps `du`, `dd`.
fn stretch(scorer: &Scorer, seed: &mut Candidate, du: f64, dd: f64, tau_px: f64, k: f64) {
    let vs = steps(k * scorer.sigma_v, du);
    let ds_axis = steps(k * scorer.sigma_d_m, dd);
    for _ in 0..2 {
        for x_axis in [true, false] {
            // The other axis' log scale and translation held.
            let (other_u, other_d) = if x_axis {
                (seed.u - seed.v, seed.d_m.y)
            } else {
                (seed.u + seed.v, seed.d_m.x)
            };
            for &w in &vs {
                // This axis' log scale: the other's plus 2v, v = w.
                let (u, v) = if x_axis {
                    (other_u + w, w)
                } else {
                    (other_u - w, w)
                };
                let ds: Vec<Point2> = ds_axis
                    .iter()
                    .map(|&d| {
                        if x_axis {
                            Point2::new(d, other_d)
                        } else {
                            Point2::new(other_d, d)
                        }
                    })
                    .collect();
                let js = scorer.score_stretched(u, v, seed.phi_rad, &ds, tau_px, 1);
                for (j, d) in js.into_iter().zip(ds) {
                    if j > seed.objective {
                        (seed.objective, seed.u, seed.v, seed.d_m) = (j, u, v, d);
                    }
                }
            }
        }
    }
}

/// The best starts for the fit, best first (at most `SEEDS`, each a local maximum of `J`
/// refined by a pattern search); empty when there is nothing to score.
pub(super) fn search_starts(
    points: &[WallPoint],
    segments: &[Segment],
    field: &DirectionField,
    prior: &Similarity,
    config: &FitConfig,
) -> Vec<Candidate> {
    let s0 = prior.scale_px_per_m();
    let k = config.search_sigmas;
    if points.is_empty() || !(k > 0.0 && s0 > 0.0) {
        return Vec::new();
    }
    let gate_m = config.gate_m.max(1e-3);
    let stride = points.len().div_ceil(MAX_POINTS);
    // The walls' dominant axis: the mean of their normals' angles taken four times over
    // (a wall and the walls across it count alike).
    let (s4, c4) = points.iter().fold((0.0, 0.0), |(s, c), w| {
        let a = 4.0 * w.normal.y.atan2(w.normal.x);
        (s + a.sin(), c + a.cos())
    });
    let axes_rad = 0.25 * s4.atan2(c4);
    let scorer = Scorer {
        points: points
            .iter()
            .step_by(stride)
            .map(|w| (w.p, normal_angle(w.normal)))
            .collect(),
        field,
        prior: *prior,
        sigma_u: config.scale_error.max(1e-3),
        sigma_v: config.proportion_error.max(1e-3),
        sigma_phi_rad: config.rotation_error_rad.max(1e-3),
        sigma_d_m: config.translation_error_m.max(1e-3),
        axes_rad,
    };
    // Steps that move the farthest point by half the gate.
    let radius_m = scorer
        .points
        .iter()
        .map(|(p, _)| p.x.hypot(p.y))
        .fold(1.0, f64::max);
    let (mut du, mut dphi, mut dd) = (
        0.5 * gate_m / radius_m,
        0.5 * gate_m / radius_m,
        0.5 * gate_m,
    );
    let tau_px = gate_m * s0;
    let coarse_stride = scorer.points.len().div_ceil(COARSE_POINTS);
    let ds_axis = steps(k * scorer.sigma_d_m, dd);
    let ds: Vec<Point2> = ds_axis
        .iter()
        .flat_map(|&y| ds_axis.iter().map(move |&x| Point2::new(x, y)))
        .collect();
    let us = steps(k * scorer.sigma_u, du);
    let mut phis: Vec<f64> = Vec::new();
    for phi in rotations(
        &scorer.points,
        segments,
        prior.rotation_rad(),
        k * scorer.sigma_phi_rad,
        scorer.sigma_phi_rad,
    ) {
        phis.extend([phi - dphi, phi, phi + dphi]);
    }
    // The grid, J per (u, φ, d); φ in runs of three about each rotation.
    let mut grid = Vec::with_capacity(us.len() * phis.len() * ds.len());
    for &u in &us {
        for &phi in &phis {
            grid.extend(scorer.score_translations(u, phi, &ds, tau_px, coarse_stride));
        }
    }
    let index = |a: usize, b: usize, c: usize| (a * phis.len() + b) * ds.len() + c;
    let n_d = ds_axis.len();
    // Local maxima over the 3⁴ neighbourhood (φ within its run), best first.
    let mut maxima: Vec<(f64, usize, usize, usize)> = Vec::new();
    for a in 0..us.len() {
        for b in 0..phis.len() {
            let run = 3 * (b / 3);
            for c in 0..ds.len() {
                let j = grid[index(a, b, c)];
                let (cx, cy) = (c % n_d, c / n_d);
                let mut is_max = true;
                'n: for na in a.saturating_sub(1)..=(a + 1).min(us.len() - 1) {
                    for nb in b.saturating_sub(1).max(run)..=(b + 1).min(run + 2) {
                        for ny in cy.saturating_sub(1)..=(cy + 1).min(n_d - 1) {
                            for nx in cx.saturating_sub(1)..=(cx + 1).min(n_d - 1) {
                                let o = grid[index(na, nb, ny * n_d + nx)];
                                if o > j
                                    || (o == j && index(na, nb, ny * n_d + nx) < index(a, b, c))
                                {
                                    is_max = false;
                                    break 'n;
                                }
                            }
                        }
                    }
                }
                if is_max {
                    maxima.push((j, a, b, c));
                }
            }
        }
    }
    maxima.sort_by(|x, y| y.0.total_cmp(&x.0));
    maxima.truncate(SEEDS);
    let mut seeds: Vec<Candidate> = maxima
        .iter()
        .map(|&(j, a, b, c)| Candidate {
            u: us[a],
            v: 0.0,
            axes_rad: scorer.axes_rad,
            phi_rad: phis[b],
            d_m: ds[c],
            objective: j,
        })
        .collect();
    let (du0, dd0) = (du, dd);
    // Pattern search from each, with every point, the steps halved twice.
    for _ in 0..2 {
        du *= 0.5;
        dphi *= 0.5;
        dd *= 0.5;
        let offsets: Vec<Point2> = [-dd, 0.0, dd]
            .iter()
            .flat_map(|&y| [-dd, 0.0, dd].into_iter().map(move |x| Point2::new(x, y)))
            .collect();
        for seed in &mut seeds {
            let mut best =
                scorer.score_translations(seed.u, seed.phi_rad, &[seed.d_m], tau_px, 1)[0];
            for _ in 0..8 {
                let mut moved = None;
                for su in [-du, 0.0, du] {
                    for sp in [-dphi, 0.0, dphi] {
                        let ds: Vec<Point2> = offsets
                            .iter()
                            .map(|o| Point2::new(seed.d_m.x + o.x, seed.d_m.y + o.y))
                            .collect();
                        let js = scorer.score_translations(
                            seed.u + su,
                            seed.phi_rad + sp,
                            &ds,
                            tau_px,
                            1,
                        );
                        for (j, d) in js.into_iter().zip(ds) {
                            if j > best {
                                best = j;
                                moved = Some((seed.u + su, seed.phi_rad + sp, d));
                            }
                        }
                    }
                }
                let Some((u, phi, d)) = moved else { break };
                (seed.u, seed.phi_rad, seed.d_m) = (u, phi, d);
            }
            seed.objective = best;
        }
    }
    let kept = distinct(seeds, du, dphi, dd);
    // Each, its axes let scale apart (a drawing's proportions may be wrong along one axis
    // only: the best similarity then lays part of the floor right and the rest off, and
    // the true stretch may start from another maximum than the best), best first.
    let mut stretched: Vec<Candidate> = Vec::with_capacity(2 * kept.len());
    for seed in kept.iter().take(STRETCHED) {
        let mut s = *seed;
        stretch(&scorer, &mut s, du0, dd0, tau_px, k);
        if s.v != 0.0 {
            stretched.push(s);
        }
    }
    stretched.extend(kept);
    distinct(stretched, du, dphi, dd)
}

/// `candidates` best first, each kept only when no better one lies within two steps (`du`
/// in u and v, `dphi`, `dd`) of it: seeds that climbed onto the same maximum count once.
fn distinct(mut candidates: Vec<Candidate>, du: f64, dphi: f64, dd: f64) -> Vec<Candidate> {
    candidates.sort_by(|x, y| y.objective.total_cmp(&x.objective));
    let mut kept: Vec<Candidate> = Vec::new();
    for s in candidates {
        if !kept.iter().any(|k| {
            (k.u - s.u).abs() <= 2.0 * du
                && (k.v - s.v).abs() <= 2.0 * du
                && (k.phi_rad - s.phi_rad).abs() <= 2.0 * dphi
                && (k.d_m.x - s.d_m.x).abs() <= 2.0 * dd
                && (k.d_m.y - s.d_m.y).abs() <= 2.0 * dd
        }) {
            kept.push(s);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of six same-size rooms, 4 m apart, south of a 2 m corridor, meters (world):
    /// the floor on which a 30 % wrong scale lays the drawing a room over.
    fn walls() -> Vec<(Point2, Point2)> {
        let mut w = vec![
            (Point2::new(0.0, 0.0), Point2::new(24.0, 0.0)),
            (Point2::new(0.0, 7.0), Point2::new(24.0, 7.0)),
            (Point2::new(0.0, 0.0), Point2::new(0.0, 7.0)),
            (Point2::new(24.0, 0.0), Point2::new(24.0, 7.0)),
        ];
        for k in 0..6 {
            // The corridor wall, a 1 m door into each room.
            let x = 4.0 * k as f64;
            w.push((Point2::new(x, 5.0), Point2::new(x + 1.5, 5.0)));
            w.push((Point2::new(x + 2.5, 5.0), Point2::new(x + 4.0, 5.0)));
            if k > 0 {
                w.push((Point2::new(x, 0.0), Point2::new(x, 5.0)));
            }
        }
        w
    }

    /// The prior (10 px/m, no turn, the start at (100, −100) px) and the drawing's truth:
    /// drawn 30 % larger, the start marked 1 m east and 0.5 m north of where it is drawn.
    fn prior_and_truth() -> (Similarity, Similarity) {
        let prior = Similarity::new(10.0, 0.0, Point2::new(100.0, -100.0));
        let truth = Similarity::new(13.0, 0.0, Point2::new(110.0, -95.0));
        (prior, truth)
    }

    /// The walls' points every 10 cm in the map frame (the robot started at (2, 6), in the
    /// corridor), and the drawing's segments through `truth`.
    fn scene(truth: &Similarity) -> (Vec<WallPoint>, Vec<Segment>) {
        let start = Point2::new(2.0, 6.0);
        let (mut points, mut segments) = (Vec::new(), Vec::new());
        for (a, b) in walls() {
            let len = a.distance(&b);
            let normal = Point2::new(-(b.y - a.y) / len, (b.x - a.x) / len);
            for i in 0..=(len / 0.1) as usize {
                let t = i as f64 * 0.1 / len;
                let p = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
                points.push(WallPoint {
                    p: Point2::new(p.x - start.x, p.y - start.y),
                    normal,
                });
            }
            let map = |p: Point2| truth.apply(Point2::new(p.x - start.x, p.y - start.y));
            segments.push(Segment {
                a: map(a),
                b: map(b),
                normal,
            });
        }
        (points, segments)
    }

    /// [`search_starts`] with the field the fit builds.
    fn starts_of(
        points: &[WallPoint],
        segments: &[Segment],
        prior: &Similarity,
        config: &FitConfig,
    ) -> Vec<Candidate> {
        let field = DirectionField::for_fit(segments, config, prior.scale_px_per_m()).unwrap();
        search_starts(points, segments, &field, prior, config)
    }

    /// The farthest any of `points` lands from where `truth` puts it, pixels.
    fn farthest_px(
        c: &Candidate,
        prior: &Similarity,
        truth: &Similarity,
        points: &[WallPoint],
    ) -> f64 {
        let grid = ControlGrid::covering(Point2::new(-3.0, -7.0), Point2::new(23.0, 2.0), 26.0);
        let warp = c.warp(prior, grid);
        points
            .iter()
            .map(|w| warp.apply(w.p).distance(&truth.apply(w.p)))
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_scale_30_percent_off_and_a_shifted_start_are_found() {
        let (prior, truth) = prior_and_truth();
        let (points, segments) = scene(&truth);
        let config = FitConfig::default();
        let starts = starts_of(&points, &segments, &prior, &config);
        // The truth: u = ln 1.3 = 0.262, v = 0, φ = 0, d = (10, 5) px / 10 px/m = (1, 0.5) m.
        // The best similarity: the search's last steps are an eighth of the gate (1 m) over
        // the farthest point (22.8 m from the start): 0.0055 in u and φ, 0.125 m in d; its
        // score is flat within a tenth of the gate and the prior pulls d towards 0, so d is
        // found within half the gate (a room over would be 4 m at the prior's scale).
        let similarity = starts.iter().find(|c| c.v == 0.0).expect("a similarity");
        assert!((similarity.u - 1.3f64.ln()).abs() < 0.02, "{similarity:?}");
        assert!(similarity.phi_rad.abs() < 0.02, "{similarity:?}");
        assert!(
            (similarity.d_m.x - 1.0).hypot(similarity.d_m.y - 0.5) < 0.5,
            "{similarity:?}"
        );
        // Every start returned, stretched or not, lays every wall within the gate (10 px)
        // of its drawn place: none is a room over. (Stretched, y's scale is held only by the
        // 7 m across the rooms, so the prior pulls it a little back.)
        for c in &starts[..2] {
            let far = farthest_px(c, &prior, &truth, &points);
            assert!(far < 10.0, "{far} px: {c:?}");
        }
    }

    #[test]
    fn a_drawing_stretched_along_x_only_is_found_stretched() {
        // Drawn 30 % wider, true to scale in y: u = v = ½ ln 1.3 = 0.131.
        let prior = Similarity::new(10.0, 0.0, Point2::new(100.0, -100.0));
        let (points, _) = scene(&prior);
        let start = Point2::new(2.0, 6.0);
        let drawn = |p: Point2| {
            Point2::new(
                100.0 + 13.0 * (p.x - start.x),
                -100.0 + 10.0 * (p.y - start.y),
            )
        };
        let segments: Vec<Segment> = walls()
            .into_iter()
            .map(|(a, b)| {
                let len = a.distance(&b);
                Segment {
                    a: drawn(a),
                    b: drawn(b),
                    normal: Point2::new(-(b.y - a.y) / len, (b.x - a.x) / len),
                }
            })
            .collect();
        let best = starts_of(&points, &segments, &prior, &FitConfig::default())[0];
        let half = 0.5 * 1.3f64.ln();
        // Within the grid's step in v (half the gate over the farthest point: 0.022).
        assert!(
            (best.u - half).abs() < 0.03 && (best.v - half).abs() < 0.03,
            "{best:?}"
        );
        assert!(best.d_m.x.hypot(best.d_m.y) < 0.5, "{best:?}");
    }

    #[test]
    fn a_drawing_stretched_along_the_walls_of_a_turned_map_is_found_stretched() {
        // The robot started turned 8° against the floor's walls, so the map's axes are not
        // the walls'; the floor is drawn 30 % wider along its walls' x, true in y, and the
        // mark's rotation is right. Stretching along the map's axes would shear the walls.
        let turn = 8f64.to_radians();
        let (sin, cos) = turn.sin_cos();
        let start = Point2::new(2.0, 6.0);
        // World → map: about the start, turned by −8°.
        let to_map = |p: Point2| {
            let (x, y) = (p.x - start.x, p.y - start.y);
            Point2::new(cos * x + sin * y, -sin * x + cos * y)
        };
        let drawn = |p: Point2| {
            Point2::new(
                100.0 + 13.0 * (p.x - start.x),
                -100.0 + 10.0 * (p.y - start.y),
            )
        };
        let mut points = Vec::new();
        let mut segments = Vec::new();
        for (a, b) in walls() {
            let len = a.distance(&b);
            let normal = Point2::new(-(b.y - a.y) / len, (b.x - a.x) / len);
            let map_normal = Point2::new(
                cos * normal.x + sin * normal.y,
                -sin * normal.x + cos * normal.y,
            );
            for i in 0..=(len / 0.1) as usize {
                let t = i as f64 * 0.1 / len;
                let p = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
                points.push(WallPoint {
                    p: to_map(p),
                    normal: map_normal,
                });
            }
            segments.push(Segment {
                a: drawn(a),
                b: drawn(b),
                normal,
            });
        }
        // The mark: the start where it is drawn, turned back by the 8°, 10 px/m.
        let prior = Similarity::new(10.0, turn, Point2::new(100.0, -100.0));
        let best = starts_of(&points, &segments, &prior, &FitConfig::default())[0];
        // The walls' first axis is the map's −8° (world x), and the stretch along it
        // u + v = ln 1.3, across it u − v = 0.
        assert!((best.axes_rad + turn).abs() < 1e-6, "{best:?}");
        let half = 0.5 * 1.3f64.ln();
        assert!(
            (best.u - half).abs() < 0.03 && (best.v - half).abs() < 0.03,
            "{best:?}"
        );
        // Its warp lays every wall within the gate (10 px) of its drawn place.
        let grid = ControlGrid::covering(Point2::new(-30.0, -30.0), Point2::new(30.0, 30.0), 60.0);
        let warp = best.warp(&prior, grid);
        let far = walls()
            .into_iter()
            .flat_map(|(a, b)| [a, b])
            .map(|p| warp.apply(to_map(p)).distance(&drawn(p)))
            .fold(0.0, f64::max);
        assert!(far < 10.0, "{far} px: {best:?}");
    }

    #[test]
    fn a_right_prior_still_wins() {
        let (prior, _) = prior_and_truth();
        let (points, segments) = scene(&prior);
        let best = starts_of(&points, &segments, &prior, &FitConfig::default())[0];
        assert!(best.u.abs() < 0.01 && best.phi_rad.abs() < 0.01, "{best:?}");
        assert!(best.d_m.x.abs() < 0.1 && best.d_m.y.abs() < 0.1, "{best:?}");
    }

    #[test]
    fn the_field_reads_the_distance_to_lines_of_the_point_s_direction() {
        // One horizontal line (normal along y) from (0, 0) to (100, 0) pixels.
        let segments = [Segment {
            a: Point2::new(0.0, 0.0),
            b: Point2::new(100.0, 0.0),
            normal: Point2::new(0.0, 1.0),
        }];
        let field = DirectionField::new(&segments, 20f64.to_radians(), 1.0, 30.0).unwrap();
        // A cell centre 10.5 px above it: 10.5 px for a wall of its direction …
        let d = field.distance_px(Point2::new(50.2, 10.7), PI / 2.0);
        assert!((d - 10.5).abs() < 1e-6, "{d}");
        // … the reach for a wall across it (normal along x), and beyond the reach.
        assert_eq!(field.distance_px(Point2::new(50.2, 10.7), 0.0), 30.0);
        assert_eq!(field.distance_px(Point2::new(50.2, 40.7), PI / 2.0), 30.0);
    }
}
