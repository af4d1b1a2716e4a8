//! One evaluation run: a scenario, a method and (for `sketch`) a drawing, mapped and scored.
//!
//! In-process mode drives the simulator library and the engine's `Mapper` in one process;
//! the artifacts and scores are then computed exactly as the real-process mode does, from
//! the `map.pgm`/`map.yaml`/`trajectory.csv` files, so both modes are comparable byte for
//! byte.

use crate::live_warp::write_live_fits;
use crate::metrics::{self, StampedPose, WallGrid};
use crate::overlay;
use crate::run_loop::map_in_process;
use crate::run_method::RunMethod;
use crate::sketch_truth::{fill_sketch_pose_scores, score_published_poses};
use crate::warp_problem_file::WarpProblemFile;
use anyhow::{Context, Result};
use serde::Serialize;
use sketchslam_engine::mapper::{Method, SketchPrior};
use sketchslam_engine::mapping::ros_export::{
    RowOrder, occupied_points_in_order, parse_map_yaml, parse_pgm,
};
use sketchslam_engine::sketch::{Sketch, SketchPose};
use sketchslam_simulator::scenario::{Scenario, SketchConfig};
use sketchslam_simulator::simulation::Simulation;
use sketchslam_simulator::world::World;
use sketchslam_types::Point2;
use sketchslam_types::trajectory_csv;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Every n-th beam of a truth scan is cast to find the wall pixels the sensor saw.
const SEEN_WALL_BEAM_STRIDE: usize = 2;

/// The scores and figures of one run; serialised as one entry of `evaluate --json`.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RunResult {
    /// Scenario name.
    pub scenario: String,
    /// Method name.
    pub method: String,
    /// Sketch name, for `sketch` runs.
    pub sketch: Option<String>,
    /// Absolute trajectory error after SE(2) alignment, meters.
    pub ate_rmse_m: f64,
    /// Mean distance of the aligned map's occupied cells to the true walls, meters (NaN,
    /// written as null, for a dataset: no true walls).
    pub map_error_m: f64,
    /// Share of seen wall pixels mapped within 0.25 m (NaN for a dataset).
    pub completeness: f64,
    /// Dataset runs: mean translational error on the relations, meters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_trans_m: Option<f64>,
    /// Dataset runs: standard deviation of the translational relation error, meters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_trans_sd_m: Option<f64>,
    /// Dataset runs: mean rotational error on the relations, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_rot_deg: Option<f64>,
    /// Dataset runs: standard deviation of the rotational relation error, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_rot_sd_deg: Option<f64>,
    /// Dataset runs: relations scored (inside the trajectory).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relations: Option<usize>,
    /// Scans processed.
    pub scans: u64,
    /// Wall-clock seconds of the mapping.
    pub wall_s: f64,
    /// Scans per wall-clock second.
    pub scans_per_s: f64,
    /// Recoveries of MCL on the sketch.
    pub recoveries: u32,
    /// Loops closed by the back end (`graph`, `sketch`).
    #[serde(default)]
    pub loop_closures: u32,
    /// Matched loops the back end refused.
    #[serde(default)]
    pub loop_closures_rejected: u32,
    /// In-process runs with a true trajectory: loops in the final graph whose measurement
    /// is off the true relative pose by more than [`crate::loop_audit::OFF_M`] or
    /// [`crate::loop_audit::OFF_DEG`] (each listed in `loops.csv`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub loops_off_truth: Option<u32>,
    /// Mean engine time per scan, milliseconds (in-process runs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scan_ms_mean: Option<f64>,
    /// 99th percentile of the engine time per scan, milliseconds (in-process runs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scan_ms_p99: Option<f64>,
    /// Simulated seconds mapped per second of engine time on one core (in-process runs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub realtime_factor: Option<f64>,
    /// Heap held by what grows with the session at its end (the mapper's scan log,
    /// trajectory, grid and keyframes: `Mapper::heap_bytes`, through the processes the
    /// service's `sketchslam_session_heap_bytes`), megabytes (10⁶ bytes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub session_heap_mb: Option<f64>,
    /// ATE of the live trajectory (`online-trajectory.csv`: each scan's pose as the session
    /// first published it, before later loop closures rewrote it), moved by the alignment of
    /// the final trajectory, meters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub online_ate_rmse_m: Option<f64>,
    /// `sketch` runs on a scenario with `sketch-truth.toml`: median error of the pose on the
    /// drawing (after each scan in-process; as published live through the processes),
    /// meters at the drawing's nominal scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sketch_pose_median_m: Option<f64>,
    /// 95th percentile of that error, meters at the nominal scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sketch_pose_p95_m: Option<f64>,
    /// Share of scans whose pose on the drawing is within 1 m-equivalent of the truth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sketch_pose_within_1m: Option<f64>,
    /// Median heading error on the drawing, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sketch_heading_median_deg: Option<f64>,
    /// In-process `sketch` runs on a scenario with `sketch-truth.toml`: median error of the
    /// final trajectory carried onto the drawing through the warp fitted to the final map
    /// ([`sketchslam_engine::mapper::Mapper::drawing_registration`]), meters at the nominal scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warp_pose_median_m: Option<f64>,
    /// 95th percentile of that error, meters at the nominal scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warp_pose_p95_m: Option<f64>,
    /// Share of those poses within 1 m-equivalent of the truth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warp_pose_within_1m: Option<f64>,
    /// `sketch` runs on a scenario with `sketch-truth.toml`: median error of each scan's
    /// pose on the drawing as the session first published it, through the warp it held then
    /// (through the processes: the event stream and the service's warp worker; in-process:
    /// [`crate::live_warp::LiveWarp`]), meters at the nominal scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub live_sketch_pose_median_m: Option<f64>,
    /// Share of those poses within 1 m-equivalent of the truth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub live_sketch_pose_within_1m: Option<f64>,
    /// In-process `sketch` runs on a scenario with `sketch-truth.toml`: median error of
    /// MCL's own estimate on the drawing after each scan (the localization model alone,
    /// `MclConfig::observation`), meters at the nominal scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mcl_pose_median_m: Option<f64>,
    /// Share of those estimates within 1 m-equivalent of the truth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mcl_pose_within_1m: Option<f64>,
    /// `sketch` runs: the share of the served trajectory on the drawing where mapped walls
    /// hold W (source `warp`), scenarios and datasets alike.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warp_held: Option<f64>,
    /// `evaluate --repeat`: which sample of its run this is ([`crate::samples`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample: Option<usize>,
    /// Where the artifacts are.
    pub out_dir: PathBuf,
}

