//! The occupancy grid: step 6 of the pipeline, where every corrected scan is fused into the
//! metric map that the service serves (PNG, ROS `map.pgm` + `map.yaml`, JSON occupancy).
//!
//! Each cell holds the log odds `l = ln(p / (1 − p))` of being occupied (binary Bayes filter,
//! Thrun, Burgard & Fox, *Probabilistic Robotics*, §9.2). For one scan taken at pose `x` of
//! the map frame, every beam with a return updates:
//! - the cells it crosses (exact voxel traversal, Amanatides & Woo 1987) with
//!   `l ← clamp(l + l_free)`,
//! - the cell holding its end point with `l ← clamp(l + l_occ)`,
//!
//! each cell at most once per scan, a hit winning over a pass (so that a wall is not
//! cleared by the grazing beams of the same scan). `p = 1 − 1/(1 + eˡ)`.
//!
//! Layout and frame (ROS `nav_msgs/OccupancyGrid` convention): cells are square with side
//! `resolution_m`; cell `(col, row)` covers `[ox + col·r, ox + (col+1)·r) × [oy + row·r,
//! oy + (row+1)·r)` with `origin() = (ox, oy)`; row 0 is at the *bottom* (smallest y).
//! Internally cells are indexed by global integers `⌊x / r⌋, ⌊y / r⌋`, so the origin is
//! always a whole multiple of the resolution and growing never moves existing content.
//!
//! Growth: the grid starts as a 128 × 128-cell square around the map origin and grows when a
//! scan reaches beyond it, by at least 64 cells and at least half its current size in each
//! direction that overflows (amortised O(1) per cell). Limits keep hostile input from
//! exhausting memory: beams longer than [`MAX_BEAM_RANGE_M`] are ignored and a scan that
//! would make a side exceed [`MAX_EXTENT_CELLS`] cells is dropped.
//!
//! Complexity of [`OccupancyGrid::insert_scan`]: O(Σ beam length / resolution) plus an
//! occasional O(cells) copy when growing.

use sketchslam_types::{Point2, Pose2, Scan};

/// Beams whose range exceeds this are ignored entirely, meters.
pub const MAX_BEAM_RANGE_M: f64 = 250.0;
/// Largest width or height the grid may grow to, cells (≈ 1.6 km at 5 cm).
pub const MAX_EXTENT_CELLS: i64 = 32_768;
/// Growth quantum, cells.
const CHUNK_CELLS: i64 = 64;

/// Parameters of the occupancy grid. Log odds are natural logarithms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridConfig {
    /// Side of a cell, meters. Default 0.05.
    pub resolution_m: f64,
    /// Log odds added to the end cell of a beam. Default 0.9 (p ≈ 0.71 after one hit: one
    /// hit on unknown is already "occupied", p > 0.65).
    pub log_odds_occupied: f64,
    /// Log odds added (negative) to a cell a beam passes through. Default −0.5 (three passes
    /// make an unknown cell "free", p < 0.196).
    pub log_odds_free: f64,
    /// Lower clamp of a cell's log odds. Default −2.0 (p ≈ 0.12): lets a cell become
    /// occupied again after two or three hits.
    pub log_odds_min: f64,
    /// Upper clamp of a cell's log odds. Default 3.5 (p ≈ 0.97).
    pub log_odds_max: f64,
    /// Free-space update for beams with *no* return: a range of `+∞` or at/above the
    /// scanner's `range_max` means "nothing up to range_max", and the cells along the beam
    /// up to `min(max_free_range_m, range_max)` are updated as free. `0.0` (the default)
    /// disables it: no-return beams change nothing (robust to heading errors on long rays
    /// and to glass). NaN, negative or below-`range_min` ranges never update anything.
    pub max_free_range_m: f64,
}

impl Default for GridConfig {
    fn default() -> Self {
        Self {
            resolution_m: 0.05,
            log_odds_occupied: 0.9,
            log_odds_free: -0.5,
            log_odds_min: -2.0,
            log_odds_max: 3.5,
            max_free_range_m: 0.0,
        }
    }
}

