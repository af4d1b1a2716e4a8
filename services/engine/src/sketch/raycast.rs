//! Ray tracing on the drawing: the pseudo-ranges `l_i` of MCL on the sketch (eq. 3) and the
//! line each beam hits (eq. 4).
//!
//! Where in the pipeline: built once per sketch (after line extraction), then queried for every
//! particle × used beam × scan by [`crate::localization::mcl`], for every beam of the estimate
//! by [`crate::localization::line_observation`], and over a grid of candidate points by
//! [`crate::localization::recovery`].
//!
//! # Construction — `O(W·H + Σ line lengths)`
//! 1. The sketch's **lines** (not the raw stroke mask: the drawing's scribbles, text and
//!    the start mark are not walls) are rasterized into a wall grid, one cell per pixel;
//!    a cell crossed by several lines keeps the line passing closest to its centre.
//! 2. An exact Euclidean distance transform (Felzenszwalb & Huttenlocher 2012: lower
//!    envelope of parabolas, one pass over columns, one over rows) gives for every pixel
//!    centre the distance `D` to the nearest wall-cell centre, and — carrying the argmin
//!    through both passes — the index of that cell's line (a nearest-line map: the paper's
//!    nearest-neighbour search of the hit line, precomputed).
//!
//! # Casting — sphere tracing
//! A point `p` in a cell with distance `D` is at least `D − √2` from any wall cell (half a
//! cell diagonal for `p` inside its cell, half for the wall inside its cell), so the ray
//! advances by `max(D − 1.5, 0.5)` px without crossing a line. Once `D ≤ 2` px, the lines
//! of the 3×3 neighbourhood in the nearest-line map are intersected exactly with the ray
//! (segments lengthened by [`ENDPOINT_SLACK_PX`] to close rasterization gaps at corners);
//! the nearest crossing ends the ray, so ranges are exact up to floating point and the
//! line index is the line actually crossed. Cost per ray: `O(k)` steps, `k` ≈ log of the
//! range in open space, up to `range / 0.5 px` for a ray grazing along a wall.

use super::{Sketch, SketchLine};

/// How much each segment is lengthened at both ends for the exact ray intersection, pixels.
pub const ENDPOINT_SLACK_PX: f64 = 1.0;

/// Below this distance-field value (pixels) the ray is tested against the nearby lines.
const NEAR_WALL_PX: f32 = 2.0;

/// Smallest sphere-tracing step, pixels.
const MIN_STEP_PX: f64 = 0.5;

/// Marker for "no line" in the index maps.
const NO_LINE: u32 = u32::MAX;

/// A beam's end on the drawing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance from the ray's origin to the line it hits, pixels.
    pub range_px: f64,
    /// Index of the hit line in [`Sketch::lines`].
    pub line_index: usize,
}

/// Precomputed wall grid, distance field and nearest-line map of a sketch's lines.
#[derive(Debug, Clone)]
pub struct SketchRaycaster {
    width_px: usize,
    height_px: usize,
    /// Distance from each pixel centre to the nearest wall-cell centre, pixels (row-major);
    /// `f32::INFINITY` when the sketch has no line.
    distance_px: Vec<f32>,
    /// Index of the line of that nearest wall cell, or [`NO_LINE`].
    nearest_line: Vec<u32>,
    lines: Vec<SketchLine>,
}

