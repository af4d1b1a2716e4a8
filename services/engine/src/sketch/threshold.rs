//! Stroke detection: which pixels of a grey-level drawing the person drew.
//!
//! Second stage of sketch ingestion (after decoding, before line extraction). A drawing can
//! be dark ink on white paper, white strokes on a black canvas, or pencil on a photographed
//! sheet with uneven lighting and paper texture, so a global threshold at 128 does not do.
//! The method is a **local adaptive threshold** in the spirit of Bradley & Roth, "Adaptive
//! thresholding using the integral image" (J. Graphics Tools, 2007):
//!
//! 1. light smoothing, a `(2r+1)²` box mean with `r = smoothing_radius_px`, which divides
//!    pixel noise (paper grain, sensor noise) by `2r + 1`;
//! 2. the local background `m(u, v)`: the mean over a large `(2R+1)²` window with
//!    `R = window_frac · max(width, height)`; the difference `d = I_smooth − m` removes
//!    lighting gradients whose scale is larger than the window;
//! 3. a noise level from the data, `σ = 1.4826 · MAD(d)` (the median absolute deviation is
//!    untouched by the few stroke pixels), and a contrast threshold
//!    `T = max(min_contrast, noise_k · σ)`;
//! 4. the **polarity** from the image: strokes are the minority, so they form the heavy tail
//!    of `d`. The tail masses `Σ (|d| − T)` over `d < −T` and over `d > T` are compared; the
//!    larger one says whether strokes are darker or lighter than their surroundings;
//! 5. stroke pixels: `s · d > T` with `s = ±1` the polarity;
//! 6. speckle removal: 8-connected components smaller than `min_component_frac · diagonal`
//!    pixels are dropped (dust, paper texture, JPEG ringing).
//!
//! Box means use running sums (separable, the 1-D form of the integral image), so the cost
//! is `O(W·H)` time and `O(W·H)` memory whatever the window sizes.

use crate::EngineError;

/// Parameters of stroke detection. All sizes are relative to the image so the same values
/// serve a 300-pixel scan and a 4000-pixel photograph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThresholdConfig {
    /// Half-width of the smoothing box, pixels. Default 1 (a 3 × 3 box).
    pub smoothing_radius_px: usize,
    /// Half-width of the local background window as a fraction of `max(width, height)`.
    /// Default 1/16 (Bradley & Roth's window of one eighth of the image).
    pub window_frac: f64,
    /// Smallest grey-level difference from the local background that counts as a stroke.
    /// Default 24 (of 255).
    pub min_contrast: f64,
    /// Threshold in units of the estimated noise σ. Default 4.
    pub noise_k: f64,
    /// Components with fewer pixels than this fraction of the image diagonal are speckle.
    /// Default 0.01 (at least the `(2r+1)² + 1` pixels a smoothed dot covers).
    pub min_component_frac: f64,
}

impl Default for ThresholdConfig {
    fn default() -> Self {
        Self {
            smoothing_radius_px: 1,
            window_frac: 1.0 / 16.0,
            min_contrast: 24.0,
            noise_k: 4.0,
            min_component_frac: 0.01,
        }
    }
}

/// Mean of `src` over the `(2r+1)²` box around each pixel, the box clipped at the borders
/// (the mean is over the pixels inside). Separable running sums: `O(W·H)` for any `r`.
pub fn box_mean(src: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let mut tmp = vec![0.0f32; w * h];
    let mut prefix = vec![0.0f64; w.max(h) + 1];
    // Horizontal pass.
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        for x in 0..w {
            prefix[x + 1] = prefix[x] + row[x] as f64;
        }
        for x in 0..w {
            let (lo, hi) = (x.saturating_sub(r), (x + r + 1).min(w));
            tmp[y * w + x] = ((prefix[hi] - prefix[lo]) / (hi - lo) as f64) as f32;
        }
    }
    // Vertical pass.
    let mut out = vec![0.0f32; w * h];
    for x in 0..w {
        for y in 0..h {
            prefix[y + 1] = prefix[y] + tmp[y * w + x] as f64;
        }
        for y in 0..h {
            let (lo, hi) = (y.saturating_sub(r), (y + r + 1).min(h));
            out[y * w + x] = ((prefix[hi] - prefix[lo]) / (hi - lo) as f64) as f32;
        }
    }
    out
}

/// Median of values already quantised to the bins of a histogram over `[lo, lo + n)`.
fn histogram_median(hist: &[u64], lo: f64) -> f64 {
    let total: u64 = hist.iter().sum();
    let mut acc = 0;
    for (i, c) in hist.iter().enumerate() {
        acc += c;
        if 2 * acc >= total {
            return lo + i as f64;
        }
    }
    lo
}

