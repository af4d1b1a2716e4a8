//! A doorway does not turn the map: passing through a 1.0 m door between two bare rooms,
//! where for a few scans the door frame's edges and the far room's walls seen through the
//! gap are most of what the LiDAR sees, the `graph` engine keeps its heading within 1° of
//! the truth at every scan of the passage — with a good 270° LiDAR and with a cheap 360° one
//! of 10 m. (Measured 2026-12-02: 0.38° and 0.50°. The turn in place at the far end of the
//! route, 4.5° per scan with the cheap LiDAR, shows a transient of up to 2.5° that the next
//! scans take back; it is printed, not asserted.)

use sketchslam_engine::mapper::Method;
use sketchslam_simulator::Simulation;
use sketchslam_simulator::scenario::Scenario;
use sketchslam_tests::metrics::pose_at;
use sketchslam_tests::run_loop::map_in_process;
use sketchslam_types::{Point2, wrap_angle};
use std::path::{Path, PathBuf};

/// World resolution, meters per pixel.
const RESOLUTION_M: f64 = 0.05;

/// Two 6 × 5 m rooms side by side (x 0.2–6.2 and 6.3–12.3 m), walls 0.1 m thick, joined by a
/// 1.0 m door in the middle of the wall between them (y 2.3–3.3 m). Row 0 is the top.
fn write_world(path: &Path) -> anyhow::Result<()> {
    let (w, h) = (252u32, 110u32);
    let mut img = image::GrayImage::from_pixel(w, h, image::Luma([255]));
    let m = |v: f64| (v / RESOLUTION_M).round() as u32;
    let mut wall = |x0: f64, y0: f64, x1: f64, y1: f64| {
        for col in m(x0)..m(x1) {
            for row_from_bottom in m(y0)..m(y1) {
                img.put_pixel(col, h - 1 - row_from_bottom, image::Luma([0]));
            }
        }
    };
    wall(0.1, 0.1, 12.4, 0.2); // south
    wall(0.1, 5.2, 12.4, 5.3); // north
    wall(0.1, 0.1, 0.2, 5.3); // west
    wall(12.3, 0.1, 12.4, 5.3); // east
    wall(6.2, 0.1, 6.3, 2.3); // the dividing wall below the door
    wall(6.2, 3.3, 6.3, 5.3); // and above it
    img.save(path)?;
    Ok(())
}

/// The scenario: from the west room's south-west, diagonally to the door, through it, and
/// on to the east room's north-east, then back the same way (the door passed twice, each
/// time turning just before and after it).
fn write_scenario(dir: &Path, lidar: &str, odometry: &str) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    write_world(&dir.join("world.png"))?;
    let toml = format!(
        r#"name = "doorway"
seed = 5

[world]
image = "world.png"
resolution = {RESOLUTION_M}

[robot]
start = [1.5, 1.2, 30.0]
path = [[5.2, 2.8], [7.3, 2.8], [11.0, 4.4], [7.3, 2.8], [5.2, 2.8], [1.5, 1.2]]
speed = 0.6
turn_rate = 45.0

{lidar}

{odometry}
"#
    );
    std::fs::write(dir.join("scenario.toml"), toml)?;
    Ok(())
}

/// The door's centre, world frame.
const DOOR: Point2 = Point2 { x: 6.25, y: 2.8 };
/// Scans this close to the door's centre are the passage, meters: from the turn before the
/// door to the turn after it, where the door frame and the gap dominate the scan.
const NEAR_DOOR_M: f64 = 1.5;

/// Maps the doorway with `graph` and returns the largest error, over the scans of the
/// passage ([`NEAR_DOOR_M`]), of the heading turned since the first scan, degrees.
fn worst_heading_error_deg(name: &str, lidar: &str, odometry: &str) -> anyhow::Result<f64> {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("sketchslam-doorway-{name}-{}", std::process::id()));
    write_scenario(&dir, lidar, odometry)?;
    let scenario = Scenario::load(&dir)?;
    let sim = Simulation::new(&scenario)?;
    let scans = sim.scan_count();
    let run = map_in_process(
        sim,
        scans,
        Method::Graph,
        None,
        scenario.seed,
        &dir.join("out"),
        None,
        |_, _| {},
    )?;
    let estimate: Vec<_> = run
        .mapper
        .trajectory()
        .iter()
        .map(|p| p.stamped())
        .collect();
    let first = run.truth.first().expect("scans");
    let first_estimate = pose_at(&estimate, first.t_s).expect("a pose at the first scan");
    let (mut worst_deg, mut anywhere_deg) = (0.0f64, 0.0f64);
    for truth in &run.truth {
        let Some(estimate) = pose_at(&estimate, truth.t_s) else {
            continue;
        };
        // Heading turned since the first scan, estimated against true.
        let error = wrap_angle(
            (estimate.heading_rad - first_estimate.heading_rad)
                - (truth.pose.heading_rad - first.pose.heading_rad),
        );
        let error_deg = error.abs().to_degrees();
        anywhere_deg = anywhere_deg.max(error_deg);
        if truth.pose.position().distance(&DOOR) <= NEAR_DOOR_M {
            worst_deg = worst_deg.max(error_deg);
        }
    }
    eprintln!(
        "doorway, {name}: {scans} scans, worst heading error {worst_deg:.2}° within {NEAR_DOOR_M} m of the door, {anywhere_deg:.2}° anywhere"
    );
    let _ = std::fs::remove_dir_all(&dir);
    Ok(worst_deg)
}

#[test]
fn through_a_one_metre_door_the_heading_stays_within_a_degree() -> anyhow::Result<()> {
    let good = worst_heading_error_deg(
        "good",
        "[lidar]\nrate_hz = 20.0\nfov_deg = 270.0\nbeams = 1081\nmax_range = 30.0\nrange_noise = 0.02",
        "[odometry]\nrate_hz = 50.0\ntrans_noise = 0.03\nrot_noise = 0.02\ntrans_bias = 0.02\nrot_bias = 0.01",
    )?;
    let cheap = worst_heading_error_deg(
        "cheap",
        "[lidar]\nrate_hz = 10.0\nfov_deg = 360.0\nbeams = 360\nmax_range = 10.0\nrange_noise = 0.03",
        "[odometry]\nrate_hz = 50.0\ntrans_noise = 0.05\nrot_noise = 0.05\ntrans_bias = 0.03\nrot_bias = 0.02",
    )?;
    assert!(good < 1.0, "good LiDAR: {good:.2}°");
    assert!(cheap < 1.0, "cheap LiDAR: {cheap:.2}°");
    Ok(())
}
