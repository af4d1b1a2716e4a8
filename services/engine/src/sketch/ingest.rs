//! Sketch ingestion: uploaded image bytes (PNG or JPEG) become a [`Sketch`].
//!
//! First stage of the pipeline (see the crate docs). The bytes are checked before any pixel
//! is decoded — byte count, then the width and height written in the header — so a file that
//! *claims* to be 50 000 × 50 000 is refused without allocating; the decoder then runs under
//! `image`'s [`Limits`] as a second fence. The decoded picture is reduced to grey levels
//! ([`to_gray`]), its strokes found by a local adaptive threshold
//! ([`super::threshold::detect_strokes`]) and its straight walls extracted
//! ([`super::hough::extract_lines`]).
//!
//! Every input byte string gives either a sketch or a typed [`EngineError`], never a panic:
//! [`EngineError::ImageDecode`] (not an image, truncated), [`EngineError::ImageEmpty`] (0
//! pixels), [`EngineError::ImageTooLarge`] (pixels or bytes), [`EngineError::NoStrokes`]
//! (blank page), [`EngineError::NoLines`] (strokes but nothing straight).

use std::io::Cursor;

use image::{DynamicImage, ImageError, ImageReader, Limits};

use super::Sketch;
use super::hough::{LineExtractionConfig, extract_lines};
use super::jpeg_check::{jpeg_data_can_fill_header, jpeg_is_complete};
use super::threshold::{ThresholdConfig, detect_strokes};
use crate::EngineError;

/// Size limits an uploaded drawing must respect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SketchLimits {
    /// Largest accepted `width × height`, pixels. Default 16 megapixels.
    pub max_pixels: u64,
    /// Largest accepted encoded size, bytes. Default 20 MB (20 × 2²⁰ bytes).
    pub max_bytes: usize,
}

impl Default for SketchLimits {
    fn default() -> Self {
        Self {
            max_pixels: 16_000_000,
            max_bytes: 20 * 1024 * 1024,
        }
    }
}

/// Everything that steers ingestion: limits, stroke detection and line extraction.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SketchOptions {
    /// Size limits.
    pub limits: SketchLimits,
    /// Stroke detection parameters.
    pub threshold: ThresholdConfig,
    /// Line extraction parameters.
    pub lines: LineExtractionConfig,
}

/// A decoded grey-level picture, row-major, one byte per pixel (0 black, 255 white).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GrayImage {
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
    /// Row-major grey levels, `width_px × height_px`.
    pub pixels: Vec<u8>,
}

impl Sketch {
    /// Decodes a PNG or JPEG drawing and extracts its strokes and lines with the default
    /// [`SketchOptions`].
    ///
    /// # Errors
    /// [`EngineError::ImageDecode`], [`EngineError::ImageEmpty`],
    /// [`EngineError::ImageTooLarge`], [`EngineError::NoStrokes`], [`EngineError::NoLines`].
    pub fn from_image_bytes(bytes: &[u8]) -> Result<Sketch, EngineError> {
        Self::from_image_bytes_with(bytes, &SketchOptions::default())
    }

    /// [`Sketch::from_image_bytes`] with explicit options.
    ///
    /// # Errors
    /// As [`Sketch::from_image_bytes`].
    pub fn from_image_bytes_with(
        bytes: &[u8],
        options: &SketchOptions,
    ) -> Result<Sketch, EngineError> {
        let gray = decode_gray(bytes, &options.limits)?;
        Self::from_gray(&gray, options)
    }

