//! The overlay picture: a sketch's extracted lines drawn over its greyed-out strokes.
//!
//! What the HTTP API returns for `GET /v1/sketches/{id}/overlay` and what a person checks
//! after an upload: the stroke mask in light grey on white, every extracted line in its own
//! colour (hues spaced by the golden angle, so neighbouring indices differ), and each line's
//! index written beside its midpoint with the built-in digit font ([`super::font`]).
//! Drawing is `O(W·H + Σ line lengths)`.

use image::{ImageEncoder, Rgb, RgbImage};

use super::Sketch;
use super::font::{draw_text, text_size_px};

/// A saturated colour for line `index`: hue `index · 137.5°` (the golden angle).
pub fn line_colour(index: usize) -> Rgb<u8> {
    let hue = (index as f64 * 137.507_764).rem_euclid(360.0) / 60.0;
    let (s, v) = (0.9, 0.85);
    let c = v * s;
    let x = c * (1.0 - (hue.rem_euclid(2.0) - 1.0).abs());
    let (r, g, b) = match hue as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let to = |f: f64| ((f + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    Rgb([to(r), to(g), to(b)])
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// The drawing's size in white with its stroke mask in `colour` (white alone when the mask
/// does not match the size): the background every picture over a drawing starts from.
pub fn strokes_on_white(sketch: &Sketch, colour: Rgb<u8>) -> RgbImage {
    let (w, h) = (sketch.width_px, sketch.height_px);
    let mut img = RgbImage::from_pixel(w, h, Rgb([255, 255, 255]));
    if sketch.strokes.len() as u64 == w as u64 * h as u64 {
        for i in sketch.strokes.ones() {
            img.put_pixel(i as u32 % w, i as u32 / w, colour);
        }
    }
    img
}

/// Renders the overlay: white background, strokes light grey, lines coloured about
/// `max(2, D / 400)` pixels thick (`D` the diagonal), indices beside the midpoints.
pub fn render_overlay(sketch: &Sketch) -> RgbImage {
    let (w, h) = (sketch.width_px, sketch.height_px);
    let mut img = strokes_on_white(sketch, Rgb([200, 200, 200]));
    let diag = ((w as f64).powi(2) + (h as f64).powi(2)).sqrt();
    let half = ((diag / 800.0).round() as i64).max(1);
    let scale = ((diag / 500.0).round() as u32).clamp(2, 8);
    for line in &sketch.lines {
        let colour = line_colour(line.index);
        let (a, b) = (line.a, line.b);
        let steps = (a.distance(&b).ceil() as usize).clamp(1, 1 << 20);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let (x, y) = (a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
            for dy in -half..half {
                for dx in -half..half {
                    put(
                        &mut img,
                        x.floor() as i64 + dx,
                        y.floor() as i64 + dy,
                        colour,
                    );
                }
            }
        }
    }
    // Labels last, so no line covers a number.
    for line in &sketch.lines {
        let colour = line_colour(line.index);
        let text = line.index.to_string();
        let (tw, th) = text_size_px(&text, scale);
        let len = line.length_px().max(1e-9);
        // Unit normal to the line, in image coordinates.
        let (nx, ny) = (-(line.b.y - line.a.y) / len, (line.b.x - line.a.x) / len);
        let off = (tw.max(th) as f64) * 0.75 + half as f64 + 2.0;
        let cx = 0.5 * (line.a.x + line.b.x) + nx * off;
        let cy = 0.5 * (line.a.y + line.b.y) + ny * off;
        let (x0, y0) = (
            (cx - tw as f64 / 2.0).round() as i64,
            (cy - th as f64 / 2.0).round() as i64,
        );
        for y in y0 - 1..y0 + th as i64 + 1 {
            for x in x0 - 1..x0 + tw as i64 + 1 {
                put(&mut img, x, y, Rgb([255, 255, 255]));
            }
        }
        draw_text(&text, x0, y0, scale, |x, y| put(&mut img, x, y, colour));
    }
    img
}

/// Encodes an RGB image as PNG bytes (empty on the impossible encoder failure of an
/// in-memory write).
pub fn encode_png(img: &RgbImage) -> Vec<u8> {
    let mut out = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut out);
    if encoder
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )
        .is_err()
    {
        out.clear();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sketch::SketchLine;
    use sketchslam_types::Point2;

    #[test]
    fn overlay_draws_lines_and_round_trips_as_png() {
        let sketch = Sketch {
            width_px: 60,
            height_px: 40,
            strokes: fixedbitset::FixedBitSet::with_capacity(60 * 40),
            lines: vec![SketchLine::new(
                0,
                Point2::new(5.0, 20.0),
                Point2::new(55.0, 20.0),
            )],
        };
        let img = render_overlay(&sketch);
        assert_eq!(*img.get_pixel(30, 20), line_colour(0));
        let png = encode_png(&img);
        let back = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(back, img);
    }

    #[test]
    fn colours_differ() {
        assert_ne!(line_colour(0), line_colour(1));
        assert_ne!(line_colour(1), line_colour(2));
    }
}
