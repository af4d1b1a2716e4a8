//! A robot driver that crashes and comes back: the simulator (sketch A session on
//! `paper-env1`, lock-step) is killed with SIGKILL after about 150 scans and restarted for the
//! same robot id.
//!
//! The restarted simulator replays its scenario from t = 0: its sequence numbers and stamps
//! start again at 0 and the robot "jumps back" to its start pose, which the odometry reports
//! as one large motion back. What a robotics engineer expects of the service, and what this
//! test proves:
//! - the session survives both the dead publisher and the new one: it never turns `Failed`,
//!   stays `Mapping`, and its `scans_processed` keeps growing past the kill point by every
//!   scan the new publisher sends (lock-step: nothing is lost);
//! - the restart is not counted as lost scans (`scans_lost` stays 0: a sequence that goes
//!   backwards is a restart, not a gap); it is counted in `publisher_restarts` and visible in
//!   the service's log as a gap whose received sequence is below the expected one;
//! - the map stays accurate: scored against the restarted run's truth (the trajectory after
//!   the restart aligned by stamp), the map's error stays within 0.3 m.

mod common;

use std::time::Duration;

use anyhow::{Context, Result, ensure};
use common::{
    SERVICE_LOG, in_temp_dir, paper_env1_sketch_a, run_simulator_lockstep,
    spawn_simulator_lockstep, start_service, start_sketch_a_session, wait_session, wait_settled,
};
use sketchslam_api::SessionState;
use sketchslam_simulator::world::World;
use sketchslam_tests::metrics::{WallGrid, score_map, score_trajectory};
use sketchslam_tests::processes::unique_prefix;
use sketchslam_tests::run::{
    map_occupied_points, parse_trajectory_csv, read_trajectory_csv, seen_wall_pixels,
};

/// Scans processed before the simulator is killed.
const KILL_AFTER: u64 = 150;
/// Scans the restarted simulator sends.
const SECOND_RUN: u64 = 300;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn session_survives_a_simulator_crash_and_restart() -> Result<()> {
    restart_run(false).await
}

/// BUG (documented, not fixed here): after a publisher restart the mapper keeps fusing scans
/// but `Mapper::push_trajectory` drops every pose whose stamp is below the newest stamp seen
/// before the restart, so `trajectory.csv` has no pose for the first ~10 s (~205 scans) of
/// the restarted run, and `/pose`'s `stamp` stays at the old maximum until the new stamps
/// pass it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "bug: the trajectory drops the poses of a restarted publisher until its stamps pass the pre-restart maximum (mapper.rs push_trajectory)"]
async fn trajectory_keeps_every_pose_after_a_simulator_restart() -> Result<()> {
    restart_run(true).await
}

async fn restart_run(strict_trajectory: bool) -> Result<()> {
    in_temp_dir("simrestart", &[(SERVICE_LOG, 60)], |dir| async move {
        run(&dir, &dir.join("data"), strict_trajectory).await
    })
    .await
}

