//! Line extraction from the stroke mask: the progressive probabilistic Hough transform.
//!
//! Third stage of sketch ingestion: stroke mask → skeleton ([`super::thinning`]) → segments
//! (this module) → merged walls, corners closed ([`super::merge`]) → [`SketchLine`]s
//! numbered from 0, longest first.
//!
//! # Algorithm
//! J. Matas, C. Galambos and J. Kittler, "Robust detection of lines using the progressive
//! probabilistic Hough transform", CVIU 78(1), 2000. A line is `ρ = x cos θ + y sin θ`;
//! the accumulator has `n_θ = π / Δθ` angle bins and `2 ⌈diag / Δρ⌉ + 1` distance bins.
//! The skeleton pixels are visited in a random order (ChaCha8 seeded with
//! [`LineExtractionConfig::seed`], so one image always gives the same lines). Each visited
//! pixel that is still free votes for every `θ`. When one of its bins reaches the vote
//! threshold, the line of that bin is followed from the pixel in both directions through a
//! corridor `±corridor` pixels wide, bridging gaps up to `max_gap`; a total least-squares
//! fit to the pixels found gives a better line, which is followed once more. If the run is
//! at least `min_length` long, its pixels are removed from the image and their votes taken
//! back out of the accumulator, and the segment is output. Because the votes of a line are
//! withdrawn as soon as it is found, later pixels vote only for what remains; the cost is
//! `O(F · n_θ)` for `F` skeleton pixels (each votes and un-votes at most once) plus
//! `O(L · corridor)` per segment walked — well under the full Hough transform's peak search
//! for a drawing of a few thousand stroke pixels.
//!
//! All lengths default to values relative to the image diagonal and to the stroke width
//! (estimated as `stroke pixels / skeleton pixels`), so the same configuration serves a
//! 500-pixel drawing and a 4000-pixel photograph.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

use super::SketchLine;
use super::merge::{MergeTolerances, Segment, merge_chains, merge_collinear, snap_corners};
use super::thinning::zhang_suen;

/// Parameters of line extraction. Lengths are relative (to the image diagonal `D` and the
/// estimated stroke width `s`) and resolved per image by [`LineExtractionConfig::resolve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineExtractionConfig {
    /// Angle resolution of the accumulator, radians. Default 1°.
    pub theta_resolution_rad: f64,
    /// Distance resolution of the accumulator, pixels. Default 1.
    pub rho_resolution_px: f64,
    /// Shortest wall kept, as a fraction of `D`. Default 0.02.
    pub min_length_diag_frac: f64,
    /// Shortest wall kept, in stroke widths (the larger of the two applies). Default 3.
    pub min_length_stroke_widths: f64,
    /// Votes a bin needs before its line is followed, as a fraction of the minimum length.
    /// Default 0.5.
    pub vote_threshold_frac: f64,
    /// Half-width of the corridor followed along a line, in stroke widths (at least 2
    /// pixels). Default 0.5: the skeleton is one pixel wide, the corridor only absorbs
    /// the hand's tremor and the accumulator's angle quantisation.
    pub corridor_stroke_widths: f64,
    /// Largest gap bridged while following a line, as a fraction of `D` (at least 1.5
    /// stroke widths). Default 0.006.
    pub max_gap_diag_frac: f64,
    /// Direction difference under which two fragments can be one wall, radians. Default 12°.
    pub merge_angle_rad: f64,
    /// Perpendicular offset under which two fragments can be one wall, in stroke widths (at
    /// least 3 pixels). Default 1.25.
    pub merge_offset_stroke_widths: f64,
    /// Gap along the wall bridged when merging, as a fraction of `D`. Default 0.012.
    pub merge_gap_diag_frac: f64,
    /// Tremor tolerated when merging fragments joined end to end, as a fraction of the
    /// merged length (see [`MergeTolerances::rel_offset_tol`]). Default 0.05.
    pub merge_rel_offset: f64,
    /// Smallest share of a followed segment's length where its corridor holds stroke
    /// pixels; rejects chords that cross strokes instead of running along one. Default 0.8.
    pub min_fill: f64,
    /// Seed of the random visiting order.
    pub seed: u64,
}

