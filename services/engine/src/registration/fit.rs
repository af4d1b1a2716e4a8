//! Fitting the warp W ([`super::warp`]) to the map's walls: the map's wall points carried
//! through W should lie on the drawing's lines.
//!
//! Sits after the back end (the map's walls in map meters: keyframe scans at their
//! optimized poses, or the grid's occupied cells) and before everything read on the
//! drawing. Inputs: wall points `p_i` (map), the drawing's lines (pixels), and a prior
//! similarity `S₀` (the user's start mark and scale guess) with its uncertainty.
//!
//! Minimises, over W's parameters `θ = (a, b, t, o)` (all linear in W),
//!
//! `E(θ) = Σ_i ρ(r_i) / σ_l² + |(a, b) − (a₀, b₀)|² / σ_ab² + |t − t₀|² / σ_t²
//!        + Σ_stencils |Δ²o|² / σ_b² + Σ_k |o_k|² / σ_o² + c · X(θ)`
//!
//! - `r_i = n_i · (W(p_i) − f_i)`: the distance of the warped point from its nearest drawn
//!   line (`f_i` the nearest point of the segment, `n_i` the unit direction from `f_i`, so
//!   point-to-line inside the segment and point-to-point beyond its ends). A point farther
//!   than the gate from every line is left out (truncated least squares, `ρ(r) = min(r², g²)`):
//!   furniture, people and walls nobody drew do not pull. The gate shrinks from
//!   `start_gate_m` (where the prior may put a wall) towards `gate_m` (how far a drawn wall
//!   may lie from its true place once warped), as ICP's does. A point pairs only with lines
//!   of its own wall's direction (within `direction_tolerance_rad`): a drawing's wall
//!   directions are right.
//! - `σ_l`: a drawn wall's own error (pen, straightness) after the warp.
//! - `Δ²o`: the offsets' second differences along the grid's rows and columns and their
//!   mixed ones — the discrete thin plate's bending energy (Bookstein, PAMI 1989), with
//!   `σ_b = proportion_change · spacing`. A stretch or a shear of the whole floor costs
//!   nothing; only a change of proportion from one cell to the next does. A person's
//!   drawing is close to one affine map of the floor (its proportions are wrong, its rooms
//!   are drawn in turn with one hand); where the walls show a room drawn otherwise, they
//!   outweigh the term. Measured against the membrane `Σ |o_k − o_l|² / σ_s²` (Mielle et al.,
//!   Robotics 2019, first differences, σ_s = proportion_error · spacing) it held before: on
//!   32 drawings (`bench-warp`), median error 1.13 → 0.25 m; the membrane makes every
//!   stretch pay, so rooms far from their walls' support bend toward the similarity.
//! - `σ_o = proportion_error · half the floor's extent`: how far a drawn point may lie from
//!   where the best similarity puts it, so what a similarity explains stays in the
//!   similarity.
//! - `X(θ)`: the steps of the robot's route (keyframe to keyframe) that W carries through a
//!   drawn wall, away from its doors and ends (`route`): the wall points say where drawn
//!   walls are, the route where they cannot be. On a partial map a wrong W can lay clutter
//!   and a half-seen room on drawn walls as well as the right one does; it then walks the
//!   robot through walls. A step through a wall counts as the wall points that wall would
//!   have given where the robot passed (`2 · gate_m / wall_spacing_m`, the margin each
//!   way), each at the gate: `c = 2 (gate_m / wall_spacing_m) g² / σ_l²` with `g` the
//!   stage's gate. `X` is a count, so it takes no part in the Gauss–Newton steps; it ranks
//!   the fits from the starts and the region search's moves, where a wrong W and the right
//!   one are told apart.
//!
//! Started from the prior and from the best starts of a global search over the prior's
//! range (`search`: scale, stretch along the walls' axes, rotation, translation scored
//! against a distance field of the drawn lines): each start runs the similarity stage and
//! the coarsest grid, the `finished_starts` of least `E` (the most probable; a point beyond
//! the gate counts at the gate) go on to the finer grids, and the least `E` is kept (the
//! search's score ranks by the share of walls near a line only: on the Intel CAD plan its
//! fourth start is the right one). From the prior alone, a scale guess 30 % off settles a
//! room over on a floor of same-size rooms. Then, round after round while `E` falls, the
//! region search (`region_search`) moves a region of the coarsest grid beyond the gates
//! where its walls lie on drawn walls and fits again: a wing drawn out of proportion with
//! the rest.
//! Each runs Gauss–Newton (the model is linear in θ; the nearest lines are found again each
//! iteration): first the similarity alone (a few iterations, the offsets held at the start's), then
//! everything on control grids refined coarse to fine (`levels`: 16, 8, 4 m at the
//! defaults; each level starts from the last, [`Warp::resampled`]; a stage stops early once
//! a step moves no point by a millimetre), so a floor's large
//! proportions settle before a room's. A level's gate is what its cells cannot bend, a
//! person's proportion error over half a cell (at least `gate_m`); the gate never widens
//! again (widened for the deformation, it folded maps onto the nearest lines). All lengths
//! in meters are turned into pixels at the prior's scale. Cost: the search's (tenths of a
//! second), then per start and iteration O(n · l) to associate n points with the l lines
//! listed near each (`segment_grid`), O(n) to build, O(m³) to solve for
//! m = 4 + 2 · nodes parameters (a 60 × 40 m floor at 4 m: 356).
//!
//! Pure: values in, values out.