impl GridConfig {
    /// The same configuration with every unusable field (non-finite, wrong sign, min > max)
    /// replaced by its default.
    pub fn sanitized(self) -> Self {
        let d = GridConfig::default();
        let pick = |v: f64, ok: bool, def: f64| if v.is_finite() && ok { v } else { def };
        let mut c = GridConfig {
            resolution_m: pick(self.resolution_m, self.resolution_m > 1e-4, d.resolution_m),
            log_odds_occupied: pick(
                self.log_odds_occupied,
                self.log_odds_occupied >= 0.0,
                d.log_odds_occupied,
            ),
            log_odds_free: pick(
                self.log_odds_free,
                self.log_odds_free <= 0.0,
                d.log_odds_free,
            ),
            log_odds_min: pick(self.log_odds_min, self.log_odds_min <= 0.0, d.log_odds_min),
            log_odds_max: pick(self.log_odds_max, self.log_odds_max >= 0.0, d.log_odds_max),
            max_free_range_m: pick(self.max_free_range_m, self.max_free_range_m >= 0.0, 0.0),
        };
        if c.log_odds_min > c.log_odds_max {
            c.log_odds_min = d.log_odds_min;
            c.log_odds_max = d.log_odds_max;
        }
        c
    }
}

/// Probability threshold above which a cell is occupied (ROS `occupied_thresh`).
pub const OCCUPIED_THRESHOLD: f64 = 0.65;
/// Probability threshold below which a cell is free (ROS `free_thresh`).
pub const FREE_THRESHOLD: f64 = 0.196;

/// A log-odds occupancy grid that grows as the robot explores. See the module docs.
#[derive(Clone)]
pub struct OccupancyGrid {
    config: GridConfig,
    /// Global cell index of column 0.
    min_col: i64,
    /// Global cell index of row 0.
    min_row: i64,
    width: usize,
    height: usize,
    /// Row-major log odds, row 0 at the bottom.
    cells: Vec<f32>,
    /// Per-cell stamp of the last scan that updated it (odd: hit, even: pass).
    marks: Vec<u32>,
    /// Stamp counter; scan k uses `2k + 1` (hit) and `2k + 2` (pass).
    stamp: u32,
    scans_inserted: u64,
}

impl std::fmt::Debug for OccupancyGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OccupancyGrid")
            .field("config", &self.config)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("origin", &self.origin())
            .field("scans_inserted", &self.scans_inserted)
            .finish_non_exhaustive()
    }
}

/// `p → l = ln(p / (1 − p))`.
pub fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

/// `l → p = 1 − 1/(1 + eˡ)`.
pub fn log_odds_to_probability(l: f64) -> f64 {
    1.0 - 1.0 / (1.0 + l.exp())
}

impl OccupancyGrid {
    /// Bytes on the heap of its cells and marks (capacities).
    pub fn heap_bytes(&self) -> usize {
        crate::heap::vec_bytes(&self.cells) + crate::heap::vec_bytes(&self.marks)
    }

    /// An empty (all unknown) grid of 128 × 128 cells centred on the map origin. Unusable
    /// configuration fields are replaced by their defaults ([`GridConfig::sanitized`]).
    pub fn new(config: GridConfig) -> Self {
        let config = config.sanitized();
        let side = 2 * CHUNK_CELLS as usize;
        Self {
            config,
            min_col: -CHUNK_CELLS,
            min_row: -CHUNK_CELLS,
            width: side,
            height: side,
            cells: vec![0.0; side * side],
            marks: vec![0; side * side],
            stamp: 0,
            scans_inserted: 0,
        }
    }

    /// The configuration in use (after sanitizing).
    pub fn config(&self) -> &GridConfig {
        &self.config
    }

    /// Side of a cell, meters.
    pub fn resolution_m(&self) -> f64 {
        self.config.resolution_m
    }

    /// Number of columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Number of scans fused so far.
    pub fn scans_inserted(&self) -> u64 {
        self.scans_inserted
    }

    /// Map-frame position of the lower-left corner of cell (0, 0), meters.
    pub fn origin(&self) -> Point2 {
        let r = self.config.resolution_m;
        Point2::new(self.min_col as f64 * r, self.min_row as f64 * r)
    }

    fn index(&self, col: usize, row: usize) -> Option<usize> {
        (col < self.width && row < self.height).then(|| row * self.width + col)
    }

    /// Log odds of cell `(col, row)`; 0 (unknown) outside the grid.
    pub fn log_odds(&self, col: usize, row: usize) -> f32 {
        self.index(col, row).map_or(0.0, |i| self.cells[i])
    }

