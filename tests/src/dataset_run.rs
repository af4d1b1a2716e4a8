//! One evaluation run on real data: a dataset's log replayed into the engine with a
//! method (and, for `sketch`, one of the dataset's drawings), mapped and scored.
//!
//! The counterpart of [`crate::run`] for a dataset folder (`dataset.toml`): the replay
//! ([`sketchslam_simulator::replay::Replay`]) stands in for the simulation, the log's
//! corrected poses at the scans are the reference trajectory (`truth.csv`), and with no
//! true walls the map is not scored: the run is scored by the ATE against the reference
//! and by the benchmark relations ([`crate::relations`]). Artifacts: `map.pgm`,
//! `map.yaml`, `trajectory.csv`, `truth.csv`, `overlay.png` (map and both trajectories on
//! white) and, for sketch runs, `sketch-overlay.png` (the map drawn over the sketch
//! through the final sketch pose and scale) and `sketch-pose.csv` (that pose; both
//! in-process only).
//!
//! Both modes exist: [`run_dataset_in_process`] drives the replay and the engine in this
//! process, [`run_dataset_real_process`] launches `slam-service` and `simulator replay`.

use crate::live_warp::write_live_fits;
use crate::metrics::{self, StampedPose};
use crate::real_process::{StreamSource, map_through_processes, sketch_pose_of};
use crate::relations::{Relation, score_relations};
use crate::run::{RunResult, read_map_occupied_points, read_trajectory_csv};
use crate::run_loop::map_in_process;
use crate::run_method::RunMethod;
use crate::warp_problem_file::WarpProblemFile;
use anyhow::{Context, Result};
use image::{Rgb, RgbImage};
use sketchslam_engine::mapper::Method;
use sketchslam_engine::sketch::SketchPose;
use sketchslam_simulator::dataset::Dataset;
use sketchslam_simulator::replay::Replay;
use sketchslam_simulator::scenario::SketchConfig;
use sketchslam_slam::codec::pose_response;
use sketchslam_slam::registration_codec::pose_through_warp;
use sketchslam_types::{Point2, Pose2};
use std::path::Path;

/// Meters per pixel of `overlay.png`.
const OVERLAY_RESOLUTION_M: f64 = 0.05;
/// Margin around the drawn content, meters.
const OVERLAY_MARGIN_M: f64 = 1.0;

const MAP: Rgb<u8> = Rgb([40, 40, 40]);
const TRUTH: Rgb<u8> = Rgb([20, 160, 40]);
const ESTIMATE: Rgb<u8> = Rgb([30, 60, 220]);
const SKETCH_MAP: Rgb<u8> = Rgb([220, 30, 30]);

/// The dataset's relations (empty without a relations file).
pub fn dataset_relations(dataset: &Dataset) -> Result<Vec<Relation>> {
    match &dataset.relations {
        Some(path) => crate::relations::read_relations(path, dataset.relations_time_offset_s),
        None => Ok(Vec::new()),
    }
}