use super::region_search::region_starts;
use super::route::RouteCheck;
use super::search::{DirectionField, search_starts};
use super::segment_grid::SegmentGrid;
use super::warp::{ControlGrid, Similarity, Warp};
use crate::scan_matching::icp::{Icp, IcpConfig};
use crate::sketch::SketchLine;
use nalgebra::{DMatrix, DVector};
use sketchslam_types::Point2;
use std::f64::consts::FRAC_PI_2;

/// Settings of [`fit_warp`]; lengths in meters at the drawing's scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitConfig {
    /// Control nodes this far apart, meters.
    pub spacing_m: f64,
    /// A drawn wall's error after the warp (σ_l), meters.
    pub line_sigma_m: f64,
    /// A person's error of proportion (a room drawn this share too long or short), 0..1:
    /// what the coarse levels' gates allow, how far an offset may go (σ_o), how far the
    /// global start searches the axes' stretch.
    pub proportion_error: f64,
    /// Uncertainty of the prior's scale, as a share of it (the user's scale guess).
    pub scale_error: f64,
    /// Uncertainty of the prior's rotation, radians (the marked start heading).
    pub rotation_error_rad: f64,
    /// Uncertainty of the prior's translation, meters (the marked start).
    pub translation_error_m: f64,
    /// First association gate, meters.
    pub start_gate_m: f64,
    /// Last association gate, meters.
    pub gate_m: f64,
    /// A wall point pairs only with drawn lines within this angle of its own wall's
    /// direction (carried through W), radians: a drawing's wall directions are right
    /// within a few degrees, so a wall is never laid on a drawn wall across it.
    pub direction_tolerance_rad: f64,
    /// Iterations fitting the similarity alone.
    pub similarity_iterations: usize,
    /// Iterations fitting everything, per level of the control grid.
    pub warp_iterations: usize,
    /// Levels of the control grid, coarse to fine: spacings `2^(levels−1) · spacing_m` down
    /// to `spacing_m`, so a floor's large proportions settle before a room's (1: the fine
    /// grid alone).
    pub levels: usize,
    /// The global start (`search`) searches this many standard deviations of the
    /// prior's scale, rotation and translation each way (0: start from the prior).
    pub search_sigmas: f64,
    /// The fit's first stages (the similarity, the coarsest grid) run from the prior and
    /// from this many of the search's starts, best first (0: the prior alone).
    pub search_starts: usize,
    /// The fits of least `E` after the first stages that go on to the finer grids; the one
    /// of least `E` at the end is kept. (The search's score ranks starts by the share of
    /// walls near a drawn line only; a stage of the fit ranks them by `E`.)
    pub finished_starts: usize,
    /// Change of the drawing's proportions from one cell to the next (σ_b / spacing): how
    /// far a person's drawing departs from a single affine map of the floor, per cell.
    pub proportion_change: f64,
    /// The map's wall points lie this far apart along a wall, meters (the mapper thins
    /// them to it): how many wall points a stretch of wall gives, so that a step of the
    /// robot's route through a drawn wall counts as the points that wall would have given.
    pub wall_spacing_m: f64,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            spacing_m: 4.0,
            line_sigma_m: 0.1,
            proportion_error: 0.25,
            scale_error: 0.3,
            rotation_error_rad: 10f64.to_radians(),
            translation_error_m: 2.0,
            start_gate_m: 3.0,
            gate_m: 1.0,
            direction_tolerance_rad: 20f64.to_radians(),
            similarity_iterations: 10,
            warp_iterations: 15,
            levels: 3,
            search_sigmas: 2.0,
            search_starts: 6,
            finished_starts: 2,
            proportion_change: 0.01,
            wall_spacing_m: 0.1,
        }
    }
}