    /// Occupancy probability of cell `(col, row)`; 0.5 outside the grid.
    pub fn probability(&self, col: usize, row: usize) -> f64 {
        log_odds_to_probability(self.log_odds(col, row) as f64)
    }

    /// True when the cell's probability exceeds [`OCCUPIED_THRESHOLD`] (0.65), tested on
    /// the log odds (`l > ln(0.65 / 0.35)`, no `exp`).
    pub fn is_occupied(&self, col: usize, row: usize) -> bool {
        self.log_odds(col, row) as f64 > logit(OCCUPIED_THRESHOLD)
    }

    /// True when the cell's probability is below [`FREE_THRESHOLD`] (0.196), tested on the
    /// log odds.
    pub fn is_free(&self, col: usize, row: usize) -> bool {
        (self.log_odds(col, row) as f64) < logit(FREE_THRESHOLD)
    }

    /// True when the cell was never updated (or its evidence cancelled out: log odds 0).
    pub fn is_unknown(&self, col: usize, row: usize) -> bool {
        self.log_odds(col, row) == 0.0
    }

    /// Map-frame centre of cell `(col, row)` (also for indices outside the grid).
    pub fn cell_center(&self, col: usize, row: usize) -> Point2 {
        // Same formula as a map read back from PGM + YAML, for bit-identical points.
        let r = self.config.resolution_m;
        let o = self.origin();
        Point2::new(o.x + (col as f64 + 0.5) * r, o.y + (row as f64 + 0.5) * r)
    }

    /// Centres of the occupied cells in the map frame, bottom row first, left to right.
    /// O(cells).
    pub fn occupied_points(&self) -> Vec<Point2> {
        self.occupied_in_cells(0, 0, self.width, self.height)
    }

    /// Centres of the occupied cells within `radius_m` of `center` (all of them for an
    /// infinite radius): a scan-to-map ICP reference. O(cells of the bounding box).
    pub fn occupied_points_near(&self, center: Point2, radius_m: f64) -> Vec<Point2> {
        if radius_m.is_infinite() && radius_m > 0.0 {
            return self.occupied_points();
        }
        if !(radius_m >= 0.0 && center.x.is_finite() && center.y.is_finite()) {
            return Vec::new();
        }
        let (min, max) = (
            Point2::new(center.x - radius_m, center.y - radius_m),
            Point2::new(center.x + radius_m, center.y + radius_m),
        );
        let mut pts = self.occupied_points_in_box(min, max);
        pts.retain(|p| p.distance(&center) <= radius_m);
        pts
    }

    /// Centres of the occupied cells whose centre lies in the box `[min, max]` (map frame),
    /// same order as [`OccupancyGrid::occupied_points`]. O(cells of the box).
    pub fn occupied_points_in_box(&self, min: Point2, max: Point2) -> Vec<Point2> {
        if [min.x, min.y, max.x, max.y].iter().any(|v| v.is_nan()) {
            return Vec::new();
        }
        let r = self.config.resolution_m;
        let o = self.origin();
        let lo = |v: f64, o: f64| ((v - o) / r - 0.5).ceil().max(0.0);
        let hi = |v: f64, o: f64, n: usize| ((v - o) / r - 0.5).floor().min(n as f64 - 1.0) + 1.0;
        let (c0, r0) = (lo(min.x, o.x), lo(min.y, o.y));
        let (c1, r1) = (hi(max.x, o.x, self.width), hi(max.y, o.y, self.height));
        if !(c1 > c0 && r1 > r0) {
            return Vec::new();
        }
        self.occupied_in_cells(c0 as usize, r0 as usize, c1 as usize, r1 as usize)
    }

    /// Occupied cell centres of columns `c0..c1`, rows `r0..r1`.
    fn occupied_in_cells(&self, c0: usize, r0: usize, c1: usize, r1: usize) -> Vec<Point2> {
        let thr = logit(OCCUPIED_THRESHOLD);
        let mut out = Vec::new();
        for row in r0..r1.min(self.height) {
            let line = &self.cells[row * self.width..(row + 1) * self.width];
            for (col, &l) in line.iter().enumerate().take(c1.min(self.width)).skip(c0) {
                if l as f64 > thr {
                    out.push(self.cell_center(col, row));
                }
            }
        }
        out
    }

