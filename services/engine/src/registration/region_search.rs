//! A second look for regions the fit laid a room over: for each node of the coarsest
//! control grid, the displacement of its region that lays the most of its wall points on
//! drawn lines, searched beyond the fit's gate; each such move is a new start for the fit,
//! kept only where it ends more probable (a lower `E`, [`super::fit`]).
//!
//! Sits inside [`super::fit::fit_warp`], after the fits from the global starts. Why: a
//! person draws some parts of a floor out of proportion with the rest (one wing 1.3× too
//! wide, the other 0.8×). The global search (`search`) finds the affine map that fits the
//! floor best as a whole, which lays one wing right and the other a room over; the fit's
//! gates (what a control cell may bend, `proportion_error` over half a cell) are too narrow
//! to pull that wing across a room, and wider gates fold walls onto the nearest lines. A
//! region's own search over displacements, scored like the global one, does not need the
//! gate: it finds where the wing's walls lie on drawn walls, and the fit from there decides.
//!
//! For node `k` of the grid of spacing `S` (the coarsest level) and the fitted warp `W`, the
//! points `p_i` with bilinear weight `w_ik > 0` on it are scored at each displacement `δ`
//! (meters at the prior's scale) as the node's offset moved by `δ` moves them:
//!
//! `G_k(δ) = Σ_i w_ik · max(0, 1 − (D_b(i)(W(p_i) + w_ik s₀ δ) / τ)²)`
//!
//! (`D_b` the distance field of the drawn lines of the point's direction, `τ` the last gate,
//! as the global search's `J`), over `|δ_x|, |δ_y| ≤ proportion_error · extent / 2` (how far
//! a person's proportion error carries a point from where the whole-floor fit puts it) at
//! steps of the gate, then about the best at steps of half the gate. A node whose best `G_k` exceeds `G_k(0)` by more than
//! [`MIN_GAIN_POINTS`] proposes that move; the best few, and all of them at once, are the
//! new starts.
//!
//! Cost: O(n · 4 · (extent · proportion_error / 2 gate)²) lookups (every point is in four
//! nodes' regions): 10⁴ points on a 60 m floor, 10⁷ lookups; then a coarsest-grid fit per
//! move.
//!
//! Pure: values in, values out.

use super::fit::{FitConfig, WallPoint};
use super::search::DirectionField;
use super::warp::{ControlGrid, Warp};
use sketchslam_types::Point2;
use std::f64::consts::PI;

/// A node proposes a move when it lays this many more of its wall points (weighted) on
/// drawn lines: a meter of wall at the fit's 0.1 m thinning.
const MIN_GAIN_POINTS: f64 = 10.0;
/// The best moves tried one by one (besides all of them at once).
const MOVES: usize = 3;

/// New starts for the fit: `warp` resampled onto `grid` with one node's (or every
/// proposing node's) offset moved, best move first; empty when no region gains.
pub(super) fn region_starts(
    points: &[WallPoint],
    field: &DirectionField,
    warp: &Warp,
    grid: ControlGrid,
    config: &FitConfig,
    s0: f64,
) -> Vec<Warp> {
    let base = warp.resampled(grid);
    let theta = base.similarity.rotation_rad();
    let tau_px = (config.gate_m * s0).max(1e-6);
    let inv_tau2 = 1.0 / (tau_px * tau_px);
    let extent_m = grid.spacing_m * ((grid.columns - 1).max(grid.rows - 1)) as f64;
    let reach_m = 0.5 * config.proportion_error * extent_m;
    let gate_m = config.gate_m.max(1e-3);
    // The reach in gates; nothing to search where it is short of half a gate (the finer step).
    let reach_gates = reach_m / gate_m;
    if reach_gates < 0.5 {
        return Vec::new();
    }
    // Per node, its points: warped position, direction (turned by W), weight.
    let mut members: Vec<Vec<(Point2, f64, f64)>> = vec![Vec::new(); grid.len()];
    for wp in points {
        let w = base.apply(wp.p);
        let normal = (wp.normal.y.atan2(wp.normal.x) + theta).rem_euclid(PI);
        for (k, weight) in grid.weights(wp.p) {
            if weight > 0.0 {
                members[k].push((w, normal, weight));
            }
        }
    }
    let gain_at = |m: &[(Point2, f64, f64)], dx_px: f64, dy_px: f64| -> f64 {
        m.iter()
            .map(|&(w, n, weight)| {
                let q = Point2::new(w.x + weight * dx_px, w.y + weight * dy_px);
                let d = field.distance_px(q, n);
                weight * (1.0 - d * d * inv_tau2).max(0.0)
            })
            .sum()
    };
    let mut moves: Vec<(f64, usize, Point2)> = Vec::new();
    for (k, m) in members.iter().enumerate() {
        let held: f64 = m.iter().map(|x| x.2).sum();
        if held < MIN_GAIN_POINTS {
            continue;
        }
        let here = gain_at(m, 0.0, 0.0);
        // The best of `best` and the displacements `centre + (i, j) · step` for |i|, |j| ≤ n.
        let scan = |best: (f64, Point2), centre: Point2, step_px: f64, n: i64| {
            let mut best = best;
            for iy in -n..=n {
                for ix in -n..=n {
                    let d = Point2::new(
                        centre.x + ix as f64 * step_px,
                        centre.y + iy as f64 * step_px,
                    );
                    let g = gain_at(m, d.x, d.y);
                    if g > best.0 {
                        best = (g, d);
                    }
                }
            }
            best
        };
        // A grid at the gate's step (the kernel is a gate wide each way, so a peak lies
        // within half a step of a grid point and scores three quarters of its height
        // there), then its best point's neighbours at half the step.
        let step_px = gate_m * s0;
        let origin = Point2::new(0.0, 0.0);
        let coarse = scan((here, origin), origin, step_px, reach_gates.floor() as i64);
        let best = scan(coarse, coarse.1, 0.5 * step_px, 1);
        if best.0 - here > MIN_GAIN_POINTS {
            moves.push((best.0 - here, k, best.1));
        }
    }
    moves.sort_by(|a, b| b.0.total_cmp(&a.0));
    let moved = |which: &[(f64, usize, Point2)]| {
        let mut w = base.clone();
        for &(_, k, d) in which {
            w.offsets[k] = Point2::new(w.offsets[k].x + d.x, w.offsets[k].y + d.y);
        }
        w
    };
    let mut starts: Vec<Warp> = moves
        .iter()
        .take(MOVES)
        .map(|m| moved(std::slice::from_ref(m)))
        .collect();
    if moves.len() > 1 {
        starts.push(moved(&moves));
    }
    starts
}