/// What [`fit_warp`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct WarpFit {
    /// The warp.
    pub warp: Warp,
    /// Points within the last gate of a drawn line.
    pub inliers: usize,
    /// RMS of their residuals, pixels.
    pub rms_px: f64,
    /// Per control node, the inliers' bilinear weight on it: how many wall points hold it
    /// (0: nothing seen there, the node follows its neighbours).
    pub support: Vec<f64>,
    /// Steps of the robot's route the warp carries through a drawn wall (`route`).
    pub walls_crossed: usize,
}

/// A drawn line as a segment in the drawing frame `(u, −v)`, with its unit normal.
pub(super) struct Segment {
    pub(super) a: Point2,
    pub(super) b: Point2,
    pub(super) normal: Point2,
}

/// A map wall point and its wall's unit normal (map frame).
#[derive(Debug, Clone, Copy)]
pub(super) struct WallPoint {
    pub(super) p: Point2,
    pub(super) normal: Point2,
}

impl Segment {
    /// The segment from `a` to `b` with its unit normal (`a → b` turned a quarter to the
    /// left); `None` when they coincide.
    pub(super) fn between(a: Point2, b: Point2) -> Option<Self> {
        let len = a.distance(&b);
        (len > 0.0).then(|| Segment {
            a,
            b,
            normal: Point2::new(-(b.y - a.y) / len, (b.x - a.x) / len),
        })
    }

    /// The nearest point of the segment to `p`.
    pub(super) fn foot(&self, p: Point2) -> Point2 {
        p.nearest_on_segment(self.a, self.b)
    }
}

/// The corners of the box holding `points` (inverted, MAX and MIN, when there are none).
pub(super) fn bounds(points: impl IntoIterator<Item = Point2>) -> (Point2, Point2) {
    points.into_iter().fold(
        (
            Point2::new(f64::MAX, f64::MAX),
            Point2::new(f64::MIN, f64::MIN),
        ),
        |(lo, hi), p| {
            (
                Point2::new(lo.x.min(p.x), lo.y.min(p.y)),
                Point2::new(hi.x.max(p.x), hi.y.max(p.y)),
            )
        },
    )
}

/// The control grid's spacing at `level` of the fit's coarse-to-fine levels, meters
/// (0 the coarsest): `2^(levels − 1 − level) · spacing_m`.
fn level_spacing_m(config: &FitConfig, level: usize) -> f64 {
    let levels = config.levels.max(1);
    config.spacing_m * f64::from(1u32 << (levels - 1 - level.min(levels - 1)).min(8))
}