    /// Builds a sketch from an already decoded grey-level picture (strokes, then lines).
    ///
    /// # Errors
    /// [`EngineError::ImageEmpty`], [`EngineError::NoStrokes`], [`EngineError::NoLines`],
    /// [`EngineError::InvalidParameter`] when the pixel buffer does not match the size.
    pub fn from_gray(gray: &GrayImage, options: &SketchOptions) -> Result<Sketch, EngineError> {
        let (w, h) = (gray.width_px, gray.height_px);
        if w == 0 || h == 0 {
            return Err(EngineError::ImageEmpty);
        }
        if gray.pixels.len() as u64 != w as u64 * h as u64 {
            return Err(EngineError::InvalidParameter {
                name: "gray.pixels",
                reason: format!("{} bytes for a {w} × {h} image", gray.pixels.len()),
            });
        }
        let strokes = detect_strokes(&gray.pixels, w as usize, h as usize, &options.threshold)?;
        let lines = extract_lines(&strokes, w as usize, h as usize, &options.lines);
        if lines.is_empty() {
            return Err(EngineError::NoLines);
        }
        Ok(Sketch {
            width_px: w,
            height_px: h,
            strokes: Sketch::mask_from_flags(&strokes),
            lines,
        })
    }
}

/// Width and height written in a PNG's IHDR chunk, if `bytes` starts like a PNG.
///
/// Layout: 8-byte signature, then the first chunk: length (4), type `IHDR` (4), width (4,
/// big-endian), height (4, big-endian), ... Read directly so that a lying header is caught
/// before any decoder runs.
fn png_header_dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    if bytes.len() < 24 || bytes[..8] != SIGNATURE || &bytes[12..16] != b"IHDR" {
        return None;
    }
    let w = u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
    let h = u32::from_be_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
    Some((w, h))
}

/// Refuses `w × h` when it is empty or over the pixel limit.
fn check_dimensions(w: u32, h: u32, limits: &SketchLimits) -> Result<(), EngineError> {
    if w == 0 || h == 0 {
        return Err(EngineError::ImageEmpty);
    }
    let pixels = w as u64 * h as u64;
    if pixels > limits.max_pixels {
        return Err(EngineError::ImageTooLarge(format!(
            "{w} × {h} = {pixels} pixels, the limit is {}",
            limits.max_pixels
        )));
    }
    Ok(())
}

fn map_image_error(err: ImageError) -> EngineError {
    match err {
        ImageError::Limits(e) => EngineError::ImageTooLarge(e.to_string()),
        other => EngineError::ImageDecode(other.to_string()),
    }
}

/// Decodes PNG or JPEG bytes to grey levels, checking sizes before decoding pixels.
///
/// # Errors
/// [`EngineError::ImageTooLarge`] (bytes or header dimensions over `limits`),
/// [`EngineError::ImageEmpty`] (a 0-pixel header), [`EngineError::ImageDecode`] (anything
/// else that is not a complete PNG/JPEG).
pub fn decode_gray(bytes: &[u8], limits: &SketchLimits) -> Result<GrayImage, EngineError> {
    if bytes.len() > limits.max_bytes {
        return Err(EngineError::ImageTooLarge(format!(
            "{} bytes, the limit is {}",
            bytes.len(),
            limits.max_bytes
        )));
    }
    if bytes.is_empty() {
        return Err(EngineError::ImageDecode("no bytes".into()));
    }
    // A PNG's IHDR is checked by hand first: the decoder may want more of the file than a
    // lying header comes with, and "too large" is the truthful answer for it.
    if let Some((w, h)) = png_header_dimensions(bytes) {
        check_dimensions(w, h, limits)?;
    }
    let reader = || -> Result<ImageReader<Cursor<&[u8]>>, EngineError> {
        let reader = ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| EngineError::ImageDecode(e.to_string()))?;
        match reader.format() {
            Some(image::ImageFormat::Png | image::ImageFormat::Jpeg) => Ok(reader),
            Some(other) => Err(EngineError::ImageDecode(format!(
                "{other:?} is not accepted, only PNG or JPEG"
            ))),
            None => Err(EngineError::ImageDecode(
                "not a PNG or JPEG (unknown format)".into(),
            )),
        }
    };
    let (w, h) = reader()?.into_dimensions().map_err(map_image_error)?;
    check_dimensions(w, h, limits)?;
    if bytes.starts_with(&[0xFF, 0xD8]) {
        if !jpeg_is_complete(bytes) {
            // The decoder fills what is missing with grey, and the cut becomes a drawn wall.
            return Err(EngineError::ImageDecode(
                "the JPEG is cut short (no end-of-image marker after its image data)".into(),
            ));
        }
        if !jpeg_data_can_fill_header(bytes) {
            return Err(EngineError::ImageDecode(format!(
                "the JPEG's image data are too short for the {w} × {h} px picture its header \
                 declares (damaged, or a header that does not match its data)"
            )));
        }
    }

    let mut decoder_limits = Limits::default();
    decoder_limits.max_image_width = Some(w);
    decoder_limits.max_image_height = Some(h);
    // Output at most 16 bits × 4 channels per pixel, plus decoder working memory.
    decoder_limits.max_alloc = Some((limits.max_pixels * 8).saturating_add(64 << 20));
    let mut reader = reader()?;
    reader.limits(decoder_limits);
    let image = reader.decode().map_err(map_image_error)?;
    if image.width() == 0 || image.height() == 0 {
        return Err(EngineError::ImageEmpty);
    }
    Ok(to_gray(&image))
}