/// What the simulator knows about a run, to score it.
pub struct Truth {
    /// One pose per scan.
    pub poses: Vec<StampedPose>,
    /// Wall pixels hit by (every other) beam of the noise-free sensor.
    pub seen_walls: Vec<(usize, usize)>,
    /// The truth's walls.
    pub walls: WallGrid,
}

/// A run's name inside its scenario's output folder: `method` or `sketch-NAME`.
pub fn run_name(method: impl std::fmt::Display, sketch: Option<&str>) -> String {
    match sketch {
        Some(name) => format!("{method}-{name}"),
        None => method.to_string(),
    }
}

/// Loads a sketch of a scenario into a prior for the mapper.
pub fn sketch_prior(cfg: &SketchConfig) -> Result<SketchPrior> {
    let bytes = std::fs::read(&cfg.image)
        .with_context(|| format!("reading sketch {}", cfg.image.display()))?;
    let sketch = Sketch::from_image_bytes(&bytes)
        .with_context(|| format!("processing sketch {}", cfg.image.display()))?;
    Ok(SketchPrior {
        sketch: Arc::new(sketch),
        start: SketchPose {
            u_px: cfg.start_u_px,
            v_px: cfg.start_v_px,
            heading_rad: cfg.start_heading_rad,
            meters_per_pixel: cfg.meters_per_pixel,
        },
    })
}

/// Maps `scenario` with `method` in this process, writes the artifacts into `out_dir` and
/// scores them; with `max_scans`, only the run's first scans (and the odometry before
/// them), as `simulator run --max-scans`. `progress(done, total)` is called as scans are
/// processed.
pub fn run_in_process(
    scenario: &Scenario,
    method: impl Into<RunMethod>,
    sketch: Option<&SketchConfig>,
    out_dir: &Path,
    max_scans: Option<u64>,
    progress: impl FnMut(u64, u64),
) -> Result<RunResult> {
    let run_method = RunMethod {
        lidar_mount: scenario.lidar.mount,
        ..method.into()
    }
    .on_wheels(&scenario.odometry);
    run_in_process_as(scenario, run_method, sketch, out_dir, max_scans, progress)
}

