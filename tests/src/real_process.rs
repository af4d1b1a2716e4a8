//! One evaluation run through the real processes: `slam-service` and `simulator`.
//!
//! The run starts the service on a free loopback port with a fresh data dir and iceoryx2
//! prefix, uploads the sketch and starts the session through the typed API client, runs
//! the simulator in lock-step (nothing lost, deterministic), waits until every published
//! scan is processed, stops the session, fetches `map.pgm`, `map.yaml` and
//! `trajectory.csv` over HTTP and scores them against the simulator's `truth.csv` exactly
//! as the in-process mode does.

use crate::metrics::StampedPose;
use crate::metrics::WallGrid;
use crate::processes::{ChildGuard, binary, unique_prefix};
use crate::run::ONLINE_TRAJECTORY_FILE;
use crate::run::{RunResult, Truth, read_trajectory_csv, score_artifacts, seen_wall_pixels};
use crate::run_loop::{
    LIVE_SKETCH_TRAJECTORY_FILE, RunFigures, SKETCH_IN_MAP_FILE, SKETCH_OVERLAY_FILE,
    WARP_TRAJECTORY_FILE, served_drawing_poses, warp_held_share, write_drawing_trajectory,
};
use crate::run_method::RunMethod;
use crate::service_histogram::{SCAN_PROCESSING, ServiceHistogram};
use crate::service_process::{ServiceOptions, ServiceProcess};
use crate::session_request::{baseline_session, sketch_session};
use crate::sketch_truth::{fill_sketch_pose_scores, score_published_poses};
use anyhow::{Context, Result, bail};
use sketchslam_api::{
    ClientError, CreateSessionRequest, DrawingPointOut, LidarMount, MAX_TRANSFORM_POINTS,
    MapPointIn, SessionEvent, SketchPoseInfo, SketchslamClient, TrajectoryPointInfo,
    TransformRequest,
};
use sketchslam_engine::mapper::{Method, SketchHeadingView};
use sketchslam_engine::sketch::SketchPose;
use sketchslam_simulator::scenario::{Scenario, SketchConfig};
use sketchslam_simulator::simulation::Simulation;
use sketchslam_simulator::world::World;
use sketchslam_slam::method::{api_drawing_localization, api_method, api_odometry_noise};
use sketchslam_types::Pose2;
use sketchslam_types::trajectory_csv::{self, NumberFormat};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The API's pose on the drawing as the engine's (degrees → radians).
pub(crate) fn sketch_pose_of(s: &SketchPoseInfo) -> SketchPose {
    SketchPose {
        u_px: s.u,
        v_px: s.v,
        heading_rad: s.heading_deg.to_radians(),
        meters_per_pixel: s.meters_per_pixel,
    }
}

/// The robot id the simulator publishes under in an evaluation run.
const ROBOT_ID: &str = "eval";
/// How long the session may go without processing a scan once the simulator is done.
const DRAIN_IDLE_TIMEOUT: Duration = Duration::from_secs(20);

/// Maps `scenario` with `method` through the real processes and scores the result; with
/// `max_scans`, only the run's first scans.
pub fn run_real_process(
    scenario: &Scenario,
    method: impl Into<RunMethod>,
    sketch: Option<&SketchConfig>,
    out_dir: &Path,
    max_scans: Option<u64>,
    progress: impl FnMut(u64, u64),
) -> Result<RunResult> {
    let source = StreamSource {
        subcommand: "run",
        dir: &scenario.dir,
        seed: scenario.seed,
        scans: Simulation::new(scenario)?.scan_count(),
        lidar_mount: scenario.lidar.mount,
    };
    let run_method = method.into().on_wheels(&scenario.odometry);
    let method = run_method.method;
    let mapped = map_through_processes(&source, run_method, sketch, out_dir, max_scans, progress)?;
    let world = World::load(&scenario.world.image, scenario.world.resolution_m)?;
    let walls = WallGrid::from_image(
        &image::open(&scenario.world.image)?.to_luma8(),
        scenario.world.resolution_m,
    );
    let poses = read_trajectory_csv(&out_dir.join("truth.csv"))?;
    let seen_walls = seen_wall_pixels(scenario, &world, &walls, &poses);
    let truth = Truth {
        poses,
        seen_walls,
        walls,
    };
    let mut result = score_artifacts(out_dir, &truth)?;
    mapped.fill(&mut result, &scenario.name, method, sketch);
    if let Some(cfg) = sketch.filter(|_| method == Method::Sketch) {
        fill_sketch_pose_scores(
            &mut result,
            &scenario.dir,
            &cfg.name,
            &truth.poses,
            &mapped.published_sketch_poses,
        )?;
        if let Some(score) =
            score_published_poses(&scenario.dir, &cfg.name, &truth.poses, &mapped.warp_poses)?
        {
            result.warp_pose_median_m = Some(score.median_m);
            result.warp_pose_p95_m = Some(score.p95_m);
            result.warp_pose_within_1m = Some(score.within_1m);
        }
        if let Some(score) = score_published_poses(
            &scenario.dir,
            &cfg.name,
            &truth.poses,
            &mapped.live_sketch_poses,
        )? {
            result.live_sketch_pose_median_m = Some(score.median_m);
            result.live_sketch_pose_within_1m = Some(score.within_1m);
        }
    }
    Ok(result)
}