/// The module doc's fit of W to `points` (map meters, non-finite ones ignored) against
/// `lines` (drawing pixels), from `prior`. `None` without points or lines, or when the
/// prior's scale is not a positive number.
pub fn fit_warp(
    points: &[Point2],
    route: &[Point2],
    lines: &[SketchLine],
    prior: Similarity,
    config: &FitConfig,
) -> Option<WarpFit> {
    let problem = Prepared::new(points, route, lines, &prior, config)?;
    // The prior itself, then the search's best starts; each on a grid of one cell over the
    // map, whose four corners hold a start whose axes scale apart exactly.
    let extent_m = (problem.hi.x - problem.lo.x)
        .max(problem.hi.y - problem.lo.y)
        .max(config.spacing_m);
    let corners = ControlGrid::covering(problem.lo, problem.hi, extent_m);
    let mut starts = vec![Warp::rigid(prior, corners)];
    // The drawn lines' distance field, read by the search and by the region search.
    let s0 = prior.scale_px_per_m();
    let field = DirectionField::for_fit(&problem.segments, config, s0);
    if let Some(field) = &field {
        starts.extend(
            search_starts(&problem.points, &problem.segments, field, &prior, config)
                .iter()
                .take(config.search_starts)
                .map(|c| c.warp(&prior, corners)),
        );
    }
    // The most probable fit: the least `E` (the module doc's, each point beyond the gate
    // counted at the gate), after the first stages from every start, then at the end from
    // the best few of those.
    let levels = config.levels.max(1);
    let mut firsts: Vec<(WarpFit, f64)> = starts
        .into_iter()
        .map(|start| problem.fit_from(start, Stages::first()))
        .collect();
    firsts.sort_by(|a, b| a.1.total_cmp(&b.1));
    firsts.truncate(config.finished_starts.max(1));
    // A fit after the first stages, on through the finer grids.
    let finish = |(fit, energy): (WarpFit, f64)| {
        if levels > 1 {
            problem.fit_from(fit.warp, Stages::rest(levels))
        } else {
            (fit, energy)
        }
    };
    let best = firsts
        .into_iter()
        .map(finish)
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    // Regions laid a room over: moved beyond the gate and fitted again (`region_search`).
    let Some(field) = field else {
        return Some(best.0);
    };
    let grid = ControlGrid::covering(problem.lo, problem.hi, level_spacing_m(config, 0));
    // Round after round while a move ends more probable: a wing drawn far out of proportion
    // is reached a region's search at a time.
    let mut best = best;
    for _ in 0..REGION_ROUNDS {
        // Told apart on the coarsest grid, as the starts are: the best fit's own refit there,
        // against each move's; the best move that beats it goes on to the finer grids.
        let coarse = Stages {
            similarity: false,
            levels: 0..1,
        };
        let here = problem
            .fit_from(best.0.warp.resampled(grid), coarse.clone())
            .1;
        let Some(moved) = region_starts(&problem.points, &field, &best.0.warp, grid, config, s0)
            .into_iter()
            .map(|start| problem.fit_from(start, coarse.clone()))
            .filter(|f| f.1 < here)
            .min_by(|a, b| a.1.total_cmp(&b.1))
        else {
            break;
        };
        let better = finish(moved);
        if better.1 >= best.1 {
            break;
        }
        best = better;
    }
    Some(best.0)
}

/// Rounds of the region search (`region_search`) at most, each from the best fit of the
/// last.
const REGION_ROUNDS: usize = 3;

/// [`fit_warp`]'s stages from `start` instead of its starts, and the fit's `E` (each point
/// beyond the last gate counted at the gate): how a benchmark asks whether a known answer is
/// more probable than the one the search found. `None` as [`fit_warp`].
pub fn fit_warp_from(
    points: &[Point2],
    route: &[Point2],
    lines: &[SketchLine],
    prior: Similarity,
    config: &FitConfig,
    start: Warp,
) -> Option<(WarpFit, f64)> {
    let problem = Prepared::new(points, route, lines, &prior, config)?;
    Some(problem.fit_from(
        start,
        Stages {
            similarity: true,
            levels: 0..config.levels.max(1),
        },
    ))
}

/// The wall points with their normals, the drawn segments (bucketed for the widest gate the
/// fit uses), the walls' extent, and the prior and settings every stage fits with.
struct Prepared {
    prior: Similarity,
    config: FitConfig,
    points: Vec<WallPoint>,
    /// The keyframes' positions in order, map meters (non-finite ones left out).
    route: Vec<Point2>,
    segments: Vec<Segment>,
    index: SegmentGrid,
    lo: Point2,
    hi: Point2,
}

impl Prepared {
    fn new(
        points: &[Point2],
        route: &[Point2],
        lines: &[SketchLine],
        prior: &Similarity,
        config: &FitConfig,
    ) -> Option<Self> {
        // The wall through each point (PCA over its neighbours, as ICP's reference normals,
        // which also drops the non-finite points); points on no line (clutter, corners) take
        // no part.
        let icp = Icp::new(points, IcpConfig::default());
        let points: Vec<WallPoint> = icp
            .points()
            .iter()
            .zip(icp.normals())
            .filter_map(|(p, n)| n.map(|normal| WallPoint { p: *p, normal }))
            .collect();
        let s0 = prior.scale_px_per_m();
        if points.is_empty() || lines.is_empty() || !(s0 > 0.0 && s0.is_finite()) {
            return None;
        }
        let segments: Vec<Segment> = lines
            .iter()
            .filter_map(|l| {
                Segment::between(Point2::new(l.a.x, -l.a.y), Point2::new(l.b.x, -l.b.y))
            })
            .collect();
        if segments.is_empty() {
            return None;
        }
        let (lo, hi) = bounds(points.iter().map(|w| w.p));
        let index = SegmentGrid::new(&segments, widest_gate_m(config) * s0)?;
        Some(Self {
            prior: *prior,
            config: *config,
            points,
            route: route
                .iter()
                .copied()
                .filter(|r| r.x.is_finite() && r.y.is_finite())
                .collect(),
            segments,
            index,
            lo,
            hi,
        })
    }

