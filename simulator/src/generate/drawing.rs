//! A hand-drawn sketch of a generated floor: the outline of the free space in black pen
//! strokes on white, at the person's guessed 0.1 m per pixel, with wrong proportions (the
//! warps of a [`DrawingMap`]), a wobbling hand, door gaps left open or drawn shut, a room
//! or a short wall left out, and no clutter.
//!
//! [`outline`] finds the walls on the world grid as axis-aligned segments (one line per
//! wall, at its middle);
//! [`render`] carries them through [`DrawingMap::to_canvas`] (the evaluation's formula) and
//! strokes them with a [`Pen`], whose wobble is a smooth displacement field of a couple of
//! pixels — the only deviation from the formula. [`super::photo`] may then photograph it.

use super::floor::Floor;
use super::mapping::DrawingMap;
use super::rect::{PX_PER_M, Rect};
use image::{GrayImage, Luma};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

/// A boundary segment of the free space, world meters, axis-aligned.
pub type Segment = (Point2, Point2);

/// The walls a person draws, as axis-aligned segments in world meters: every drawn area
/// (overlapping corridor pieces and halls merged into one outline) grown to the middle of
/// its walls, so that a thin wall between two rooms is ONE line; an open door leaves a gap
/// in it. `areas[k]` / `open_doors[k]` say which areas are drawn and which doors are gaps.
pub fn outline(floor: &Floor, areas: &[bool], open_doors: &[bool]) -> Vec<Segment> {
    let (w, h) = floor.size_px();
    // Overlapping areas share an outline: union them through the links.
    let mut group: Vec<usize> = (0..floor.areas.len()).collect();
    fn root(g: &mut [usize], k: usize) -> usize {
        let mut r = k;
        while g[r] != r {
            r = g[r];
        }
        g[k] = r;
        r
    }
    for l in &floor.links {
        let (a, b) = (root(&mut group, l.areas[0]), root(&mut group, l.areas[1]));
        group[a.max(b)] = a.min(b);
    }
    let grow = ((floor.wall_m * PX_PER_M).round() / 2.0).ceil() as i64;
    let cell = |v_m: f64| (v_m * PX_PER_M).round() as i64;
    let mut label = vec![0usize; w * h];
    for (k, a) in floor.areas.iter().enumerate() {
        if !areas[k] {
            continue;
        }
        let id = root(&mut group, k) + 1;
        let r = &a.rect;
        let (i0, i1) = (
            (cell(r.x0_m) - grow).max(0),
            (cell(r.x1_m) + grow).min(w as i64),
        );
        let (j0, j1) = (
            (cell(r.y0_m) - grow).max(0),
            (cell(r.y1_m) + grow).min(h as i64),
        );
        for j in j0..j1 {
            label[j as usize * w + i0 as usize..j as usize * w + i1 as usize].fill(id);
        }
    }
    // Gaps: each open door's opening, through the grown walls on both sides.
    let reach = (grow + 1) as f64 / PX_PER_M;
    let gaps: Vec<Rect> = floor
        .doors
        .iter()
        .zip(open_doors)
        .filter(|(d, open)| **open && d.areas.iter().all(|&a| areas[a]))
        .map(|(d, _)| {
            let r = d.rect;
            if r.width_m() < r.height_m() {
                Rect {
                    x0_m: r.x0_m - reach,
                    x1_m: r.x1_m + reach,
                    ..r
                }
            } else {
                Rect {
                    y0_m: r.y0_m - reach,
                    y1_m: r.y1_m + reach,
                    ..r
                }
            }
        })
        .collect();
    let in_gap = |x: f64, y: f64| gaps.iter().any(|g| g.contains(Point2::new(x, y), 0.0));
    let at = |i: i64, j: i64| {
        if i >= 0 && j >= 0 && (i as usize) < w && (j as usize) < h {
            label[j as usize * w + i as usize]
        } else {
            0
        }
    };
    let m = |c: i64| c as f64 / PX_PER_M;
    let mut out = Vec::new();
    let mut flush = |run: &mut Option<i64>, end: i64, line: i64, horizontal: bool| {
        if let Some(start) = run.take() {
            out.push(if horizontal {
                (Point2::new(m(start), m(line)), Point2::new(m(end), m(line)))
            } else {
                (Point2::new(m(line), m(start)), Point2::new(m(line), m(end)))
            });
        }
    };
    for j in 0..=h as i64 {
        let mut run = None;
        for i in 0..=w as i64 {
            let edge = i < w as i64 && at(i, j - 1) != at(i, j) && !in_gap(m(i) + 0.025, m(j));
            if edge && run.is_none() {
                run = Some(i);
            } else if !edge {
                flush(&mut run, i, j, true);
            }
        }
    }
    for i in 0..=w as i64 {
        let mut run = None;
        for j in 0..=h as i64 {
            let edge = j < h as i64 && at(i - 1, j) != at(i, j) && !in_gap(m(i), m(j) + 0.025);
            if edge && run.is_none() {
                run = Some(j);
            } else if !edge {
                flush(&mut run, j, i, false);
            }
        }
    }
    out
}