/// What the `simulator` process streams: `simulator SUBCOMMAND DIR` (`run` a scenario or
/// `replay` a dataset), the session seed and the stream's scan count.
pub struct StreamSource<'a> {
    /// `run` or `replay`.
    pub subcommand: &'static str,
    /// The scenario or dataset folder.
    pub dir: &'a Path,
    /// Seed of the session.
    pub seed: u64,
    /// Scans in the whole stream.
    pub scans: u64,
    /// Where the stream's LiDAR sits on the robot (sent with the session).
    pub lidar_mount: Pose2,
}

/// What the service reported once a run through the processes was done.
pub struct ProcessRun {
    /// Scans processed, wall seconds from the simulator's start to the last scan
    /// processed, recoveries and loops closed.
    pub figures: RunFigures,
    /// The session's last pose: map frame, and on the drawing (`sketch` sessions).
    pub final_pose: (Pose2, Option<SketchPose>),
    /// `sketch` sessions: the session's pose on the drawing at each scan (its trajectory on
    /// the drawing, `GET …/trajectory?frame=sketch`, the points MCL gave), stamp in seconds.
    pub published_sketch_poses: Vec<(f64, SketchPose)>,
    /// `sketch` sessions: the final trajectory on the drawing through the session's warp
    /// (`POST …/transform`), stamp in seconds.
    pub warp_poses: Vec<(f64, SketchPose)>,
    /// `sketch` sessions: each scan's pose on the drawing as the event stream first
    /// published it (through the warp the session held then), stamp in seconds.
    pub live_sketch_poses: Vec<(f64, SketchPose)>,
    /// The service's time per scan (its `/metrics` histogram, read once every scan was
    /// processed), seconds; `None` when it had none.
    pub processing: Option<ServiceHistogram>,
    /// The stream's span in sensor time: last minus first stamp of the session's
    /// trajectory, seconds.
    pub stream_span_s: f64,
    /// The session's `sketchslam_session_heap_bytes` once every scan was processed.
    pub heap_bytes: Option<u64>,
}

impl ProcessRun {
    /// Writes the run's name and figures into a scored `result`.
    pub fn fill(
        &self,
        result: &mut RunResult,
        name: &str,
        method: Method,
        sketch: Option<&SketchConfig>,
    ) {
        self.figures.fill(result, name, method, sketch);
        if let Some(h) = &self.processing {
            result.scan_ms_mean = h.mean().map(|s| s * 1e3);
            result.scan_ms_p99 = h.quantile(0.99).map(|s| s * 1e3);
            // As in-process: the stream's duration over the engine's time.
            result.realtime_factor = (h.sum > 0.0).then(|| self.stream_span_s / h.sum);
        }
        result.session_heap_mb = self.heap_bytes.map(|b| b as f64 / 1e6);
    }
}