impl Default for LineExtractionConfig {
    fn default() -> Self {
        Self {
            theta_resolution_rad: 1f64.to_radians(),
            rho_resolution_px: 1.0,
            min_length_diag_frac: 0.02,
            min_length_stroke_widths: 3.0,
            vote_threshold_frac: 0.5,
            corridor_stroke_widths: 0.5,
            max_gap_diag_frac: 0.006,
            merge_angle_rad: 12f64.to_radians(),
            merge_offset_stroke_widths: 1.25,
            merge_gap_diag_frac: 0.012,
            merge_rel_offset: 0.05,
            min_fill: 0.8,
            seed: 0x5ce7_c451,
        }
    }
}

/// [`LineExtractionConfig`] resolved to pixels for one image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolvedLineParams {
    /// Estimated stroke width, pixels.
    pub stroke_width_px: f64,
    /// Shortest wall kept, pixels.
    pub min_length_px: f64,
    /// Votes needed before a line is followed.
    pub vote_threshold: u32,
    /// Corridor half-width, pixels.
    pub corridor_px: f64,
    /// Largest gap bridged while following, pixels.
    pub max_gap_px: f64,
    /// Merge tolerances.
    pub merge: MergeTolerances,
}

impl LineExtractionConfig {
    /// Resolves the relative parameters for a `w × h` image with strokes `stroke_width_px`
    /// wide.
    pub fn resolve(&self, w: usize, h: usize, stroke_width_px: f64) -> ResolvedLineParams {
        let diag = ((w * w + h * h) as f64).sqrt();
        let s = if stroke_width_px.is_finite() {
            stroke_width_px.clamp(1.0, 50.0)
        } else {
            1.0
        };
        let min_length_px = (self.min_length_diag_frac * diag)
            .max(self.min_length_stroke_widths * s)
            .max(5.0);
        ResolvedLineParams {
            stroke_width_px: s,
            min_length_px,
            vote_threshold: ((self.vote_threshold_frac * min_length_px).round() as u32).max(5),
            corridor_px: (self.corridor_stroke_widths * s).max(2.0),
            max_gap_px: (self.max_gap_diag_frac * diag).max(1.5 * s),
            merge: MergeTolerances {
                angle_tol_rad: self.merge_angle_rad,
                offset_tol_px: (self.merge_offset_stroke_widths * s).max(3.0),
                gap_tol_px: (self.merge_gap_diag_frac * diag).max(2.0 * s),
                rel_offset_tol: self.merge_rel_offset,
            },
        }
    }
}

/// Extracts the straight walls of a stroke mask: thinning, PPHT, merging, dropping walls
/// shorter than the minimum length. `lines[i].index == i`, longest first. An empty or
/// malformed mask gives no lines.
pub fn extract_lines(
    strokes: &[bool],
    w: usize,
    h: usize,
    config: &LineExtractionConfig,
) -> Vec<SketchLine> {
    if strokes.len() != w * h || w == 0 || h == 0 {
        return Vec::new();
    }
    let mut skeleton = strokes.to_vec();
    zhang_suen(&mut skeleton, w, h);
    let stroke_count = strokes.iter().filter(|&&s| s).count();
    let skeleton_count = skeleton.iter().filter(|&&s| s).count();
    if skeleton_count == 0 {
        return Vec::new();
    }
    let stroke_width_px = stroke_count as f64 / skeleton_count as f64;
    let params = config.resolve(w, h, stroke_width_px);
    let segments = progressive_hough(&skeleton, w, h, config, &params);
    let drawn =
        |p: Point2, q: Point2| skeleton_connects(&skeleton, w, h, p, q, params.stroke_width_px);
    let chains = merge_chains(segments, &params.merge, &drawn);
    let mut merged = merge_collinear(chains, &params.merge);
    merged.retain(|s| s.length_px() >= params.min_length_px);
    snap_corners(
        &mut merged,
        params.corridor_px + params.stroke_width_px + 1.0,
    );
    let mut lines: Vec<SketchLine> = merged
        .into_iter()
        .filter(|s| s.length_px() >= params.min_length_px)
        .map(|s| SketchLine::new(0, s.a, s.b))
        .collect();
    lines.sort_by(|a, b| b.length_px().total_cmp(&a.length_px()));
    for (i, l) in lines.iter_mut().enumerate() {
        l.index = i;
    }
    lines
}

