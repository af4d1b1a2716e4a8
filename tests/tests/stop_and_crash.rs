//! Stopping a session from many clients at once, and a crash in the middle of a save,
//! against the real `slam-service` (issue 17, finding 1).
//!
//! Twelve staggered `DELETE`s of one sketch session that mapped 150 lock-step scans of
//! `paper-env1`: every one answers 200 with the same final status, and the stored files are
//! what their names say (before 2026-12-03 every file of a session went through one
//! `map.tmp`, and concurrent stops wrote PNG bytes into `map.yaml`). Then the service is
//! killed with SIGKILL, the leftovers of a save cut short are planted in its data dir (a
//! temporary file in the stopped session's folder, a session folder without `meta.json`),
//! and on restart the stopped session is served byte for byte, the temporary file is gone
//! and the torn folder is moved to `incomplete/`, never listed.
//!
//! A service killed while sessions run lists them, after its restart, as `interrupted` with
//! the map, trajectory and counts of their last checkpoint; a session killed before its
//! robot sent anything is listed too (every session is written once at its start), and the
//! robots are free for new sessions (issue 17, finding 2).
//!
//! And a session whose robot falls silent stops and stores itself (`--idle-stop-s`), saying
//! so in its status, while one whose robot never started keeps waiting.

mod common;

use std::time::Duration;

use anyhow::{Context, Result, ensure};
use common::{
    SERVICE_LOG, in_temp_dir, run_simulator_lockstep, start_service, start_sketch_a_session,
    wait_session,
};
use sketchslam_api::{MappingMethod, SessionState, StopReason};
use sketchslam_tests::processes::unique_prefix;
use sketchslam_tests::session_request::baseline_session;

const SCANS: u64 = 150;
const STOPS: usize = 12;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn concurrent_stops_store_one_intact_map_and_a_torn_save_is_cleaned_on_restart() -> Result<()>
{
    in_temp_dir("stopcrash", &[(SERVICE_LOG, 60)], |dir| async move {
        run(&dir.join("data")).await
    })
    .await
}

