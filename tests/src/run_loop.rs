//! The in-process mapping loop shared by scenario runs ([`crate::run`]) and dataset runs
//! ([`crate::dataset_run`]): a stream of [`SimStep`]s (a `Simulation` or a `Replay`, which
//! yield the same steps) fed to the engine's [`Mapper`], timed per scan, with the true
//! pose of every scan kept; then the run's artifacts written as the real processes would
//! (`map.pgm`, `map.yaml`, `trajectory.csv`, `truth.csv`).
//!
//! Scoring stays with each caller (walls and completeness for a scenario, relations for a
//! dataset); [`RunFigures`] fills the figures every run reports, in-process or through the
//! processes ([`crate::real_process`]).

use crate::live_warp::{LiveFit, LiveWarp};
use crate::loop_audit;
use crate::metrics::StampedPose;
use crate::run::{ONLINE_TRAJECTORY_FILE, RunResult, sketch_prior};
use crate::run_method::RunMethod;
use anyhow::Result;
use sketchslam_api::SketchTrajectoryResponse;
use sketchslam_engine::mapper::{
    DrawingPoseSource, Mapper, Method, TrajectoryPoint, trajectory_csv,
};
use sketchslam_engine::registration::{render_drawing_on_map, render_map_on_drawing};
use sketchslam_engine::sketch::SketchPose;
use sketchslam_simulator::SimStep;
use sketchslam_simulator::scenario::SketchConfig;
use sketchslam_slam::registration_codec::served_sketch_trajectory;
use sketchslam_types::SensorEvent;
use sketchslam_types::sketch_trajectory_csv::{self, DrawingRow};
use std::path::Path;
use std::time::Instant;

/// A finished in-process mapping: the mapper and what the loop measured.
pub struct InProcessRun {
    /// The mapper after the last scan.
    pub mapper: Mapper,
    /// The true pose at every scan mapped, stamp in seconds.
    pub truth: Vec<StampedPose>,
    /// Engine seconds spent in `Mapper::on_event` (scans and odometry).
    pub mapping_s: f64,
    /// Engine milliseconds per scan, in scan order.
    pub scan_ms: Vec<f64>,
    /// `sketch` runs: MCL's pose on the drawing at each scan, stamp in seconds, in scan
    /// order ([`served_drawing_poses`] of the mapper's trajectory on the drawing).
    pub sketch_poses: Vec<(f64, SketchPose)>,
    /// `sketch` runs: every pose of the final trajectory carried onto the drawing through the
    /// warp fitted to the final map, stamp in seconds (empty when there was nothing to fit).
    pub warp_poses: Vec<(f64, SketchPose)>,
    /// `sketch` runs: [`warp_held_share`] of the served trajectory on the drawing.
    pub warp_held: Option<f64>,
    /// `sketch` runs: each scan's pose on the drawing as published then ([`LiveWarp`]),
    /// stamp in seconds.
    pub live_sketch_poses: Vec<(f64, SketchPose)>,
    /// `sketch` runs with `RunMethod::keep_live_warps`: every live fit ([`LiveWarp`]).
    pub live_fits: Vec<LiveFit>,
    /// `sketch` runs: MCL's own estimate on the drawing after each scan
    /// ([`Mapper::drawing_trajectory`]), stamp in seconds: the localization model alone,
    /// before W takes over what is served.
    pub mcl_poses: Vec<(f64, SketchPose)>,
}