/// Maps `dataset`'s log with `method` in this process, writes the artifacts into `out_dir`
/// and scores them; with `max_scans`, only the log's first scans. `progress(done, total)`
/// is called as scans are processed.
pub fn run_dataset_in_process(
    dataset: &Dataset,
    method: impl Into<RunMethod>,
    sketch: Option<&SketchConfig>,
    out_dir: &Path,
    max_scans: Option<u64>,
    progress: impl FnMut(u64, u64),
) -> Result<RunResult> {
    let replay = Replay::new(dataset)?;
    // A bag's /tf_static may say where the LiDAR sits.
    let method = RunMethod {
        lidar_mount: replay.lidar_mount().unwrap_or(Pose2::IDENTITY),
        ..method.into()
    };
    let scans = replay.scan_count();
    let run = map_in_process(
        replay,
        scans,
        method,
        sketch,
        dataset.seed,
        out_dir,
        max_scans,
        progress,
    )?;
    if let Some(cfg) = sketch.filter(|_| method.method == Method::Sketch)
        && let Some(problem) = run.mapper.warp_problem()
    {
        WarpProblemFile::new(&problem, &dataset.dir, &cfg.name).write(out_dir)?;
    }
    if let Some(cfg) = sketch {
        write_live_fits(out_dir, &run.live_fits, &run.truth, &dataset.dir, &cfg.name)?;
    }
    let relations = dataset_relations(dataset)?;
    let reference = dataset.has_reference_poses().then_some(&run.truth[..]);
    let mut result = score_dataset_artifacts(out_dir, reference, &relations)?;
    // The final pose on the drawing as the stopped service serves it, by its own codec:
    // through the final map's warp once the map is registered, MCL's before.
    let estimate = run.mapper.pose();
    let mut pose = pose_response("in-process", &estimate, &run.mapper.health());
    if let Some(r) = run.mapper.drawing_registration() {
        pose_through_warp(&mut pose, run.mapper.pose_on_drawing_through(&r));
    }
    if let (Some(cfg), Some(sketch_pose)) = (sketch, pose.sketch.as_ref().map(sketch_pose_of)) {
        write_sketch_artifacts(out_dir, cfg, estimate.map, &sketch_pose)?;
    }
    run.fill(&mut result, &dataset.name, method, sketch);
    if dataset.has_reference_poses() {
        // The log's corrected poses are a reference (GMapping's on the Intel log): each
        // loop of the graph against them, as for a simulated run.
        result.loops_off_truth = run.audit_loops(out_dir)?;
    }
    Ok(result)
}

/// Maps `dataset`'s log with `method` through the real processes (`slam-service` and
/// `simulator replay`, lock-step) and scores the result as the in-process mode does; with
/// `max_scans`, only the log's first scans. The sketch overlay goes through the session's
/// last pose as `GET /v1/sessions/{id}/pose` gave it.
pub fn run_dataset_real_process(
    dataset: &Dataset,
    method: Method,
    sketch: Option<&SketchConfig>,
    out_dir: &Path,
    max_scans: Option<u64>,
    progress: impl FnMut(u64, u64),
) -> Result<RunResult> {
    let replay = Replay::new(dataset)?;
    let source = StreamSource {
        subcommand: "replay",
        dir: &dataset.dir,
        seed: dataset.seed,
        scans: replay.scan_count(),
        lidar_mount: replay.lidar_mount().unwrap_or(Pose2::IDENTITY),
    };
    drop(replay);
    let mapped = map_through_processes(&source, method, sketch, out_dir, max_scans, progress)?;
    let truth = read_trajectory_csv(&out_dir.join("truth.csv"))?;
    let relations = dataset_relations(dataset)?;
    let reference = dataset.has_reference_poses().then_some(&truth[..]);
    let mut result = score_dataset_artifacts(out_dir, reference, &relations)?;
    if let (Some(cfg), (map_pose, Some(sketch_pose))) = (sketch, &mapped.final_pose) {
        write_sketch_artifacts(out_dir, cfg, *map_pose, sketch_pose)?;
    }
    mapped.fill(&mut result, &dataset.name, method, sketch);
    Ok(result)
}

