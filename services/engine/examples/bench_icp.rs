//! Per-scan cost of the engine's geometric steps on synthetic 1081-beam scans: RANSAC line
//! extraction, ICP reference preparation (k-d tree + normals), frame-to-frame point-to-line
//! ICP (full SE(2) and translation only), grid insertion and a scan-to-map ICP against the
//! grid's occupied cells within 15 m.
//!
//! `cargo run --release -p sketchslam-slam --example bench_icp [scans]`
//! Prints a table and one JSON line (`{"bench":"icp",...}`), times in microseconds.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sketchslam_engine::lines::ransac::{RansacConfig, extract_scan_lines};
use sketchslam_engine::mapping::grid::{GridConfig, OccupancyGrid};
use sketchslam_engine::scan_matching::icp::{Icp, IcpConfig, IcpMode};
use sketchslam_types::{Point2, Pose2, Scan};
use std::time::Instant;

// The integration tests' segment worlds, exact ray cast and noisy 270° scans.
#[path = "../tests/common/mod.rs"]
mod common;

use common::{Seg, scan_270};

/// An office-like floor: a 30 m × 12 m outline, a corridor wall with doors, rooms, boxes.
fn world() -> Vec<Seg> {
    let mut w = Vec::new();
    let mut s = |ax: f64, ay: f64, bx: f64, by: f64| {
        w.push((Point2::new(ax, ay), Point2::new(bx, by)));
    };
    s(0.0, 0.0, 30.0, 0.0);
    s(30.0, 0.0, 30.0, 12.0);
    s(30.0, 12.0, 0.0, 12.0);
    s(0.0, 12.0, 0.0, 0.0);
    // Corridor wall at y = 4 with 1 m doors every 6 m.
    let mut x = 0.0;
    while x < 30.0 {
        s(x, 4.0, (x + 5.0f64).min(30.0), 4.0);
        x += 6.0;
    }
    // Room partitions above the corridor.
    for xr in [8.0, 16.0, 24.0] {
        s(xr, 4.0, xr, 9.0);
    }
    // Furniture.
    for (cx, cy) in [(4.0, 8.0), (12.0, 10.0), (20.0, 7.0), (27.0, 9.5)] {
        s(cx, cy, cx + 1.2, cy);
        s(cx + 1.2, cy, cx + 1.2, cy + 0.6);
        s(cx + 1.2, cy + 0.6, cx, cy + 0.6);
        s(cx, cy + 0.6, cx, cy);
    }
    s(2.0, 1.0, 3.0, 2.5);
    w
}