impl SketchRaycaster {
    /// Rasterizes `sketch.lines` and computes the distance field and nearest-line map.
    /// `O(W·H + Σ line lengths)` time, `8·W·H` bytes.
    pub fn new(sketch: &Sketch) -> Self {
        let (w, h) = (sketch.width_px as usize, sketch.height_px as usize);
        let n = w * h;
        let mut wall_line = vec![NO_LINE; n];
        let mut wall_dist = vec![f64::INFINITY; n];
        for (li, line) in sketch.lines.iter().enumerate() {
            if !(line.a.x.is_finite()
                && line.a.y.is_finite()
                && line.b.x.is_finite()
                && line.b.y.is_finite())
            {
                continue;
            }
            let len = line.length_px();
            let samples = (len / 0.25).ceil().min(1.0e6) as usize + 1;
            for k in 0..=samples {
                let t = k as f64 / samples as f64;
                let x = line.a.x + t * (line.b.x - line.a.x);
                let y = line.a.y + t * (line.b.y - line.a.y);
                if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
                    continue;
                }
                let (col, row) = (x as usize, y as usize);
                let cell = row * w + col;
                let d = point_segment_distance(col as f64 + 0.5, row as f64 + 0.5, line, 0.0);
                if d < wall_dist[cell] {
                    wall_dist[cell] = d;
                    wall_line[cell] = li as u32;
                }
            }
        }
        let (distance_px, nearest_line) = distance_transform(w, h, &wall_line);
        Self {
            width_px: w,
            height_px: h,
            distance_px,
            nearest_line,
            lines: sketch.lines.clone(),
        }
    }

    /// Image width, pixels.
    pub fn width_px(&self) -> usize {
        self.width_px
    }

    /// Image height, pixels.
    pub fn height_px(&self) -> usize {
        self.height_px
    }

    /// The lines this raycaster traces against.
    pub fn lines(&self) -> &[SketchLine] {
        &self.lines
    }

    /// True when `(u, v)` lies inside the image.
    pub fn contains(&self, u_px: f64, v_px: f64) -> bool {
        u_px >= 0.0 && v_px >= 0.0 && u_px < self.width_px as f64 && v_px < self.height_px as f64
    }

    fn cell(&self, u_px: f64, v_px: f64) -> Option<usize> {
        self.contains(u_px, v_px)
            .then(|| v_px as usize * self.width_px + u_px as usize)
    }

    /// The distance-field value at the pixel holding `(u, v)`: distance from its centre to
    /// the nearest wall-cell centre; `None` outside the image. O(1).
    pub fn grid_distance_px(&self, u_px: f64, v_px: f64) -> Option<f64> {
        self.cell(u_px, v_px).map(|c| self.distance_px[c] as f64)
    }

    /// The distance field bilinearly interpolated between the four pixel centres around
    /// `(u, v)`: continuous in the point, within ±1 px of the distance to the nearest
    /// line (the field is to wall-cell centres); `f64::INFINITY` outside the image or
    /// when the sketch has no line. Four lookups: the likelihood field's read
    /// ([`crate::localization::observation_model`]), where the exact
    /// [`SketchRaycaster::distance_to_wall_px`] costs five times as much.
    pub fn interpolated_distance_px(&self, u_px: f64, v_px: f64) -> f64 {
        if !self.contains(u_px, v_px) {
            return f64::INFINITY;
        }
        let (w, h) = (self.width_px, self.height_px);
        // Pixel centres sit at (col + ½, row + ½); clamp at the image's border.
        let (x, y) = (
            (u_px - 0.5).clamp(0.0, (w - 1) as f64),
            (v_px - 0.5).clamp(0.0, (h - 1) as f64),
        );
        let (c0, r0) = (x as usize, y as usize);
        let (c1, r1) = ((c0 + 1).min(w - 1), (r0 + 1).min(h - 1));
        let (fx, fy) = ((x - c0 as f64) as f32, (y - r0 as f64) as f32);
        let at = |c: usize, r: usize| self.distance_px[r * w + c];
        let top = at(c0, r0) + fx * (at(c1, r0) - at(c0, r0));
        let bottom = at(c0, r1) + fx * (at(c1, r1) - at(c0, r1));
        let d = top + fy * (bottom - top);
        if d.is_finite() {
            d as f64
        } else {
            f64::INFINITY
        }
    }

    /// Index of the line nearest to `(u, v)` by the nearest-line map; `None` outside the
    /// image or when the sketch has no line. O(1).
    pub fn nearest_line_index(&self, u_px: f64, v_px: f64) -> Option<usize> {
        let c = self.cell(u_px, v_px)?;
        let l = self.nearest_line[c];
        (l != NO_LINE).then_some(l as usize)
    }

    /// Distance from `(u, v)` to the nearest line, pixels: exact (point to segment) within
    /// 3 px of a line, the distance field (±1 px) farther out; `f64::INFINITY` outside the
    /// image, for non-finite input or when the sketch has no line. O(1).
    pub fn distance_to_wall_px(&self, u_px: f64, v_px: f64) -> f64 {
        let Some(c) = self.cell(u_px, v_px) else {
            return f64::INFINITY;
        };
        let d = self.distance_px[c];
        if d > 3.0 {
            return d as f64;
        }
        let mut best = f64::INFINITY;
        for li in self.neighbour_lines(c) {
            best = best.min(point_segment_distance(u_px, v_px, &self.lines[li], 0.0));
        }
        best.min(d as f64 + 1.5)
    }

    /// True when `(u, v)` is inside the image and more than 1 px from every line. O(1).
    pub fn is_free(&self, u_px: f64, v_px: f64) -> bool {
        self.contains(u_px, v_px) && self.distance_to_wall_px(u_px, v_px) > 1.0
    }

    /// True when `(u, v)` lies inside the drawing's outer boundary: inside the image, and
    /// at least 6 of 8 rays in evenly spaced directions hit a line before leaving the
    /// image (a point outside the outer walls sees lines only on one side). 8 casts.
    pub fn inside_drawing(&self, u_px: f64, v_px: f64) -> bool {
        self.enclosure(u_px, v_px, 8) >= 0.75 - 1e-9
    }

    /// Share (0..1) of `rays` evenly spaced rays from `(u, v)` that hit a line before
    /// leaving the image; 0 outside the image. `rays` casts.
    pub fn enclosure(&self, u_px: f64, v_px: f64, rays: usize) -> f64 {
        if !self.contains(u_px, v_px) || rays == 0 {
            return 0.0;
        }
        let max_px = (self.width_px as f64).hypot(self.height_px as f64);
        let hits = (0..rays)
            .filter(|&k| {
                let a = k as f64 * std::f64::consts::TAU / rays as f64;
                self.cast(u_px, v_px, a, max_px).is_some()
            })
            .count();
        hits as f64 / rays as f64
    }

    /// Distinct line indices of the nearest-line map in the 3×3 cells around `c`.
    fn neighbour_lines(&self, c: usize) -> impl Iterator<Item = usize> {
        let (col, row) = ((c % self.width_px) as isize, (c / self.width_px) as isize);
        let mut found = [NO_LINE; 9];
        let mut n = 0;
        for dr in -1..=1 {
            for dc in -1..=1 {
                let (cc, rr) = (col + dc, row + dr);
                if cc < 0 || rr < 0 || cc >= self.width_px as isize || rr >= self.height_px as isize
                {
                    continue;
                }
                let l = self.nearest_line[rr as usize * self.width_px + cc as usize];
                if l != NO_LINE && !found[..n].contains(&l) {
                    found[n] = l;
                    n += 1;
                }
            }
        }
        found.into_iter().take(n).map(|l| l as usize)
    }

    /// Casts a ray from `(u, v)` (pixels) at `angle_rad` (counter-clockwise from +u as the
    /// drawing is seen: direction `(cos a, −sin a)` in `(u, v)`), up to `max_range_px`.
    /// Returns the first line crossed and the exact distance to it, or `None` when the ray
    /// leaves the image or reaches `max_range_px` first, or on non-finite input.
    pub fn cast(&self, u_px: f64, v_px: f64, angle_rad: f64, max_range_px: f64) -> Option<RayHit> {
        if !(angle_rad.is_finite() && max_range_px > 0.0 && self.contains(u_px, v_px)) {
            return None;
        }
        let (sin, cos) = angle_rad.sin_cos();
        let (du, dv) = (cos, -sin);
        let mut t = 0.0f64;
        while t <= max_range_px {
            let (u, v) = (u_px + t * du, v_px + t * dv);
            let c = self.cell(u, v)?;
            let d = self.distance_px[c];
            if !d.is_finite() {
                return None;
            }
            if d <= NEAR_WALL_PX {
                let mut best: Option<(f64, usize)> = None;
                for li in self.neighbour_lines(c) {
                    if let Some(th) = ray_segment(u_px, v_px, du, dv, &self.lines[li])
                        && best.is_none_or(|(bt, _)| th < bt)
                    {
                        best = Some((th, li));
                    }
                }
                if let Some((th, li)) = best {
                    return (th <= max_range_px).then_some(RayHit {
                        range_px: th,
                        line_index: li,
                    });
                }
                t += MIN_STEP_PX;
            } else {
                t += (d as f64 - 1.5).max(MIN_STEP_PX);
            }
        }
        None
    }
}

