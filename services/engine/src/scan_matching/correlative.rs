//! Correlative scan matching: the exhaustive search that finds a scan's pose against a
//! reference when the guess is too far off for ICP's local descent — a loop closure after
//! metres of drift, or scans seconds apart.
//!
//! Sits before ICP in the loop-closure step ([`crate::back_end::loop_closure`]): this search finds
//! the basin, ICP then refines inside it.
//!
//! Method (Olson, "Real-time correlative scan matching", ICRA 2009): the reference points
//! become a likelihood field on a grid of resolution r,
//!
//! ```text
//! L(c) = exp(−d(c)² / 2σ²),   d(c) = distance from cell c to the nearest reference point,
//! ```
//!
//! and a pose x = (t, θ) scores the mean of L over the scan points moved by it,
//! `S(x) = 1/n Σ L(R(θ)pᵢ + t)`, in 0..1. The search covers a window of angles (step chosen
//! so the farthest point moves about one cell, the formula of Hess et al., "Real-time loop
//! closure in 2D LIDAR SLAM", ICRA 2016, eq. 7) and of translations in whole cells. It is
//! exact branch and bound with one coarse level: a coarse table holds, at each cell, the
//! maximum of L over the f×f cells from it, so the sum of coarse values at a block's corner
//! bounds every fine shift in the block from above; blocks are visited best bound first and
//! the search stops when no bound beats the best fine score found.
//!
//! Cost: building the field is O(m·(3σ/r)²) for m reference points; a search is
//! O(a·(w/f)²·n) for a angles, w² shifts and n points, plus the refined blocks.

use sketchslam_types::{Point2, Pose2};

/// Settings of the likelihood field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrelativeConfig {
    /// Cell size of the field and the translation step of the search, meters.
    pub resolution_m: f64,
    /// Standard deviation of the likelihood kernel, meters.
    pub sigma_m: f64,
    /// Fine cells per coarse cell along each axis.
    pub coarse_factor: usize,
}

impl Default for CorrelativeConfig {
    fn default() -> Self {
        Self {
            resolution_m: 0.05,
            sigma_m: 0.1,
            coarse_factor: 4,
        }
    }
}

/// The poses a search covers around its guess.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchWindow {
    /// Translations within ± this along each axis, meters.
    pub linear_m: f64,
    /// Headings within ± this, radians.
    pub angular_rad: f64,
}

/// The best pose a search found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrelativeMatch {
    /// Pose of the scan in the reference frame.
    pub pose: Pose2,
    /// Its score, the mean likelihood of the scan points, 0..1.
    pub score: f64,
}

/// The reference as a likelihood field, with its coarse upper-bound table.
#[derive(Debug, Clone)]
pub struct LikelihoodField {
    config: CorrelativeConfig,
    /// World position of cell (0, 0)'s lower-left corner.
    origin: Point2,
    width: usize,
    height: usize,
    fine: Vec<f32>,
    coarse: Vec<f32>,
}

impl LikelihoodField {
    /// The field of `reference` (points in the reference frame). Non-finite points are
    /// skipped; an empty reference gives a field that scores every pose 0.
    pub fn new(reference: &[Point2], config: CorrelativeConfig) -> Self {
        let config = CorrelativeConfig {
            resolution_m: if config.resolution_m > 1e-3 {
                config.resolution_m
            } else {
                0.05
            },
            sigma_m: config.sigma_m.max(1e-3),
            coarse_factor: config.coarse_factor.clamp(1, 16),
        };
        let finite: Vec<Point2> = reference
            .iter()
            .copied()
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .collect();
        let res = config.resolution_m;
        let kernel_cells = (3.0 * config.sigma_m / res).ceil() as i64;
        let margin = (kernel_cells + 1) as f64 * res;
        let (lo, hi) = bounding_box(finite.iter().copied())
            .unwrap_or((Point2::new(0.0, 0.0), Point2::new(0.0, 0.0)));
        let origin = Point2::new(lo.x - margin, lo.y - margin);
        let width = (((hi.x - lo.x + 2.0 * margin) / res).ceil() as usize).max(1);
        let height = (((hi.y - lo.y + 2.0 * margin) / res).ceil() as usize).max(1);
        let mut fine = vec![0f32; width * height];
        let two_sigma_sq = 2.0 * config.sigma_m * config.sigma_m;
        for p in &finite {
            let cx = ((p.x - origin.x) / res).floor() as i64;
            let cy = ((p.y - origin.y) / res).floor() as i64;
            for dy in -kernel_cells..=kernel_cells {
                let y = cy + dy;
                if y < 0 || y >= height as i64 {
                    continue;
                }
                let wy = origin.y + (y as f64 + 0.5) * res - p.y;
                for dx in -kernel_cells..=kernel_cells {
                    let x = cx + dx;
                    if x < 0 || x >= width as i64 {
                        continue;
                    }
                    let wx = origin.x + (x as f64 + 0.5) * res - p.x;
                    let l = (-(wx * wx + wy * wy) / two_sigma_sq).exp() as f32;
                    let cell = &mut fine[y as usize * width + x as usize];
                    if l > *cell {
                        *cell = l;
                    }
                }
            }
        }
        let coarse = block_max(&fine, width, height, config.coarse_factor);
        Self {
            config,
            origin,
            width,
            height,
            fine,
            coarse,
        }
    }