    /// The cell holding map-frame point `p`, or `None` outside the grid or for non-finite
    /// coordinates.
    pub fn cell_of(&self, p: Point2) -> Option<(usize, usize)> {
        let (gc, gr) = self.global_cell(p)?;
        let col = gc - self.min_col;
        let row = gr - self.min_row;
        (col >= 0 && row >= 0 && (col as usize) < self.width && (row as usize) < self.height)
            .then_some((col as usize, row as usize))
    }

    fn global_cell(&self, p: Point2) -> Option<(i64, i64)> {
        let r = self.config.resolution_m;
        let (fx, fy) = ((p.x / r).floor(), (p.y / r).floor());
        // Far beyond any grid we would build; also rejects NaN and infinities.
        let lim = 1e15;
        (fx.abs() < lim && fy.abs() < lim).then_some((fx as i64, fy as i64))
    }

    /// Grows the grid so that the global cell box `[c0, c1] × [r0, r1]` is inside. Returns
    /// false (and changes nothing) when that would exceed [`MAX_EXTENT_CELLS`].
    fn ensure(&mut self, c0: i64, r0: i64, c1: i64, r1: i64) -> bool {
        let (max_col, max_row) = (
            self.min_col + self.width as i64,
            self.min_row + self.height as i64,
        );
        if c0 >= self.min_col && r0 >= self.min_row && c1 < max_col && r1 < max_row {
            return true;
        }
        let Some((new_min_col, new_max_col)) = grown_range(self.min_col, max_col, c0, c1 + 1)
        else {
            return false;
        };
        let Some((new_min_row, new_max_row)) = grown_range(self.min_row, max_row, r0, r1 + 1)
        else {
            return false;
        };
        let nw = (new_max_col - new_min_col) as usize;
        let nh = (new_max_row - new_min_row) as usize;
        let mut cells = vec![0.0f32; nw * nh];
        let mut marks = vec![0u32; nw * nh];
        let dc = (self.min_col - new_min_col) as usize;
        let dr = (self.min_row - new_min_row) as usize;
        for row in 0..self.height {
            let src = row * self.width;
            let dst = (row + dr) * nw + dc;
            cells[dst..dst + self.width].copy_from_slice(&self.cells[src..src + self.width]);
            marks[dst..dst + self.width].copy_from_slice(&self.marks[src..src + self.width]);
        }
        self.cells = cells;
        self.marks = marks;
        self.min_col = new_min_col;
        self.min_row = new_min_row;
        self.width = nw;
        self.height = nh;
        true
    }

    fn global_index(&self, gc: i64, gr: i64) -> Option<usize> {
        let col = gc - self.min_col;
        let row = gr - self.min_row;
        (col >= 0 && row >= 0 && (col as usize) < self.width && (row as usize) < self.height)
            .then(|| row as usize * self.width + col as usize)
    }