/// Distance from `(x, y)` to the segment `line` lengthened by `slack_px` at both ends.
fn point_segment_distance(x: f64, y: f64, line: &SketchLine, slack_px: f64) -> f64 {
    let (ax, ay, bx, by) = (line.a.x, line.a.y, line.b.x, line.b.y);
    let (ex, ey) = (bx - ax, by - ay);
    let len2 = ex * ex + ey * ey;
    if len2 <= 0.0 {
        return (x - ax).hypot(y - ay);
    }
    let len = len2.sqrt();
    let s = (((x - ax) * ex + (y - ay) * ey) / len).clamp(-slack_px, len + slack_px);
    let (px, py) = (ax + ex * s / len, ay + ey * s / len);
    (x - px).hypot(y - py)
}

/// Ray `o + t·d` (unit `d`) against the segment lengthened by [`ENDPOINT_SLACK_PX`]:
/// the `t ≥ 0` of the crossing, or `None` (parallel or missing).
fn ray_segment(ou: f64, ov: f64, du: f64, dv: f64, line: &SketchLine) -> Option<f64> {
    let (ax, ay) = (line.a.x, line.a.y);
    let (ex, ey) = (line.b.x - ax, line.b.y - ay);
    let len = ex.hypot(ey);
    if len <= 0.0 {
        return None;
    }
    // o + t d = a + s e  →  solve with 2-D cross products.
    let denom = du * ey - dv * ex;
    if denom.abs() < 1e-12 * len {
        return None;
    }
    let (wx, wy) = (ax - ou, ay - ov);
    let t = (wx * ey - wy * ex) / denom;
    let s = (wx * dv - wy * du) / denom;
    let slack = ENDPOINT_SLACK_PX / len;
    (t >= 0.0 && s >= -slack && s <= 1.0 + slack).then_some(t)
}