/// Reads a dataset run's `map.pgm`, `map.yaml` and `trajectory.csv`, scores the trajectory
/// against the reference poses (`truth`, ATE after SE(2) alignment) and the relations,
/// and draws `overlay.png`. Map error and completeness are NaN (no true walls), and so is
/// the ATE of a log without reference poses (`truth` `None`: raw odometry, e.g. MIT CSAIL,
/// where only the relations score a run and the overlay shows the map and estimate alone);
/// name/method fields are left empty.
pub fn score_dataset_artifacts(
    out_dir: &Path,
    truth: Option<&[StampedPose]>,
    relations: &[Relation],
) -> Result<RunResult> {
    let occupied = read_map_occupied_points(out_dir)?;
    let estimate = read_trajectory_csv(&out_dir.join("trajectory.csv"))?;
    let (ate_rmse_m, alignment, drawn_truth) = match truth {
        Some(truth) => {
            let traj = metrics::score_trajectory(&estimate, truth)
                .context("the trajectory does not overlap the reference")?;
            (traj.ate_rmse_m, traj.alignment, truth)
        }
        None => (f64::NAN, Pose2::IDENTITY, &[][..]),
    };
    let online_ate_rmse_m = match truth {
        Some(truth) => crate::run::online_ate(out_dir, truth, &alignment)?,
        None => None,
    };
    let rel = score_relations(&estimate, relations);
    draw_overlay(&occupied, &estimate, drawn_truth, &alignment)
        .save(out_dir.join("overlay.png"))?;
    Ok(RunResult {
        scenario: String::new(),
        method: String::new(),
        sketch: None,
        ate_rmse_m,
        online_ate_rmse_m,
        map_error_m: f64::NAN,
        completeness: f64::NAN,
        rel_trans_m: rel.map(|r| r.trans_mean_m),
        rel_trans_sd_m: rel.map(|r| r.trans_sd_m),
        rel_rot_deg: rel.map(|r| r.rot_mean_deg),
        rel_rot_sd_deg: rel.map(|r| r.rot_sd_deg),
        relations: Some(rel.map_or(0, |r| r.used)),
        scans: 0,
        wall_s: 0.0,
        scans_per_s: 0.0,
        recoveries: 0,
        loop_closures: 0,
        loop_closures_rejected: 0,
        loops_off_truth: None,
        scan_ms_mean: None,
        scan_ms_p99: None,
        realtime_factor: None,
        session_heap_mb: None,
        sketch_pose_median_m: None,
        warp_pose_median_m: None,
        warp_pose_p95_m: None,
        warp_pose_within_1m: None,
        warp_held: None,
        live_sketch_pose_median_m: None,
        live_sketch_pose_within_1m: None,
        mcl_pose_median_m: None,
        mcl_pose_within_1m: None,
        sketch_pose_p95_m: None,
        sketch_pose_within_1m: None,
        sketch_heading_median_deg: None,
        sample: None,
        out_dir: out_dir.to_path_buf(),
    })
}

/// The map (dark), the reference trajectory (green) and the aligned estimate (blue) on
/// white, in the reference frame, north up, at `OVERLAY_RESOLUTION_M`.
pub fn draw_overlay(
    occupied_map_frame: &[Point2],
    estimate: &[StampedPose],
    truth: &[StampedPose],
    alignment: &Pose2,
) -> RgbImage {
    let map: Vec<Point2> = occupied_map_frame
        .iter()
        .map(|p| alignment.transform_point(p))
        .collect();
    let est: Vec<Point2> = estimate
        .iter()
        .map(|e| alignment.transform_point(&e.pose.position()))
        .collect();
    let tru: Vec<Point2> = truth.iter().map(|t| t.pose.position()).collect();
    let all = map.iter().chain(&est).chain(&tru);
    let (mut min_x, mut min_y, mut max_x, mut max_y) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in all {
        min_x = min_x.min(p.x);
        min_y = min_y.min(p.y);
        max_x = max_x.max(p.x);
        max_y = max_y.max(p.y);
    }
    if min_x > max_x {
        return RgbImage::from_pixel(1, 1, Rgb([255, 255, 255]));
    }
    let (min_x, min_y) = (min_x - OVERLAY_MARGIN_M, min_y - OVERLAY_MARGIN_M);
    // Capped so a runaway estimate cannot ask for a huge image.
    let w =
        (((max_x + OVERLAY_MARGIN_M - min_x) / OVERLAY_RESOLUTION_M).ceil() as u32).clamp(1, 8000);
    let h =
        (((max_y + OVERLAY_MARGIN_M - min_y) / OVERLAY_RESOLUTION_M).ceil() as u32).clamp(1, 8000);
    let mut img = RgbImage::from_pixel(w, h, Rgb([255, 255, 255]));
    let plot = |img: &mut RgbImage, p: &Point2, colour: Rgb<u8>, radius: i64| {
        let c = ((p.x - min_x) / OVERLAY_RESOLUTION_M).floor() as i64;
        let r = h as i64 - 1 - ((p.y - min_y) / OVERLAY_RESOLUTION_M).floor() as i64;
        for dr in -radius..=radius {
            for dc in -radius..=radius {
                let (x, y) = (c + dc, r + dr);
                if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                    img.put_pixel(x as u32, y as u32, colour);
                }
            }
        }
    };
    for p in &map {
        plot(&mut img, p, MAP, 0);
    }
    for p in &tru {
        plot(&mut img, p, TRUTH, 1);
    }
    for p in &est {
        plot(&mut img, p, ESTIMATE, 0);
    }
    img
}

