//! A hand-drawn sketch of a generated floor: the outline of the free space in black pen
//! strokes on white, at the person's guessed 0.1 m per pixel, with wrong proportions (the
//! warps of a [`DrawingMap`]), a wobbling hand, door gaps left open or drawn shut, a room
//! or a short wall left out, and no clutter.
//!
//! [`outline`] finds the free space's boundary on the world grid as axis-aligned segments;
//! [`render`] carries them through [`DrawingMap::to_canvas`] (the evaluation's formula) and
//! strokes them with a [`Pen`], whose wobble is a smooth displacement field of a couple of
//! pixels — the only deviation from the formula. [`super::photo`] may then photograph it.

use super::floor::PX_PER_M;
use super::mapping::DrawingMap;
use image::{GrayImage, Luma};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

/// A boundary segment of the free space, world meters, axis-aligned.
pub type Segment = (Point2, Point2);

/// The boundary between free and wall cells of `free` (`w × h`, row-major from the bottom;
/// outside counts as wall), merged into maximal horizontal and vertical segments.
pub fn outline(free: &[bool], w: usize, h: usize) -> Vec<Segment> {
    let at = |i: i64, j: i64| {
        i >= 0
            && j >= 0
            && (i as usize) < w
            && (j as usize) < h
            && free[j as usize * w + i as usize]
    };
    let mut out = Vec::new();
    let m = |c: usize| c as f64 / PX_PER_M;
    // Horizontal grid lines y = j.
    for j in 0..=h as i64 {
        let mut run: Option<usize> = None;
        for i in 0..=w {
            let edge = i < w && at(i as i64, j - 1) != at(i as i64, j);
            match (edge, run) {
                (true, None) => run = Some(i),
                (false, Some(i0)) => {
                    out.push((
                        Point2::new(m(i0), m(j as usize)),
                        Point2::new(m(i), m(j as usize)),
                    ));
                    run = None;
                }
                _ => {}
            }
        }
    }
    // Vertical grid lines x = i.
    for i in 0..=w as i64 {
        let mut run: Option<usize> = None;
        for j in 0..=h {
            let edge = j < h && at(i - 1, j as i64) != at(i, j as i64);
            match (edge, run) {
                (true, None) => run = Some(j),
                (false, Some(j0)) => {
                    out.push((
                        Point2::new(m(i as usize), m(j0)),
                        Point2::new(m(i as usize), m(j)),
                    ));
                    run = None;
                }
                _ => {}
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