/// Exact squared-Euclidean distance transform with argmin (Felzenszwalb–Huttenlocher),
/// columns then rows; returns the distances (pixels) and each pixel's nearest wall line.
fn distance_transform(w: usize, h: usize, wall_line: &[u32]) -> (Vec<f32>, Vec<u32>) {
    const INF: f64 = f64::INFINITY;
    let n = w * h;
    let mut d1 = vec![INF; n];
    let mut l1 = vec![NO_LINE; n];
    let mut scratch = Envelope::with_capacity(w.max(h));
    let mut f = vec![INF; h];
    let mut out_d = vec![INF; w.max(h)];
    let mut out_arg = vec![usize::MAX; w.max(h)];
    // Pass 1: along each column.
    for col in 0..w {
        for row in 0..h {
            f[row] = if wall_line[row * w + col] != NO_LINE {
                0.0
            } else {
                INF
            };
        }
        scratch.run(&f[..h], &mut out_d[..h], &mut out_arg[..h]);
        for row in 0..h {
            d1[row * w + col] = out_d[row];
            if out_arg[row] != usize::MAX {
                l1[row * w + col] = wall_line[out_arg[row] * w + col];
            }
        }
    }
    // Pass 2: along each row, over the column pass's squared distances.
    let mut distance = vec![f32::INFINITY; n];
    let mut nearest = vec![NO_LINE; n];
    for row in 0..h {
        let base = row * w;
        scratch.run(&d1[base..base + w], &mut out_d[..w], &mut out_arg[..w]);
        for col in 0..w {
            distance[base + col] = out_d[col].sqrt() as f32;
            if out_arg[col] != usize::MAX {
                nearest[base + col] = l1[base + out_arg[col]];
            }
        }
    }
    (distance, nearest)
}

/// Scratch space of the 1-D lower envelope of parabolas `(p − q)² + f(q)`.
struct Envelope {
    sites: Vec<usize>,
    bounds: Vec<f64>,
}

impl Envelope {
    fn with_capacity(n: usize) -> Self {
        Self {
            sites: Vec::with_capacity(n),
            bounds: Vec::with_capacity(n + 1),
        }
    }