/// Draws the map over the sketch through the final pose: a map point `p` is seen from the
/// final map pose, placed at the final sketch pose and divided by its scale.
/// Writes `sketch-overlay.png` (the map drawn over the drawing through the session's last
/// map pose and its pose and scale on the drawing) and `sketch-pose.csv` (that pose on the
/// drawing, to compare with the start marked on it).
fn write_sketch_artifacts(
    out_dir: &Path,
    cfg: &SketchConfig,
    final_map_pose: Pose2,
    sketch_pose: &SketchPose,
) -> Result<()> {
    draw_sketch_overlay(out_dir, cfg, final_map_pose, sketch_pose)
        .context("drawing sketch-overlay.png")?;
    std::fs::write(
        out_dir.join("sketch-pose.csv"),
        format!(
            "u_px,v_px,heading_rad,meters_per_pixel\n{},{},{},{}\n",
            sketch_pose.u_px,
            sketch_pose.v_px,
            sketch_pose.heading_rad,
            sketch_pose.meters_per_pixel
        ),
    )?;
    Ok(())
}

fn draw_sketch_overlay(
    out_dir: &Path,
    cfg: &SketchConfig,
    final_map_pose: Pose2,
    sketch_pose: &SketchPose,
) -> Result<()> {
    let occupied = read_map_occupied_points(out_dir)?;
    let sketch = image::open(&cfg.image)
        .with_context(|| format!("reading {}", cfg.image.display()))?
        .to_luma8();
    // The sketches are white strokes on black or black on white: draw the strokes grey on
    // white either way (strokes are the minority of pixels).
    let bright = sketch.pixels().filter(|p| p.0[0] >= 128).count();
    let strokes_bright = bright * 2 < sketch.pixels().len();
    let mut img = RgbImage::from_fn(sketch.width(), sketch.height(), |x, y| {
        let v = sketch.get_pixel(x, y).0[0] >= 128;
        if v == strokes_bright {
            Rgb([150, 150, 150])
        } else {
            Rgb([255, 255, 255])
        }
    });
    let s = sketch_pose.meters_per_pixel;
    let sketch_metric = Pose2::new(
        sketch_pose.u_px * s,
        -sketch_pose.v_px * s,
        sketch_pose.heading_rad,
    );
    let to_sketch = sketch_metric.compose(&final_map_pose.inverse());
    for p in &occupied {
        let m = to_sketch.transform_point(p);
        let (u, v) = ((m.x / s).floor(), (-m.y / s).floor());
        if u >= 0.0 && v >= 0.0 && u < img.width() as f64 && v < img.height() as f64 {
            img.put_pixel(u as u32, v as u32, SKETCH_MAP);
        }
    }
    img.save(out_dir.join("sketch-overlay.png"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlay_spans_the_content() {
        let truth = vec![
            StampedPose {
                t_s: 0.0,
                pose: Pose2::new(0.0, 0.0, 0.0),
            },
            StampedPose {
                t_s: 1.0,
                pose: Pose2::new(4.0, 1.0, 0.0),
            },
        ];
        let img = draw_overlay(&[Point2::new(5.0, 3.0)], &truth, &truth, &Pose2::IDENTITY);
        assert!((139..=141).contains(&img.width()), "{}", img.width());
        assert!((99..=101).contains(&img.height()), "{}", img.height());
    }
}
