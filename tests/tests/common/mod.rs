//! Helpers shared by the multi-process tests (`simulator_restart`, `service_restart`,
//! `bad_scans`, `http_errors`, `vda5050_mqtt`, ...): a temporary folder removed on drop and
//! a test body run in one with its logs printed on failure ([`in_temp_dir`]), the real
//! `slam-service` started on a free port and waited for, the simulator launched on
//! `paper-env1`, and bounded polling of a session.
//!
//! Every wait has a deadline; every child is a [`ChildGuard`], killed on drop.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use sketchslam_api::{SessionInfo, SessionState, SketchslamClient};
use sketchslam_simulator::scenario::{Scenario, SketchConfig};
use sketchslam_simulator::simulation::Simulation;
use sketchslam_tests::processes::{ChildGuard, binary, bundled_scenario, unique_prefix};
#[allow(unused_imports)] // not every test dumps a log
pub use sketchslam_tests::service_process::dump_log;
use sketchslam_tests::service_process::{ServiceOptions, ServiceProcess};
use sketchslam_tests::session_request::sketch_session;
use sketchslam_types::{SensorEvent, StampedPose};

/// A folder removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    /// A fresh folder under the system temp dir.
    pub fn new(tag: &str) -> Result<Self> {
        let p = std::env::temp_dir().join(format!("{}-{tag}", unique_prefix(tag)));
        std::fs::create_dir_all(&p)?;
        Ok(TempDir(p))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The log [`start_service`] writes for a data dir `DIR/data`, relative to `DIR`.
pub const SERVICE_LOG: &str = "data.log";

/// Runs `body` in a fresh temporary folder (removed afterwards; a service run in it keeps
/// its data in `data/`), and when it fails prints the end of each of `logs`: paths relative
/// to the folder with how many last lines, e.g. `(SERVICE_LOG, 60)`.
pub async fn in_temp_dir<F, Fut>(tag: &str, logs: &[(&str, usize)], body: F) -> Result<()>
where
    F: FnOnce(PathBuf) -> Fut,
    Fut: std::future::Future<Output = Result<()>>,
{
    let dir = TempDir::new(tag)?;
    let result = body(dir.0.clone()).await;
    if result.is_err() {
        for (name, lines) in logs {
            dump_log(&dir.0.join(name), *lines);
        }
    }
    result
}

/// A running `slam-service` and a client of it.
pub type Service = ServiceProcess;

/// Starts `slam-service` on a free port over `data_dir` and `prefix`, with `extra` arguments
/// and `env` variables, logging to `data_dir.log` (appended: a restart on the same data dir
/// continues it), and waits until `/healthz` answers.
pub async fn start_service(
    data_dir: &Path,
    prefix: &str,
    extra: &[&str],
    env: &[(&str, &str)],
) -> Result<Service> {
    let mut options =
        ServiceOptions::new(data_dir, prefix, data_dir.with_extension("log")).append_log();
    options = options.args(extra);
    for (k, v) in env {
        options = options.env(*k, *v);
    }
    ServiceProcess::start(&options).await
}

/// `paper-env1` and its sketch A.
pub fn paper_env1_sketch_a() -> Result<(Scenario, SketchConfig)> {
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    let sketch = scenario
        .sketches
        .iter()
        .find(|s| s.name == "A")
        .context("sketch A of paper-env1")?
        .clone();
    Ok((scenario, sketch))
}

/// `paper-env1` copied into `dir` with its LiDAR mounted 0.3 m ahead of the centre and
/// turned 5° (`mount` added to its `[lidar]` table).
pub fn paper_env1_mounted(dir: &Path) -> Result<Scenario> {
    std::fs::create_dir_all(dir)?;
    for entry in std::fs::read_dir(bundled_scenario("paper-env1"))? {
        let entry = entry?;
        std::fs::copy(entry.path(), dir.join(entry.file_name()))?;
    }
    let toml = std::fs::read_to_string(dir.join("scenario.toml"))?;
    anyhow::ensure!(
        toml.contains("\n[lidar]\n"),
        "paper-env1 has no [lidar] table"
    );
    let toml = toml.replace("\n[lidar]\n", "\n[lidar]\nmount = [0.3, 0.0, 5.0]\n");
    std::fs::write(dir.join("scenario.toml"), toml)?;
    let scenario = Scenario::load(dir)?;
    anyhow::ensure!(
        scenario.lidar.mount != sketchslam_types::Pose2::IDENTITY,
        "the mount was not read"
    );
    Ok(scenario)
}

/// The first `scans` scans of `scenario` with the odometry before them, in stream order,
/// and the truth at each scan.
pub fn first_scans(
    scenario: &Scenario,
    scans: u64,
) -> Result<(Vec<SensorEvent>, Vec<StampedPose>)> {
    let mut events = Vec::new();
    let mut truth = Vec::new();
    for step in Simulation::new(scenario)? {
        if let SensorEvent::Scan(_) = step.event {
            truth.push(StampedPose {
                t_s: step.t_s(),
                pose: step.truth,
            });
        }
        events.push(step.event);
        if truth.len() as u64 == scans {
            break;
        }
    }
    Ok((events, truth))
}

/// Uploads sketch A and starts a sketch session for `robot` at its marked start.
pub async fn start_sketch_a_session(
    client: &SketchslamClient,
    robot: &str,
) -> Result<(String, SessionInfo)> {
    let (_, cfg) = paper_env1_sketch_a()?;
    let sketch = client
        .upload_sketch(std::fs::read(&cfg.image)?, Some("A"))
        .await?;
    let session = client
        .create_session(&sketch_session(robot, &sketch.id, &cfg, None))
        .await?;
    Ok((sketch.id, session))
}

/// Launches the simulator on `paper-env1` in lock-step for `robot`.
pub fn spawn_simulator_lockstep(
    prefix: &str,
    robot: &str,
    max_scans: u64,
    truth_out: Option<&Path>,
) -> Result<ChildGuard> {
    let exe = binary("sketchslam-simulator", "simulator")?;
    let mut cmd = Command::new(exe);
    cmd.arg("run")
        .arg(bundled_scenario("paper-env1"))
        .args(["--robot", robot, "--lockstep", "--quiet"])
        .args(["--ipc-prefix", prefix])
        .args(["--max-scans", &max_scans.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if let Some(p) = truth_out {
        cmd.arg("--truth-out").arg(p);
    }
    ChildGuard::spawn("simulator", &mut cmd)
}

/// Runs the simulator on `paper-env1` in lock-step for `robot` until it has published
/// `max_scans` scans (writing its truth to `truth_out`) and exits; an error unless it exits
/// successfully within `timeout`.
pub async fn run_simulator_lockstep(
    prefix: &str,
    robot: &str,
    max_scans: u64,
    truth_out: Option<&Path>,
    timeout: Duration,
) -> Result<()> {
    let mut sim = spawn_simulator_lockstep(prefix, robot, max_scans, truth_out)?;
    let status = tokio::task::spawn_blocking(move || {
        let s = sim.wait_timeout(timeout);
        (sim, s)
    })
    .await?
    .1?;
    if !status.success() {
        bail!("the simulator failed: {status}");
    }
    Ok(())
}

/// Polls the session every 100 ms until `done` holds (Ok), it fails, or `timeout` passes.
pub async fn wait_session(
    client: &SketchslamClient,
    id: &str,
    timeout: Duration,
    what: &str,
    mut done: impl FnMut(&SessionInfo) -> bool,
) -> Result<SessionInfo> {
    let deadline = Instant::now() + timeout;
    loop {
        let info = client.get_session(id).await?;
        if info.state == SessionState::Failed {
            bail!(
                "session failed while waiting for {what}: {:?}",
                info.last_error
            );
        }
        if done(&info) {
            return Ok(info);
        }
        if Instant::now() > deadline {
            bail!("timed out after {timeout:?} waiting for {what}; last status {info:?}");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Waits until the session's scan count has not changed for `quiet`, at most `timeout`.
pub async fn wait_settled(
    client: &SketchslamClient,
    id: &str,
    quiet: Duration,
    timeout: Duration,
) -> Result<SessionInfo> {
    let deadline = Instant::now() + timeout;
    let mut last = client.get_session(id).await?;
    let mut since = Instant::now();
    loop {
        tokio::time::sleep(Duration::from_millis(100)).await;
        let info = client.get_session(id).await?;
        if info.scans_processed != last.scans_processed {
            since = Instant::now();
        } else if since.elapsed() >= quiet {
            return Ok(info);
        }
        last = info;
        if Instant::now() > deadline {
            bail!("the session did not settle within {timeout:?}: {last:?}");
        }
    }
}