/// [`run_in_process`] with `run_method` exactly as given, its LiDAR mount included (a test
/// tells the mapper a wrong one to see what the right one is worth).
pub fn run_in_process_as(
    scenario: &Scenario,
    run_method: RunMethod,
    sketch: Option<&SketchConfig>,
    out_dir: &Path,
    max_scans: Option<u64>,
    progress: impl FnMut(u64, u64),
) -> Result<RunResult> {
    let method = run_method.method;
    let world = World::load(&scenario.world.image, scenario.world.resolution_m)?;
    let sim = Simulation::new(scenario)?;
    let scans = sim.scan_count();
    let run = map_in_process(
        sim,
        scans,
        run_method,
        sketch,
        scenario.seed,
        out_dir,
        max_scans,
        progress,
    )?;
    if let Some(cfg) = sketch.filter(|_| method == Method::Sketch)
        && let Some(problem) = run.mapper.warp_problem()
    {
        WarpProblemFile::new(&problem, &scenario.dir, &cfg.name).write(out_dir)?;
    }
    if let Some(cfg) = sketch {
        write_live_fits(
            out_dir,
            &run.live_fits,
            &run.truth,
            &scenario.dir,
            &cfg.name,
        )?;
    }
    let walls = WallGrid::from_image(
        &image::open(&scenario.world.image)?.to_luma8(),
        scenario.world.resolution_m,
    );
    let seen_walls = seen_wall_pixels(scenario, &world, &walls, &run.truth);
    let truth = Truth {
        poses: run.truth.clone(),
        seen_walls,
        walls,
    };
    let mut result = score_artifacts(out_dir, &truth)?;
    run.fill(&mut result, &scenario.name, run_method, sketch);
    result.loops_off_truth = run.audit_loops(out_dir)?;
    if let Some(cfg) = sketch.filter(|_| method == Method::Sketch) {
        fill_sketch_pose_scores(
            &mut result,
            &scenario.dir,
            &cfg.name,
            &run.truth,
            &run.sketch_poses,
        )?;
        if let Some(score) =
            score_published_poses(&scenario.dir, &cfg.name, &run.truth, &run.warp_poses)?
        {
            result.warp_pose_median_m = Some(score.median_m);
            result.warp_pose_p95_m = Some(score.p95_m);
            result.warp_pose_within_1m = Some(score.within_1m);
        }
        if let Some(score) =
            score_published_poses(&scenario.dir, &cfg.name, &run.truth, &run.live_sketch_poses)?
        {
            result.live_sketch_pose_median_m = Some(score.median_m);
            result.live_sketch_pose_within_1m = Some(score.within_1m);
        }
        if let Some(score) =
            score_published_poses(&scenario.dir, &cfg.name, &run.truth, &run.mcl_poses)?
        {
            result.mcl_pose_median_m = Some(score.median_m);
            result.mcl_pose_within_1m = Some(score.within_1m);
        }
    }
    Ok(result)
}

/// Wall pixels the noise-free sensor saw from the true poses.
pub fn seen_wall_pixels(
    scenario: &Scenario,
    world: &World,
    walls: &WallGrid,
    truth: &[StampedPose],
) -> Vec<(usize, usize)> {
    let lidar = &scenario.lidar;
    let step_rad = lidar.fov_rad / (lidar.beams.max(2) - 1) as f64;
    let mut seen = HashSet::new();
    for t in truth {
        // The rays start at the scanner, wherever it sits on the robot.
        let sensor = t.pose.compose(&lidar.mount);
        for i in (0..lidar.beams).step_by(SEEN_WALL_BEAM_STRIDE) {
            let angle = sensor.heading_rad - 0.5 * lidar.fov_rad + i as f64 * step_rad;
            if let Some(r) = world.cast(sensor.position(), angle, lidar.max_range_m) {
                // Half a pixel past the boundary lands inside the wall pixel hit.
                let d = r + 0.5 * walls.resolution_m;
                let p = Point2::new(sensor.x + d * angle.cos(), sensor.y + d * angle.sin());
                if let Some(px) = walls.pixel_of(p).filter(|(c, r)| walls.is_wall(*c, *r)) {
                    seen.insert(px);
                }
            }
        }
    }
    let mut seen: Vec<_> = seen.into_iter().collect();
    seen.sort_unstable();
    seen
}

