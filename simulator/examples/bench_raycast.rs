//! Ray-casting throughput on the bundled paper-env1 world: 1081-beam scans (270°, 50 m
//! range) from poses spread evenly in time along the scenario's path.
//!
//! `cargo run --release --example bench_raycast [-- POSES]` prints a table and one JSON line.
//! Two figures: bare exact casts (`World::cast`), and whole noisy scans (`Lidar::scan`, which
//! adds one Gaussian draw per return), the cost the simulator pays per scan.

use sketchslam_simulator::lidar::Lidar;
use sketchslam_simulator::motion::Motion;
use sketchslam_simulator::simulation::{LIDAR_STREAM, stream_rng};
use sketchslam_simulator::{Scenario, SimError};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

/// Best of this many timed passes.
const PASSES: usize = 5;

fn main() -> Result<(), SimError> {
    let poses_n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(500);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-env1");
    let scenario = Scenario::load(&dir)?;
    let world = scenario.load_world()?;
    let motion = Motion::new(&scenario.robot);
    let lidar = Lidar::new(&scenario.lidar);
    let poses: Vec<_> = (0..poses_n)
        .map(|k| motion.pose_at(motion.duration_s() * (k as f64 + 0.5) / poses_n as f64))
        .collect();
    let beams = lidar.beams();
    let rays = (poses_n * beams) as f64;

    // Bare casts.
    let mut best_cast_s = f64::INFINITY;
    let mut range_sum_m = 0.0;
    let mut hits = 0usize;
    for _ in 0..PASSES {
        let t0 = Instant::now();
        let (mut sum, mut n) = (0.0, 0usize);
        for pose in &poses {
            for i in 0..beams {
                let a = pose.heading_rad + lidar.beam_angle_rad(i);
                if let Some(r) = world.cast(black_box(pose.position()), a, lidar.max_range_m()) {
                    sum += r;
                    n += 1;
                }
            }
        }
        best_cast_s = best_cast_s.min(t0.elapsed().as_secs_f64());
        range_sum_m = sum;
        hits = n;
    }

    // Whole scans with noise.
    let mut rng = stream_rng(scenario.seed, LIDAR_STREAM);
    let mut best_scan_s = f64::INFINITY;
    for _ in 0..PASSES {
        let t0 = Instant::now();
        for pose in &poses {
            black_box(lidar.scan(&world, *pose, &mut rng));
        }
        best_scan_s = best_scan_s.min(t0.elapsed().as_secs_f64());
    }

    let cast_rays_per_s = rays / best_cast_s;
    let scan_rays_per_s = rays / best_scan_s;
    let scans_per_s = poses_n as f64 / best_scan_s;
    let mean_range_m = range_sum_m / hits.max(1) as f64;
    let cells_per_ray = mean_range_m / world.resolution_m();
    println!(
        "ray casting on {} ({}x{} cells of {} m), best of {PASSES}",
        scenario.name,
        world.width(),
        world.height(),
        world.resolution_m()
    );
    println!("{:<28} {:>14}", "poses", poses_n);
    println!("{:<28} {:>14}", "beams per scan", beams);
    println!("{:<28} {:>14.2}", "mean range (m)", mean_range_m);
    println!(
        "{:<28} {:>14.1}",
        "hit rate (%)",
        100.0 * hits as f64 / rays
    );
    println!("{:<28} {:>14.0}", "World::cast rays/s", cast_rays_per_s);
    println!("{:<28} {:>14.0}", "Lidar::scan rays/s", scan_rays_per_s);
    println!("{:<28} {:>14.0}", "Lidar::scan scans/s", scans_per_s);
    println!(
        "{:<28} {:>14.1}",
        "ns per cell stepped",
        best_cast_s * 1e9 / (rays * cells_per_ray)
    );
    println!(
        "{{\"bench\":\"raycast\",\"scenario\":\"{}\",\"poses\":{poses_n},\"beams\":{beams},\"mean_range_m\":{mean_range_m:.3},\"cast_rays_per_s\":{cast_rays_per_s:.0},\"scan_rays_per_s\":{scan_rays_per_s:.0},\"scans_per_s\":{scans_per_s:.1}}}",
        scenario.name
    );
    Ok(())
}