    /// Steps of the route `warp` carries through a drawn wall ([`RouteCheck`]).
    fn walls_crossed(&self, warp: &Warp) -> usize {
        let s0 = self.prior.scale_px_per_m();
        RouteCheck {
            segments: &self.segments,
            index: &self.index,
            reach_px: widest_gate_m(&self.config) * s0,
            margin_px: self.config.gate_m * s0,
            cos_tol: direction_cos(&self.config),
        }
        .walls_crossed(warp, &self.route)
    }

    /// The fit's `stages` (similarity, then the control grids coarse to fine) from
    /// `start`; a run that starts past the similarity starts at its first level's gate (a
    /// gate never widens again).
    fn fit_from(&self, start: Warp, stages: Stages) -> (WarpFit, f64) {
        let (points, segments, index, lo, hi) = (
            self.points.as_slice(),
            self.segments.as_slice(),
            &self.index,
            self.lo,
            self.hi,
        );
        let (prior, config) = (self.prior, &self.config);
        let s0 = prior.scale_px_per_m();
        let px = |m: f64| m * s0;
        let cos_tol = direction_cos(config);
        // Coarse to fine: spacings 2^(L−1)·s … s. A level's gate is what its cells cannot bend:
        // a person's proportion error over half a cell, and at least `gate_m`.
        let levels = config.levels.max(1);
        let spacing_at = |level: usize| level_spacing_m(config, level);
        let level_gate_px =
            |spacing_m: f64| px((0.5 * config.proportion_error * spacing_m).max(config.gate_m));
        let mut warp = start;
        // The similarity first, its gate shrinking from the start gate to the first level's.
        let first_level = stages.levels.start.min(levels - 1);
        let mut gate_px = if stages.similarity {
            px(config.start_gate_m.max(config.gate_m))
        } else {
            level_gate_px(spacing_at(first_level))
        };
        let similarity_iterations = if stages.similarity {
            config.similarity_iterations
        } else {
            0
        };
        for _ in 0..similarity_iterations {
            let pairs = associate(&warp, points, segments, index, gate_px, cos_tol);
            let Some(step) = solve_step(&warp, &pairs, &prior, config, false) else {
                break;
            };
            apply_step(&mut warp, &step, false);
            let shrunk = (gate_px * 0.8).max(level_gate_px(spacing_at(0)));
            if converged(&step, lo, hi, s0) && shrunk == gate_px {
                break;
            }
            gate_px = shrunk;
        }
        for level in stages.levels.start..stages.levels.end.min(levels) {
            let spacing_m = spacing_at(level);
            warp = warp.resampled(ControlGrid::covering(lo, hi, spacing_m));
            gate_px = gate_px.min(level_gate_px(spacing_m));
            for _ in 0..config.warp_iterations {
                let pairs = associate(&warp, points, segments, index, gate_px, cos_tol);
                let Some(step) = solve_step(&warp, &pairs, &prior, config, true) else {
                    break;
                };
                apply_step(&mut warp, &step, true);
                if converged(&step, lo, hi, s0) {
                    break;
                }
            }
        }
        let grid = warp.grid;
        let pairs = associate(&warp, points, segments, index, gate_px, cos_tol);
        let mut support = vec![0.0; grid.len()];
        let mut sum_sq = 0.0;
        for pair in &pairs {
            sum_sq += pair.distance_px * pair.distance_px;
            for (k, w) in grid.weights(pair.p) {
                support[k] += w;
            }
        }
        // E at the fit: the inliers' residuals, every other point at the gate, the priors.
        let sigma_l_px = (config.line_sigma_m * s0).max(1e-6);
        let outliers = points.len().saturating_sub(pairs.len()) as f64;
        // And each step of the route through a drawn wall (`route`) at the wall points that
        // wall would have given where the robot passed, the margin each way, each at the gate.
        let walls_crossed = self.walls_crossed(&warp);
        let points_per_crossing = 2.0 * config.gate_m / config.wall_spacing_m.max(1e-3);
        let cost = (sum_sq
            + (outliers + points_per_crossing * walls_crossed as f64) * gate_px * gate_px)
            / (sigma_l_px * sigma_l_px)
            + normal_equations(&warp, &[], &prior, config, true).2;
        let fit = WarpFit {
            warp,
            inliers: pairs.len(),
            rms_px: (sum_sq / pairs.len().max(1) as f64).sqrt(),
            support,
            walls_crossed,
        };
        (fit, cost)
    }
}