/// Maps `steps` (a stream of `scan_count` scans) with `method` (and, for `sketch`, the
/// drawing `sketch`) seeded with `seed`; with `max_scans`, only the first scans (stopping
/// right after the last, as the simulator's `--max-scans` does). `progress(done, total)`
/// is called after every scan. Writes `map.pgm`, `map.yaml`, `trajectory.csv` and
/// `truth.csv` into `out_dir`.
#[allow(clippy::too_many_arguments)]
pub fn map_in_process(
    steps: impl IntoIterator<Item = SimStep>,
    scan_count: u64,
    method: impl Into<RunMethod>,
    sketch: Option<&SketchConfig>,
    seed: u64,
    out_dir: &Path,
    max_scans: Option<u64>,
    mut progress: impl FnMut(u64, u64),
) -> Result<InProcessRun> {
    let run_method: RunMethod = method.into();
    let method = run_method.method;
    let prior = match (method, sketch) {
        (Method::Sketch, Some(cfg)) => Some(sketch_prior(cfg)?),
        (Method::Sketch, None) => anyhow::bail!("the sketch method needs a sketch"),
        _ => None,
    };
    let config = run_method.config(seed);
    let mut mapper = Mapper::new(method, prior, config)?;
    let total = max_scans.map_or(scan_count, |m| m.min(scan_count));
    let mut truth = Vec::new();
    let mut mapping_s = 0.0;
    let mut scan_ms: Vec<f64> = Vec::new();
    // Each scan's pose as the session publishes it then, before later closures move it.
    let mut live: Vec<TrajectoryPoint> = Vec::new();
    let mut live_warp = (method == Method::Sketch && run_method.live_warp)
        .then(|| LiveWarp::new(run_method.keep_live_warps));
    let mut live_sketch_poses = Vec::new();
    for step in steps {
        // The truth does not depend on the mapper: recorded before it runs, outside the
        // timed call.
        if let SensorEvent::Scan(scan) = &step.event {
            truth.push(StampedPose {
                t_s: scan.header.stamp_ns as f64 * 1e-9,
                pose: step.truth,
            });
        }
        let started = Instant::now();
        mapper.on_event(&step.event);
        let spent_s = started.elapsed().as_secs_f64();
        mapping_s += spent_s;
        if let SensorEvent::Scan(scan) = &step.event {
            scan_ms.push(spent_s * 1e3);
            let now = mapper.pose();
            live.push(TrajectoryPoint {
                stamp_ns: scan.header.stamp_ns,
                pose: now.map,
            });
            if let Some(on) = live_warp
                .as_mut()
                .and_then(|w| w.after_scan(&mut mapper, truth.len()))
            {
                live_sketch_poses.push((scan.header.stamp_ns as f64 * 1e-9, on));
            }
            progress(truth.len() as u64, total);
            if truth.len() as u64 >= total {
                break;
            }
        }
    }
    std::fs::create_dir_all(out_dir)?;
    let grid = mapper.refresh_map();
    std::fs::write(out_dir.join("map.pgm"), grid.to_pgm())?;
    std::fs::write(out_dir.join("map.yaml"), grid.to_yaml("map.pgm"))?;
    std::fs::write(
        out_dir.join("trajectory.csv"),
        trajectory_csv(&mapper.trajectory()),
    )?;
    sketchslam_simulator::truth::write_truth_csv(&out_dir.join("truth.csv"), &truth)?;
    std::fs::write(out_dir.join(ONLINE_TRAJECTORY_FILE), trajectory_csv(&live))?;
    let mut sketch_poses = Vec::new();
    let mut warp_poses = Vec::new();
    let mut warp_held = None;
    let mut mcl_poses = Vec::new();
    if method == Method::Sketch {
        mcl_poses = mapper
            .drawing_trajectory()
            .iter()
            .map(|p| (p.stamp_ns as f64 * 1e-9, p.pose))
            .collect();
        write_drawing_trajectory(out_dir, LIVE_SKETCH_TRAJECTORY_FILE, &live_sketch_poses)?;
        // The whole trajectory on the drawing, through the service's own codec, so the file
        // is what `?frame=sketch&format=csv` serves once the session stopped: the final
        // map's warp where its walls hold it, MCL's poses elsewhere.
        let registration = mapper.drawing_registration();
        let on_drawing = served_sketch_trajectory("in-process", &mapper, registration.as_ref());
        std::fs::write(out_dir.join("sketch-trajectory.csv"), on_drawing.to_csv())?;
        sketch_poses = served_drawing_poses(&on_drawing);
        warp_held = warp_held_share(&on_drawing);
        if let Some(registration) = registration {
            let warp = registration.warp();
            warp_poses = mapper
                .trajectory()
                .iter()
                .map(|t| (t.stamp_ns as f64 * 1e-9, warp.pose_on_drawing(&t.pose)))
                .collect();
            write_drawing_trajectory(out_dir, WARP_TRAJECTORY_FILE, &warp_poses)?;
            if let Some(drawing) = mapper.drawing() {
                // The service's pictures, by the same renderers (the grid refreshed above).
                let route: Vec<_> = mapper.trajectory().iter().map(|t| t.pose).collect();
                let grid = mapper.grid_as_built();
                render_map_on_drawing(&drawing.sketch, warp, &grid.occupied_points(), &route)
                    .save(out_dir.join(SKETCH_OVERLAY_FILE))?;
                render_drawing_on_map(grid, &registration.lines_in_map(&drawing.sketch.lines))
                    .save(out_dir.join(SKETCH_IN_MAP_FILE))?;
            }
        }
    }
    Ok(InProcessRun {
        mapper,
        truth,
        mapping_s,
        scan_ms,
        sketch_poses,
        warp_poses,
        warp_held,
        live_sketch_poses,
        live_fits: live_warp.map(LiveWarp::kept).unwrap_or_default(),
        mcl_poses,
    })
}