    /// Fuses one scan taken at `pose` (the robot in the map frame). Free space along each
    /// beam with a return (cells crossed by the segment robot → end point, end cell
    /// excluded), occupied at its end; no-return beams as described at
    /// [`GridConfig::max_free_range_m`]. Non-finite poses are ignored. O(Σ beam cells).
    pub fn insert_scan(&mut self, pose: &Pose2, scan: &Scan) {
        if !pose.is_finite() {
            return;
        }
        let origin = pose.position();
        let range_max = scan.header.range_max_m as f64;
        let free_cap_m = if self.config.max_free_range_m > 0.0 {
            if range_max.is_finite() && range_max > 0.0 {
                self.config.max_free_range_m.min(range_max)
            } else {
                self.config.max_free_range_m
            }
            .min(MAX_BEAM_RANGE_M)
        } else {
            0.0
        };
        // (end point, is a hit)
        let mut beams: Vec<(Point2, bool)> = Vec::with_capacity(scan.ranges_m.len());
        for (i, &r) in scan.ranges_m.iter().enumerate() {
            let angle = pose.heading_rad + scan.beam_angle_rad(i);
            if !angle.is_finite() {
                continue;
            }
            let (s, c) = angle.sin_cos();
            if scan.is_return(i) {
                let r = r as f64;
                if r <= MAX_BEAM_RANGE_M {
                    beams.push((Point2::new(origin.x + r * c, origin.y + r * s), true));
                }
            } else if free_cap_m > 0.0
                && (r == f32::INFINITY || (r.is_finite() && r as f64 >= range_max))
            {
                let r = free_cap_m;
                beams.push((Point2::new(origin.x + r * c, origin.y + r * s), false));
            }
        }
        let Some((gc0, gr0)) = self.global_cell(origin) else {
            return;
        };
        let (mut c0, mut r0, mut c1, mut r1) = (gc0, gr0, gc0, gr0);
        let mut cells_of_ends = Vec::with_capacity(beams.len());
        for (p, _) in &beams {
            let Some((gc, gr)) = self.global_cell(*p) else {
                return;
            };
            c0 = c0.min(gc);
            r0 = r0.min(gr);
            c1 = c1.max(gc);
            r1 = r1.max(gr);
            cells_of_ends.push((gc, gr));
        }
        if !self.ensure(c0, r0, c1, r1) {
            return;
        }
        // Fresh stamps for this scan.
        if self.stamp >= u32::MAX - 2 {
            self.marks.iter_mut().for_each(|m| *m = 0);
            self.stamp = 0;
        }
        let hit_stamp = self.stamp + 1;
        let pass_stamp = self.stamp + 2;
        self.stamp += 2;
        let (lo, hi) = (
            self.config.log_odds_min as f32,
            self.config.log_odds_max as f32,
        );
        let l_occ = self.config.log_odds_occupied as f32;
        let l_free = self.config.log_odds_free as f32;
        // Hits first, so that passes of the same scan cannot clear them.
        for ((_, hit), &(gc, gr)) in beams.iter().zip(&cells_of_ends) {
            if !hit {
                continue;
            }
            if let Some(i) = self.global_index(gc, gr)
                && self.marks[i] != hit_stamp
            {
                self.marks[i] = hit_stamp;
                self.cells[i] = (self.cells[i] + l_occ).clamp(lo, hi);
            }
        }
        let r = self.config.resolution_m;
        let start = Point2::new(origin.x / r, origin.y / r);
        for (&(end, hit), _) in beams.iter().zip(&cells_of_ends) {
            let end_g = Point2::new(end.x / r, end.y / r);
            let (cells, marks) = (&mut self.cells, &mut self.marks);
            let (min_col, min_row, width, height) =
                (self.min_col, self.min_row, self.width, self.height);
            traverse(start, end_g, !hit, |gc, gr| {
                let col = gc - min_col;
                let row = gr - min_row;
                if col < 0 || row < 0 || col as usize >= width || row as usize >= height {
                    return;
                }
                let i = row as usize * width + col as usize;
                if marks[i] != hit_stamp && marks[i] != pass_stamp {
                    marks[i] = pass_stamp;
                    cells[i] = (cells[i] + l_free).clamp(lo, hi);
                }
            });
        }
        self.scans_inserted += 1;
    }
}

/// One axis of `OccupancyGrid::ensure`: the half-open range `[lo, hi)` grown to hold
/// `[want_lo, want_hi)` with a margin of at least one chunk and half the current size,
/// aligned to chunks, capped at [`MAX_EXTENT_CELLS`]; `None` when even the bare union of
/// both ranges is too long.
fn grown_range(lo: i64, hi: i64, want_lo: i64, want_hi: i64) -> Option<(i64, i64)> {
    let (union_lo, union_hi) = (lo.min(want_lo), hi.max(want_hi));
    if union_hi - union_lo > MAX_EXTENT_CELLS {
        return None;
    }
    let grow = CHUNK_CELLS.max((hi - lo) / 2);
    let mut new_lo = if want_lo < lo {
        (want_lo - grow).div_euclid(CHUNK_CELLS) * CHUNK_CELLS
    } else {
        lo
    };
    let mut new_hi = if want_hi > hi {
        (want_hi + grow + CHUNK_CELLS - 1).div_euclid(CHUNK_CELLS) * CHUNK_CELLS
    } else {
        hi
    };
    if new_hi - new_lo > MAX_EXTENT_CELLS {
        new_lo = new_lo.max(union_hi - MAX_EXTENT_CELLS);
        new_hi = new_lo + MAX_EXTENT_CELLS;
    }
    Some((new_lo, new_hi))
}