    /// The field's settings.
    pub fn config(&self) -> &CorrelativeConfig {
        &self.config
    }

    /// Mean likelihood of `points` (scan frame) placed at `pose`, 0..1.
    pub fn score(&self, points: &[Point2], pose: &Pose2) -> f64 {
        if points.is_empty() {
            return 0.0;
        }
        let sum: f64 = points
            .iter()
            .map(|p| {
                let w = pose.transform_point(p);
                self.cell(w)
                    .map_or(0.0, |(x, y)| self.fine[y * self.width + x] as f64)
            })
            .sum();
        sum / points.len() as f64
    }

    /// The field's likelihood L at `p` (reference frame), 0 outside its cells.
    pub fn likelihood(&self, p: Point2) -> f64 {
        self.cell(p)
            .map_or(0.0, |(x, y)| self.fine[y * self.width + x] as f64)
    }

    /// The field's likelihood at `p` interpolated bilinearly between the four nearest
    /// cell centres (outside cells count 0): continuous in `p`, so a score read from it
    /// changes with motions smaller than a cell.
    pub fn likelihood_bilinear(&self, p: Point2) -> f64 {
        let res = self.config.resolution_m;
        let gx = (p.x - self.origin.x) / res - 0.5;
        let gy = (p.y - self.origin.y) / res - 0.5;
        if !(gx.is_finite() && gy.is_finite()) {
            return 0.0;
        }
        let (x0, y0) = (gx.floor(), gy.floor());
        let (fx, fy) = (gx - x0, gy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let at = |x: i64, y: i64| self.table_at(&self.fine, x, y) as f64;
        (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x0 + 1, y0))
            + fy * ((1.0 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1))
    }

