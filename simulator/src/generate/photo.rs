//! Photographed paper: a flat drawing from [`super::drawing`] turned by the map's
//! `rotate_deg` into the enlarged canvas (exactly as `sketch-truth.toml` says), lit
//! unevenly (a brightness gradient and a vignette that make the paper grey), slightly
//! blurred and grainy. [`super::files`] saves the result as JPEG.

use super::mapping::DrawingMap;
use image::{GrayImage, Luma};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// How the photograph was taken, for the scenario's comment.
#[derive(Debug, Clone, PartialEq)]
pub struct Photo {
    /// Darkest paper, as a share of white.
    pub darkest: f64,
    /// Gaussian blur, pixels.
    pub blur_px: f64,
    /// JPEG quality.
    pub quality: u8,
}

/// Photographs `flat` (the drawing before the turn) through `map`.
pub fn photograph(flat: &GrayImage, map: &DrawingMap, rng: &mut ChaCha8Rng) -> (GrayImage, Photo) {
    let (new_w, new_h) = map.rotated_size();
    let (w, h) = (new_w as u32, new_h as u32);
    // The light: brightest at a random point, falling off linearly and radially.
    let (lu, lv) = (rng.random_range(0.0..new_w), rng.random_range(0.0..new_h));
    let base = rng.random_range(0.88..0.97);
    let fall = rng.random_range(0.15..0.3);
    let diag = new_w.hypot(new_h);
    let light = |u: f64, v: f64| {
        let r = (u - lu).hypot(v - lv) / diag;
        base * (1.0 - fall * r - 0.5 * fall * r * r)
    };
    let turned = GrayImage::from_fn(w, h, |i, j| {
        let (u, v) = map.unrotate(i as f64, j as f64);
        let paper = bilinear(flat, u, v);
        Luma([(paper * light(i as f64, j as f64))
            .round()
            .clamp(0.0, 255.0) as u8])
    });
    let blur_px = rng.random_range(0.6..1.0);
    let mut out = gaussian_blur(&turned, blur_px);
    let grain = Normal::new(0.0, rng.random_range(1.5..3.5)).expect("positive sd");
    for p in out.pixels_mut() {
        p.0[0] = (p.0[0] as f64 + grain.sample(rng))
            .round()
            .clamp(0.0, 255.0) as u8;
    }
    let darkest = base * (1.0 - 1.5 * fall);
    let quality = rng.random_range(70..=85);
    (
        out,
        Photo {
            darkest,
            blur_px,
            quality,
        },
    )
}

/// `img` at the real pixel position `(u, v)` (pixel `i` at `u = i`), white outside.
fn bilinear(img: &GrayImage, u: f64, v: f64) -> f64 {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (i0, j0) = (u.floor() as i64, v.floor() as i64);
    let (fu, fv) = (u - i0 as f64, v - j0 as f64);
    let px = |i: i64, j: i64| {
        if i < 0 || j < 0 || i >= w || j >= h {
            255.0
        } else {
            img.get_pixel(i as u32, j as u32).0[0] as f64
        }
    };
    let top = px(i0, j0) * (1.0 - fu) + px(i0 + 1, j0) * fu;
    let bottom = px(i0, j0 + 1) * (1.0 - fu) + px(i0 + 1, j0 + 1) * fu;
    top * (1.0 - fv) + bottom * fv
}

/// A separable Gaussian blur of standard deviation `sigma_px` (edges clamped).
fn gaussian_blur(img: &GrayImage, sigma_px: f64) -> GrayImage {
    let r = (2.5 * sigma_px).ceil() as i64;
    let kernel: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let sum: f64 = kernel.iter().sum();
    let (w, h) = (img.width() as i64, img.height() as i64);
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        let mut dst = vec![0.0; src.len()];
        for j in 0..h {
            for i in 0..w {
                let mut acc = 0.0;
                for (k, wk) in kernel.iter().enumerate() {
                    let o = k as i64 - r;
                    let (ii, jj) = if horizontal {
                        ((i + o).clamp(0, w - 1), j)
                    } else {
                        (i, (j + o).clamp(0, h - 1))
                    };
                    acc += wk * src[(jj * w + ii) as usize];
                }
                dst[(j * w + i) as usize] = acc / sum;
            }
        }
        dst
    };
    let src: Vec<f64> = img.pixels().map(|p| p.0[0] as f64).collect();
    let out = pass(&pass(&src, true), false);
    GrayImage::from_fn(w as u32, h as u32, |i, j| {
        Luma([out[(j as i64 * w + i as i64) as usize]
            .round()
            .clamp(0.0, 255.0) as u8])
    })
}
