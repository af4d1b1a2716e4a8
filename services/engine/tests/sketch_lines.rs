//! Sketch ingestion and line extraction end to end: bytes in, numbered lines out.
//!
//! Synthetic drawings with known walls (clean, and a "photograph" with uneven lighting,
//! paper noise and faint pencil), the shared drawings against their inverted images, and
//! every kind of bad upload with its own typed error.

use std::path::{Path, PathBuf};

use image::{GrayImage, Luma, RgbaImage};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sketchslam_engine::EngineError;
use sketchslam_engine::sketch::{Sketch, SketchLine, encode_png, render_overlay};
use sketchslam_types::Point2;

fn png_bytes(img: &GrayImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// Draws a segment `width_px` wide (pixels whose centre is within `width_px / 2` of it).
fn draw_segment(
    img: &mut GrayImage,
    a: (f64, f64),
    b: (f64, f64),
    width_px: f64,
    ink: impl Fn(u8) -> u8,
) {
    let (w, h) = img.dimensions();
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let t = (((px - a.0) * dx + (py - a.1) * dy) / len2).clamp(0.0, 1.0);
            let (qx, qy) = (a.0 + t * dx, a.1 + t * dy);
            if (px - qx).hypot(py - qy) <= width_px / 2.0 {
                let g = img.get_pixel(x, y).0[0];
                img.put_pixel(x, y, Luma([ink(g)]));
            }
        }
    }
}

/// The line of `lines` matching segment `(a, b)`: both endpoints within `tol_px`, either way
/// round.
fn find_line(lines: &[SketchLine], a: Point2, b: Point2, tol_px: f64) -> Option<&SketchLine> {
    lines.iter().find(|l| {
        (l.a.distance(&a) <= tol_px && l.b.distance(&b) <= tol_px)
            || (l.a.distance(&b) <= tol_px && l.b.distance(&a) <= tol_px)
    })
}

fn rectangle_corners() -> [Point2; 4] {
    [
        Point2::new(60.5, 50.5),
        Point2::new(340.5, 50.5),
        Point2::new(340.5, 250.5),
        Point2::new(60.5, 250.5),
    ]
}

fn assert_rectangle(sketch: &Sketch, tol_px: f64) {
    let c = rectangle_corners();
    assert_eq!(sketch.lines.len(), 4, "{:#?}", sketch.lines);
    for k in 0..4 {
        let (a, b) = (c[k], c[(k + 1) % 4]);
        assert!(
            find_line(&sketch.lines, a, b, tol_px).is_some(),
            "side {a:?}–{b:?} not found within {tol_px} px in {:#?}",
            sketch.lines
        );
    }
    for (i, l) in sketch.lines.iter().enumerate() {
        assert_eq!(l.index, i);
    }
}

#[test]
fn a_drawn_rectangle_gives_its_four_sides() {
    let mut img = GrayImage::from_pixel(400, 300, Luma([255]));
    let c = rectangle_corners();
    for k in 0..4 {
        let (a, b) = (c[k], c[(k + 1) % 4]);
        draw_segment(&mut img, (a.x, a.y), (b.x, b.y), 3.0, |_| 0);
    }
    let sketch = Sketch::from_image_bytes(&png_bytes(&img)).unwrap();
    assert_rectangle(&sketch, 2.0);
    // Same bytes, same lines.
    assert_eq!(Sketch::from_image_bytes(&png_bytes(&img)).unwrap(), sketch);
    // The overlay has the image's size and encodes.
    let overlay = render_overlay(&sketch);
    assert_eq!(overlay.dimensions(), (400, 300));
    assert!(!encode_png(&overlay).is_empty());
}

#[test]
fn a_photographed_pencil_rectangle_gives_its_four_sides() {
    // Paper lit from the top-left: 235 down to 120 across the sheet, Gaussian grain σ = 6,
    // pencil strokes only 45 grey levels darker than the paper around them, as a JPEG.
    let (w, h) = (400u32, 300u32);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let grain = Normal::new(0.0, 6.0).unwrap();
    let mut img = GrayImage::new(w, h);
    let paper: Vec<f64> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 / w as f64, (i / w) as f64 / h as f64);
            235.0 - 70.0 * x - 45.0 * y
        })
        .collect();
    let c = rectangle_corners();
    for k in 0..4 {
        let (a, b) = (c[k], c[(k + 1) % 4]);
        draw_segment(&mut img, (a.x, a.y), (b.x, b.y), 3.0, |_| 1);
    }
    for (i, p) in img.pixels_mut().enumerate() {
        let pencil = if p.0[0] == 1 { 45.0 } else { 0.0 };
        let g = paper[i] - pencil + grain.sample(&mut rng);
        p.0[0] = g.round().clamp(0.0, 255.0) as u8;
    }
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 85)
        .encode_image(&img)
        .unwrap();
    let sketch = Sketch::from_image_bytes(&jpeg).unwrap();
    assert_rectangle(&sketch, 3.0);
}