    fn cell(&self, p: Point2) -> Option<(usize, usize)> {
        let x = ((p.x - self.origin.x) / self.config.resolution_m).floor();
        let y = ((p.y - self.origin.y) / self.config.resolution_m).floor();
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.width && (y as usize) < self.height)
            .then_some((x as usize, y as usize))
    }

    /// The (possibly outside) cells of the finite `points` placed at `pose`.
    fn cells_at(&self, points: &[Point2], pose: &Pose2) -> Vec<(i64, i64)> {
        let res = self.config.resolution_m;
        points
            .iter()
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .map(|p| {
                let w = pose.transform_point(p);
                (
                    ((w.x - self.origin.x) / res).floor() as i64,
                    ((w.y - self.origin.y) / res).floor() as i64,
                )
            })
            .collect()
    }

    /// Sum of `table` at the cells of `cells` shifted by (dx, dy); outside cells count 0.
    fn sum_at(&self, table: &[f32], cells: &[(i64, i64)], dx: i64, dy: i64) -> f32 {
        let mut sum = 0f32;
        for &(x, y) in cells {
            sum += self.table_at(table, x + dx, y + dy);
        }
        sum
    }

    /// `table`'s value (the fine or the coarse field, laid out as the grid) at cell
    /// `(x, y)`; 0 outside the grid.
    #[inline]
    fn table_at(&self, table: &[f32], x: i64, y: i64) -> f32 {
        let (w, h) = (self.width as i64, self.height as i64);
        if x >= 0 && y >= 0 && x < w && y < h {
            table[(y * w + x) as usize]
        } else {
            0.0
        }
    }

    /// The best pose of `points` within `window` around `guess`, by branch and bound;
    /// `None` without points or when nothing scores above 0.
    pub fn search(
        &self,
        points: &[Point2],
        guess: Pose2,
        window: &SearchWindow,
    ) -> Option<CorrelativeMatch> {
        let points: Vec<Point2> = points
            .iter()
            .copied()
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .collect();
        if points.is_empty() || !guess.is_finite() {
            return None;
        }
        let res = self.config.resolution_m;
        let f = self.config.coarse_factor as i64;
        let n = points.len() as f32;
        let step_rad = angular_step_rad(&points, res);
        let angle_steps = (window.angular_rad.max(0.0) / step_rad).ceil() as i64;
        let shift_cells = (window.linear_m.max(0.0) / res).ceil() as i64;
        let blocks = (2 * shift_cells + 1 + f - 1) / f;

        // (bound, angle index, block x, block y)
        let mut candidates: Vec<(f32, i64, i64, i64)> = Vec::new();
        let mut rotated: Vec<Vec<(i64, i64)>> = Vec::new();
        for a in -angle_steps..=angle_steps {
            let heading = guess.heading_rad + a as f64 * step_rad;
            let pose = Pose2::new(guess.x, guess.y, heading);
            let cells = self.cells_at(&points, &pose);
            let ai = rotated.len() as i64;
            for by in 0..blocks {
                for bx in 0..blocks {
                    let dx = -shift_cells + bx * f;
                    let dy = -shift_cells + by * f;
                    let bound = self.sum_at(&self.coarse, &cells, dx, dy);
                    if bound > 0.0 {
                        candidates.push((bound, ai, bx, by));
                    }
                }
            }
            rotated.push(cells);
        }
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut best: Option<(f32, i64, i64, i64)> = None;
        for (bound, ai, bx, by) in candidates {
            if best.is_some_and(|b| bound <= b.0) {
                break;
            }
            let cells = &rotated[ai as usize];
            for sy in 0..f {
                for sx in 0..f {
                    let dx = -shift_cells + bx * f + sx;
                    let dy = -shift_cells + by * f + sy;
                    if dx > shift_cells || dy > shift_cells {
                        continue;
                    }
                    let s = self.sum_at(&self.fine, cells, dx, dy);
                    if best.is_none_or(|b| s > b.0) {
                        best = Some((s, ai, dx, dy));
                    }
                }
            }
        }
        let (sum, ai, dx, dy) = best?;
        let heading = guess.heading_rad + (ai - angle_steps) as f64 * step_rad;
        Some(CorrelativeMatch {
            pose: Pose2::new(
                guess.x + dx as f64 * res,
                guess.y + dy as f64 * res,
                sketchslam_types::wrap_angle(heading),
            ),
            score: (sum / n) as f64,
        })
    }
}

impl LikelihoodField {
    /// How well `points` at `best` pin the translation down: the covariance (m², x then y)
    /// of the translations within ±`radius_m` of it, at its heading, whose score reaches
    /// `fraction` of the best (uniformly weighted), plus one cell's own variance r²/12.
    /// In a corridor those poses line up along it and the variance there is large; in a
    /// room they are a small blob. A relative of Olson's (2009) covariance from the score
    /// distribution, with the plateau in place of an assumed likelihood scale.
    /// O((2·radius/r)² · n).
    pub fn translation_covariance(
        &self,
        points: &[Point2],
        best: &Pose2,
        radius_m: f64,
        fraction: f64,
    ) -> [[f64; 2]; 2] {
        let res = self.config.resolution_m;
        let cells = self.cells_at(points, best);
        let reach = (radius_m.max(0.0) / res).ceil() as i64;
        let mut scores = Vec::new();
        let mut top = 0f32;
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let s = self.sum_at(&self.fine, &cells, dx, dy);
                top = top.max(s);
                scores.push((dx, dy, s));
            }
        }
        let threshold = fraction as f32 * top;
        let near: Vec<(f64, f64)> = scores
            .iter()
            .filter(|(_, _, s)| top > 0.0 && *s >= threshold)
            .map(|&(dx, dy, _)| (dx as f64 * res, dy as f64 * res))
            .collect();
        plateau_spread(&near, res).1
    }
}

