//! The Python robot driver (issue 18, part 3): `examples/python/sketchslam_driver.py`, on
//! iceoryx2's own Python package (installed by `scripts/install-test-deps`), feeds the real
//! `slam-service`, and the session maps it.
//!
//! First its structs must be the Rust ones byte for byte (size, alignment, every field's
//! offset, the type names iceoryx2 checks); then the first 200 scans of `paper-env1` (with
//! their odometry), written as JSON lines the way `SensorEvent` serializes, are published by
//! the Python process at twice real time while a `graph` session for its robot runs; every
//! scan must be processed, none lost, and the trajectory must follow the truth.

mod common;

use std::io::Write;
use std::mem::{align_of, offset_of, size_of};
use std::process::{Command, Stdio};
use std::time::Duration;

use anyhow::{Context, Result, ensure};
use common::{SERVICE_LOG, first_scans, in_temp_dir, start_service, wait_session};
use serde_json::Value;
use sketchslam_api::MappingMethod;
use sketchslam_simulator::scenario::Scenario;
use sketchslam_tests::processes::{bundled_scenario, unique_prefix, workspace_root};
use sketchslam_tests::session_request::baseline_session;
use sketchslam_types::{Odometry, ScanHeader};

const SCANS: u64 = 200;

fn driver() -> std::path::PathBuf {
    workspace_root().join("examples/python/sketchslam_driver.py")
}

fn python() -> String {
    std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string())
}

#[test]
fn the_python_structs_are_the_rust_structs() -> Result<()> {
    let out = Command::new(python())
        .arg(driver())
        .arg("--print-layout")
        .output()
        .context("running python3 (scripts/install-test-deps installs what the test needs)")?;
    ensure!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let layout: Value = serde_json::from_slice(&out.stdout)?;
    let check = |name: &str, size: usize, align: usize, fields: &[(&str, usize)]| -> Result<()> {
        let py = &layout[name];
        ensure!(
            py["size"] == size,
            "{name}: size {} in Python, {size} in Rust",
            py["size"]
        );
        ensure!(
            py["align"] == align,
            "{name}: alignment {} in Python, {align} in Rust",
            py["align"]
        );
        ensure!(
            py["fields"].as_object().map(|f| f.len()) == Some(fields.len()),
            "{name}: fields {} in Python",
            py["fields"]
        );
        for (field, offset) in fields {
            ensure!(
                py["fields"][*field] == *offset,
                "{name}.{field}: offset {} in Python, {offset} in Rust",
                py["fields"][*field]
            );
        }
        Ok(())
    };
    check(
        "sketchslam::ScanHeader",
        size_of::<ScanHeader>(),
        align_of::<ScanHeader>(),
        &[
            ("sequence", offset_of!(ScanHeader, sequence)),
            ("stamp_ns", offset_of!(ScanHeader, stamp_ns)),
            ("angle_min_rad", offset_of!(ScanHeader, angle_min_rad)),
            (
                "angle_increment_rad",
                offset_of!(ScanHeader, angle_increment_rad),
            ),
            ("range_min_m", offset_of!(ScanHeader, range_min_m)),
            ("range_max_m", offset_of!(ScanHeader, range_max_m)),
            ("beam_count", offset_of!(ScanHeader, beam_count)),
        ],
    )?;
    check(
        "sketchslam::Odometry",
        size_of::<Odometry>(),
        align_of::<Odometry>(),
        &[
            ("sequence", offset_of!(Odometry, sequence)),
            ("stamp_ns", offset_of!(Odometry, stamp_ns)),
            ("x_m", offset_of!(Odometry, x_m)),
            ("y_m", offset_of!(Odometry, y_m)),
            ("theta_rad", offset_of!(Odometry, theta_rad)),
        ],
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_python_driver_feeds_a_session_that_maps_it() -> Result<()> {
    in_temp_dir("pydriver", &[(SERVICE_LOG, 60)], |dir| async move {
        run(&dir, &dir.join("data")).await
    })
    .await
}

async fn run(dir: &std::path::Path, data: &std::path::Path) -> Result<()> {
    // The recording: paper-env1's first SCANS scans and the odometry before them.
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    let recording = dir.join("recording.jsonl");
    let (events, truth) = first_scans(&scenario, SCANS)?;
    let mut file = std::io::BufWriter::new(std::fs::File::create(&recording)?);
    for event in &events {
        serde_json::to_writer(&mut file, event)?;
        file.write_all(b"\n")?;
    }
    file.flush()?;
    drop(file);
    let truth_end = truth.last().context("no scan")?.pose;

    let prefix = unique_prefix("pydriver");
    let service = start_service(data, &prefix, &[], &[]).await?;
    let client = service.client.clone();
    let session = client
        .create_session(&baseline_session("py1", MappingMethod::Graph, Some(3)))
        .await?;
    let status = tokio::task::spawn_blocking({
        let prefix = prefix.clone();
        move || {
            Command::new(python())
                .arg(driver())
                .arg(&recording)
                .args(["--robot", "py1", "--prefix", &prefix, "--rate", "2"])
                .stdout(Stdio::null())
                .status()
        }
    })
    .await??;
    ensure!(status.success(), "the Python driver failed: {status}");
    let info = wait_session(
        &client,
        &session.id,
        Duration::from_secs(30),
        "every scan the driver published",
        |i| i.scans_processed >= SCANS,
    )
    .await?;
    ensure!(info.scans_lost == 0, "scans lost: {}", info.scans_lost);
    // The map frame starts at the robot's start: the last pose is the truth's displacement.
    let pose = client.pose(&session.id).await?;
    let start = scenario.robot.start;
    let moved = start.between(&truth_end);
    let error_m = (pose.x - moved.x).hypot(pose.y - moved.y);
    eprintln!(
        "python driver: {} scans processed, {} lost; last pose {error_m:.3} m from the truth \
         after {:.1} m",
        info.scans_processed,
        info.scans_lost,
        moved.x.hypot(moved.y)
    );
    ensure!(
        moved.x.hypot(moved.y) > 3.0 && error_m < 0.3,
        "the session's last pose ({:.2}, {:.2}) against the truth's ({:.2}, {:.2})",
        pose.x,
        pose.y,
        moved.x,
        moved.y
    );
    let png = client.map_png(&session.id).await?;
    ensure!(png.len() > 100, "no map");
    Ok(())
}
