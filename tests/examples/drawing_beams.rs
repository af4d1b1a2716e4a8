//! `drawing_beams SCENARIO_DIR... [--every N]`: what each drawing explains of the scans at
//! the true pose — the physical ground of MCL's likelihood field
//! (`localization::observation_model`). The true pose and every used beam's end (MCL's 60
//! evenly spaced beams) are carried onto the drawing by the scenario's `sketch-truth.toml`,
//! and each beam is counted as
//! - *hit*: its end within `3σ(r)` of a drawn line (σ as MCL's, meters at the drawing's
//!   nominal scale);
//! - *short*: not a hit, and the ray to `r − 3σ(r)` crosses no drawn line (clutter, a wall
//!   nobody drew);
//! - *through*: not a hit, and that ray crosses a drawn line (a door drawn closed, a gap
//!   between strokes, the drawing's error) — what `z_seen_through` stands for.
//!
//! Prints one row per drawing and the shares over all. Run with
//! `cargo run --release -p sketchslam-tests --example drawing_beams -- simulator/scenarios/*`.

use anyhow::{Context, Result};
use sketchslam_engine::localization::mcl::{MclConfig, used_beams};
use sketchslam_engine::localization::observation_model::UNEXPLAINED_SIGMAS;
use sketchslam_engine::sketch::Sketch;
use sketchslam_engine::sketch::raycast::SketchRaycaster;
use sketchslam_simulator::scenario::Scenario;
use sketchslam_simulator::simulation::Simulation;
use sketchslam_tests::sketch_truth::DrawingTruth;
use sketchslam_types::{Pose2, SensorEvent};
use std::path::PathBuf;

fn main() -> Result<()> {
    let mut dirs: Vec<PathBuf> = Vec::new();
    let mut every = 25usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--every" {
            every = args.next().context("--every N")?.parse()?;
        } else {
            dirs.push(a.into());
        }
    }
    let config = MclConfig::default();
    let mut total = [0usize; 3];
    println!("| drawing | beams | hit | short | through |");
    println!("| --- | ---: | ---: | ---: | ---: |");
    for dir in &dirs {
        let scenario = Scenario::load(dir)?;
        for cfg in &scenario.sketches {
            let Some(truth) = DrawingTruth::load(dir, &cfg.name)? else {
                continue;
            };
            let sketch = Sketch::from_image_bytes(&std::fs::read(&cfg.image)?)?;
            let rc = SketchRaycaster::new(&sketch);
            let mpp = truth.meters_per_pixel;
            let mut count = [0usize; 3];
            let mut scan_k = 0usize;
            for step in Simulation::new(&scenario)? {
                let SensorEvent::Scan(scan) = step.event else {
                    continue;
                };
                scan_k += 1;
                if !scan_k.is_multiple_of(every) {
                    continue;
                }
                let sensor = step.truth.compose(&scenario.lidar.mount);
                let at = truth.world_to_drawing(&sensor);
                for i in used_beams(&scan, config.beams_used) {
                    let r = scan.ranges_m[i] as f64;
                    let angle = sensor.heading_rad + scan.beam_angle_rad(i);
                    let end =
                        Pose2::new(sensor.x + r * angle.cos(), sensor.y + r * angle.sin(), 0.0);
                    let e = truth.world_to_drawing(&end);
                    let sigma = config.sigma_at_m(r);
                    let class = if rc.distance_to_wall_px(e.u_px, e.v_px) * mpp
                        <= UNEXPLAINED_SIGMAS * sigma
                    {
                        0
                    } else {
                        let (du, dv) = (e.u_px - at.u_px, e.v_px - at.v_px);
                        let reach_px = du.hypot(dv) - UNEXPLAINED_SIGMAS * sigma / mpp;
                        let on_drawing = (-dv).atan2(du);
                        if reach_px > 0.0
                            && rc.cast(at.u_px, at.v_px, on_drawing, reach_px).is_some()
                        {
                            2
                        } else {
                            1
                        }
                    };
                    count[class] += 1;
                }
            }
            let n = count.iter().sum::<usize>().max(1);
            let pct = |k: usize| 100.0 * count[k] as f64 / n as f64;
            println!(
                "| {} {} | {n} | {:.1} % | {:.1} % | {:.1} % |",
                scenario.name,
                cfg.name,
                pct(0),
                pct(1),
                pct(2)
            );
            for k in 0..3 {
                total[k] += count[k];
            }
        }
    }
    let n = total.iter().sum::<usize>().max(1);
    let pct = |k: usize| 100.0 * total[k] as f64 / n as f64;
    println!(
        "| all | {n} | {:.1} % | {:.1} % | {:.1} % |",
        pct(0),
        pct(1),
        pct(2)
    );
    Ok(())
}