async fn run(dir: &std::path::Path, data: &std::path::Path, strict_trajectory: bool) -> Result<()> {
    let prefix = unique_prefix("simrestart");
    let service = start_service(data, &prefix, &[], &[]).await?;
    let client = service.client.clone();
    let (_, session) = start_sketch_a_session(&client, "r1").await?;

    // First run: killed mid-way (it would send 2000 scans).
    let mut sim = spawn_simulator_lockstep(&prefix, "r1", 2000, None)?;
    wait_session(
        &client,
        &session.id,
        Duration::from_secs(60),
        "150 scans",
        |i| i.scans_processed >= KILL_AFTER,
    )
    .await?;
    sim.kill();
    let at_kill = wait_settled(
        &client,
        &session.id,
        Duration::from_millis(1500),
        Duration::from_secs(20),
    )
    .await?;
    eprintln!(
        "after SIGKILL: {} scans processed, {} lost, state {:?}",
        at_kill.scans_processed, at_kill.scans_lost, at_kill.state
    );
    ensure!(
        at_kill.state == SessionState::Mapping,
        "state after the publisher died: {:?}",
        at_kill.state
    );
    let before = parse_trajectory_csv(&client.trajectory_csv(&session.id).await?)?;
    let t_kill = before.last().context("an empty trajectory")?.t_s;

    // Second run: same robot, from the scenario's start.
    let truth2 = dir.join("truth2.csv");
    run_simulator_lockstep(
        &prefix,
        "r1",
        SECOND_RUN,
        Some(&truth2),
        Duration::from_secs(90),
    )
    .await
    .context("the restarted simulator")?;
    let target = at_kill.scans_processed + SECOND_RUN;
    let after = wait_session(
        &client,
        &session.id,
        Duration::from_secs(60),
        "the restarted run's scans",
        |i| i.scans_processed >= target,
    )
    .await?;
    eprintln!(
        "after restart: {} scans processed (target {target}), {} lost, state {:?}, recoveries {}",
        after.scans_processed, after.scans_lost, after.state, after.recoveries
    );
    ensure!(after.state == SessionState::Mapping, "{after:?}");
    ensure!(
        after.scans_processed == target,
        "processed {} scans, expected {target}",
        after.scans_processed
    );
    ensure!(
        after.scans_lost == 0,
        "a restart counted as {} lost scans",
        after.scans_lost
    );
    ensure!(
        after.publisher_restarts >= 1,
        "the publisher restart is not counted ({} restarts)",
        after.publisher_restarts
    );
    let log = std::fs::read_to_string(&service.log)?;
    ensure!(
        log.contains("gap in the robot's stream"),
        "the sequence restart is not in the service log"
    );

    // The map after the restart, scored against the restarted run's truth.
    let stopped = client.stop_session(&session.id).await?;
    ensure!(stopped.state == SessionState::Stopped);
    let occupied = map_occupied_points(
        &client.map_yaml(&session.id).await?,
        &client.map_pgm(&session.id).await?,
    )?;
    let estimate = parse_trajectory_csv(&client.trajectory_csv(&session.id).await?)?;
    // The poses the restarted run added (its stamps restart at 0).
    ensure!(estimate.len() > before.len(), "no pose after the restart");
    let tail = &estimate[before.len()..];
    let truth = read_trajectory_csv(&truth2)?;
    let first_after = tail.first().map_or(f64::NAN, |p| p.t_s);
    eprintln!(
        "trajectory: {} poses before the kill (last t {t_kill:.2} s), {} after the restart \
         (first t {first_after:.2} s) for {} restarted scans",
        before.len(),
        tail.len(),
        truth.len()
    );
    if strict_trajectory {
        ensure!(
            first_after < 1.0,
            "the restarted run's poses start at t = {first_after:.2} s, not at its start: \
             the poses before t = {t_kill:.2} s were dropped"
        );
    }
    let traj = score_trajectory(tail, &truth).context("no overlap with the truth")?;
    let (scenario, _) = paper_env1_sketch_a()?;
    let walls = WallGrid::from_image(
        &image::open(&scenario.world.image)?.to_luma8(),
        scenario.world.resolution_m,
    );
    let world = World::load(&scenario.world.image, scenario.world.resolution_m)?;
    let seen = seen_wall_pixels(&scenario, &world, &walls, &truth);
    let map = score_map(&occupied, &traj.alignment, &walls, &seen);
    eprintln!(
        "restart run: ATE {:.3} m over {} poses; whole map error {:.3} m over {} cells, completeness {:.2}",
        traj.ate_rmse_m, traj.matched, map.map_error_m, map.occupied_cells, map.completeness
    );
    ensure!(traj.ate_rmse_m <= 0.3, "ATE {:.3} m", traj.ate_rmse_m);
    ensure!(map.map_error_m <= 0.3, "map error {:.3} m", map.map_error_m);
    Ok(())
}