/// `../../simulator/...` is in the repository; `../../../shared/...` lies beside it.
fn manifest_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn inverted_png(bytes: &[u8]) -> Vec<u8> {
    let mut img: RgbaImage = image::load_from_memory(bytes).unwrap().to_rgba8();
    for p in img.pixels_mut() {
        for c in 0..3 {
            p.0[c] = 255 - p.0[c];
        }
    }
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

#[test]
fn drawings_and_their_inverted_images_give_the_same_lines() {
    let mut files = vec![manifest_path(
        "../../simulator/scenarios/paper-env1/sketch-a.png",
    )];
    let intel = manifest_path("../../../shared/datasets/intel-lab");
    if intel.is_dir() {
        files.push(intel.join("sketch-1.png"));
        files.push(intel.join("sketch-2.png"));
    } else {
        println!(
            "note: {} is absent, the Intel Lab sketches are skipped",
            intel.display()
        );
    }
    for file in files {
        let bytes = std::fs::read(&file).unwrap();
        let direct = Sketch::from_image_bytes(&bytes).unwrap();
        let inverted = Sketch::from_image_bytes(&inverted_png(&bytes)).unwrap();
        let (n, m) = (direct.lines.len() as f64, inverted.lines.len() as f64);
        println!("{}: {n} lines, inverted {m}", file.display());
        assert!(n >= 10.0, "{}: only {n} lines", file.display());
        assert!(
            (n - m).abs() <= 0.1 * n,
            "{}: {n} lines, inverted {m}",
            file.display()
        );
    }
}

/// A CAD-style floor plan (double-line walls, grey outside the building, PNG grey + alpha)
/// is accepted and used like a drawing: the Intel Lab plan gives a wall per line.
#[test]
fn a_cad_floor_plan_with_alpha_ingests_with_its_walls() {
    let file = manifest_path("../../../shared/datasets/intel-lab/floorplan-cad.png");
    if !file.is_file() {
        println!(
            "note: {} is absent, the CAD plan is skipped",
            file.display()
        );
        return;
    }
    let bytes = std::fs::read(&file).unwrap();
    let decoded = image::load_from_memory(&bytes).unwrap();
    assert!(
        decoded.color().has_alpha(),
        "the plan is meant to carry alpha"
    );
    let sketch = Sketch::from_image_bytes(&bytes).unwrap();
    assert_eq!((sketch.width_px, sketch.height_px), (708, 763));
    let n = sketch.lines.len();
    assert!(n >= 40, "only {n} lines from the CAD plan");
}

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320) as PNG chunks use it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A PNG made of only its signature and a valid IHDR chunk claiming `w × h`, 8-bit grey.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut out = vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    let mut chunk = b"IHDR".to_vec();
    chunk.extend_from_slice(&w.to_be_bytes());
    chunk.extend_from_slice(&h.to_be_bytes());
    chunk.extend_from_slice(&[8, 0, 0, 0, 0]); // depth, colour type, compression, filter, interlace
    out.extend_from_slice(&13u32.to_be_bytes());
    out.extend_from_slice(&chunk);
    out.extend_from_slice(&crc32(&chunk).to_be_bytes());
    out
}

#[test]
fn bad_images_get_their_own_errors() {
    // Truncated: the first half of a good PNG.
    let mut img = GrayImage::from_pixel(200, 150, Luma([255]));
    draw_segment(&mut img, (20.0, 20.0), (180.0, 130.0), 3.0, |_| 0);
    let good = png_bytes(&img);
    assert!(Sketch::from_image_bytes(&good).is_ok());
    let truncated = Sketch::from_image_bytes(&good[..good.len() / 2]);
    assert!(
        matches!(truncated, Err(EngineError::ImageDecode(_))),
        "{truncated:?}"
    );
    // Not an image at all.
    let text = Sketch::from_image_bytes(b"a wall, another wall");
    assert!(matches!(text, Err(EngineError::ImageDecode(_))), "{text:?}");
    // 0 × 0.
    let empty = Sketch::from_image_bytes(&png_header_only(0, 0));
    assert!(matches!(empty, Err(EngineError::ImageEmpty)), "{empty:?}");
    // A header claiming 50 000 × 50 000 with no data: refused before any allocation.
    let huge = Sketch::from_image_bytes(&png_header_only(50_000, 50_000));
    assert!(
        matches!(huge, Err(EngineError::ImageTooLarge(_))),
        "{huge:?}"
    );
    // A blank white page.
    let blank = Sketch::from_image_bytes(&png_bytes(&GrayImage::from_pixel(300, 200, Luma([255]))));
    assert!(matches!(blank, Err(EngineError::NoStrokes)), "{blank:?}");
    // Strokes, but nothing long and straight: a few dots.
    let mut dots = GrayImage::from_pixel(300, 200, Luma([255]));
    for k in 0..5 {
        let x = 40.0 + 50.0 * k as f64;
        draw_segment(&mut dots, (x, 100.0), (x + 1.0, 100.0), 5.0, |_| 0);
    }
    let no_lines = Sketch::from_image_bytes(&png_bytes(&dots));
    assert!(
        matches!(no_lines, Err(EngineError::NoLines)),
        "{no_lines:?}"
    );
}
