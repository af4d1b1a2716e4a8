//! `simulator`: a thin command line over the simulator library.
//!
//! - `simulator run SCENARIO_DIR --robot ID [--rate F | --lockstep] [--truth-out FILE]
//!   [--ipc-prefix P] [--max-scans N]` simulates the scenario and publishes its scans and
//!   odometry over iceoryx2 (`shared::ipc`), then writes the true poses of what it sent;
//! - `simulator replay DATASET_DIR --robot ID [same options as run]` publishes a dataset's
//!   recorded log the same way (the log's corrected poses plus seeded drift as odometry;
//!   `--truth-out` gets the log's poses at the scans);
//! - `simulator replay BAG.mcap --robot ID [--scan-topic /scan] [--odom-topic /odom]
//!   [--base-frame F] [same options]` publishes a ROS 2 bag's LaserScan and Odometry, stamps
//!   from their headers, and logs the LiDAR's mount from `/tf_static` (`rosbag` module);
//! - `simulator render SCENARIO_DIR --out FILE.png [--scans N]` draws the scenario;
//! - `simulator generate OUT_DIR --seed N [--kind office|corridor|hall|mixed]
//!   [--lidar good|cheap]` writes a generated scenario folder (`generate` module).
//!
//! Logs go to stderr (`RUST_LOG`, default `info`); the exit code is non-zero with a message
//! on any bad input.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use sketchslam_ipc::{DEFAULT_BACKPRESSURE_TIMEOUT, IpcConfig, RobotPublisher};
use sketchslam_simulator::dataset::Dataset;
use sketchslam_simulator::generate::{GenerateOptions, Kind, LidarGrade};
use sketchslam_simulator::publish::{Pace, PublishOptions, publish_events};
use sketchslam_simulator::replay::Replay;
use sketchslam_simulator::rosbag::{BagTopics, read_bag};
use sketchslam_simulator::{Scenario, SimStep, Simulation};
use sketchslam_types::SensorEvent;
use sketchslam_types::StampedPose;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Debug, Parser)]
#[command(name = "simulator", version, about = "sketchslam sensor simulator")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a scenario and publish its scans and odometry over iceoryx2.
    Run(RunArgs),
    /// Replay a dataset's log (dataset.toml) or a ROS 2 bag (.mcap: LaserScan, Odometry,
    /// /tf_static) and publish it like a simulation.
    Replay(RunArgs),
    /// Draw a scenario (world, path, start, a few scans) as a PNG.
    Render(RenderArgs),
    /// Generate a scenario folder (world, route, sensors, sketches, sketch truth) from a seed.
    Generate(GenerateArgs),
}

#[derive(Debug, clap::Args)]
struct GenerateArgs {
    /// The folder to write (created if needed; files of the same names are replaced).
    out_dir: PathBuf,
    /// Seed of every random draw: the same seed gives the same bytes.
    #[arg(long)]
    seed: u64,
    /// The building: office, corridor, hall, or mixed (one of the three, by seed).
    #[arg(long, default_value = "mixed")]
    kind: Kind,
    /// The sensors: good (270°, 1081 beams, 30-50 m) or cheap (360°, 8-12 m, worn odometry).
    #[arg(long, default_value = "good")]
    lidar: LidarGrade,
}

#[derive(Debug, clap::Args)]
struct RunArgs {
    /// The scenario folder (holding scenario.toml); for `replay`, a dataset folder (holding
    /// dataset.toml) or a ROS 2 bag (`.mcap`).
    scenario_dir: PathBuf,
    /// `replay` of a bag: the `sensor_msgs/msg/LaserScan` topic.
    #[arg(long, default_value = "/scan")]
    scan_topic: String,
    /// `replay` of a bag: the `nav_msgs/msg/Odometry` topic.
    #[arg(long, default_value = "/odom")]
    odom_topic: String,
    /// `replay` of a bag: the robot's frame, where `/tf_static`'s chain to the laser starts
    /// (default: the odometry's child_frame_id, else base_link).
    #[arg(long)]
    base_frame: Option<String>,
    /// The robot id the messages are published under.
    #[arg(long)]
    robot: String,
    /// Speed-up over real time (1.0 = real time); a slow subscriber loses samples.
    #[arg(long, conflicts_with = "lockstep")]
    rate: Option<f64>,
    /// Wait for a subscriber, then send as fast as it consumes; nothing is lost.
    #[arg(long)]
    lockstep: bool,
    /// Write the true poses of the published events here (CSV `t,x,y,theta`).
    #[arg(long)]
    truth_out: Option<PathBuf>,
    /// The iceoryx2 prefix (isolates parallel runs).
    #[arg(long, env = "SKETCHSLAM_IPC_PREFIX", default_value = sketchslam_types::DEFAULT_PREFIX)]
    ipc_prefix: String,
    /// Stop after this many scans.
    #[arg(long)]
    max_scans: Option<u64>,
    /// Lock-step: seconds to wait for a subscriber before giving up.
    #[arg(long, default_value_t = 60.0)]
    connect_timeout_s: f64,
    /// Lock-step: milliseconds a live subscriber may keep its buffer full before a sample
    /// is discarded for it (dead subscribers are detected within ~20 ms regardless).
    #[arg(long, default_value_t = DEFAULT_BACKPRESSURE_TIMEOUT.as_millis() as u64)]
    backpressure_timeout_ms: u64,
    /// No progress line on stderr.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, clap::Args)]
struct RenderArgs {
    /// The scenario folder (holding scenario.toml).
    scenario_dir: PathBuf,
    /// The PNG to write.
    #[arg(long)]
    out: PathBuf,
    /// Scans drawn along the path.
    #[arg(long, default_value_t = 8)]
    scans: usize,
}

fn main() {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run(args, false),
        Command::Replay(args) => run(args, true),
        Command::Render(args) => render(args),
        Command::Generate(args) => generate(args),
    };
    if let Err(e) = result {
        eprintln!("simulator: error: {e:#}");
        std::process::exit(1);
    }
}