/// Reads a run's `map.pgm`, `map.yaml` and `trajectory.csv`, scores them against the
/// truth and draws `overlay.png`. Scenario/method fields of the result are left empty.
pub fn score_artifacts(out_dir: &Path, truth: &Truth) -> Result<RunResult> {
    let occupied = read_map_occupied_points(out_dir)?;
    let estimate = read_trajectory_csv(&out_dir.join("trajectory.csv"))?;
    let traj = metrics::score_trajectory(&estimate, &truth.poses)
        .context("the trajectory does not overlap the truth")?;
    let map = metrics::score_map(&occupied, &traj.alignment, &truth.walls, &truth.seen_walls);
    let online_ate_rmse_m = online_ate(out_dir, &truth.poses, &traj.alignment)?;
    overlay::draw(
        &truth.walls,
        &occupied,
        &estimate,
        &truth.poses,
        &traj.alignment,
    )
    .save(out_dir.join("overlay.png"))?;
    Ok(RunResult {
        scenario: String::new(),
        method: String::new(),
        sketch: None,
        ate_rmse_m: traj.ate_rmse_m,
        online_ate_rmse_m,
        map_error_m: map.map_error_m,
        completeness: map.completeness,
        rel_trans_m: None,
        rel_trans_sd_m: None,
        rel_rot_deg: None,
        rel_rot_sd_deg: None,
        relations: None,
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
        sketch_pose_p95_m: None,
        sketch_pose_within_1m: None,
        sketch_heading_median_deg: None,
        warp_pose_median_m: None,
        warp_pose_p95_m: None,
        warp_pose_within_1m: None,
        warp_held: None,
        live_sketch_pose_median_m: None,
        live_sketch_pose_within_1m: None,
        mcl_pose_median_m: None,
        mcl_pose_within_1m: None,
        sample: None,
        out_dir: out_dir.to_path_buf(),
    })
}

/// Map-frame centres of the occupied pixels of a saved map (`map.yaml` text and
/// `map.pgm` bytes), by the engine's map_server rule
/// ([`sketchslam_engine::mapping::ros_export::pixel_is_occupied`]). Listed top row first
/// (the image's order): the map error sums over them in this order, as it always has.
pub fn map_occupied_points(map_yaml: &str, map_pgm: &[u8]) -> Result<Vec<Point2>> {
    let yaml = parse_map_yaml(map_yaml)?;
    let (width, height, pixels) = parse_pgm(map_pgm)?;
    Ok(occupied_points_in_order(
        &yaml,
        width,
        height,
        &pixels,
        RowOrder::TopFirst,
    ))
}

/// [`map_occupied_points`] of the `map.yaml` and `map.pgm` in `out_dir`.
pub fn read_map_occupied_points(out_dir: &Path) -> Result<Vec<Point2>> {
    let yaml = std::fs::read_to_string(out_dir.join("map.yaml"))?;
    map_occupied_points(&yaml, &std::fs::read(out_dir.join("map.pgm"))?)
}

/// The file of a run's live trajectory (see [`RunResult::online_ate_rmse_m`]).
pub const ONLINE_TRAJECTORY_FILE: &str = "online-trajectory.csv";

/// The ATE of the run's `online-trajectory.csv`, when it wrote one, under the final
/// trajectory's `alignment`.
pub fn online_ate(
    out_dir: &Path,
    truth: &[StampedPose],
    alignment: &sketchslam_types::Pose2,
) -> Result<Option<f64>> {
    let path = out_dir.join(ONLINE_TRAJECTORY_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let live = read_trajectory_csv(&path)?;
    Ok(metrics::ate_with_alignment(&live, truth, alignment))
}

/// Reads a `t,x,y,theta` CSV (trajectory or truth), headings wrapped to (−π, π].
pub fn read_trajectory_csv(path: &Path) -> Result<Vec<StampedPose>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_trajectory_csv(&text).with_context(|| format!("parsing {}", path.display()))
}

/// Parses `t,x,y,theta` CSV text ([`trajectory_csv::parse`]), headings wrapped to (−π, π].
pub fn parse_trajectory_csv(text: &str) -> Result<Vec<StampedPose>> {
    Ok(trajectory_csv::parse(text)?
        .into_iter()
        .map(StampedPose::wrapped)
        .collect())
}