/// The share of a served trajectory on the drawing whose poses mapped walls hold W at
/// (source `warp`, against `warp_extrapolated`, `mcl` and `odometry`): how much of the run
/// the drawing is registered for. `None` for an empty trajectory.
pub fn warp_held_share(on_drawing: &SketchTrajectoryResponse) -> Option<f64> {
    let n = on_drawing.points.len();
    let held = on_drawing
        .points
        .iter()
        .filter(|p| p.source == DrawingPoseSource::Warp.as_str())
        .count();
    (n > 0).then(|| held as f64 / n as f64)
}

/// The final trajectory on the drawing through the fitted warp, written by `sketch` runs.
pub const WARP_TRAJECTORY_FILE: &str = "warp-trajectory.csv";
/// The map and route over the drawing through the warp (the service's
/// `sketch-overlay.png`), written by `sketch` runs.
pub const SKETCH_OVERLAY_FILE: &str = "sketch-overlay.png";
/// The drawing's lines over the map through the warp's inverse (the service's
/// `sketch-in-map.png`), written by `sketch` runs.
pub const SKETCH_IN_MAP_FILE: &str = "sketch-in-map.png";

/// Each scan's pose on the drawing as the session published it then (`live drw`), written
/// by `sketch` runs in both modes.
pub const LIVE_SKETCH_TRAJECTORY_FILE: &str = "live-sketch-trajectory.csv";

/// Writes poses on the drawing (stamp in seconds) as `file` in `out_dir`
/// ([`WARP_TRAJECTORY_FILE`], [`LIVE_SKETCH_TRAJECTORY_FILE`]), in the format of
/// `sketch-trajectory.csv` by the same writer.
pub fn write_drawing_trajectory(
    out_dir: &Path,
    file: &str,
    poses: &[(f64, SketchPose)],
) -> Result<()> {
    let rows: Vec<DrawingRow> = poses
        .iter()
        .map(|(t_s, p)| DrawingRow {
            t_s: *t_s,
            u_px: p.u_px,
            v_px: p.v_px,
            heading_rad: p.heading_rad,
            meters_per_pixel: p.meters_per_pixel,
        })
        .collect();
    std::fs::write(out_dir.join(file), sketch_trajectory_csv::write(&rows))?;
    Ok(())
}

/// The poses a session served on the drawing, stamp in seconds — the warp's where the
/// mapped walls hold it, MCL's at each scan elsewhere (MCL's carried forward by odometry
/// between scans are left out): what the scoring of the pose on the drawing compares with
/// the truth, in both modes.
pub fn served_drawing_poses(on_drawing: &SketchTrajectoryResponse) -> Vec<(f64, SketchPose)> {
    on_drawing
        .points
        .iter()
        .filter(|p| p.source != DrawingPoseSource::Odometry.as_str())
        .map(|p| {
            let pose = SketchPose {
                u_px: p.u,
                v_px: p.v,
                heading_rad: p.heading,
                meters_per_pixel: p.meters_per_pixel,
            };
            (p.t, pose)
        })
        .collect()
}