/// Which of the fit's stages run: the similarity alone, and the control grids' levels
/// (0 the coarsest).
#[derive(Debug, Clone)]
struct Stages {
    similarity: bool,
    levels: std::ops::Range<usize>,
}

impl Stages {
    /// The similarity and the coarsest grid: where starts are told apart.
    fn first() -> Self {
        Self {
            similarity: true,
            levels: 0..1,
        }
    }

    /// The finer grids after [`Stages::first`].
    fn rest(levels: usize) -> Self {
        Self {
            similarity: false,
            levels: 1..levels,
        }
    }
}

/// Whether a Gauss–Newton step moved no point of the map's extent (corners `lo`, `hi`) by
/// more than [`CONVERGED_M`] (at the prior's scale `s0` px/m): the next association would be
/// the same, and so the next step nothing.
fn converged(step: &DVector<f64>, lo: Point2, hi: Point2, s0: f64) -> bool {
    let reach_m = lo.x.abs().max(hi.x.abs()).hypot(lo.y.abs().max(hi.y.abs()));
    // (a, b) move a point at distance r by r·|(δa, δb)|, t and the offsets by themselves.
    let linear = step[0].hypot(step[1]) * reach_m;
    let rest = step.iter().skip(2).fold(0.0f64, |m, v| m.max(v.abs()));
    linear.max(rest) < CONVERGED_M * s0
}

/// The cosine of the direction tolerance: a wall point and a drawn line (or two drawn
/// lines) are of one direction when their normals' dot product is at least this.
fn direction_cos(config: &FitConfig) -> f64 {
    config.direction_tolerance_rad.clamp(0.0, FRAC_PI_2).cos()
}

/// A Gauss–Newton step below this (meters at the drawing's scale) ends a stage: a tenth of
/// a centimetre, far below a pen's width.
const CONVERGED_M: f64 = 1e-3;

/// The widest gate [`fit_from`] uses, meters: the start gate, or the coarsest level's.
fn widest_gate_m(config: &FitConfig) -> f64 {
    config
        .start_gate_m
        .max(config.gate_m)
        .max(0.5 * config.proportion_error * level_spacing_m(config, 0))
}

/// A wall point paired with the nearest drawn line of its direction.
struct Pair {
    /// The map point.
    p: Point2,
    /// Its distance from the line after the warp, pixels.
    distance_px: f64,
    /// The unit direction from the line's nearest point to the warped point.
    n: Point2,
}

/// Each wall point whose warped position lies within `gate_px` of a drawn line of its own
/// direction (the map normal turned by W's rotation against the line's normal, within
/// `acos(cos_tol)`), paired with the nearest such line (`gate_px` at most `index`'s reach).
/// O(n · the lines listed near a point).
fn associate(
    warp: &Warp,
    points: &[WallPoint],
    segments: &[Segment],
    index: &SegmentGrid,
    gate_px: f64,
    cos_tol: f64,
) -> Vec<Pair> {
    let (sin, cos) = warp.similarity.rotation_rad().sin_cos();
    points
        .iter()
        .filter_map(|wp| {
            let w = warp.apply(wp.p);
            let nm = Point2::new(
                cos * wp.normal.x - sin * wp.normal.y,
                sin * wp.normal.x + cos * wp.normal.y,
            );
            let (d, f) = index
                .near(w)
                .iter()
                .map(|&k| &segments[k as usize])
                .filter(|s| (s.normal.x * nm.x + s.normal.y * nm.y).abs() >= cos_tol)
                .map(|s| {
                    let f = s.foot(w);
                    (w.distance(&f), f)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))?;
            (d <= gate_px && d > 1e-12).then(|| Pair {
                p: wp.p,
                distance_px: d,
                n: Point2::new((w.x - f.x) / d, (w.y - f.y) / d),
            })
        })
        .collect()
}

/// One Gauss–Newton step of the module doc's `E` at `warp`: `δθ` for `(a, b, tx, ty)` and,
/// when `full`, every offset. `None` when the system cannot be solved.
fn solve_step(
    warp: &Warp,
    pairs: &[Pair],
    prior: &Similarity,
    config: &FitConfig,
    full: bool,
) -> Option<DVector<f64>> {
    let (h, g, _) = normal_equations(warp, pairs, prior, config, full);
    let step = h.cholesky()?.solve(&(-g));
    step.iter().all(|v| v.is_finite()).then_some(step)
}