    /// `out_d[p] = min_q (p − q)² + f[q]`, `out_arg[p]` the minimizing `q` (`usize::MAX`
    /// when every `f` is infinite). O(n).
    fn run(&mut self, f: &[f64], out_d: &mut [f64], out_arg: &mut [usize]) {
        self.sites.clear();
        self.bounds.clear();
        for (q, &fq) in f.iter().enumerate() {
            if !fq.is_finite() {
                continue;
            }
            let qf = q as f64;
            loop {
                let Some(&v) = self.sites.last() else {
                    self.sites.push(q);
                    self.bounds.push(f64::NEG_INFINITY);
                    break;
                };
                let vf = v as f64;
                let s = ((fq + qf * qf) - (f[v] + vf * vf)) / (2.0 * (qf - vf));
                if s <= *self.bounds.last().unwrap() {
                    self.sites.pop();
                    self.bounds.pop();
                } else {
                    self.sites.push(q);
                    self.bounds.push(s);
                    break;
                }
            }
        }
        if self.sites.is_empty() {
            out_d.fill(f64::INFINITY);
            out_arg.fill(usize::MAX);
            return;
        }
        let mut k = 0;
        for p in 0..f.len() {
            let pf = p as f64;
            while k + 1 < self.sites.len() && self.bounds[k + 1] < pf {
                k += 1;
            }
            let q = self.sites[k];
            let dq = pf - q as f64;
            out_d[p] = dq * dq + f[q];
            out_arg[p] = q;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::Point2;

    fn square(size: u32, lines: &[(f64, f64, f64, f64)]) -> Sketch {
        Sketch {
            width_px: size,
            height_px: size,
            strokes: fixedbitset::FixedBitSet::with_capacity((size * size) as usize),
            lines: lines
                .iter()
                .enumerate()
                .map(|(i, &(a, b, c, d))| SketchLine::new(i, Point2::new(a, b), Point2::new(c, d)))
                .collect(),
        }
    }

    #[test]
    fn distance_field_matches_brute_force() {
        let s = square(40, &[(5.0, 5.0, 30.0, 12.0), (10.0, 35.0, 10.0, 20.0)]);
        let rc = SketchRaycaster::new(&s);
        let walls: Vec<(usize, usize)> = (0..40 * 40)
            .filter(|&c| rc.distance_px[c] == 0.0)
            .map(|c| (c % 40, c / 40))
            .collect();
        assert!(!walls.is_empty());
        for c in 0..40 * 40 {
            let (x, y) = ((c % 40) as f64, (c / 40) as f64);
            let bf = walls
                .iter()
                .map(|&(wx, wy)| (x - wx as f64).hypot(y - wy as f64))
                .fold(f64::INFINITY, f64::min);
            assert!((bf - rc.distance_px[c] as f64).abs() < 1e-4, "cell {c}");
        }
    }

    #[test]
    fn interpolated_distance_is_the_field_at_centres_and_near_the_exact_one_between() {
        let s = square(40, &[(5.0, 5.0, 30.0, 12.0), (10.0, 35.0, 10.0, 20.0)]);
        let rc = SketchRaycaster::new(&s);
        // At a pixel centre it is that pixel's field value.
        for (c, r) in [(3usize, 3usize), (20, 30), (38, 1)] {
            let at = rc.interpolated_distance_px(c as f64 + 0.5, r as f64 + 0.5);
            assert!((at - rc.distance_px[r * 40 + c] as f64).abs() < 1e-5);
        }
        // Between centres, within the field's ±1 px (plus the interpolation's chord) of the
        // exact distance to the lines; halfway between two centres, their mean.
        for k in 0..400 {
            let (u, v) = (0.5 + (k % 20) as f64 * 1.93, 0.5 + (k / 20) as f64 * 1.91);
            let exact = (0..2)
                .map(|i| point_segment_distance(u, v, &s.lines[i], 0.0))
                .fold(f64::INFINITY, f64::min);
            assert!(
                (rc.interpolated_distance_px(u, v) - exact).abs() < 1.5,
                "({u}, {v})"
            );
        }
        let mid = rc.interpolated_distance_px(21.0, 30.5);
        let mean = 0.5 * (rc.distance_px[30 * 40 + 20] + rc.distance_px[30 * 40 + 21]) as f64;
        assert!((mid - mean).abs() < 1e-5);
        assert!(rc.interpolated_distance_px(-1.0, 3.0).is_infinite());
        assert!(square(20, &[]).lines.is_empty());
        assert!(
            SketchRaycaster::new(&square(20, &[]))
                .interpolated_distance_px(5.0, 5.0)
                .is_infinite()
        );
    }

    #[test]
    fn empty_sketch_casts_nothing() {
        let s = square(20, &[]);
        let rc = SketchRaycaster::new(&s);
        assert!(rc.cast(10.0, 10.0, 0.3, 100.0).is_none());
        assert!(rc.distance_to_wall_px(10.0, 10.0).is_infinite());
        assert!(rc.cast(f64::NAN, 10.0, 0.3, 100.0).is_none());
        assert!(rc.cast(10.0, 10.0, f64::INFINITY, 100.0).is_none());
    }
}
