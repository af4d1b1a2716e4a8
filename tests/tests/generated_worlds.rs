//! Generated worlds are fit to be the exam: their drawings ingest into the engine, the
//! evaluation's own reading of `sketch-truth.toml` lands the generator's wall corners on
//! drawn ink, and on a generated office closing loops does not make the map worse than
//! leaving them open.

use sketchslam_engine::mapper::Method;
use sketchslam_engine::sketch::Sketch;
use sketchslam_simulator::generate::{GenerateOptions, Kind, LidarGrade, generate};
use sketchslam_simulator::scenario::Scenario;
use sketchslam_tests::run::run_in_process;
use sketchslam_tests::run_method::RunMethod;
use sketchslam_tests::sketch_truth::DrawingTruth;
use sketchslam_types::Pose2;
use std::path::PathBuf;

fn temp_dir(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!(
        "sketchslam-generated-{name}-{}",
        std::process::id()
    ))
}

/// Darkest luma within `radius_px` of `(u, v)` in a drawing.
fn darkest_near(img: &image::GrayImage, u: f64, v: f64, radius_px: i64) -> u8 {
    let mut darkest = u8::MAX;
    for dv in -radius_px..=radius_px {
        for du in -radius_px..=radius_px {
            let (x, y) = (u.round() as i64 + du, v.round() as i64 + dv);
            if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
                darkest = darkest.min(img.get_pixel(x as u32, y as u32).0[0]);
            }
        }
    }
    darkest
}

#[test]
fn drawings_ingest_and_the_evaluations_truth_lands_corners_on_ink() -> anyhow::Result<()> {
    for (i, kind) in Kind::CONCRETE.into_iter().enumerate() {
        let dir = temp_dir(&format!("truth-{kind}"));
        let options = GenerateOptions {
            seed: 40 + i as u64,
            kind,
            lidar: LidarGrade::Good,
        };
        let world = generate(&options, &dir)?;
        let scenario = Scenario::load(&world.dir)?;
        assert_eq!(scenario.sketches.len(), world.drawings.len());
        for drawing in &world.drawings {
            let cfg = scenario.sketch(&drawing.name).expect("listed");
            let bytes = std::fs::read(&cfg.image)?;
            let sketch = Sketch::from_image_bytes(&bytes)
                .map_err(|e| anyhow::anyhow!("{kind} sketch {}: {e}", drawing.name))?;
            assert!(
                sketch.lines.len() >= 4,
                "{kind} sketch {}: {} lines",
                drawing.name,
                sketch.lines.len()
            );
            // The evaluation's implementation of the formula, not the generator's.
            let truth = DrawingTruth::load(&world.dir, &drawing.name)?.expect("in the file");
            let img = image::load_from_memory(&bytes)?.to_luma8();
            let mut on_ink = 0;
            for corner in &drawing.corners_m {
                let at = truth.world_to_drawing(&Pose2::new(corner.x, corner.y, 0.0));
                // The generator's mapping of the same point agrees to a hair.
                let (u, v, _) = drawing
                    .map
                    .world_to_drawing(&Pose2::new(corner.x, corner.y, 0.0));
                assert!(
                    (u - at.u_px).abs() < 1e-6 && (v - at.v_px).abs() < 1e-6,
                    "{kind} {}: ({u}, {v}) vs ({}, {})",
                    drawing.name,
                    at.u_px,
                    at.v_px
                );
                if darkest_near(&img, at.u_px, at.v_px, 5) < 128 {
                    on_ink += 1;
                }
            }
            // Left-out strokes may take a few corners with them.
            let n = drawing.corners_m.len();
            assert!(n >= 4, "{kind} {}: {n} corners", drawing.name);
            assert!(
                on_ink * 10 >= n * 8,
                "{kind} {}: only {on_ink} of {n} corners on ink",
                drawing.name
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(())
}

/// Scans of the office run: long enough to come back over its way and close loops.
const OFFICE_SCANS: u64 = 3000;

#[test]
fn on_a_generated_office_closing_loops_does_not_make_the_map_worse() -> anyhow::Result<()> {
    let dir = temp_dir("office");
    let options = GenerateOptions {
        seed: 1,
        kind: Kind::Office,
        lidar: LidarGrade::Good,
    };
    let world = generate(&options, &dir)?;
    let scenario = Scenario::load(&world.dir)?;
    let closed = run_in_process(
        &scenario,
        Method::Graph,
        None,
        &dir.join("graph"),
        Some(OFFICE_SCANS),
        |_, _| {},
    )?;
    let open: RunMethod = "graph-open".parse().map_err(anyhow::Error::msg)?;
    let open = run_in_process(
        &scenario,
        open,
        None,
        &dir.join("graph-open"),
        Some(OFFICE_SCANS),
        |_, _| {},
    )?;
    eprintln!(
        "generated office, {OFFICE_SCANS} scans: map error {:.3} m with {} loops closed ({} rejected), {:.3} m open",
        closed.map_error_m, closed.loop_closures, closed.loop_closures_rejected, open.map_error_m
    );
    assert!(closed.loop_closures > 0, "{closed:?}");
    assert_eq!(open.loop_closures, 0);
    assert!(
        closed.map_error_m <= open.map_error_m + 0.005,
        "loops closed: {:.3} m, left open: {:.3} m (see {})",
        closed.map_error_m,
        open.map_error_m,
        dir.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