/// True when the skeleton connects `p` and `q` (pixel coordinates, centres at `+0.5`) by a
/// path of at most `1.5 · |pq| + 2 s` pixels, starting and ending within `s` (the stroke
/// width) of them: a breadth-first search over 8-neighbours, bounded by that length, so a
/// few hundred pixels at most.
fn skeleton_connects(skeleton: &[bool], w: usize, h: usize, p: Point2, q: Point2, s: f64) -> bool {
    use std::collections::{HashMap, VecDeque};
    let radius = s.ceil() as i64;
    let max_steps = (1.5 * p.distance(&q) + 2.0 * s).ceil() as u32;
    let pixel = |x: i64, y: i64| -> Option<usize> {
        (x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h)
            .then(|| y as usize * w + x as usize)
            .filter(|&i| skeleton[i])
    };
    let near = |c: Point2| -> Vec<usize> {
        let (cx, cy) = (c.x.floor() as i64, c.y.floor() as i64);
        let mut v = Vec::new();
        for y in cy - radius..=cy + radius {
            for x in cx - radius..=cx + radius {
                if let Some(i) = pixel(x, y) {
                    v.push(i);
                }
            }
        }
        v
    };
    let goals = near(q);
    if goals.is_empty() {
        return false;
    }
    let mut dist: HashMap<usize, u32> = HashMap::new();
    let mut queue = VecDeque::new();
    for i in near(p) {
        dist.insert(i, 0);
        queue.push_back(i);
    }
    while let Some(i) = queue.pop_front() {
        if goals.contains(&i) {
            return true;
        }
        let d = dist[&i];
        if d >= max_steps {
            continue;
        }
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        for dy in -1..=1 {
            for dx in -1..=1 {
                if let Some(j) = pixel(x + dx, y + dy)
                    && !dist.contains_key(&j)
                {
                    dist.insert(j, d + 1);
                    queue.push_back(j);
                }
            }
        }
    }
    false
}

/// Per-pixel state during the transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Px {
    Background,
    Free,
    Voted,
    Used,
}

/// The accumulator with its trigonometric tables.
struct Accumulator {
    n_theta: usize,
    n_rho: usize,
    rho_offset: i64,
    /// `cos θ / Δρ`, `sin θ / Δρ` per angle bin.
    cos_sin: Vec<(f64, f64)>,
    theta_rad: Vec<f64>,
    votes: Vec<u32>,
}

impl Accumulator {
    fn new(w: usize, h: usize, theta_res: f64, rho_res: f64) -> Self {
        let n_theta = ((std::f64::consts::PI / theta_res).round() as usize).clamp(4, 3600);
        let diag = ((w * w + h * h) as f64).sqrt();
        let rho_offset = (diag / rho_res).ceil() as i64 + 1;
        let n_rho = 2 * rho_offset as usize + 1;
        let theta_rad: Vec<f64> = (0..n_theta)
            .map(|t| t as f64 * std::f64::consts::PI / n_theta as f64)
            .collect();
        let cos_sin = theta_rad
            .iter()
            .map(|t| (t.cos() / rho_res, t.sin() / rho_res))
            .collect();
        Self {
            n_theta,
            n_rho,
            rho_offset,
            cos_sin,
            theta_rad,
            votes: vec![0; n_theta * n_rho],
        }
    }

    fn bin(&self, t: usize, x: f64, y: f64) -> usize {
        let (c, s) = self.cos_sin[t];
        let r = ((x * c + y * s).round() as i64 + self.rho_offset).clamp(0, self.n_rho as i64 - 1);
        t * self.n_rho + r as usize
    }

    /// Adds the votes of `(x, y)`; returns the best (votes, θ index) among its bins.
    fn vote(&mut self, x: f64, y: f64) -> (u32, usize) {
        let mut best = (0, 0);
        for t in 0..self.n_theta {
            let b = self.bin(t, x, y);
            self.votes[b] += 1;
            if self.votes[b] > best.0 {
                best = (self.votes[b], t);
            }
        }
        best
    }

