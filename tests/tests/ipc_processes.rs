//! Two-process transport tests: the real `simulator` binary publishes paper-env1 over
//! iceoryx2 and the `scan-probe` binary subscribes. Each test has its own iceoryx2 prefix,
//! and every child is killed when its guard drops, even when an assertion fails.

use anyhow::{Context, Result, bail};
use serde_json::Value;
use sketchslam_ipc::ranges_checksum;
use sketchslam_simulator::{Scenario, Simulation};
use sketchslam_tests::processes::{ChildGuard, binary, bundled_scenario, unique_prefix};
use sketchslam_types::SensorEvent;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

const ROBOT: &str = "r1";

/// A running `scan-probe` and its stdout lines.
struct Probe {
    guard: ChildGuard,
    lines: Receiver<String>,
}

impl Probe {
    fn start(prefix: &str, extra: &[&str]) -> Result<Probe> {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_scan-probe"));
        cmd.args(["--robot", ROBOT, "--ipc-prefix", prefix])
            .args(extra)
            .stdout(Stdio::piped());
        let mut guard = ChildGuard::spawn("scan-probe", &mut cmd)?;
        let stdout = guard
            .child_mut()
            .stdout
            .take()
            .context("probe stdout not piped")?;
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let probe = Probe { guard, lines };
        probe.expect_line(|l| l == "subscribed", Duration::from_secs(30))?;
        Ok(probe)
    }

    /// Waits for a stdout line matching `accept`; returns it.
    fn expect_line(&self, accept: impl Fn(&str) -> bool, timeout: Duration) -> Result<String> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) if accept(&line) => return Ok(line),
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => bail!("probe: no expected line in {timeout:?}"),
                Err(RecvTimeoutError::Disconnected) => bail!("probe: stdout closed"),
            }
        }
    }

    /// Waits for the JSON summary and the exit.
    fn summary(mut self, timeout: Duration) -> Result<Value> {
        let line = self.expect_line(|l| l.starts_with('{'), timeout)?;
        let status = self.guard.wait_timeout(Duration::from_secs(10))?;
        if !status.success() {
            bail!("scan-probe exited with {status}");
        }
        Ok(serde_json::from_str(&line)?)
    }
}

fn start_simulator(prefix: &str, extra: &[&str]) -> Result<ChildGuard> {
    let exe = binary("sketchslam-simulator", "simulator")?;
    let mut cmd = Command::new(exe);
    cmd.arg("run")
        .arg(bundled_scenario("paper-env1"))
        .args(["--robot", ROBOT, "--ipc-prefix", prefix, "--quiet"])
        .args(extra)
        .stdout(Stdio::null());
    ChildGuard::spawn("simulator", &mut cmd)
}

/// The checksums of the first `max_scans` scans of the seeded simulation, computed here.
fn expected_checksums(max_scans: usize) -> Result<Vec<String>> {
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    Ok(Simulation::new(&scenario)?
        .filter_map(|step| match step.event {
            SensorEvent::Scan(scan) => Some(format!("{:016x}", ranges_checksum(&scan.ranges_m))),
            SensorEvent::Odometry(_) => None,
        })
        .take(max_scans)
        .collect())
}

