//! Extracts the lines of hand-drawn sketches and writes their overlays.
//!
//! ```text
//! cargo run --release -p sketchslam-slam --example sketch_lines -- [--out DIR] IMAGE...
//! ```
//!
//! Prints one table row per image (size, stroke pixels, line count, milliseconds) followed
//! by one JSON line per image, and writes `DIR/<image stem>-overlay.png` (default DIR:
//! `sketch-overlays`).

use std::path::PathBuf;
use std::time::Instant;

use sketchslam_engine::sketch::{Sketch, encode_png, render_overlay};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut out_dir = PathBuf::from("sketch-overlays");
    let mut paths = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        if arg == "--out" {
            out_dir = PathBuf::from(args.next().ok_or("--out needs a folder")?);
        } else {
            paths.push(PathBuf::from(arg));
        }
    }
    if paths.is_empty() {
        return Err("usage: sketch_lines [--out DIR] IMAGE...".into());
    }
    std::fs::create_dir_all(&out_dir)?;
    println!(
        "{:<40} {:>11} {:>8} {:>6} {:>9}",
        "sketch", "size", "strokes", "lines", "time_ms"
    );
    let mut json_lines = Vec::new();
    for path in &paths {
        let bytes = std::fs::read(path)?;
        let started = Instant::now();
        let result = Sketch::from_image_bytes(&bytes);
        let elapsed_ms = started.elapsed().as_secs_f64() * 1e3;
        let name = path.display().to_string();
        match result {
            Ok(sketch) => {
                let strokes = sketch.strokes.count_ones(..);
                println!(
                    "{:<40} {:>11} {:>8} {:>6} {:>9.1}",
                    name,
                    format!("{}x{}", sketch.width_px, sketch.height_px),
                    strokes,
                    sketch.lines.len(),
                    elapsed_ms
                );
                let stem = path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "sketch".into());
                let out = out_dir.join(format!("{stem}-overlay.png"));
                std::fs::write(&out, encode_png(&render_overlay(&sketch)))?;
                json_lines.push(serde_json::json!({
                    "sketch": name,
                    "width_px": sketch.width_px,
                    "height_px": sketch.height_px,
                    "stroke_px": strokes,
                    "lines": sketch.lines.len(),
                    "time_ms": elapsed_ms,
                    "overlay": out.display().to_string(),
                }));
            }
            Err(e) => {
                println!("{name:<40} error: {e}");
                json_lines.push(serde_json::json!({
                    "sketch": name, "error": e.to_string(), "time_ms": elapsed_ms,
                }));
            }
        }
    }
    for j in json_lines {
        println!("{j}");
    }
    Ok(())
}