/// Reduces a decoded image to grey levels (Rec. 601 luma, `Y = 0.299 R + 0.587 G + 0.114 B`).
///
/// Transparency: a drawing saved with a transparent background has its strokes in the
/// opaque pixels. The opaque pixels' mean luma tells the stroke colour, and the picture is
/// composited over the *opposite* grey (dark strokes over white, light strokes over black),
/// so a transparent pixel always reads as background. Opaque images are unaffected.
pub fn to_gray(image: &DynamicImage) -> GrayImage {
    let rgba = image.to_rgba8();
    let (w, h) = rgba.dimensions();
    let luma = |p: &image::Rgba<u8>| -> f64 {
        0.299 * p.0[0] as f64 + 0.587 * p.0[1] as f64 + 0.114 * p.0[2] as f64
    };
    let has_alpha = rgba.pixels().any(|p| p.0[3] < 255);
    let background = if has_alpha {
        // Mean luma of the opaque part, weighted by opacity.
        let (mut sum, mut weight) = (0.0, 0.0);
        for p in rgba.pixels() {
            let a = p.0[3] as f64 / 255.0;
            sum += a * luma(p);
            weight += a;
        }
        if weight > 0.0 && sum / weight < 128.0 {
            255.0
        } else {
            0.0
        }
    } else {
        0.0
    };
    let pixels = rgba
        .pixels()
        .map(|p| {
            let a = p.0[3] as f64 / 255.0;
            let y = a * luma(p) + (1.0 - a) * background;
            y.round().clamp(0.0, 255.0) as u8
        })
        .collect();
    GrayImage {
        width_px: w,
        height_px: h,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::super::jpeg_check::tests::{drawing_jpeg, sof_size_at};
    use super::*;

    #[test]
    fn png_header_dimensions_are_read() {
        let mut bytes = vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A, 0, 0, 0, 13];
        bytes.extend_from_slice(b"IHDR");
        bytes.extend_from_slice(&50_000u32.to_be_bytes());
        bytes.extend_from_slice(&40_000u32.to_be_bytes());
        assert_eq!(png_header_dimensions(&bytes), Some((50_000, 40_000)));
        assert!(matches!(
            decode_gray(&bytes, &SketchLimits::default()),
            Err(EngineError::ImageTooLarge(_))
        ));
    }

    #[test]
    fn cut_images_are_refused_and_whole_ones_decode() {
        // A drawing: a dark frame on white, 120 × 80, as PNG and as JPEG.
        let img = image::GrayImage::from_fn(120, 80, |x, y| {
            let wall = x < 4 || y < 4 || x >= 116 || y >= 76 || x == 60;
            image::Luma([if wall { 0 } else { 255 }])
        });
        let limits = SketchLimits::default();
        for format in [image::ImageFormat::Jpeg, image::ImageFormat::Png] {
            let mut bytes = Vec::new();
            img.write_to(&mut Cursor::new(&mut bytes), format).unwrap();
            assert!(decode_gray(&bytes, &limits).is_ok(), "{format:?} whole");
            if format == image::ImageFormat::Jpeg {
                assert!(jpeg_is_complete(&bytes));
            }
            // Half a file; for the JPEG also all but its end-of-image marker (a PNG cut in
            // its 12-byte IEND trailer has all its pixels and may decode).
            let mut cuts = vec![bytes.len() / 2];
            if format == image::ImageFormat::Jpeg {
                cuts.push(bytes.len() - 2);
            }
            for keep in cuts {
                match decode_gray(&bytes[..keep], &limits) {
                    Err(EngineError::ImageDecode(_)) => {}
                    Err(other) => panic!("{format:?} cut at {keep}: {other}"),
                    Ok(_) => panic!("{format:?} cut at {keep} of {} decoded", bytes.len()),
                }
            }
        }
    }

    #[test]
    fn a_jpeg_whose_data_do_not_fill_its_header_is_refused() {
        let limits = SketchLimits::default();
        for colour in [false, true] {
            let bytes = drawing_jpeg(colour);
            let whole = decode_gray(&bytes, &limits).unwrap();
            assert_eq!((whole.width_px, whole.height_px), (540, 390));
            // The header says 4000 × 4000 over the same data: a lenient decoder would
            // return 16 MP, nearly all of it grey.
            let mut lying = bytes.clone();
            let at = sof_size_at(&lying);
            lying[at..at + 2].copy_from_slice(&4000u16.to_be_bytes());
            lying[at + 2..at + 4].copy_from_slice(&4000u16.to_be_bytes());
            match decode_gray(&lying, &limits) {
                Err(EngineError::ImageDecode(m)) => {
                    assert!(m.contains("4000 × 4000"), "{m}")
                }
                other => panic!("colour {colour}: {:?}", other.map(|g| g.width_px)),
            }
            // A header smaller than its data is not refused (the rest is ignored).
            let mut smaller = bytes.clone();
            smaller[at..at + 2].copy_from_slice(&200u16.to_be_bytes());
            assert_eq!(decode_gray(&smaller, &limits).unwrap().height_px, 200);
        }
    }

    #[test]
    fn garbage_is_a_decode_error() {
        for bytes in [&b""[..], b"hello", &[0u8; 100], &[0x89, b'P', b'N', b'G']] {
            assert!(matches!(
                decode_gray(bytes, &SketchLimits::default()),
                Err(EngineError::ImageDecode(_))
            ));
        }
    }

    #[test]
    fn too_many_bytes_are_refused_before_decoding() {
        let limits = SketchLimits {
            max_pixels: 100,
            max_bytes: 10,
        };
        assert!(matches!(
            decode_gray(&[0u8; 11], &limits),
            Err(EngineError::ImageTooLarge(_))
        ));
    }

    #[test]
    fn transparent_background_reads_as_background() {
        // White strokes on a transparent background → composited over black.
        let mut img = image::RgbaImage::new(4, 1);
        img.put_pixel(0, 0, image::Rgba([255, 255, 255, 255]));
        let gray = to_gray(&DynamicImage::ImageRgba8(img));
        assert_eq!(gray.pixels, vec![255, 0, 0, 0]);
        // Black strokes on a transparent (white-coded) background → over white.
        let mut img = image::RgbaImage::from_pixel(4, 1, image::Rgba([0, 0, 0, 0]));
        img.put_pixel(0, 0, image::Rgba([0, 0, 0, 255]));
        let gray = to_gray(&DynamicImage::ImageRgba8(img));
        assert_eq!(gray.pixels, vec![0, 255, 255, 255]);
    }
}