async fn run(data: &std::path::Path) -> Result<()> {
    let prefix = unique_prefix("stopcrash");
    let mut service = start_service(data, &prefix, &[], &[]).await?;
    let client = service.client.clone();
    let (_, session) = start_sketch_a_session(&client, "r1").await?;
    run_simulator_lockstep(&prefix, "r1", SCANS, None, Duration::from_secs(60)).await?;
    wait_session(
        &client,
        &session.id,
        Duration::from_secs(30),
        "all scans",
        |i| i.scans_processed >= SCANS,
    )
    .await?;

    // Twelve stops, 5 ms apart, all in flight together.
    let mut stops = Vec::new();
    for k in 0..STOPS {
        let c = client.clone();
        let id = session.id.clone();
        stops.push(tokio::spawn(async move {
            tokio::time::sleep(Duration::from_millis(5 * k as u64)).await;
            c.stop_session(&id).await
        }));
    }
    let mut answers = Vec::new();
    for stop in stops {
        answers.push(stop.await?.context("a concurrent stop failed")?);
    }
    let first = &answers[0];
    ensure!(first.state == SessionState::Stopped, "{first:?}");
    ensure!(
        answers.iter().all(|a| a == first),
        "the stops answered differently: {answers:?}"
    );

    let folder = data.join("sessions").join(&session.id);
    let yaml = std::fs::read_to_string(folder.join("map.yaml")).context("map.yaml is not text")?;
    ensure!(
        yaml.starts_with("image:") && yaml.contains("resolution:"),
        "map.yaml holds {:?}",
        &yaml[..yaml.len().min(40)]
    );
    ensure!(std::fs::read(folder.join("map.pgm"))?.starts_with(b"P5"));
    ensure!(std::fs::read(folder.join("map.png"))?.starts_with(b"\x89PNG"));
    serde_json::from_slice::<serde_json::Value>(&std::fs::read(folder.join("map.json"))?)
        .context("map.json is not JSON")?;
    let names: Vec<String> = std::fs::read_dir(&folder)?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<std::io::Result<_>>()?;
    ensure!(
        names
            .iter()
            .all(|n| !n.starts_with('.') && !n.ends_with(".tmp")),
        "temporary files left: {names:?}"
    );
    let pgm = client.map_pgm(&session.id).await?;
    let served_yaml = client.map_yaml(&session.id).await?;
    ensure!(served_yaml == yaml);

    // The crash, with a save cut short in the data dir.
    service.guard.kill();
    std::fs::write(folder.join(".sketchslam-tmp-cut"), b"half a file")?;
    let torn = data.join("sessions").join("torn-session");
    std::fs::create_dir_all(&torn)?;
    std::fs::write(torn.join("map.pgm"), b"P5 half")?;

    let again = start_service(data, &prefix, &[], &[]).await?;
    let c = &again.client;
    let listed = c.list_sessions().await?;
    ensure!(
        listed.sessions.len() == 1 && listed.sessions[0].id == session.id,
        "sessions after the restart: {listed:?}"
    );
    ensure!(c.map_pgm(&session.id).await? == pgm, "map.pgm changed");
    ensure!(c.map_yaml(&session.id).await? == yaml, "map.yaml changed");
    ensure!(
        !folder.join(".sketchslam-tmp-cut").exists(),
        "the temporary file was not cleaned"
    );
    ensure!(
        !torn.exists(),
        "the torn session folder is still in sessions/"
    );
    ensure!(
        data.join("incomplete/sessions-torn-session/map.pgm")
            .exists(),
        "the torn session folder was not kept in incomplete/"
    );
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_session_whose_robot_falls_silent_stops_and_stores_itself() -> Result<()> {
    in_temp_dir("idlestop", &[(SERVICE_LOG, 60)], |dir| async move {
        run_idle(&dir.join("data")).await
    })
    .await
}

async fn run_idle(data: &std::path::Path) -> Result<()> {
    let prefix = unique_prefix("idlestop");
    let service = start_service(data, &prefix, &["--idle-stop-s", "2"], &[]).await?;
    let client = service.client.clone();
    let request = |robot: &str| baseline_session(robot, MappingMethod::Odometry, None);
    let fed = client.create_session(&request("r1")).await?;
    let waiting = client.create_session(&request("r2")).await?;
    run_simulator_lockstep(&prefix, "r1", 60, None, Duration::from_secs(60)).await?;
    let stopped = wait_session(
        &client,
        &fed.id,
        Duration::from_secs(30),
        "the silent robot's session to stop",
        |i| i.state == SessionState::Stopped,
    )
    .await?;
    ensure!(
        stopped.stop_reason == Some(StopReason::RobotSilent) && stopped.scans_processed == 60,
        "{stopped:?}"
    );
    // A client's stop now waits for that one stop's save and answers it.
    let again = client.stop_session(&fed.id).await?;
    ensure!(
        again.stop_reason == Some(StopReason::RobotSilent),
        "{again:?}"
    );
    ensure!(
        data.join("sessions")
            .join(&fed.id)
            .join("meta.json")
            .exists()
    );
    ensure!(client.map_pgm(&fed.id).await?.starts_with(b"P5"));
    // The robot that never published: still waiting, long past the idle time.
    let still = client.get_session(&waiting.id).await?;
    ensure!(still.state == SessionState::WaitingForData, "{still:?}");
    // A client's stop says so.
    let by_hand = client.stop_session(&waiting.id).await?;
    ensure!(
        by_hand.stop_reason == Some(StopReason::Requested),
        "{by_hand:?}"
    );
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_service_lists_its_running_sessions_as_interrupted_with_their_checkpoint()
-> Result<()> {
    in_temp_dir("interrupted", &[(SERVICE_LOG, 60)], |dir| async move {
        run_interrupted(&dir.join("data")).await
    })
    .await
}

async fn run_interrupted(data: &std::path::Path) -> Result<()> {
    let prefix = unique_prefix("interrupted");
    let args = ["--checkpoint-s", "0.5", "--idle-stop-s", "0"];
    let mut service = start_service(data, &prefix, &args, &[]).await?;
    let client = service.client.clone();
    let (_, mapped) = start_sketch_a_session(&client, "r1").await?;
    let request = baseline_session("r2", MappingMethod::Graph, None);
    let waiting = client.create_session(&request).await?;
    run_simulator_lockstep(&prefix, "r1", SCANS, None, Duration::from_secs(60)).await?;
    wait_session(
        &client,
        &mapped.id,
        Duration::from_secs(30),
        "all scans",
        |i| i.scans_processed >= SCANS,
    )
    .await?;
    // The status says when the last checkpoint was written. Once nothing more arrives,
    // the next checkpoint holds everything, and none follows it (nothing changed since):
    // wait until the stamp has held for four periods.
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    let mut last = None;
    let mut held_since = std::time::Instant::now();
    loop {
        let stamp = client.get_session(&mapped.id).await?.checkpoint_unix_ms;
        if stamp != last {
            (last, held_since) = (stamp, std::time::Instant::now());
        } else if stamp.is_some() && held_since.elapsed() > Duration::from_secs(2) {
            break;
        }
        ensure!(
            std::time::Instant::now() < deadline,
            "checkpoints never settled"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let live_trajectory = client.trajectory(&mapped.id).await?;

    service.guard.kill();
    let again = start_service(data, &prefix, &args, &[]).await?;
    let c = &again.client;
    let after = c.get_session(&mapped.id).await?;
    ensure!(
        after.state == SessionState::Interrupted
            && after.scans_processed == SCANS
            && after.checkpoint_unix_ms.is_some()
            && after.stop_reason.is_none(),
        "{after:?}"
    );
    ensure!(c.map_pgm(&mapped.id).await?.starts_with(b"P5"));
    let trajectory = c.trajectory(&mapped.id).await?;
    ensure!(
        trajectory.points.len() == live_trajectory.points.len(),
        "{} poses after the restart, {} before",
        trajectory.points.len(),
        live_trajectory.points.len()
    );
    let sketch_trajectory = c.sketch_trajectory(&mapped.id).await?;
    ensure!(!sketch_trajectory.points.is_empty());
    // The session whose robot never published is on record too.
    let never = c.get_session(&waiting.id).await?;
    ensure!(
        never.state == SessionState::Interrupted && never.scans_processed == 0,
        "{never:?}"
    );
    // Stopping an interrupted session changes nothing; its robots are free again.
    ensure!(c.stop_session(&mapped.id).await?.state == SessionState::Interrupted);
    let next = c
        .create_session(&baseline_session("r1", MappingMethod::Graph, None))
        .await?;
    ensure!(next.state == SessionState::WaitingForData, "{next:?}");
    let metrics = c.metrics().await?;
    ensure!(
        metrics.contains("sketchslam_sessions{state=\"interrupted\"} 2"),
        "{metrics}"
    );
    Ok(())
}