/// Runs `slam-service` and `simulator SUBCOMMAND` (lock-step) on `source`, waits until
/// every published scan is processed and writes `map.pgm`, `map.yaml`, `trajectory.csv`
/// (from the service) and `truth.csv` (from the simulator) into `out_dir`. Of `method`'s
/// settings the session is asked for the drawing localization when it is not the
/// service's default; the others are the service's.
pub fn map_through_processes(
    source: &StreamSource<'_>,
    method: impl Into<RunMethod>,
    sketch: Option<&SketchConfig>,
    out_dir: &Path,
    max_scans: Option<u64>,
    mut progress: impl FnMut(u64, u64),
) -> Result<ProcessRun> {
    let simulator_bin = binary("sketchslam-simulator", "simulator")?;
    std::fs::create_dir_all(out_dir)?;
    let data_dir = out_dir.join("service-data");
    let _ = std::fs::remove_dir_all(&data_dir);
    let prefix = unique_prefix("eval");
    let options = ServiceOptions::new(&data_dir, &prefix, out_dir.join("service.log"));
    // One worker, so the event reader below runs while this thread polls the session.
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()?;
    let mut service = runtime.block_on(ServiceProcess::start(&options))?;
    let client = service.client.clone();
    let run_method = method.into();
    let method = run_method.method;

    let request = match (method, sketch) {
        (Method::Sketch, Some(cfg)) => {
            let bytes = std::fs::read(&cfg.image)
                .with_context(|| format!("reading {}", cfg.image.display()))?;
            let info = runtime.block_on(client.upload_sketch(bytes, Some(&cfg.name)))?;
            sketch_session(ROBOT_ID, &info.id, cfg, Some(source.seed))
        }
        (Method::Sketch, None) => bail!("the sketch method needs a sketch"),
        (m, _) => baseline_session(ROBOT_ID, api_method(m), Some(source.seed)),
    };
    let mount = source.lidar_mount;
    let view = run_method.sketch_heading_view;
    let request = CreateSessionRequest {
        lidar_mount: (mount != Pose2::IDENTITY).then(|| LidarMount::from_pose(mount)),
        odometry_noise: run_method.odometry_noise.as_ref().map(api_odometry_noise),
        drawing_localization: (method == Method::Sketch && view != SketchHeadingView::default())
            .then(|| api_drawing_localization(view)),
        ..request
    };
    let session = runtime.block_on(client.create_session(&request))?;
    // The poses as a live client sees them (map frame, and on the drawing), until the
    // session stops.
    let mut events = runtime.block_on(client.events(&session.id))?;
    let recorder = runtime.spawn(async move {
        let (mut poses, mut on_drawing) = (Vec::new(), Vec::new());
        while let Ok(Some(event)) = events.next_event().await {
            if let SessionEvent::Pose(p) = event
                && let Some(t_s) = p.stamp
            {
                poses.push(StampedPose {
                    t_s,
                    pose: Pose2::new(p.x, p.y, p.theta),
                });
                if let Some(sketch) = &p.sketch {
                    on_drawing.push((t_s, sketch_pose_of(sketch)));
                }
            }
        }
        (poses, on_drawing)
    });

    let total = max_scans.map_or(source.scans, |m| m.min(source.scans));
    let truth_path = out_dir.join("truth.csv");
    let started = Instant::now();
    let mut simulator = ChildGuard::spawn(
        "simulator",
        Command::new(&simulator_bin)
            .arg(source.subcommand)
            .arg(source.dir)
            .args([
                "--robot",
                ROBOT_ID,
                "--lockstep",
                "--quiet",
                "--ipc-prefix",
                &prefix,
            ])
            .arg("--truth-out")
            .arg(&truth_path)
            .args(["--max-scans", &total.to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null()),
    )?;
    // Follow the session until the simulator is done and every scan is processed.
    let mut last_count = 0;
    let mut last_change = Instant::now();
    let mut simulator_done = false;
    loop {
        std::thread::sleep(Duration::from_millis(200));
        if !simulator_done && let Some(status) = simulator.child_mut().try_wait()? {
            if !status.success() {
                bail!("the simulator failed: {status}");
            }
            simulator_done = true;
        }
        let info = runtime.block_on(client.get_session(&session.id))?;
        if let Some(err) = &info.last_error
            && info.state == sketchslam_api::types::SessionState::Failed
        {
            bail!("the session failed: {err}");
        }
        progress(info.scans_processed, total);
        if info.scans_processed != last_count {
            last_count = info.scans_processed;
            last_change = Instant::now();
        }
        if simulator_done && last_count >= total {
            break;
        }
        if simulator_done && last_change.elapsed() > DRAIN_IDLE_TIMEOUT {
            bail!("the session stopped at {last_count} of {total} scans");
        }
    }
    let wall_s = started.elapsed().as_secs_f64();
    // One session per service: the service's histogram is this session's.
    let metrics = runtime.block_on(client.metrics())?;
    let processing = ServiceHistogram::parse(&metrics, SCAN_PROCESSING);
    let heap_bytes = metrics
        .lines()
        .filter(|l| l.starts_with("sketchslam_session_heap_bytes{"))
        .find(|l| l.contains(&format!("session=\"{}\"", session.id)))
        .and_then(|l| l.rsplit_once(' ')?.1.parse().ok());
    let stopped = runtime.block_on(client.stop_session(&session.id))?;
    // The stopped session's last pose: on the drawing through the final map's warp.
    let pose = runtime.block_on(client.pose(&session.id))?;
    let final_pose = (
        Pose2::new(pose.x, pose.y, pose.theta),
        pose.sketch.as_ref().map(sketch_pose_of),
    );
    // The event stream ends with the session.
    let (published_poses, live_sketch_poses) = runtime
        .block_on(async { tokio::time::timeout(Duration::from_secs(20), recorder).await })
        .context("the session's event stream did not end after the stop")??;
    std::fs::write(
        out_dir.join(ONLINE_TRAJECTORY_FILE),
        trajectory_csv::write(&published_poses, NumberFormat::Fixed),
    )?;
    let (mut published_sketch_poses, mut warp_poses) = (Vec::new(), Vec::new());
    let mut warp_held = None;
    if method == Method::Sketch {
        write_drawing_trajectory(out_dir, LIVE_SKETCH_TRAJECTORY_FILE, &live_sketch_poses)?;
        let on_drawing = runtime.block_on(client.sketch_trajectory(&session.id))?;
        std::fs::write(out_dir.join("sketch-trajectory.csv"), on_drawing.to_csv())?;
        published_sketch_poses = served_drawing_poses(&on_drawing);
        warp_held = warp_held_share(&on_drawing);
        warp_poses = fetch_registration(&runtime, &client, &session.id, out_dir)?;
    }
    std::fs::write(
        out_dir.join("map.pgm"),
        runtime.block_on(client.map_pgm(&session.id))?,
    )?;
    std::fs::write(
        out_dir.join("map.yaml"),
        runtime.block_on(client.map_yaml(&session.id))?,
    )?;
    std::fs::write(
        out_dir.join("trajectory.csv"),
        runtime.block_on(client.trajectory_csv(&session.id))?,
    )?;
    service.guard.terminate(Duration::from_secs(10));
    let trajectory = read_trajectory_csv(&out_dir.join("trajectory.csv"))?;
    let stream_span_s = match (trajectory.first(), trajectory.last()) {
        (Some(first), Some(last)) => last.t_s - first.t_s,
        _ => 0.0,
    };
    Ok(ProcessRun {
        figures: RunFigures {
            scans: stopped.scans_processed,
            wall_s,
            recoveries: stopped.recoveries as u32,
            loop_closures: stopped.loop_closures as u32,
            loop_closures_rejected: stopped.loop_closures_rejected as u32,
            warp_held,
        },
        final_pose,
        published_sketch_poses,
        warp_poses,
        live_sketch_poses,
        processing,
        stream_span_s,
        heap_bytes,
    })
}

/// A transform request carrying trajectory `points` (with their headings) onto the drawing.
pub fn to_drawing_request(points: &[TrajectoryPointInfo]) -> TransformRequest {
    TransformRequest {
        to_map: vec![],
        to_drawing: points
            .iter()
            .map(|p| MapPointIn {
                x_m: p.x,
                y_m: p.y,
                heading_rad: Some(p.theta),
            })
            .collect(),
    }
}

/// Trajectory `points` paired with `POST …/transform`'s answers for them, as poses on the
/// drawing stamped in seconds (a heading not asked for is NaN).
pub fn poses_on_drawing(
    points: &[TrajectoryPointInfo],
    answers: &[DrawingPointOut],
) -> Vec<(f64, SketchPose)> {
    points
        .iter()
        .zip(answers)
        .map(|(p, d)| {
            let pose = SketchPose {
                u_px: d.u_px,
                v_px: d.v_px,
                heading_rad: d.heading_rad.unwrap_or(f64::NAN),
                meters_per_pixel: d.meters_per_pixel,
            };
            (p.t, pose)
        })
        .collect()
}

/// A `sketch` session's map laid on its drawing, over HTTP: the final trajectory through
/// `POST /transform` (written as `warp-trajectory.csv` and returned, stamp in seconds), and
/// `sketch-overlay.png`, `sketch-in-map.png`. Nothing (and no error) while the session has
/// nothing registered (409).
fn fetch_registration(
    runtime: &tokio::runtime::Runtime,
    client: &SketchslamClient,
    session_id: &str,
    out_dir: &Path,
) -> Result<Vec<(f64, SketchPose)>> {
    let trajectory = runtime.block_on(client.trajectory(session_id))?;
    // In batches the endpoint takes.
    let mut to_drawing = Vec::with_capacity(trajectory.points.len());
    for chunk in trajectory.points.chunks(MAX_TRANSFORM_POINTS) {
        match runtime.block_on(client.transform(session_id, &to_drawing_request(chunk))) {
            Err(ClientError::Api { status, .. }) if status.as_u16() == 409 => {
                return Ok(Vec::new());
            }
            other => to_drawing.extend(other?.to_drawing),
        }
    }
    let poses = poses_on_drawing(&trajectory.points, &to_drawing);
    write_drawing_trajectory(out_dir, WARP_TRAJECTORY_FILE, &poses)?;
    std::fs::write(
        out_dir.join(SKETCH_OVERLAY_FILE),
        runtime.block_on(client.sketch_overlay_on_map_png(session_id))?,
    )?;
    std::fs::write(
        out_dir.join(SKETCH_IN_MAP_FILE),
        runtime.block_on(client.sketch_in_map_png(session_id))?,
    )?;
    Ok(poses)
}