/// The spread of a score plateau: the mean of its translations `near` (m, uniformly
/// weighted) and their covariance (m², x then y) plus one cell's own variance r²/12 for
/// cells of `res` m. O(n).
pub fn plateau_spread(near: &[(f64, f64)], res: f64) -> ((f64, f64), [[f64; 2]; 2]) {
    let cell_var = res * res / 12.0;
    let n = near.len().max(1) as f64;
    let (mx, my) = near.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (mx / n, my / n);
    let mut c = [[cell_var, 0.0], [0.0, cell_var]];
    for (x, y) in near {
        let (ex, ey) = (x - mx, y - my);
        c[0][0] += ex * ex / n;
        c[0][1] += ex * ey / n;
        c[1][1] += ey * ey / n;
    }
    c[1][0] = c[0][1];
    ((mx, my), c)
}

/// The angular step of a search over `points` on cells of `res` m (Hess et al. 2016, eq. 7):
/// the farthest point moves about one cell, `acos(1 − r²/2d²_max)`. O(n).
pub(super) fn angular_step_rad(points: &[Point2], res: f64) -> f64 {
    let d_max = points.iter().map(Point2::norm).fold(res, f64::max);
    (1.0 - res * res / (2.0 * d_max * d_max))
        .clamp(-1.0, 1.0)
        .acos()
        .max(1e-4)
}

/// The smallest box holding the finite `points`, as (lower-left, upper-right) corners;
/// `None` without a finite point. O(n).
pub fn bounding_box(points: impl IntoIterator<Item = Point2>) -> Option<(Point2, Point2)> {
    points
        .into_iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .fold(None, |b, p| {
            let (lo, hi) = b.unwrap_or((p, p));
            Some((
                Point2::new(lo.x.min(p.x), lo.y.min(p.y)),
                Point2::new(hi.x.max(p.x), hi.y.max(p.y)),
            ))
        })
}

/// `out[c] = max(table[c'])` over the f×f cells c' from c (c'.x ∈ [c.x, c.x+f), same in y):
/// the bound of every fine shift in a block at the block's corner. Two separable passes.
fn block_max(table: &[f32], width: usize, height: usize, f: usize) -> Vec<f32> {
    let mut rows = vec![0f32; table.len()];
    for y in 0..height {
        for x in 0..width {
            let end = (x + f).min(width);
            rows[y * width + x] = table[y * width + x..y * width + end]
                .iter()
                .copied()
                .fold(0.0, f32::max);
        }
    }
    let mut out = vec![0f32; table.len()];
    for y in 0..height {
        for x in 0..width {
            out[y * width + x] = (y..(y + f).min(height))
                .map(|yy| rows[yy * width + x])
                .fold(0.0, f32::max);
        }
    }
    out
}