fn checksums(summary: &Value) -> Vec<String> {
    summary["checksums"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default()
}

fn assert_lossless(summary: &Value, expected: &[String]) {
    assert_eq!(
        summary["scans"].as_u64(),
        Some(expected.len() as u64),
        "{summary}"
    );
    assert_eq!(summary["first_sequence"].as_u64(), Some(0));
    assert_eq!(summary["sequences_in_order"], true);
    assert_eq!(summary["stamps_in_order"], true);
    assert_eq!(summary["odometry_in_order"], true);
    assert_eq!(summary["header_consistent"], true);
    assert_eq!(summary["scans_lost"], 0);
    assert_eq!(summary["odometry_lost"], 0);
    assert_eq!(summary["first_header"]["beam_count"], 1081);
    let got = checksums(summary);
    let first_bad = got.iter().zip(expected).position(|(g, e)| g != e);
    assert_eq!(
        first_bad, None,
        "scan ranges differ from the in-process simulation"
    );
}

#[test]
fn ipc_lockstep_delivers_every_scan_intact() -> Result<()> {
    let prefix = unique_prefix("lockstep");
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    let total = Simulation::new(&scenario)?.scan_count() as usize;
    let expected = expected_checksums(total)?;
    let probe = Probe::start(&prefix, &["--max-scans", &total.to_string()])?;
    let mut sim = start_simulator(&prefix, &["--lockstep"])?;
    let summary = probe.summary(Duration::from_secs(240))?;
    let status = sim.wait_timeout(Duration::from_secs(30))?;
    assert!(status.success(), "simulator exited with {status}");
    assert_lossless(&summary, &expected);
    Ok(())
}

#[test]
fn ipc_late_subscriber_loses_nothing_in_lockstep() -> Result<()> {
    let prefix = unique_prefix("late");
    let max_scans = 400;
    let expected = expected_checksums(max_scans)?;
    let mut sim = start_simulator(
        &prefix,
        &["--lockstep", "--max-scans", &max_scans.to_string()],
    )?;
    // The publisher is up and waiting before anyone subscribes.
    std::thread::sleep(Duration::from_millis(1500));
    let probe = Probe::start(&prefix, &["--max-scans", &max_scans.to_string()])?;
    let summary = probe.summary(Duration::from_secs(120))?;
    let status = sim.wait_timeout(Duration::from_secs(30))?;
    assert!(status.success(), "simulator exited with {status}");
    assert_lossless(&summary, &expected);
    Ok(())
}

#[test]
fn ipc_killed_subscriber_does_not_block_lockstep_publisher() -> Result<()> {
    let prefix = unique_prefix("killed");
    let max_scans: u64 = 1500;
    let mut sim = start_simulator(
        &prefix,
        &[
            "--lockstep",
            "--max-scans",
            &max_scans.to_string(),
            // Far longer than the test may wait: only dead-node detection can free it.
            "--backpressure-timeout-ms",
            "600000",
        ],
    )?;
    // A slow subscriber that the publisher waits for, killed midway with SIGKILL.
    let mut victim = Probe::start(&prefix, &["--progress", "--delay-ms", "5"])?;
    victim.expect_line(|l| l == "scan 100", Duration::from_secs(60))?;
    // A second subscriber joins while the first still holds the publisher back.
    let survivor = Probe::start(&prefix, &["--delay-ms", "2", "--idle-timeout-ms", "5000"])?;
    std::thread::sleep(Duration::from_millis(300));
    victim.guard.kill();

    let summary = survivor.summary(Duration::from_secs(120))?;
    let status = sim.wait_timeout(Duration::from_secs(60))?;
    assert!(status.success(), "simulator exited with {status}");
    let scans = summary["scans"].as_u64().unwrap_or(0);
    assert!(scans > 0, "the survivor received nothing: {summary}");
    assert_eq!(summary["sequences_in_order"], true, "{summary}");
    assert_eq!(
        summary["last_sequence"].as_u64(),
        Some(max_scans - 1),
        "{summary}"
    );

    // After the kill a brand-new subscriber can still connect (to a fresh publisher).
    let mut sim2 = start_simulator(&prefix, &["--lockstep", "--max-scans", "50"])?;
    let late = Probe::start(&prefix, &["--max-scans", "50"])?;
    let summary2 = late.summary(Duration::from_secs(60))?;
    assert!(sim2.wait_timeout(Duration::from_secs(30))?.success());
    assert_eq!(summary2["scans"], 50, "{summary2}");
    assert_eq!(summary2["first_sequence"], 0, "{summary2}");
    Ok(())
}

#[test]
fn ipc_real_time_is_paced_by_the_sim_clock() -> Result<()> {
    let prefix = unique_prefix("realtime");
    // 60 scans at 20 Hz are 2.95 s of simulated time; at rate 4 about 0.74 s of wall time.
    let probe = Probe::start(&prefix, &["--max-scans", "60", "--idle-timeout-ms", "2000"])?;
    let started = Instant::now();
    let mut sim = start_simulator(&prefix, &["--rate", "4", "--max-scans", "60"])?;
    let status = sim.wait_timeout(Duration::from_secs(60))?;
    let wall = started.elapsed();
    assert!(status.success(), "simulator exited with {status}");
    assert!(wall >= Duration::from_millis(700), "not paced: {wall:?}");
    let summary = probe.summary(Duration::from_secs(30))?;
    // A real-time publisher does not wait for the subscriber to connect, so the first few
    // samples may be missed; what arrives is in order.
    assert!(summary["scans"].as_u64().unwrap_or(0) >= 50, "{summary}");
    assert_eq!(summary["sequences_in_order"], true, "{summary}");
    assert_eq!(summary["stamps_in_order"], true, "{summary}");
    Ok(())
}

#[test]
fn ipc_bad_input_exits_nonzero_with_a_message() -> Result<()> {
    let exe = binary("sketchslam-simulator", "simulator")?;
    let out = Command::new(&exe)
        .args(["run", "/nonexistent-scenario", "--robot", "r1"])
        .output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nonexistent-scenario"));
    let out = Command::new(&exe)
        .arg("run")
        .arg(bundled_scenario("paper-env1"))
        .args(["--robot", "bad/id", "--rate", "1"])
        .output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("robot id"));
    let out = Command::new(&exe)
        .arg("run")
        .arg(bundled_scenario("paper-env1"))
        .args(["--robot", "r1", "--rate=-2"])
        .output()?;
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--rate"));
    Ok(())
}
