//! ROS 2 bags in (issue 18, part 1): a rosbag2 MCAP file written by the test with the `mcap`
//! crate from `paper-env1` (its LiDAR mounted 0.3 m ahead and turned 5°: `LaserScan`,
//! `Odometry` and the mount on `/tf_static`, CDR as ROS 2 writes them) reads back as the same
//! stream and the same mount, and `simulator replay BAG.mcap` through the real processes maps
//! to the same trajectory as `simulator run` of the scenario itself; a dataset folder whose
//! `dataset.toml` names the bag (and relations made from the truth) is mapped and scored by
//! `evaluate`'s dataset path.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use anyhow::{Context, Result, ensure};
use common::{
    SERVICE_LOG, TempDir, first_scans, in_temp_dir, paper_env1_mounted, start_service, wait_session,
};
use sketchslam_api::{LidarMount, MappingMethod, SketchslamClient};
use sketchslam_simulator::Scenario;
use sketchslam_simulator::rosbag::{BagTopics, read_bag, write_bag};
use sketchslam_tests::processes::{ChildGuard, binary, unique_prefix};
use sketchslam_tests::session_request::baseline_session;
use sketchslam_types::{Pose2, SensorEvent, wrap_angle};

const SCANS: u64 = 300;

/// The scenario's first `SCANS` scans with their odometry.
fn events(scenario: &Scenario) -> Result<Vec<SensorEvent>> {
    Ok(first_scans(scenario, SCANS)?.0)
}

#[test]
fn a_bag_reads_back_as_the_stream_and_the_mount_it_was_written_from() -> Result<()> {
    let dir = TempDir::new("bagread")?;
    let scenario = paper_env1_mounted(&dir.0.join("scenario"))?;
    let original = events(&scenario)?;
    let bag = dir.0.join("run.mcap");
    let topics = BagTopics::default();
    write_bag(
        &bag,
        &original,
        &topics,
        "laser",
        Some(scenario.lidar.mount),
    )?;
    let read = read_bag(&bag, &topics)?;
    ensure!(read.scans == SCANS, "{} scans read", read.scans);
    ensure!(read.events.len() == original.len());
    for (a, b) in original.iter().zip(&read.events) {
        match (a, b) {
            (SensorEvent::Scan(a), SensorEvent::Scan(b)) => ensure!(
                a == b,
                "scan {} changed: {:?} / {:?}",
                a.header.sequence,
                a.header,
                b.header
            ),
            (SensorEvent::Odometry(a), SensorEvent::Odometry(b)) => {
                // Through a quaternion the heading comes back wrapped to (−π, π].
                ensure!(
                    a.sequence == b.sequence
                        && a.stamp_ns == b.stamp_ns
                        && a.x_m == b.x_m
                        && a.y_m == b.y_m
                        && wrap_angle(a.theta_rad - b.theta_rad).abs() < 1e-12,
                    "odometry {a:?} came back as {b:?}"
                );
            }
            _ => anyhow::bail!(
                "the order changed at stamp {} ns: a scan and an odometry reading swapped",
                a.stamp_ns()
            ),
        }
    }
    let m = read.lidar_mount.context("no mount from /tf_static")?;
    let want = scenario.lidar.mount;
    ensure!(
        (m.x - want.x).abs() < 1e-12
            && (m.y - want.y).abs() < 1e-12
            && (m.heading_rad - want.heading_rad).abs() < 1e-12,
        "mount {m:?}, wanted {want:?}"
    );
    // A topic the bag lacks is named with what it has.
    let wrong = BagTopics {
        scan: "/laser".into(),
        ..BagTopics::default()
    };
    let e = read_bag(&bag, &wrong).unwrap_err().to_string();
    ensure!(e.contains("/laser") && e.contains("/scan"), "{e}");
    // Not a bag at all: said so, with the file's name.
    let bogus = dir.0.join("bogus.mcap");
    std::fs::write(&bogus, b"not an mcap file")?;
    let e = read_bag(&bogus, &topics).unwrap_err().to_string();
    ensure!(
        e.contains("bogus.mcap") && e.contains("not an MCAP file"),
        "{e}"
    );
    Ok(())
}