/// One point per occupied `cell_m` square (the first seen): even density, so near walls
/// do not outvote far ones in a score. O(n).
pub fn voxel_filter(points: &[Point2], cell_m: f64) -> Vec<Point2> {
    let mut seen = std::collections::HashSet::new();
    points
        .iter()
        .copied()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .filter(|p| seen.insert(((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64)))
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Points every 2 cm along the walls of an L-shaped room corner set: a 6 × 4 m box
    /// with an inner 1 m pillar, so no shift or turn maps it onto itself.
    pub(crate) fn room() -> Vec<Point2> {
        let mut pts = Vec::new();
        let mut wall = |a: Point2, b: Point2| {
            let n = (a.distance(&b) / 0.02).ceil() as usize;
            for i in 0..=n {
                let t = i as f64 / n as f64;
                pts.push(Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)));
            }
        };
        let c = [(-3.0, -2.0), (3.0, -2.0), (3.0, 2.0), (-3.0, 2.0)];
        for i in 0..4 {
            let (a, b) = (c[i], c[(i + 1) % 4]);
            wall(Point2::new(a.0, a.1), Point2::new(b.0, b.1));
        }
        wall(Point2::new(1.0, 0.0), Point2::new(2.0, 0.0));
        wall(Point2::new(2.0, 0.0), Point2::new(2.0, 1.0));
        pts
    }

    #[test]
    fn a_point_on_the_reference_scores_one_and_far_away_zero() {
        let field = LikelihoodField::new(&[Point2::new(0.0, 0.0)], CorrelativeConfig::default());
        // The cell holding the point has its centre within half a cell: L ≥ exp(−(0.035)²/0.02).
        let near = field.score(&[Point2::new(0.0, 0.0)], &Pose2::IDENTITY);
        assert!(near > 0.93, "{near}");
        // 0.2 m away: exp(−0.04/0.02) = e⁻² ≈ 0.135 at the point itself; the field holds
        // it at cell centres, up to 0.035 m nearer or farther: exp(−0.235²/0.02) ≈ 0.063 to
        // exp(−0.165²/0.02) ≈ 0.256.
        let at = field.score(&[Point2::new(0.2, 0.0)], &Pose2::IDENTITY);
        assert!((0.063..0.256).contains(&at), "{at}");
        assert_eq!(field.score(&[Point2::new(5.0, 5.0)], &Pose2::IDENTITY), 0.0);
    }

    #[test]
    fn coarse_table_bounds_the_fine_one() {
        let t: Vec<f32> = (0..20).map(|i| (i % 7) as f32).collect();
        let m = block_max(&t, 5, 4, 2);
        for y in 0..4 {
            for x in 0..5 {
                for yy in y..(y + 2).min(4) {
                    for xx in x..(x + 2).min(5) {
                        assert!(m[y * 5 + x] >= t[yy * 5 + xx]);
                    }
                }
            }
        }
        assert_eq!(m[0], 6.0); // max of t[0], t[1], t[5], t[6] = 0, 1, 5, 6
    }

    #[test]
    fn search_recovers_a_known_shift_and_turn() {
        let reference = room();
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        // The scan is the room seen from the true pose; the guess is 0.6 m and 8° off.
        let truth = Pose2::new(0.4, -0.3, 0.12);
        let scan: Vec<Point2> = reference
            .iter()
            .map(|p| truth.inverse_transform_point(p))
            .collect();
        let scan = voxel_filter(&scan, 0.1);
        let guess = Pose2::new(0.4 - 0.45, -0.3 + 0.4, 0.12 - 8f64.to_radians());
        let window = SearchWindow {
            linear_m: 1.0,
            angular_rad: 15f64.to_radians(),
        };
        let m = field.search(&scan, guess, &window).unwrap();
        assert!((m.pose.x - truth.x).abs() < 0.06, "{:?}", m.pose);
        assert!((m.pose.y - truth.y).abs() < 0.06, "{:?}", m.pose);
        assert!(
            (m.pose.heading_rad - truth.heading_rad).abs() < 0.01,
            "{:?}",
            m.pose
        );
        assert!(m.score > 0.85, "{}", m.score);
        // The reported score is the field's score of the reported pose (up to rounding).
        assert!((field.score(&scan, &m.pose) - m.score).abs() < 0.02);
    }

    #[test]
    fn a_corridor_is_uncertain_along_itself_only() {
        // Two parallel walls 2 m apart along x, 20 m long: a scan of their middle part
        // slides along x without losing score, not across.
        let reference = corridor(-10.0, 10.0);
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        let c = field.translation_covariance(&middle(&reference), &Pose2::IDENTITY, 1.0, 0.95);
        // Along x the plateau spans the whole ±1 m: variance of a uniform 2 m segment,
        // 2²/12 ≈ 0.33 m²; across it is one cell.
        assert!(c[0][0] > 0.25, "{c:?}");
        assert!(c[1][1] < 0.01, "{c:?}");
        // The room of the other tests pins both.
        let room = room();
        let field = LikelihoodField::new(&room, CorrelativeConfig::default());
        let c =
            field.translation_covariance(&voxel_filter(&room, 0.1), &Pose2::IDENTITY, 1.0, 0.95);
        assert!(c[0][0] < 0.01 && c[1][1] < 0.01, "{c:?}");
    }

    /// Points every 2 cm along the two walls y = ±1 of a corridor, from `x0` to `x1`.
    pub(crate) fn corridor(x0: f64, x1: f64) -> Vec<Point2> {
        let n = ((x1 - x0) / 0.02).round() as usize;
        (0..=n)
            .flat_map(|i| {
                let x = x0 + 0.02 * i as f64;
                [Point2::new(x, -1.0), Point2::new(x, 1.0)]
            })
            .collect()
    }

    /// Door frames: 0.7 m stubs, a point every 2 cm, from both walls of [`corridor`] at
    /// each of `xs`.
    pub(crate) fn door_frames(xs: &[f64]) -> Vec<Point2> {
        let mut pts = Vec::new();
        for &x in xs {
            for i in 0..=35 {
                let y = 0.3 + 0.02 * i as f64;
                pts.push(Point2::new(x, y));
                pts.push(Point2::new(x, -y));
            }
        }
        pts
    }

    /// The points of `reference` within 3 m of x = 0: a scan of a corridor's middle.
    fn middle(reference: &[Point2]) -> Vec<Point2> {
        reference
            .iter()
            .copied()
            .filter(|p| p.x.abs() < 3.0)
            .collect()
    }

    #[test]
    fn a_hump_from_partial_overlap_has_a_top_wider_than_the_kernel() {
        // The reference saw the corridor up to x = 2 m; the scan sees −3..3 m. Every shift
        // toward −x overlaps more of it, up to −1 m where all of it overlaps: the top is a
        // flat shelf from −1 m on, a metre from the truth (0), and at shift s > −1 a share
        // (5 − s)/6 of the points overlaps, 0.95 of the best at s = −0.7. Nothing on it is
        // a feature, and its plateau (≥ 0.8 m long, σ ≥ 0.8/√12 ≈ 0.23 m) is wider than
        // the kernel (σ = 0.1 m); across, the walls pin it within the kernel.
        let field = LikelihoodField::new(&corridor(-10.0, 2.0), CorrelativeConfig::default());
        let scan = corridor(-3.0, 3.0);
        let window = SearchWindow {
            linear_m: 1.5,
            angular_rad: 0.0,
        };
        let best = field.search(&scan, Pose2::IDENTITY, &window).unwrap();
        assert!(best.pose.x <= -0.95, "{:?}", best.pose);
        let c = field.translation_covariance(&scan, &best.pose, 1.5, 0.95);
        assert!(c[0][0].sqrt() > 0.2, "{c:?}");
        assert!(c[1][1].sqrt() < 0.05, "{c:?}");
    }

    #[test]
    fn a_door_jamb_on_a_corridor_makes_a_top_narrower_than_the_kernel() {
        // The same corridor seen whole, narrowed at x = 0 by a door frame (0.7 m stubs
        // from both walls, 72 of the scan's 672 points, ~50 of them more than the kernel's
        // reach from a wall): a shift δ along x costs those points 1 − exp(−δ²/2σ²) each,
        // 2.9 % of the score at δ = 0.1 m and 5.9 % at 0.15 m, so the 95 % plateau
        // reaches ±0.1 m and not ±0.15 m (measured σ 0.076 m, whole cells and their
        // rounding included), narrower than the kernel. (With 0.5 m stubs, ~30 points
        // off the walls, it reaches ±0.2 m, σ 0.115 m: a feature must be seen by more
        // than a few percent of the scan to pin it.)
        let mut reference = corridor(-10.0, 10.0);
        reference.extend(door_frames(&[0.0]));
        let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
        let c = field.translation_covariance(&middle(&reference), &Pose2::IDENTITY, 1.5, 0.95);
        assert!(c[0][0].sqrt() < 0.1, "{c:?}");
    }

    #[test]
    fn nothing_to_match_gives_none() {
        let field = LikelihoodField::new(&room(), CorrelativeConfig::default());
        let window = SearchWindow {
            linear_m: 0.5,
            angular_rad: 0.1,
        };
        assert!(field.search(&[], Pose2::IDENTITY, &window).is_none());
        let far = [Point2::new(100.0, 100.0)];
        assert!(field.search(&far, Pose2::IDENTITY, &window).is_none());
        let empty = LikelihoodField::new(&[], CorrelativeConfig::default());
        assert!(empty.search(&room(), Pose2::IDENTITY, &window).is_none());
    }

    #[test]
    fn voxel_filter_keeps_one_point_per_cell() {
        let pts = [
            Point2::new(0.01, 0.01),
            Point2::new(0.02, 0.03),
            Point2::new(0.15, 0.0),
            Point2::new(f64::NAN, 0.0),
        ];
        assert_eq!(voxel_filter(&pts, 0.1).len(), 2);
    }
}