    fn unvote(&mut self, x: f64, y: f64) {
        for t in 0..self.n_theta {
            let b = self.bin(t, x, y);
            self.votes[b] = self.votes[b].saturating_sub(1);
        }
    }
}

/// A line to follow: a point on it and its unit direction, pixel-index coordinates.
#[derive(Debug, Clone, Copy)]
struct Ray {
    x: f64,
    y: f64,
    dx: f64,
    dy: f64,
}

/// Follows `ray` both ways through the corridor; returns the free or voted pixels found
/// between the last hits on either side (deduplicated through `stamp`) and the fraction of
/// the unit steps between those ends where the corridor holds a stroke pixel.
fn follow(
    state: &[Px],
    w: usize,
    h: usize,
    ray: Ray,
    params: &ResolvedLineParams,
    stamp: &mut [u32],
    stamp_id: u32,
) -> (Vec<usize>, f64) {
    let c = params.corridor_px;
    let offsets: Vec<f64> = {
        let n = c.floor() as i64;
        (-n..=n).map(|o| o as f64).collect()
    };
    let pixel_at = |k: f64, o: f64| -> Option<usize> {
        let x = (ray.x + k * ray.dx - o * ray.dy).round();
        let y = (ray.y + k * ray.dy + o * ray.dx).round();
        if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
            return None;
        }
        let i = y as usize * w + x as usize;
        matches!(state[i], Px::Free | Px::Voted).then_some(i)
    };
    let hit = |k: f64| offsets.iter().any(|&o| pixel_at(k, o).is_some());
    let max_gap = params.max_gap_px.ceil() as i64;
    let mut ends = [0i64; 2];
    for (side, sign) in [(0usize, 1i64), (1, -1)] {
        let (mut k, mut gap) = (0i64, 0i64);
        // Bounded by the image diagonal: a ray leaves the image within it.
        let limit = (w + h) as i64 + max_gap + 2;
        while gap <= max_gap && k.abs() <= limit {
            k += sign;
            if hit(k as f64) {
                ends[side] = k;
                gap = 0;
            } else {
                gap += 1;
            }
        }
    }
    let mut found = Vec::new();
    let mut hit_steps = 0usize;
    for k in ends[1]..=ends[0] {
        let mut hit_here = false;
        for &o in &offsets {
            if let Some(i) = pixel_at(k as f64, o) {
                hit_here = true;
                if stamp[i] != stamp_id {
                    stamp[i] = stamp_id;
                    found.push(i);
                }
            }
        }
        hit_steps += usize::from(hit_here);
    }
    let steps = (ends[0] - ends[1] + 1) as f64;
    (found, hit_steps as f64 / steps)
}