/// Publishes a simulation of a scenario, or (`replay`) a dataset's log.
fn run(args: RunArgs, replay: bool) -> Result<()> {
    let pace = if args.lockstep {
        if !(args.connect_timeout_s.is_finite() && args.connect_timeout_s > 0.0) {
            bail!("--connect-timeout-s must be a positive number of seconds");
        }
        Pace::LockStep {
            min_subscribers: 1,
            connect_timeout: Duration::from_secs_f64(args.connect_timeout_s),
        }
    } else {
        let rate = args.rate.unwrap_or(1.0);
        if !(rate.is_finite() && rate > 0.0) {
            bail!("--rate must be a positive factor (1.0 = real time), got {rate}");
        }
        Pace::RealTime { rate }
    };
    if args.backpressure_timeout_ms == 0 {
        bail!("--backpressure-timeout-ms must be at least 1");
    }
    let is_bag = replay
        && args
            .scenario_dir
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    if is_bag && args.truth_out.is_some() {
        bail!("--truth-out: a bag has no true poses");
    }
    let (steps, scan_count): (Box<dyn Iterator<Item = SimStep>>, u64) = if is_bag {
        let topics = BagTopics {
            scan: args.scan_topic.clone(),
            odom: args.odom_topic.clone(),
            base_frame: args.base_frame.clone(),
        };
        let replay = Replay::from_bag(&args.scenario_dir, read_bag(&args.scenario_dir, &topics)?);
        tracing::info!("{}", replay.drift_note());
        let scans = replay.scan_count();
        (Box::new(replay), scans)
    } else if replay {
        let dataset = Dataset::load(&args.scenario_dir)
            .with_context(|| format!("loading dataset {}", args.scenario_dir.display()))?;
        let replay = Replay::new(&dataset).context("reading the log")?;
        tracing::warn!("{}", replay.drift_note());
        let scans = replay.scan_count();
        (Box::new(replay), scans)
    } else {
        let scenario = Scenario::load(&args.scenario_dir)
            .with_context(|| format!("loading scenario {}", args.scenario_dir.display()))?;
        let simulation = Simulation::new(&scenario).context("setting up the simulation")?;
        let scans = simulation.scan_count();
        (Box::new(simulation), scans)
    };
    let expected_scans = match args.max_scans {
        Some(max) => max.min(scan_count),
        None => scan_count,
    };
    let config = IpcConfig::new(&args.ipc_prefix).context("--ipc-prefix")?;
    let delivery = pace.delivery(Duration::from_millis(args.backpressure_timeout_ms));
    let mut publisher =
        RobotPublisher::new(&config, &args.robot, delivery).context("opening iceoryx2")?;
    tracing::info!(
        scenario = %args.scenario_dir.display(),
        robot = %args.robot,
        prefix = %args.ipc_prefix,
        scans = expected_scans,
        ?pace,
        "publishing"
    );

    let mut truth: Vec<StampedPose> = Vec::new();
    let keep_truth = args.truth_out.is_some();
    let events = steps
        .inspect(|step| {
            // truth.csv holds one row per scan (docs/architecture.md, "Files").
            if keep_truth && matches!(step.event, SensorEvent::Scan(_)) {
                truth.push(StampedPose {
                    t_s: step.t_s(),
                    pose: step.truth,
                });
            }
        })
        .map(|step| step.event);
    let options = PublishOptions {
        pace,
        max_scans: args.max_scans,
        expected_scans: Some(expected_scans),
        progress: !args.quiet,
    };
    let summary = publish_events(&mut publisher, events, &options)?;
    tracing::info!(
        scans = summary.scans_sent,
        odometry = summary.odometry_sent,
        discarded = summary.discarded,
        dead_nodes_cleaned = summary.dead_nodes_cleaned,
        wall_s = summary.wall_time.as_secs_f64(),
        sim_s = summary.sim_time_s,
        "done"
    );
    if let Some(path) = &args.truth_out {
        sketchslam_simulator::truth::write_truth_csv(path, &truth)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn render(args: RenderArgs) -> Result<()> {
    let scenario = Scenario::load(&args.scenario_dir)
        .with_context(|| format!("loading scenario {}", args.scenario_dir.display()))?;
    let img = sketchslam_simulator::render::render_scenario(&scenario, args.scans)?;
    sketchslam_simulator::render::save_png(&img, &args.out)?;
    tracing::info!(out = %args.out.display(), "rendered");
    Ok(())
}

fn generate(args: GenerateArgs) -> Result<()> {
    let options = GenerateOptions {
        seed: args.seed,
        kind: args.kind,
        lidar: args.lidar,
    };
    let world = sketchslam_simulator::generate::generate(&options, &args.out_dir)
        .with_context(|| format!("generating into {}", args.out_dir.display()))?;
    tracing::info!(
        out = %args.out_dir.display(),
        name = %world.name,
        size_m = %format!("{:.1} x {:.1}", world.floor.width_m, world.floor.height_m),
        route_m = %format!("{:.0}", world.route.length_m),
        sketches = world.drawings.len(),
        "generated"
    );
    Ok(())
}