impl InProcessRun {
    /// With loop closure: writes `loops.csv` into `out_dir` (every loop of the final graph
    /// against the truth, [`crate::loop_audit`]) and returns how many are off the truth;
    /// `None` without loop closure (`graph-open` included). Only for runs whose truth is a
    /// real trajectory.
    pub fn audit_loops(&self, out_dir: &Path) -> Result<Option<u32>> {
        let Some(closed) = self.mapper.closed_loops() else {
            return Ok(None);
        };
        let audited = loop_audit::audit(&closed, &self.truth);
        std::fs::write(out_dir.join("loops.csv"), loop_audit::loops_csv(&audited))?;
        Ok(Some(audited.iter().filter(|l| l.is_off()).count() as u32))
    }

    /// The figures of the run (scans, engine seconds, recoveries, loop closures).
    pub fn figures(&self) -> RunFigures {
        let health = self.mapper.health();
        RunFigures {
            scans: health.scans_processed,
            wall_s: self.mapping_s,
            recoveries: health.recoveries,
            loop_closures: health.loop_closures,
            loop_closures_rejected: health.loop_closures_rejected,
            warp_held: self.warp_held,
        }
    }

    /// Writes the run's name, figures and engine timing (mean and 99th percentile per
    /// scan, realtime factor over the truth's span) into a scored `result`.
    pub fn fill(
        &self,
        result: &mut RunResult,
        name: &str,
        method: impl Into<RunMethod>,
        sketch: Option<&SketchConfig>,
    ) {
        self.figures().fill(result, name, method, sketch);
        let mut scan_ms = self.scan_ms.clone();
        scan_ms.sort_by(f64::total_cmp);
        if !scan_ms.is_empty() {
            result.scan_ms_mean = Some(scan_ms.iter().sum::<f64>() / scan_ms.len() as f64);
            result.scan_ms_p99 = Some(scan_ms[(scan_ms.len() * 99 / 100).min(scan_ms.len() - 1)]);
        }
        if let (Some(first), Some(last)) = (self.truth.first(), self.truth.last()) {
            result.realtime_factor = Some((last.t_s - first.t_s) / self.mapping_s.max(1e-9));
        }
        result.session_heap_mb = Some(self.mapper.heap_bytes() as f64 / 1e6);
    }
}

/// What every run reports besides its scores, in-process or through the processes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunFigures {
    /// Scans processed.
    pub scans: u64,
    /// Seconds of the mapping (engine time in-process, wall time through the processes).
    pub wall_s: f64,
    /// Recoveries of MCL on the sketch.
    pub recoveries: u32,
    /// Loops closed.
    pub loop_closures: u32,
    /// Matched loops refused.
    pub loop_closures_rejected: u32,
    /// `sketch` runs: the share of the served trajectory where mapped walls hold W.
    pub warp_held: Option<f64>,
}

impl RunFigures {
    /// Writes the run's name and these figures into a scored `result`.
    pub fn fill(
        &self,
        result: &mut RunResult,
        name: &str,
        method: impl Into<RunMethod>,
        sketch: Option<&SketchConfig>,
    ) {
        let method: RunMethod = method.into();
        result.scenario = name.to_string();
        result.method = method.to_string();
        result.sketch = sketch.map(|s| s.name.clone());
        result.scans = self.scans;
        result.wall_s = self.wall_s;
        result.scans_per_s = self.scans as f64 / self.wall_s.max(1e-9);
        result.recoveries = self.recoveries;
        result.loop_closures = self.loop_closures;
        result.loop_closures_rejected = self.loop_closures_rejected;
        result.warp_held = self.warp_held;
    }
}