/// Total least-squares line through pixels: centroid and unit principal direction, with
/// the extent `[t_min, t_max]` of their projections on it.
fn fit(pixels: &[usize], w: usize) -> Option<(Ray, f64, f64)> {
    if pixels.len() < 2 {
        return None;
    }
    let n = pixels.len() as f64;
    let (mut mx, mut my) = (0.0, 0.0);
    for &i in pixels {
        mx += (i % w) as f64;
        my += (i / w) as f64;
    }
    mx /= n;
    my /= n;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for &i in pixels {
        let (x, y) = ((i % w) as f64 - mx, (i / w) as f64 - my);
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
    }
    let phi = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let ray = Ray {
        x: mx,
        y: my,
        dx: phi.cos(),
        dy: phi.sin(),
    };
    let (mut t_min, mut t_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for &i in pixels {
        let t = ((i % w) as f64 - mx) * ray.dx + ((i / w) as f64 - my) * ray.dy;
        t_min = t_min.min(t);
        t_max = t_max.max(t);
    }
    Some((ray, t_min, t_max))
}

/// The progressive probabilistic Hough transform over a skeleton (see the module docs).
/// Returns segments in `(u, v)` pixel coordinates (pixel centres at `+0.5`).
fn progressive_hough(
    skeleton: &[bool],
    w: usize,
    h: usize,
    config: &LineExtractionConfig,
    params: &ResolvedLineParams,
) -> Vec<Segment> {
    let mut state: Vec<Px> = skeleton
        .iter()
        .map(|&s| if s { Px::Free } else { Px::Background })
        .collect();
    let mut order: Vec<usize> = (0..w * h).filter(|&i| skeleton[i]).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    order.shuffle(&mut rng);
    let mut acc = Accumulator::new(w, h, config.theta_resolution_rad, config.rho_resolution_px);
    let mut stamp = vec![0u32; w * h];
    let mut stamp_id = 0u32;
    let mut segments = Vec::new();

    for &p in &order {
        if state[p] != Px::Free {
            continue;
        }
        let (x, y) = ((p % w) as f64, (p / w) as f64);
        let (votes, t) = acc.vote(x, y);
        state[p] = Px::Voted;
        if votes < params.vote_threshold {
            continue;
        }
        // Normal (cos θ, sin θ) → direction (−sin θ, cos θ).
        let theta = acc.theta_rad[t];
        let mut ray = Ray {
            x,
            y,
            dx: -theta.sin(),
            dy: theta.cos(),
        };
        let mut pixels = Vec::new();
        let mut fill = 0.0;
        let mut extent = None;
        // Follow the bin's line, then twice more along the least-squares fit of the pixels
        // found (the bin's angle is only good to ±Δθ/2).
        for _ in 0..3 {
            stamp_id = stamp_id.wrapping_add(1);
            (pixels, fill) = follow(&state, w, h, ray, params, &mut stamp, stamp_id);
            match fit(&pixels, w) {
                Some((r, t0, t1)) => {
                    ray = r;
                    extent = Some((t0, t1));
                }
                None => {
                    extent = None;
                    break;
                }
            }
        }
        let Some((t0, t1)) = extent else { continue };
        // A chord across several strokes meets pixels only where it crosses them.
        if t1 - t0 < params.min_length_px || fill < config.min_fill {
            continue;
        }
        for &i in &pixels {
            if state[i] == Px::Voted {
                acc.unvote((i % w) as f64, (i / w) as f64);
            }
            state[i] = Px::Used;
        }
        segments.push(Segment {
            a: Point2::new(ray.x + t0 * ray.dx + 0.5, ray.y + t0 * ray.dy + 0.5),
            b: Point2::new(ray.x + t1 * ray.dx + 0.5, ray.y + t1 * ray.dy + 0.5),
        });
    }
    segments
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thick_diagonal_stroke_is_one_line() {
        let (w, h) = (200, 200);
        let mut m = vec![false; w * h];
        for k in 0..150 {
            for d in -2i64..=2 {
                let (x, y) = (25 + k, (30 + k / 2) as i64 + d);
                m[y as usize * w + x] = true;
            }
        }
        let lines = extract_lines(&m, w, h, &LineExtractionConfig::default());
        assert_eq!(lines.len(), 1, "{lines:?}");
        let l = &lines[0];
        // Thinning shortens a free end by about half the stroke width.
        assert!((l.length_px() - 167.7).abs() < 8.0, "{l:?}");
        let expected = 0.5f64.atan();
        let angle = std::f64::consts::PI - l.angle_rad;
        assert!((angle - expected).abs() < 0.02, "{} vs {expected}", angle);
    }

    #[test]
    fn same_mask_same_lines() {
        let (w, h) = (120, 120);
        let mut m = vec![false; w * h];
        for k in 10..110 {
            m[20 * w + k] = true;
            m[k * w + 60] = true;
        }
        let a = extract_lines(&m, w, h, &LineExtractionConfig::default());
        let b = extract_lines(&m, w, h, &LineExtractionConfig::default());
        assert_eq!(a, b);
        assert_eq!(a.len(), 2);
    }

    #[test]
    fn empty_masks_give_nothing() {
        assert!(extract_lines(&[], 0, 0, &LineExtractionConfig::default()).is_empty());
        assert!(extract_lines(&[false; 16], 4, 4, &LineExtractionConfig::default()).is_empty());
        assert!(extract_lines(&[true; 3], 4, 4, &LineExtractionConfig::default()).is_empty());
    }
}
