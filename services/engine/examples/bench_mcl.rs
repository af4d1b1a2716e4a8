//! Benchmark of MCL on the sketch: pseudo-range rays per second on a drawing, and the time
//! of one MCL update per scan at the defaults (500 particles, 60 beams) with each
//! observation model (the paper's ray-traced eq. (3), the drawing's likelihood field), on
//! the same drive and seed.
//!
//! The drawing is synthetic (0.05 m/px, 1000 × 700 px, a corridor loop with rooms, 20
//! lines), so the numbers do not depend on the sketch ingestion. Run with
//! `cargo run --release -p sketchslam-slam --example bench_mcl`; prints a table and one
//! JSON line.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sketchslam_engine::localization::line_observation::{LineObservationConfig, observe_lines};
use sketchslam_engine::localization::mcl::{MclConfig, SketchMcl, StartSpread};
use sketchslam_engine::localization::observation_model::ObservationModel;
use sketchslam_engine::sketch::raycast::SketchRaycaster;
use sketchslam_engine::sketch::{Sketch, SketchLine, SketchPose};
use sketchslam_types::{Point2, Pose2, Scan, ScanHeader};
use std::time::Instant;

fn sketch() -> Sketch {
    // Pixels: outer walls, an inner block, two rooms off the top corridor, a stub.
    let segs = [
        ((20.0, 20.0), (980.0, 20.0)),
        ((980.0, 20.0), (980.0, 680.0)),
        ((980.0, 680.0), (20.0, 680.0)),
        ((20.0, 680.0), (20.0, 20.0)),
        ((100.0, 300.0), (860.0, 300.0)),
        ((860.0, 300.0), (860.0, 600.0)),
        ((860.0, 600.0), (100.0, 600.0)),
        ((100.0, 600.0), (100.0, 300.0)),
        ((20.0, 220.0), (300.0, 220.0)),
        ((360.0, 220.0), (600.0, 220.0)),
        ((660.0, 220.0), (980.0, 220.0)),
        ((400.0, 20.0), (400.0, 220.0)),
        ((700.0, 20.0), (700.0, 220.0)),
        ((150.0, 20.0), (150.0, 120.0)),
        ((500.0, 300.0), (500.0, 450.0)),
        ((300.0, 450.0), (700.0, 450.0)),
        ((880.0, 400.0), (960.0, 400.0)),
        ((200.0, 620.0), (200.0, 680.0)),
        ((600.0, 620.0), (600.0, 680.0)),
        ((920.0, 240.0), (960.0, 280.0)),
    ];
    Sketch {
        width_px: 1000,
        height_px: 700,
        strokes: fixedbitset::FixedBitSet::with_capacity(700_000),
        lines: segs
            .iter()
            .enumerate()
            .map(|(i, &(a, b))| SketchLine::new(i, Point2::new(a.0, a.1), Point2::new(b.0, b.1)))
            .collect(),
    }
}

fn scan_at(rc: &SketchRaycaster, pose: &SketchPose) -> Scan {
    let beams = 1081usize;
    let fov = 270f64.to_radians();
    let mut scan = Scan {
        header: ScanHeader {
            angle_min_rad: (-fov / 2.0) as f32,
            angle_increment_rad: (fov / (beams - 1) as f64) as f32,
            range_min_m: 0.05,
            range_max_m: 50.0,
            beam_count: beams as u32,
            ..Default::default()
        },
        ranges_m: vec![f32::INFINITY; beams],
    };
    for i in 0..beams {
        let a = pose.heading_rad + scan.beam_angle_rad(i);
        if let Some(h) = rc.cast(pose.u_px, pose.v_px, a, 50.0 / pose.meters_per_pixel) {
            scan.ranges_m[i] = (h.range_px * pose.meters_per_pixel) as f32;
        }
    }
    scan
}