/// Runs `simulator ARGS... --lockstep` for robot `robot` into a graph session with `mount`
/// and returns the session's last pose once every scan is processed.
async fn map_with(
    client: &SketchslamClient,
    prefix: &str,
    robot: &str,
    mount: Pose2,
    simulator_args: &[&std::ffi::OsStr],
) -> Result<Pose2> {
    let request = sketchslam_api::CreateSessionRequest {
        lidar_mount: Some(LidarMount::from_pose(mount)),
        ..baseline_session(robot, MappingMethod::Graph, Some(5))
    };
    let session = client.create_session(&request).await?;
    let mut cmd = Command::new(binary("sketchslam-simulator", "simulator")?);
    cmd.args(simulator_args)
        .args([
            "--robot",
            robot,
            "--lockstep",
            "--quiet",
            "--ipc-prefix",
            prefix,
        ])
        .args(["--max-scans", &SCANS.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    let mut sim = ChildGuard::spawn("simulator", &mut cmd)?;
    let status = tokio::task::spawn_blocking(move || {
        let s = sim.wait_timeout(Duration::from_secs(120));
        (sim, s)
    })
    .await?
    .1?;
    ensure!(status.success(), "the simulator failed: {status}");
    wait_session(
        client,
        &session.id,
        Duration::from_secs(30),
        "all scans",
        |i| i.scans_processed >= SCANS,
    )
    .await?;
    let p = client.pose(&session.id).await?;
    Ok(Pose2::new(p.x, p.y, p.theta))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn replaying_the_bag_maps_like_the_scenario_itself() -> Result<()> {
    in_temp_dir("bagreplay", &[(SERVICE_LOG, 60)], |dir| async move {
        replay(&dir, &dir.join("data")).await
    })
    .await
}

async fn replay(dir: &Path, data: &Path) -> Result<()> {
    let scenario_dir = dir.join("scenario");
    let scenario = paper_env1_mounted(&scenario_dir)?;
    let bag = dir.join("run.mcap");
    write_bag(
        &bag,
        &events(&scenario)?,
        &BagTopics::default(),
        "laser",
        Some(scenario.lidar.mount),
    )?;
    let mount = read_bag(&bag, &BagTopics::default())?
        .lidar_mount
        .context("no mount")?;
    let prefix = unique_prefix("bagreplay");
    let service = start_service(data, &prefix, &[], &[]).await?;
    let client = service.client.clone();
    let direct = map_with(
        &client,
        &prefix,
        "direct",
        scenario.lidar.mount,
        &["run".as_ref(), scenario_dir.as_os_str()],
    )
    .await?;
    let replayed = map_with(
        &client,
        &prefix,
        "bag",
        mount,
        &["replay".as_ref(), bag.as_os_str()],
    )
    .await?;
    let gap_m = (direct.x - replayed.x).hypot(direct.y - replayed.y);
    eprintln!(
        "last pose after {SCANS} scans: scenario ({:.4}, {:.4}), bag ({:.4}, {:.4}), {gap_m:.2e} m apart",
        direct.x, direct.y, replayed.x, replayed.y
    );
    ensure!(
        gap_m < 1e-3 && wrap_angle(direct.heading_rad - replayed.heading_rad).abs() < 1e-4,
        "the bag mapped to {replayed:?}, the scenario to {direct:?}"
    );
    Ok(())
}

#[test]
fn a_dataset_naming_a_bag_is_mapped_and_scored_by_its_relations() -> Result<()> {
    let dir = TempDir::new("bagdataset")?;
    let scenario = paper_env1_mounted(&dir.0.join("scenario"))?;
    let data = dir.0.join("dataset");
    std::fs::create_dir_all(&data)?;
    // The bag, and relations between scans 20 apart from the truth (t1 t2 x y z roll pitch yaw).
    let (events, truth) = first_scans(&scenario, SCANS)?;
    write_bag(
        &data.join("run.mcap"),
        &events,
        &BagTopics::default(),
        "laser",
        Some(scenario.lidar.mount),
    )?;
    let relations: String = truth
        .iter()
        .zip(truth.iter().skip(20))
        .step_by(20)
        .map(|(a, b)| {
            let d = a.pose.between(&b.pose);
            format!(
                "{} {} {} {} 0 0 0 {}\n",
                a.t_s, b.t_s, d.x, d.y, d.heading_rad
            )
        })
        .collect();
    std::fs::write(data.join("run.relations"), relations)?;
    std::fs::write(
        data.join("dataset.toml"),
        "name = \"bag-paper-env1\"\nbag = \"run.mcap\"\nrelations = \"run.relations\"\n",
    )?;
    let dataset = sketchslam_simulator::dataset::Dataset::load(&data)?;
    ensure!(dataset.bag.is_some() && !dataset.has_reference_poses());
    let result = sketchslam_tests::dataset_run::run_dataset_in_process(
        &dataset,
        sketchslam_engine::mapper::Method::Graph,
        None,
        &dir.0.join("out"),
        None,
        |_, _| {},
    )?;
    eprintln!(
        "bag dataset, graph: {} scans, {} relations, translation error {:.4} m, rotation {:.3}°",
        result.scans,
        result.relations.unwrap_or(0),
        result.rel_trans_m.unwrap_or(f64::NAN),
        result.rel_rot_deg.unwrap_or(f64::NAN)
    );
    ensure!(result.scans == SCANS, "{} scans mapped", result.scans);
    ensure!(
        result.relations.unwrap_or(0) >= 10,
        "relations: {:?}",
        result.relations
    );
    // The relations are the robot's motion. The mount came from /tf_static: ignored, its 5°
    // would turn each 0.8 m relation by 5°, about 0.07 m of error.
    ensure!(
        result.rel_trans_m.is_some_and(|e| e < 0.05),
        "relation translation error {:?}",
        result.rel_trans_m
    );
    ensure!(dir.0.join("out/map.pgm").is_file(), "no map written");
    // A dataset that names both a log and a bag is refused, naming the key.
    std::fs::write(
        data.join("dataset.toml"),
        "name = \"x\"\nbag = \"run.mcap\"\nlog = \"run.mcap\"\n",
    )?;
    let e = sketchslam_simulator::dataset::Dataset::load(&data)
        .unwrap_err()
        .to_string();
    ensure!(e.contains("bag") && e.contains("not both"), "{e}");
    Ok(())
}