/// The Gauss–Newton system `(H, g)` of `E` at `warp` (the parameters of [`solve_step`]), and
/// the priors' part of `E` there.
fn normal_equations(
    warp: &Warp,
    pairs: &[Pair],
    prior: &Similarity,
    config: &FitConfig,
    full: bool,
) -> (DMatrix<f64>, DVector<f64>, f64) {
    let mut energy = 0.0;
    let s0 = prior.scale_px_per_m();
    let grid = &warp.grid;
    let m = if full { 4 + 2 * grid.len() } else { 4 };
    let mut h = DMatrix::<f64>::zeros(m, m);
    let mut g = DVector::<f64>::zeros(m);
    let info_l = 1.0 / (config.line_sigma_m * s0).max(1e-6).powi(2);
    let mut jac: Vec<(usize, f64)> = Vec::with_capacity(12);
    for pair in pairs {
        let (p, n, r) = (&pair.p, pair.n, pair.distance_px);
        jac.clear();
        jac.push((0, n.x * p.x + n.y * p.y));
        jac.push((1, -n.x * p.y + n.y * p.x));
        jac.push((2, n.x));
        jac.push((3, n.y));
        if full {
            for (k, b) in grid.weights(*p) {
                jac.push((4 + 2 * k, b * n.x));
                jac.push((5 + 2 * k, b * n.y));
            }
        }
        for &(i, ji) in &jac {
            g[i] += info_l * r * ji;
            for &(j, jj) in &jac {
                h[(i, j)] += info_l * ji * jj;
            }
        }
    }
    // The prior similarity: (a, b) within σ_ab, t within σ_t.
    let sigma_ab = s0 * config.scale_error.max(config.rotation_error_rad).max(1e-6);
    let sigma_t = (config.translation_error_m * s0).max(1e-6);
    let s = &warp.similarity;
    let residual_prior = [
        (0, s.a - prior.a, sigma_ab),
        (1, s.b - prior.b, sigma_ab),
        (2, s.t.x - prior.t.x, sigma_t),
        (3, s.t.y - prior.t.y, sigma_t),
    ];
    for (i, r, sigma) in residual_prior {
        h[(i, i)] += 1.0 / (sigma * sigma);
        g[i] += r / (sigma * sigma);
        energy += r * r / (sigma * sigma);
    }
    if full {
        // σ_o: the proportion error over half the floor.
        let half_extent_m =
            0.5 * grid.spacing_m * ((grid.columns - 1) as f64).hypot((grid.rows - 1) as f64);
        let sigma_o = (config.proportion_error * half_extent_m.max(grid.spacing_m) * s0).max(1e-6);
        let info_o = 1.0 / (sigma_o * sigma_o);
        for (k, o) in warp.offsets.iter().enumerate() {
            for (c, v) in [(0, o.x), (1, o.y)] {
                h[(4 + 2 * k + c, 4 + 2 * k + c)] += info_o;
                g[4 + 2 * k + c] += info_o * v;
                energy += info_o * v * v;
            }
        }
        energy += add_bending(&mut h, &mut g, warp, config, s0);
    }
    (h, g, energy)
}

/// A difference of offsets: `(node, coefficient)` (unused places at coefficient 0) and its
/// weight in the energy.
type Stencil = ([(usize, f64); 4], f64);