fn main() {
    let sketch = sketch();
    let t0 = Instant::now();
    let rc = SketchRaycaster::new(&sketch);
    let build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut rng = ChaCha8Rng::seed_from_u64(1);

    // Rays per second from random free points in random directions, 50 m at 0.05 m/px.
    let origins: Vec<(f64, f64)> =
        std::iter::repeat_with(|| (rng.random_range(20.0..980.0), rng.random_range(20.0..680.0)))
            .filter(|&(u, v)| rc.is_free(u, v))
            .take(4096)
            .collect();
    let rays = 2_000_000usize;
    let t0 = Instant::now();
    let mut hits = 0usize;
    for k in 0..rays {
        let (u, v) = origins[k % origins.len()];
        let a = k as f64 * 0.618_033_988_7 * std::f64::consts::TAU;
        hits += rc.cast(u, v, a, 1000.0).is_some() as usize;
    }
    let ray_s = t0.elapsed().as_secs_f64();
    let rays_per_s = rays as f64 / ray_s;
    println!("| measure | value |");
    println!("| --- | --- |");
    println!("| raycaster build (1000×700 px, 20 lines) | {build_ms:.1} ms |");
    println!(
        "| pseudo-range rays per second | {:.2} M/s ({hits} of {rays} hit) |",
        rays_per_s / 1e6
    );
    let mut json = Vec::new();
    for model in [ObservationModel::RayCast, ObservationModel::LikelihoodField] {
        let run = drive(&rc, model);
        println!(
            "| {model:?}: MCL predict per scan ({} particles) | {:.3} ms |",
            run.particles, run.predict_ms
        );
        println!(
            "| {model:?}: MCL update per scan ({} particles × {} beams) | {:.2} ms |",
            run.particles, run.beams_used, run.update_ms
        );
        println!(
            "| {model:?}: eq. (4) per scan (1081 beams) | {:.3} ms |",
            run.observe_ms
        );
        println!(
            "| {model:?}: final error / scale | {:.3} m / {:.4} m/px |",
            run.err_m, run.scale
        );
        json.push(format!(
            "{{\"model\":\"{model:?}\",\"particles\":{},\"beams_used\":{},\"predict_ms\":{:.4},\
             \"update_ms\":{:.3},\"observe_lines_ms\":{:.4},\"final_error_m\":{:.4},\
             \"final_scale_m_per_px\":{:.5}}}",
            run.particles,
            run.beams_used,
            run.predict_ms,
            run.update_ms,
            run.observe_ms,
            run.err_m,
            run.scale
        ));
    }
    println!(
        "{{\"bench\":\"bench_mcl\",\"build_ms\":{build_ms:.2},\"rays_per_s\":{rays_per_s:.0},\
         \"models\":[{}]}}",
        json.join(",")
    );
}

/// One model's drive: timings per scan and where it ended.
struct Drive {
    particles: usize,
    beams_used: usize,
    predict_ms: f64,
    update_ms: f64,
    observe_ms: f64,
    err_m: f64,
    scale: f64,
}

/// MCL with `model` while the robot drives along the bottom corridor, one scan per 0.08 m;
/// the same seed for every model.
fn drive(rc: &SketchRaycaster, model: ObservationModel) -> Drive {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut truth = SketchPose {
        u_px: 60.0,
        v_px: 640.0,
        heading_rad: 0.0,
        meters_per_pixel: 0.05,
    };
    let start = SketchPose {
        meters_per_pixel: 0.06,
        ..truth
    };
    let config = MclConfig {
        observation: model,
        ..MclConfig::default()
    };
    let (particles, beams_used) = (config.particles, config.beams_used);
    let mut mcl = SketchMcl::new(config, start, StartSpread::default(), &mut rng).unwrap();
    let scans = 300usize;
    let (mut predict_s, mut update_s, mut observe_s) = (0.0, 0.0, 0.0);
    for _ in 0..scans {
        truth = truth.advanced(0.08, 0.0, 0.0);
        let scan = scan_at(rc, &truth);
        let t = Instant::now();
        mcl.predict(Pose2::new(0.08, 0.0, 0.0), &mut rng);
        predict_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        mcl.update(&scan, rc);
        update_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let obs = observe_lines(
            &mcl.estimate(),
            &scan,
            rc,
            &LineObservationConfig::default(),
        );
        observe_s += t.elapsed().as_secs_f64();
        std::hint::black_box(obs);
    }
    let est = mcl.estimate();
    let per = |s: f64| s / scans as f64 * 1e3;
    Drive {
        particles,
        beams_used,
        predict_ms: per(predict_s),
        update_ms: per(update_s),
        observe_ms: per(observe_s),
        err_m: (est.u_px - truth.u_px).hypot(est.v_px - truth.v_px) * 0.05,
        scale: est.meters_per_pixel,
    }
}