/// The hand: stroke width, ink, and the wobble field.
#[derive(Debug, Clone)]
pub struct Pen {
    /// Half the stroke width, pixels.
    pub radius_px: f64,
    /// Darkness of the ink, 0..1.
    pub ink: f64,
    /// Plane waves `(k_u, k_v, phase, amp_u, amp_v)` whose sum displaces every stroke
    /// point, pixels.
    waves: Vec<[f64; 5]>,
}

impl Pen {
    /// A random hand: strokes 2–3 px wide, a wobble of at most `wobble_px` pixels with
    /// wavelengths of 40–150 px.
    pub fn random(wobble_px: f64, rng: &mut ChaCha8Rng) -> Pen {
        let n = 3;
        let waves = (0..n)
            .map(|_| {
                let dir = rng.random_range(0.0..std::f64::consts::TAU);
                let k = std::f64::consts::TAU / rng.random_range(40.0..150.0);
                let amp = wobble_px / n as f64;
                [
                    k * dir.cos(),
                    k * dir.sin(),
                    rng.random_range(0.0..std::f64::consts::TAU),
                    amp * rng.random_range(0.6..1.0),
                    amp * rng.random_range(0.6..1.0),
                ]
            })
            .collect();
        Pen {
            radius_px: rng.random_range(1.0..1.5),
            ink: rng.random_range(0.85..1.0),
            waves,
        }
    }

    /// The wobble displacement at canvas point `(u, v)`, pixels.
    pub fn wobble(&self, u: f64, v: f64) -> (f64, f64) {
        self.waves.iter().fold((0.0, 0.0), |(du, dv), w| {
            let s = (w[0] * u + w[1] * v + w[2]).sin();
            let c = (w[1] * u - w[0] * v + w[2]).cos();
            (du + w[3] * s, dv + w[4] * c)
        })
    }
}

/// Strokes `segments` (world meters) onto a white canvas of `map`'s size (before any turn).
pub fn render(map: &DrawingMap, segments: &[Segment], pen: &Pen) -> GrayImage {
    let (w, h) = (map.width_px as usize, map.height_px as usize);
    let mut dark = vec![0f32; w * h];
    let r = pen.radius_px;
    let mut stamp = |u: f64, v: f64| {
        let (i0, i1) = (
            (u - r - 1.0).floor().max(0.0) as usize,
            ((u + r + 1.0).ceil().max(0.0) as usize).min(w - 1),
        );
        let (j0, j1) = (
            (v - r - 1.0).floor().max(0.0) as usize,
            ((v + r + 1.0).ceil().max(0.0) as usize).min(h - 1),
        );
        for j in j0..=j1 {
            for i in i0..=i1 {
                let d = (i as f64 - u).hypot(j as f64 - v);
                let a = ((r + 0.5 - d).clamp(0.0, 1.0) * pen.ink) as f32;
                let cell = &mut dark[j * w + i];
                *cell = cell.max(a);
            }
        }
    };
    for &(a, b) in segments {
        let (ua, va) = map.to_canvas(a.x, a.y);
        let (ub, vb) = map.to_canvas(b.x, b.y);
        let n = ((ub - ua).hypot(vb - va) / 0.4).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            // Through the world point, so a warp's knot inside the segment is honoured.
            let p = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
            let (u, v) = map.to_canvas(p.x, p.y);
            let (du, dv) = pen.wobble(u, v);
            stamp(u + du, v + dv);
        }
    }
    GrayImage::from_fn(w as u32, h as u32, |i, j| {
        let a = dark[j as usize * w + i as usize] as f64;
        Luma([(255.0 - a * 230.0).round().clamp(0.0, 255.0) as u8])
    })
}
