//! Garbage from a robot driver never reaches the map: a publisher in the test process
//! (iceoryx2, lock-step, so nothing is lost) sends a session good scans of a 10 m × 8 m box
//! room, interleaved with scans whose ranges are all NaN, all +inf, all −inf, all negative,
//! all zero, a scan with no beam at all, and good scans with such values sprinkled in.
//!
//! This test proves, against the real `slam-service`: the session stays `Mapping` (never
//! `Failed`), processes every good scan, counts nothing as lost, and its map (fetched as JSON
//! occupancy) has occupied cells only on the room's walls — none inside the room, none
//! outside it — and free cells only inside the room.

mod common;

use std::time::Duration;

use anyhow::{Context, Result, ensure};
use common::{SERVICE_LOG, in_temp_dir, start_service, wait_settled};
use sketchslam_api::{CreateSessionRequest, MappingMethod, SessionState};
use sketchslam_ipc::{Delivery, IpcConfig, RobotPublisher};
use sketchslam_tests::processes::unique_prefix;
use sketchslam_types::{Odometry, ScanHeader};

/// Half sizes of the box room, meters; the robot starts at its centre.
const HALF_X: f64 = 5.0;
const HALF_Y: f64 = 4.0;
const BEAMS: usize = 541;
const FOV_RAD: f64 = 270.0 * std::f64::consts::PI / 180.0;
const RANGE_MAX: f32 = 30.0;
/// Rounds of one good scan followed by every kind of bad one.
const ROUNDS: u64 = 12;

/// The kinds of scan the publisher sends each round.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Good,
    AllNan,
    AllPosInf,
    AllNegInf,
    AllNegative,
    AllZero,
    NoBeams,
    Sprinkled,
}

const ROUND: [Kind; 9] = [
    Kind::Good,
    Kind::AllNan,
    Kind::AllPosInf,
    Kind::Good,
    Kind::AllNegInf,
    Kind::AllNegative,
    Kind::AllZero,
    Kind::NoBeams,
    Kind::Sprinkled,
];

/// Distance from `(px, py)` along heading `a` to the box's walls.
fn ray_to_box(px: f64, py: f64, a: f64) -> f64 {
    let (s, c) = a.sin_cos();
    let tx = if c > 1e-12 {
        (HALF_X - px) / c
    } else if c < -1e-12 {
        (-HALF_X - px) / c
    } else {
        f64::INFINITY
    };
    let ty = if s > 1e-12 {
        (HALF_Y - py) / s
    } else if s < -1e-12 {
        (-HALF_Y - py) / s
    } else {
        f64::INFINITY
    };
    tx.min(ty)
}

/// The true ranges from pose `(x, 0, theta)`.
fn good_ranges(x: f64, theta: f64) -> Vec<f32> {
    (0..BEAMS)
        .map(|i| {
            let a = -FOV_RAD / 2.0 + i as f64 * FOV_RAD / (BEAMS - 1) as f64;
            ray_to_box(x, 0.0, theta + a) as f32
        })
        .collect()
}

fn ranges_of(kind: Kind, x: f64, theta: f64) -> Vec<f32> {
    match kind {
        Kind::Good => good_ranges(x, theta),
        Kind::AllNan => vec![f32::NAN; BEAMS],
        Kind::AllPosInf => vec![f32::INFINITY; BEAMS],
        Kind::AllNegInf => vec![f32::NEG_INFINITY; BEAMS],
        Kind::AllNegative => vec![-1.5; BEAMS],
        Kind::AllZero => vec![0.0; BEAMS],
        Kind::NoBeams => Vec::new(),
        Kind::Sprinkled => {
            let bad = [
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                -2.0,
                0.0,
                1e-30,
                1e30,
                f32::MIN,
            ];
            good_ranges(x, theta)
                .into_iter()
                .enumerate()
                .map(|(i, r)| {
                    if i % 3 == 0 {
                        bad[(i / 3) % bad.len()]
                    } else {
                        r
                    }
                })
                .collect()
        }
    }
}