/// The bending term of the module doc: `Σ |Σ_j c_j o_j|² / σ_b²` over the grid's second
/// differences along rows and columns (`c = (1, −2, 1)`) and its mixed ones
/// (`(1, −1, −1, 1)`, weighted 2 as in the thin plate's energy, Bookstein 1989),
/// `σ_b = proportion_change · spacing`. Adds its Gauss–Newton terms to `h` and `g` and
/// returns its energy at `warp`. O(nodes).
fn add_bending(
    h: &mut DMatrix<f64>,
    g: &mut DVector<f64>,
    warp: &Warp,
    config: &FitConfig,
    s0: f64,
) -> f64 {
    let mut energy = 0.0;
    let grid = &warp.grid;
    let sigma_b = (config.proportion_change * grid.spacing_m * s0).max(1e-6);
    let info_b = 1.0 / (sigma_b * sigma_b);
    let (cols, rows) = (grid.columns, grid.rows);
    let at = |i: usize, j: usize| j * cols + i;
    let mut stencils: Vec<Stencil> = Vec::new();
    for j in 0..rows {
        for i in 0..cols {
            if i + 2 < cols {
                stencils.push((
                    [
                        (at(i, j), 1.0),
                        (at(i + 1, j), -2.0),
                        (at(i + 2, j), 1.0),
                        (0, 0.0),
                    ],
                    1.0,
                ));
            }
            if j + 2 < rows {
                stencils.push((
                    [
                        (at(i, j), 1.0),
                        (at(i, j + 1), -2.0),
                        (at(i, j + 2), 1.0),
                        (0, 0.0),
                    ],
                    1.0,
                ));
            }
            if i + 1 < cols && j + 1 < rows {
                stencils.push((
                    [
                        (at(i, j), 1.0),
                        (at(i + 1, j), -1.0),
                        (at(i, j + 1), -1.0),
                        (at(i + 1, j + 1), 1.0),
                    ],
                    2.0,
                ));
            }
        }
    }
    for (stencil, weight) in stencils {
        let info = weight * info_b;
        for c in 0..2 {
            let r: f64 = stencil
                .iter()
                .map(|&(k, w)| {
                    let o = warp.offsets[k];
                    w * if c == 0 { o.x } else { o.y }
                })
                .sum();
            energy += info * r * r;
            for &(k, wk) in &stencil {
                let a = 4 + 2 * k + c;
                g[a] += info * r * wk;
                for &(l, wl) in &stencil {
                    h[(a, 4 + 2 * l + c)] += info * wk * wl;
                }
            }
        }
    }
    energy
}

/// Adds `step` (from [`solve_step`]) to `warp`'s parameters.
fn apply_step(warp: &mut Warp, step: &DVector<f64>, full: bool) {
    let s = &mut warp.similarity;
    s.a += step[0];
    s.b += step[1];
    s.t = Point2::new(s.t.x + step[2], s.t.y + step[3]);
    if full {
        for (k, o) in warp.offsets.iter_mut().enumerate() {
            *o = Point2::new(o.x + step[4 + 2 * k], o.y + step[5 + 2 * k]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 × 3 grid of 2 m cells with the given offsets (pixels) at each node `(x, y)`
    /// meters.
    fn warp_with(offset: impl Fn(f64, f64) -> Point2) -> Warp {
        let grid = ControlGrid::covering(Point2::new(0.0, 0.0), Point2::new(6.0, 4.0), 2.0);
        let mut warp = Warp::rigid(Similarity::new(10.0, 0.0, Point2::new(0.0, 0.0)), grid);
        for (k, o) in warp.offsets.iter_mut().enumerate() {
            let (i, j) = (k % grid.columns, k / grid.columns);
            *o = offset(2.0 * i as f64, 2.0 * j as f64);
        }
        warp
    }

    fn bending_gradient(warp: &Warp, config: &FitConfig) -> DVector<f64> {
        let m = 4 + 2 * warp.grid.len();
        let (mut h, mut g) = (DMatrix::zeros(m, m), DVector::zeros(m));
        add_bending(&mut h, &mut g, warp, config, 10.0);
        g
    }

    #[test]
    fn a_stretch_or_a_shear_bends_nothing() {
        let warp = warp_with(|x, y| Point2::new(3.0 * x + 2.0 * y + 1.0, -x + 0.5 * y));
        let g = bending_gradient(&warp, &FitConfig::default());
        assert!(g.iter().all(|v| v.abs() < 1e-9), "{g}");
    }

    #[test]
    fn a_kink_in_the_proportions_pulls_on_its_three_nodes() {
        // x offsets 0, 0, c, 2c along each row: the stretch changes once, at node 1.
        let c = 4.0;
        let warp = warp_with(|x, _| Point2::new(c * (x / 2.0 - 1.0).max(0.0), 0.0));
        let config = FitConfig::default();
        // σ_b = proportion_change · 2 m · 10 px/m.
        let sigma_b = config.proportion_change * 2.0 * 10.0;
        let info = 1.0 / (sigma_b * sigma_b);
        let g = bending_gradient(&warp, &config);
        for j in 0..3 {
            let x = |i: usize| g[4 + 2 * (4 * j + i)];
            assert!((x(0) - info * c).abs() < 1e-9, "{g}");
            assert!((x(1) + 2.0 * info * c).abs() < 1e-9, "{g}");
            assert!((x(2) - info * c).abs() < 1e-9, "{g}");
            assert!(x(3).abs() < 1e-9, "{g}");
        }
        // Nothing pulls the y offsets.
        assert!((0..12).all(|k| g[5 + 2 * k].abs() < 1e-9));
    }
}
