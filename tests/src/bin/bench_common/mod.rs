//! Support shared by `bench-fleet` and `bench-http` (included with `#[path]`, not a binary):
//! starting the real `slam-service` (through `ServiceProcess`), the real-time simulator,
//! sessions on `paper-env1`, the service's CPU time from `/proc`, and the scan processing time
//! histogram from `/metrics`.

#![allow(dead_code)]

use anyhow::{Context, Result, bail};
use sketchslam_api::{MappingMethod, SessionInfo, SketchslamClient};
use sketchslam_engine::mapper::Method;
use sketchslam_simulator::scenario::{Scenario, SketchConfig};
use sketchslam_slam::method::api_method;
use sketchslam_tests::processes::{ChildGuard, binary, bundled_scenario};
use sketchslam_tests::service_process::{ServiceOptions, ServiceProcess};
use sketchslam_tests::session_request::{baseline_session, sketch_session};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Starts `slam-service` over `data_dir` as the benchmarks run it (64 sessions at most,
/// warnings only in `log`) and waits for `/healthz`.
pub async fn start_service(data_dir: &Path, prefix: &str, log: &Path) -> Result<ServiceProcess> {
    let options = ServiceOptions::new(data_dir, prefix, log)
        .args(["--max-sessions", "64"])
        .env("RUST_LOG", "warn");
    ServiceProcess::start(&options).await
}

/// `paper-env1` and its sketch A.
pub fn paper_env1() -> Result<(Scenario, SketchConfig)> {
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    let sketch = scenario
        .sketches
        .iter()
        .find(|s| s.name == "A")
        .context("sketch A")?
        .clone();
    Ok((scenario, sketch))
}

/// Parses `sketch`, `icp` or `odometry` (the engine's names, through the runtime's one
/// mapping to the API's methods).
pub fn parse_method(s: &str) -> Result<MappingMethod> {
    let method: Method = s.parse()?;
    Ok(api_method(method))
}

/// Starts a session for `robot`; `sketch_id` is the uploaded sketch A for the sketch method.
pub async fn create_session(
    client: &SketchslamClient,
    robot: &str,
    method: MappingMethod,
    sketch_id: Option<&str>,
    cfg: &SketchConfig,
) -> Result<SessionInfo> {
    let request = match (method, sketch_id) {
        (MappingMethod::Sketch, Some(id)) => sketch_session(robot, id, cfg, None),
        (MappingMethod::Sketch, None) => bail!("a sketch session needs an uploaded sketch"),
        (m, _) => baseline_session(robot, m, None),
    };
    Ok(client.create_session(&request).await?)
}

/// Launches the simulator in real time (`--rate`) for `robot`, writing its truth rows (one
/// per published scan) to `truth` and its log to `log`.
pub fn spawn_simulator(
    prefix: &str,
    robot: &str,
    rate: f64,
    max_scans: u64,
    truth: &Path,
    log: &Path,
) -> Result<ChildGuard> {
    let exe = binary("sketchslam-simulator", "simulator")?;
    ChildGuard::spawn(
        "simulator",
        Command::new(exe)
            .arg("run")
            .arg(bundled_scenario("paper-env1"))
            .args(["--robot", robot, "--quiet", "--ipc-prefix", prefix])
            .args(["--rate", &rate.to_string()])
            .args(["--max-scans", &max_scans.to_string()])
            .arg("--truth-out")
            .arg(truth)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log)?),
    )
}

/// Waits for every child to exit, `timeout` at most for all; fails on a non-zero exit.
pub async fn wait_all(children: &mut [ChildGuard], timeout: Duration) -> Result<()> {
    let deadline = Instant::now() + timeout;
    for c in children.iter_mut() {
        loop {
            if let Some(status) = c.child_mut().try_wait()? {
                if !status.success() {
                    bail!("a simulator failed: {status}");
                }
                break;
            }
            if Instant::now() > deadline {
                bail!("the simulators did not finish within {timeout:?}");
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
    Ok(())
}

/// Waits until no session's scan count changed for `quiet` (at most `timeout`).
pub async fn wait_settled(
    client: &SketchslamClient,
    ids: &[String],
    quiet: Duration,
    timeout: Duration,
) -> Result<Vec<SessionInfo>> {
    let deadline = Instant::now() + timeout;
    let mut last: Vec<u64> = Vec::new();
    let mut since = Instant::now();
    loop {
        let mut infos = Vec::new();
        for id in ids {
            infos.push(client.get_session(id).await?);
        }
        let counts: Vec<u64> = infos.iter().map(|i| i.scans_processed).collect();
        if counts != last {
            last = counts;
            since = Instant::now();
        } else if since.elapsed() >= quiet || Instant::now() > deadline {
            return Ok(infos);
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// Rows of a truth CSV = scans the simulator published.
pub fn truth_rows(path: &Path) -> Result<u64> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let rows = sketchslam_types::trajectory_csv::parse(&text)
        .with_context(|| format!("parsing {}", path.display()))?;
    Ok(rows.len() as u64)
}

/// Samples the simulator discarded for a full subscriber buffer (its `done` log line).
pub fn discarded_in_log(path: &Path) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    let line = text.lines().rev().find(|l| l.contains("discarded="))?;
    let rest = &line[line.find("discarded=")? + "discarded=".len()..];
    rest.split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

/// User + system CPU seconds of process `pid` so far (from `/proc/PID/stat`).
pub fn cpu_seconds(pid: u32) -> Result<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))?;
    // Fields after the command name (which may hold spaces) in parentheses.
    let after = &stat[stat.rfind(')').context("malformed stat")? + 2..];
    let fields: Vec<&str> = after.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line: 12 and 13 after ")".
    let utime: f64 = fields.get(11).context("utime")?.parse()?;
    let stime: f64 = fields.get(12).context("stime")?.parse()?;
    Ok((utime + stime) / clock_ticks() as f64)
}

fn clock_ticks() -> u64 {
    // SAFETY: sysconf has no preconditions.
    let t = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    if t > 0 { t as u64 } else { 100 }
}

/// Percentile `p` (0..1) of sorted values.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// A fresh folder for one benchmark case.
pub fn case_dir(root: &Path, name: &str) -> Result<PathBuf> {
    let d = root.join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d)?;
    Ok(d)
}
