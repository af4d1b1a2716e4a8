//! A service crash: `slam-service` killed with SIGKILL (no shutdown hook runs) and started
//! again on the same data dir.
//!
//! Before the kill: two sketches uploaded, a sketch-A session mapped 200 lock-step scans of
//! `paper-env1` and was stopped, and a second session (odometry, another robot) is live but
//! idle. After the restart this test proves that everything stored before the kill is still
//! there: both sketches listed with their lines, the stopped session listed as `Stopped` with
//! its scan count, and its `map.pgm`, `map.yaml` and `trajectory.csv` served byte for byte as
//! before. The live session's fate (it cannot resume: its mapper died with the process) is
//! printed, and it must at least not be reported as still `Mapping`/`WaitingForData` by a
//! service that has no mapper for it.

mod common;

use std::time::Duration;

use anyhow::{Context, Result, ensure};
use common::{
    SERVICE_LOG, in_temp_dir, paper_env1_sketch_a, run_simulator_lockstep, start_service,
    start_sketch_a_session, wait_session,
};
use sketchslam_api::{CreateSessionRequest, MappingMethod, SessionState};
use sketchslam_tests::processes::unique_prefix;

const SCANS: u64 = 200;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stored_sketches_and_sessions_survive_sigkill() -> Result<()> {
    in_temp_dir("svcrestart", &[(SERVICE_LOG, 60)], |dir| async move {
        run(&dir.join("data")).await
    })
    .await
}

async fn run(data: &std::path::Path) -> Result<()> {
    let prefix = unique_prefix("svcrestart");
    let mut service = start_service(data, &prefix, &[], &[]).await?;
    let client = service.client.clone();
    let (sketch_a, session) = start_sketch_a_session(&client, "r1").await?;
    let (scenario, _) = paper_env1_sketch_a()?;
    let sketch_b_cfg = scenario
        .sketches
        .iter()
        .find(|s| s.name == "B")
        .context("sketch B")?;
    let sketch_b = client
        .upload_sketch(std::fs::read(&sketch_b_cfg.image)?, Some("B"))
        .await?;

    run_simulator_lockstep(&prefix, "r1", SCANS, None, Duration::from_secs(60)).await?;
    wait_session(
        &client,
        &session.id,
        Duration::from_secs(30),
        "all scans",
        |i| i.scans_processed >= SCANS,
    )
    .await?;
    let stopped = client.stop_session(&session.id).await?;
    ensure!(stopped.state == SessionState::Stopped);
    let live = client
        .create_session(&CreateSessionRequest::new("r2", MappingMethod::Odometry))
        .await?;

    let pgm = client.map_pgm(&session.id).await?;
    let yaml = client.map_yaml(&session.id).await?;
    let csv = client.trajectory_csv(&session.id).await?;
    let sketches_before = client.list_sketches().await?;
    let a_before = client.get_sketch(&sketch_a).await?;

    // The crash.
    service.guard.kill();
    let again = start_service(data, &prefix, &[], &[]).await?;
    let c = &again.client;
    let sketches = c.list_sketches().await?;
    for id in [&sketch_a, &sketch_b.id] {
        ensure!(
            sketches.sketches.iter().any(|s| &s.id == id),
            "sketch {id} lost: {sketches:?}"
        );
    }
    ensure!(sketches.sketches.len() == sketches_before.sketches.len());
    let a_after = c.get_sketch(&sketch_a).await?;
    ensure!(
        a_after.lines.len() == a_before.lines.len()
            && a_after.width_px == a_before.width_px
            && a_after.height_px == a_before.height_px,
        "sketch A changed across the restart"
    );
    ensure!(
        c.sketch_overlay_png(&sketch_a)
            .await?
            .starts_with(b"\x89PNG")
    );

    let sessions = c.list_sessions().await?;
    let s = sessions
        .sessions
        .iter()
        .find(|s| s.id == session.id)
        .context("the stopped session is not listed after the restart")?;
    ensure!(
        s.state == SessionState::Stopped && s.scans_processed == stopped.scans_processed,
        "stopped session after restart: {s:?}"
    );
    ensure!(
        c.map_pgm(&session.id).await? == pgm,
        "map.pgm differs after the restart"
    );
    ensure!(c.map_yaml(&session.id).await? == yaml, "map.yaml differs");
    ensure!(
        c.trajectory_csv(&session.id).await? == csv,
        "trajectory.csv differs"
    );
    ensure!(c.map_png(&session.id).await?.starts_with(b"\x89PNG"));

    match c.get_session(&live.id).await {
        Ok(info) => {
            eprintln!(
                "session live at the kill, after restart: state {:?}, error {:?}",
                info.state, info.last_error
            );
            ensure!(
                !matches!(
                    info.state,
                    SessionState::Mapping | SessionState::WaitingForData
                ),
                "a session whose mapper died is reported as {:?}",
                info.state
            );
        }
        Err(e) => eprintln!("session live at the kill, after restart: {e}"),
    }
    Ok(())
}