/// Mean and 95th percentile, microseconds.
fn stats(v: &mut [f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let p95 = v[((v.len() as f64 * 0.95) as usize).min(v.len() - 1)];
    (mean, p95)
}

fn main() {
    let scans: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let walls = world();
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    // Down the corridor and back, 4 cm and a little turn per scan (0.8 m/s at 20 Hz).
    let poses: Vec<Pose2> = (0..scans)
        .map(|k| {
            let t = k as f64 / scans.max(2) as f64;
            let x = 1.5 + 26.0 * (std::f64::consts::PI * t).sin().abs().min(1.0) * t.min(1.0);
            Pose2::new(
                x.min(28.5),
                2.0 + 0.3 * (7.0 * t).sin(),
                0.3 * (5.0 * t).sin(),
            )
        })
        .collect();
    let data: Vec<(Scan, Vec<Point2>)> = poses
        .iter()
        .map(|p| {
            let s = scan_270(&walls, p, 0.02, 30.0, &mut rng);
            let pts = s.points().map(|(_, q)| q).collect();
            (s, pts)
        })
        .collect();

    let cfg = IcpConfig::default();
    let rcfg = RansacConfig::default();
    let mut t_ransac = Vec::new();
    let mut n_lines = Vec::new();
    let mut t_build = Vec::new();
    let mut t_full = Vec::new();
    let mut t_trans = Vec::new();
    let mut t_grid = Vec::new();
    let mut t_map_ref = Vec::new();
    let mut t_map_icp = Vec::new();
    let mut it_full = Vec::new();
    let mut err_full_m = Vec::new();
    let mut err_full_deg = Vec::new();
    let mut err_trans_m = Vec::new();
    let mut grid = OccupancyGrid::new(GridConfig::default());
    let mut odo_rng = ChaCha8Rng::seed_from_u64(7);
    let odo_noise = Normal::new(0.0, 0.02).unwrap();
    for k in 0..data.len() {
        let (scan, pts) = &data[k];
        let t0 = Instant::now();
        let lines = extract_scan_lines(scan, &rcfg, &mut rng);
        t_ransac.push(t0.elapsed().as_secs_f64() * 1e6);
        n_lines.push(lines.len() as f64);
        if k > 0 {
            let prev = &data[k - 1].1;
            let t0 = Instant::now();
            let icp = Icp::new(prev, cfg);
            t_build.push(t0.elapsed().as_secs_f64() * 1e6);
            let truth = poses[k - 1].between(&poses[k]);
            let guess = truth.compose(&Pose2::new(
                odo_noise.sample(&mut odo_rng),
                odo_noise.sample(&mut odo_rng),
                0.5 * odo_noise.sample(&mut odo_rng),
            ));
            let t0 = Instant::now();
            let r = icp.align(pts, guess, IcpMode::Full);
            t_full.push(t0.elapsed().as_secs_f64() * 1e6);
            it_full.push(r.iterations as f64);
            let e = truth.between(&r.pose);
            err_full_m.push(e.x.hypot(e.y));
            err_full_deg.push(e.heading_rad.abs().to_degrees());
            let t0 = Instant::now();
            let r = icp.align(
                pts,
                Pose2::new(guess.x, guess.y, truth.heading_rad),
                IcpMode::TranslationOnly,
            );
            t_trans.push(t0.elapsed().as_secs_f64() * 1e6);
            let e = truth.between(&r.pose);
            err_trans_m.push(e.x.hypot(e.y));
            // Scan-to-map against what the grid holds so far.
            let t0 = Instant::now();
            let reference = grid.occupied_points_near(poses[k].position(), 15.0);
            let map_icp = Icp::new(&reference, cfg);
            t_map_ref.push(t0.elapsed().as_secs_f64() * 1e6);
            let t0 = Instant::now();
            let _ = map_icp.align(pts, poses[k - 1].compose(&guess), IcpMode::Full);
            t_map_icp.push(t0.elapsed().as_secs_f64() * 1e6);
        }
        let t0 = Instant::now();
        grid.insert_scan(&poses[k], scan);
        t_grid.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    let rows: Vec<(&str, (f64, f64))> = vec![
        ("ransac_lines", stats(&mut t_ransac)),
        ("icp_build_ref_f2f", stats(&mut t_build)),
        ("icp_align_full_f2f", stats(&mut t_full)),
        ("icp_align_trans_f2f", stats(&mut t_trans)),
        ("grid_insert_scan", stats(&mut t_grid)),
        ("map_ref_build_15m", stats(&mut t_map_ref)),
        ("icp_align_full_map", stats(&mut t_map_icp)),
    ];
    println!("{} synthetic scans, 1081 beams, 270°, σ = 2 cm", data.len());
    println!("{:<22} {:>12} {:>12}", "step", "mean µs", "p95 µs");
    for (name, (m, p)) in &rows {
        println!("{name:<22} {m:>12.1} {p:>12.1}");
    }
    let (lines_mean, _) = stats(&mut n_lines);
    let (it_mean, _) = stats(&mut it_full);
    let (ef_m, ef_p95) = stats(&mut err_full_m);
    let (ef_deg, _) = stats(&mut err_full_deg);
    let (et_m, _) = stats(&mut err_trans_m);
    println!(
        "lines/scan {lines_mean:.1}; full ICP iterations {it_mean:.1}; frame-to-frame error: full \
         {:.2} mm (p95 {:.2}) {ef_deg:.3}°, translation-only {:.2} mm",
        ef_m * 1e3,
        ef_p95 * 1e3,
        et_m * 1e3
    );
    let mut json = String::from("{\"bench\":\"icp\",\"scans\":");
    json += &data.len().to_string();
    for (name, (m, p)) in &rows {
        json += &format!(",\"{name}_mean_us\":{m:.1},\"{name}_p95_us\":{p:.1}");
    }
    json += &format!(
        ",\"lines_per_scan\":{lines_mean:.2},\"icp_full_iterations\":{it_mean:.2},\
         \"f2f_full_err_m\":{ef_m:.5},\"f2f_full_err_deg\":{ef_deg:.4},\"f2f_trans_err_m\":{et_m:.5}}}"
    );
    println!("{json}");
}