/// Exact grid traversal (Amanatides & Woo 1987) of the segment `a → b` given in cell units:
/// calls `visit(col, row)` for every global cell the segment crosses, in order, the cell of
/// `b` included only when `include_end`. O(|Δcol| + |Δrow|).
fn traverse(a: Point2, b: Point2, include_end: bool, mut visit: impl FnMut(i64, i64)) {
    let (mut col, mut row) = (a.x.floor() as i64, a.y.floor() as i64);
    let (end_col, end_row) = (b.x.floor() as i64, b.y.floor() as i64);
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let step_c: i64 = if dx > 0.0 { 1 } else { -1 };
    let step_r: i64 = if dy > 0.0 { 1 } else { -1 };
    let t_delta_x = if dx != 0.0 {
        1.0 / dx.abs()
    } else {
        f64::INFINITY
    };
    let t_delta_y = if dy != 0.0 {
        1.0 / dy.abs()
    } else {
        f64::INFINITY
    };
    let mut t_max_x = if dx > 0.0 {
        (a.x.floor() + 1.0 - a.x) * t_delta_x
    } else if dx < 0.0 {
        (a.x - a.x.floor()) * t_delta_x
    } else {
        f64::INFINITY
    };
    let mut t_max_y = if dy > 0.0 {
        (a.y.floor() + 1.0 - a.y) * t_delta_y
    } else if dy < 0.0 {
        (a.y - a.y.floor()) * t_delta_y
    } else {
        f64::INFINITY
    };
    // The walk takes exactly |Δcol| + |Δrow| steps; bounding it guards against rounding.
    let steps = (end_col - col).abs() + (end_row - row).abs();
    for _ in 0..steps {
        if col == end_col && row == end_row {
            break;
        }
        visit(col, row);
        if t_max_x < t_max_y {
            col += step_c;
            t_max_x += t_delta_x;
        } else {
            row += step_r;
            t_max_y += t_delta_y;
        }
    }
    if col == end_col && row == end_row {
        if include_end {
            visit(col, row);
        }
    } else {
        // Rounding left the walk a cell off its end: the current cell is still on the path.
        visit(col, row);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::ScanHeader;

    fn scan(angles_ranges: &[(f64, f32)]) -> Vec<Scan> {
        angles_ranges
            .iter()
            .map(|&(a, r)| Scan {
                header: ScanHeader {
                    angle_min_rad: a as f32,
                    angle_increment_rad: 0.0,
                    range_min_m: 0.05,
                    range_max_m: 30.0,
                    beam_count: 1,
                    ..Default::default()
                },
                ranges_m: vec![r],
            })
            .collect()
    }

    #[test]
    fn traversal_visits_a_connected_path() {
        let mut cells = Vec::new();
        traverse(
            Point2::new(0.5, 0.5),
            Point2::new(5.5, 2.5),
            true,
            |c, r| cells.push((c, r)),
        );
        assert_eq!(cells.first(), Some(&(0, 0)));
        assert_eq!(cells.last(), Some(&(5, 2)));
        for w in cells.windows(2) {
            let d = (w[1].0 - w[0].0).abs() + (w[1].1 - w[0].1).abs();
            assert_eq!(d, 1);
        }
    }

    #[test]
    fn single_beam_marks_end_and_clears_path() {
        let mut g = OccupancyGrid::new(GridConfig::default());
        for s in scan(&[(0.0, 1.0)]) {
            g.insert_scan(&Pose2::new(0.01, 0.01, 0.0), &s);
        }
        let end = g.cell_of(Point2::new(1.01, 0.01)).unwrap();
        assert!(g.is_occupied(end.0, end.1));
        let mid = g.cell_of(Point2::new(0.5, 0.01)).unwrap();
        assert!(g.log_odds(mid.0, mid.1) < 0.0);
    }

    #[test]
    fn nan_range_and_nan_pose_change_nothing() {
        let mut g = OccupancyGrid::new(GridConfig::default());
        for s in scan(&[(0.0, f32::NAN), (1.0, f32::INFINITY), (2.0, -1.0)]) {
            g.insert_scan(&Pose2::new(0.0, 0.0, 0.0), &s);
        }
        let s = &scan(&[(0.0, 1.0)])[0];
        g.insert_scan(&Pose2::new(f64::NAN, 0.0, 0.0), s);
        assert!(g.cells.iter().all(|&l| l == 0.0));
    }
}