/// Finds the stroke pixels of a grey-level drawing (see the module docs for the method).
///
/// `gray` is row-major `w × h`, 0 black to 255 white. Returns the row-major stroke mask.
///
/// # Errors
/// [`EngineError::NoStrokes`] for a blank or uniform page (nothing stands out of the
/// background, or only speckle does); [`EngineError::InvalidParameter`] when `gray` does
/// not hold `w × h` pixels.
pub fn detect_strokes(
    gray: &[u8],
    w: usize,
    h: usize,
    config: &ThresholdConfig,
) -> Result<Vec<bool>, EngineError> {
    if gray.len() != w * h {
        return Err(EngineError::InvalidParameter {
            name: "gray",
            reason: format!("{} pixels for a {w} × {h} image", gray.len()),
        });
    }
    if w == 0 || h == 0 {
        return Err(EngineError::ImageEmpty);
    }
    let src: Vec<f32> = gray.iter().map(|&g| g as f32).collect();
    let smooth = if config.smoothing_radius_px > 0 {
        box_mean(&src, w, h, config.smoothing_radius_px)
    } else {
        src
    };
    let window_r = ((config.window_frac * w.max(h) as f64).round() as usize).max(7);
    let background = box_mean(&smooth, w, h, window_r);
    let diff: Vec<f32> = smooth.iter().zip(&background).map(|(s, m)| s - m).collect();

    // Robust noise level: MAD over a 1-grey-level histogram of d ∈ [−255, 255].
    let mut hist = vec![0u64; 511];
    for &d in &diff {
        hist[(d.round() as i64 + 255).clamp(0, 510) as usize] += 1;
    }
    let median = histogram_median(&hist, -255.0);
    let mut dev_hist = vec![0u64; 511];
    for &d in &diff {
        dev_hist[((d as f64 - median).abs().round() as usize).min(510)] += 1;
    }
    let sigma = 1.4826 * histogram_median(&dev_hist, 0.0);
    let threshold = config.min_contrast.max(config.noise_k * sigma) as f32;

    // Polarity: the heavier tail beyond the threshold is the strokes'.
    let (mut dark_mass, mut light_mass) = (0.0f64, 0.0f64);
    for &d in &diff {
        if d < -threshold {
            dark_mass += (-d - threshold) as f64;
        } else if d > threshold {
            light_mass += (d - threshold) as f64;
        }
    }
    if dark_mass == 0.0 && light_mass == 0.0 {
        return Err(EngineError::NoStrokes);
    }
    let sign: f32 = if dark_mass >= light_mass { -1.0 } else { 1.0 };
    let mut mask: Vec<bool> = diff.iter().map(|&d| sign * d > threshold).collect();

    let diagonal = ((w * w + h * h) as f64).sqrt();
    // A one-pixel dot smoothed by the box becomes (2r + 1)² pixels: always speckle.
    let smoothed_dot = (2 * config.smoothing_radius_px + 1).pow(2) + 1;
    let min_component = ((config.min_component_frac * diagonal).round() as usize).max(smoothed_dot);
    remove_small_components(&mut mask, w, h, min_component);
    if mask.iter().filter(|&&m| m).count() < min_component {
        return Err(EngineError::NoStrokes);
    }
    Ok(mask)
}

/// Clears the 8-connected components of `mask` with fewer than `min_pixels` pixels.
/// Iterative flood fill with an explicit stack: `O(W·H)`, no recursion.
pub fn remove_small_components(mask: &mut [bool], w: usize, h: usize, min_pixels: usize) {
    let mut seen = vec![false; w * h];
    let mut stack = Vec::new();
    let mut component = Vec::new();
    for start in 0..w * h {
        if !mask[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        component.clear();
        while let Some(i) = stack.pop() {
            component.push(i);
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if mask[j] && !seen[j] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        if component.len() < min_pixels {
            for &i in &component {
                mask[i] = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(dark_on_light: bool) -> (Vec<u8>, usize, usize) {
        let (w, h) = (120, 90);
        let (bg, ink) = if dark_on_light { (230, 20) } else { (10, 240) };
        let mut g = vec![bg; w * h];
        for x in 20..100 {
            for t in 0..3 {
                g[(20 + t) * w + x] = ink;
                g[(70 + t) * w + x] = ink;
            }
        }
        (g, w, h)
    }

    #[test]
    fn both_polarities_give_the_same_mask() {
        let (a, w, h) = square(true);
        let (b, _, _) = square(false);
        let ma = detect_strokes(&a, w, h, &ThresholdConfig::default()).unwrap();
        let mb = detect_strokes(&b, w, h, &ThresholdConfig::default()).unwrap();
        assert_eq!(ma, mb);
        assert!(ma[21 * w + 50] && !ma[45 * w + 50]);
    }

    #[test]
    fn uniform_page_has_no_strokes() {
        let g = vec![200u8; 64 * 64];
        assert!(matches!(
            detect_strokes(&g, 64, 64, &ThresholdConfig::default()),
            Err(EngineError::NoStrokes)
        ));
    }

    #[test]
    fn speckle_is_removed() {
        let (w, h) = (100, 100);
        let mut g = vec![255u8; w * h];
        g[50 * w + 50] = 0;
        g[10 * w + 80] = 0;
        assert!(matches!(
            detect_strokes(&g, w, h, &ThresholdConfig::default()),
            Err(EngineError::NoStrokes)
        ));
    }

    #[test]
    fn box_mean_of_constant_is_constant() {
        let src = vec![3.0f32; 7 * 5];
        assert!(
            box_mean(&src, 7, 5, 2)
                .iter()
                .all(|&m| (m - 3.0).abs() < 1e-6)
        );
    }
}