/// Publishes the rounds lock-step; returns (scans sent, good scans sent).
fn publish(prefix: &str, robot: &str) -> Result<(u64, u64)> {
    let config = IpcConfig::new(prefix)?;
    let mut publisher = RobotPublisher::new(&config, robot, Delivery::lock_step())?;
    ensure!(
        publisher.wait_for_subscribers(1, Duration::from_secs(30))?,
        "the service did not subscribe"
    );
    let (mut seq, mut good) = (0u64, 0u64);
    for _ in 0..ROUNDS {
        for kind in ROUND {
            // Slowly along x and turning a little, so that a propagated garbage value
            // would show at different places. The first pose is the odometry origin, so
            // that the map frame (origin at the robot's start) is the room's frame.
            let x = 0.02 * seq as f64;
            let theta = 0.01 * seq as f64;
            let stamp_ns = 1_000_000_000 + seq * 50_000_000;
            publisher.publish_odometry(&Odometry {
                sequence: seq,
                stamp_ns,
                x_m: x,
                y_m: 0.0,
                theta_rad: theta,
            })?;
            let ranges = ranges_of(kind, x, theta);
            let header = ScanHeader {
                sequence: seq,
                stamp_ns,
                angle_min_rad: (-FOV_RAD / 2.0) as f32,
                angle_increment_rad: (FOV_RAD / (BEAMS - 1) as f64) as f32,
                range_min_m: 0.05,
                range_max_m: RANGE_MAX,
                beam_count: ranges.len() as u32,
            };
            publisher
                .publish_scan(&header, &ranges)
                .with_context(|| format!("publishing a {kind:?} scan"))?;
            seq += 1;
            if matches!(kind, Kind::Good) {
                good += 1;
            }
        }
    }
    // Keep the publisher alive a moment so that the last samples are taken.
    std::thread::sleep(Duration::from_millis(500));
    Ok((seq, good))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_ranges_never_reach_the_map() -> Result<()> {
    in_temp_dir("badscans", &[(SERVICE_LOG, 60)], |dir| async move {
        run(&dir.join("data")).await
    })
    .await
}

async fn run(data: &std::path::Path) -> Result<()> {
    let prefix = unique_prefix("badscans");
    let service = start_service(data, &prefix, &[], &[]).await?;
    let client = service.client.clone();
    let session = client
        .create_session(&CreateSessionRequest {
            seed: Some(1),
            ..CreateSessionRequest::new("box", MappingMethod::Odometry)
        })
        .await?;
    let p = prefix.clone();
    let (sent, good) = tokio::task::spawn_blocking(move || publish(&p, "box")).await??;
    let info = wait_settled(
        &client,
        &session.id,
        Duration::from_millis(1500),
        Duration::from_secs(30),
    )
    .await?;
    eprintln!(
        "sent {sent} scans ({good} good): processed {}, lost {}, state {:?}, error {:?}",
        info.scans_processed, info.scans_lost, info.state, info.last_error
    );
    ensure!(info.state == SessionState::Mapping, "{info:?}");
    ensure!(info.scans_lost == 0, "{info:?}");
    ensure!(
        info.scans_processed >= good && info.scans_processed <= sent,
        "processed {} of {sent} scans ({good} good)",
        info.scans_processed
    );
    let pose = client.pose(&session.id).await?;
    ensure!(
        pose.x.is_finite() && pose.y.is_finite() && pose.theta.is_finite(),
        "{pose:?}"
    );

    let grid = client.map(&session.id).await?;
    let map = &grid.info;
    ensure!(grid.data.len() == (map.width * map.height) as usize);
    ensure!(grid.header.frame_id == "map");
    let origin = map.origin.position;
    let (s, c) = map.origin.orientation.yaw_rad().sin_cos();
    let (mut walls, mut garbage) = (0usize, Vec::new());
    for row in 0..map.height as usize {
        for col in 0..map.width as usize {
            let v = grid.data[row * map.width as usize + col];
            if v < 0 || (20..65).contains(&v) {
                continue;
            }
            let lx = (col as f64 + 0.5) * map.resolution;
            let ly = (row as f64 + 0.5) * map.resolution;
            let x = origin.x + c * lx - s * ly;
            let y = origin.y + s * lx + c * ly;
            // On a wall: within two cells of the box's outline.
            let tol = 2.0 * map.resolution + 0.02;
            let inside_outer = x.abs() <= HALF_X + tol && y.abs() <= HALF_Y + tol;
            let inside_inner = x.abs() < HALF_X - tol && y.abs() < HALF_Y - tol;
            if v < 20 {
                // Free: only inside the room (a beam never passes through a wall).
                if !inside_outer {
                    garbage.push((x, y, v));
                }
            } else if inside_outer && !inside_inner {
                walls += 1;
            } else {
                garbage.push((x, y, v));
            }
        }
    }
    eprintln!(
        "map {}×{} at {} m: {walls} occupied wall cells, {} elsewhere",
        map.width,
        map.height,
        map.resolution,
        garbage.len()
    );
    ensure!(
        garbage.is_empty(),
        "occupied cells off the walls: {:?}",
        &garbage[..garbage.len().min(10)]
    );
    // The walls were mapped (not an empty map): 36 m of outline, most of it seen.
    let outline_cells = 2.0 * (2.0 * HALF_X + 2.0 * HALF_Y) / map.resolution;
    ensure!(
        walls as f64 > 0.5 * outline_cells,
        "only {walls} wall cells of ~{outline_cells:.0}"
    );
    Ok(())
}
