//! The stamp-ordered merge of scans and odometry through real iceoryx2 ports, in one
//! process: a publisher thread and a subscriber thread, each with its own node (ports are
//! not `Send`, so each side lives on its thread, as in the real processes). Synthetic events
//! with beam counts from 360 to 4 000 and equal stamps on both topics; a subscriber that
//! pauses now and then so that the lock-step publisher has to wait.

use anyhow::{Result, anyhow};
use sketchslam_ipc::{Delivery, IpcConfig, RobotPublisher, RobotSubscriber};
use sketchslam_simulator::publish::{Pace, PublishOptions, publish_events};
use sketchslam_tests::processes::unique_prefix;
use sketchslam_types::{Odometry, Scan, ScanHeader, SensorEvent};
use std::time::Duration;

/// Scans at 20 Hz, odometry at 50 Hz (stamps coincide every 100 ms; odometry first then).
fn synthetic_events(duration_ms: u64) -> Vec<SensorEvent> {
    let beams = [360usize, 1081, 4000, 2500, 1];
    let mut events = Vec::new();
    let (mut scan_seq, mut odom_seq) = (0u64, 0u64);
    for t_ms in 0..duration_ms {
        let t_ns = t_ms * 1_000_000;
        if t_ms % 20 == 0 {
            events.push(SensorEvent::Odometry(Odometry {
                sequence: odom_seq,
                stamp_ns: t_ns,
                x_m: t_ms as f64 * 1e-3,
                y_m: -(odom_seq as f64),
                theta_rad: 0.1,
            }));
            odom_seq += 1;
        }
        if t_ms % 50 == 0 {
            let n = beams[scan_seq as usize % beams.len()];
            let ranges_m: Vec<f32> = (0..n)
                .map(|i| match i % 97 {
                    0 => f32::INFINITY,
                    1 => f32::NAN,
                    _ => (scan_seq as f32) * 0.01 + i as f32 * 1e-3,
                })
                .collect();
            events.push(SensorEvent::Scan(Scan {
                header: ScanHeader {
                    sequence: scan_seq,
                    stamp_ns: t_ns,
                    angle_min_rad: -1.0,
                    angle_increment_rad: 2.0 / n as f32,
                    range_min_m: 0.05,
                    range_max_m: 30.0,
                    beam_count: n as u32,
                },
                ranges_m,
            }));
            scan_seq += 1;
        }
    }
    events
}

/// Events compared bit for bit (NaN ranges included).
fn same(a: &SensorEvent, b: &SensorEvent) -> bool {
    match (a, b) {
        (SensorEvent::Odometry(x), SensorEvent::Odometry(y)) => x == y,
        (SensorEvent::Scan(x), SensorEvent::Scan(y)) => {
            x.header == y.header
                && x.ranges_m.len() == y.ranges_m.len()
                && x.ranges_m
                    .iter()
                    .zip(&y.ranges_m)
                    .all(|(p, q)| p.to_bits() == q.to_bits())
        }
        _ => false,
    }
}

#[test]
fn ipc_merge_delivers_stamp_order_through_iceoryx2() -> Result<()> {
    let config = IpcConfig::new(&unique_prefix("merge"))?;
    let events = synthetic_events(6_000); // 120 scans, 300 odometry readings
    let total = events.len();

    let sub_config = config.clone();
    let subscriber = std::thread::spawn(move || -> Result<Vec<SensorEvent>> {
        let mut sub = RobotSubscriber::new(&sub_config, "m1")?;
        let mut got = Vec::new();
        while got.len() < total {
            match sub.receive_timeout(Duration::from_secs(20))? {
                Some(e) => got.push(e),
                None => break,
            }
            if got.len() % 50 == 0 {
                // A slow moment: the publisher's buffers fill and it must wait.
                std::thread::sleep(Duration::from_millis(30));
            }
        }
        let stats = sub.stats();
        if stats.scans_lost + stats.odometry_lost + stats.out_of_order > 0 {
            return Err(anyhow!("subscriber saw losses: {stats:?}"));
        }
        Ok(got)
    });

    let sent = events.clone();
    let publisher = std::thread::spawn(move || -> Result<_> {
        let mut publisher = RobotPublisher::new(&config, "m1", Delivery::lock_step())?;
        let options = PublishOptions {
            pace: Pace::LockStep {
                min_subscribers: 1,
                connect_timeout: Duration::from_secs(20),
            },
            max_scans: None,
            expected_scans: None,
            progress: false,
        };
        let summary = publish_events(&mut publisher, sent, &options)?;
        // Keep the ports alive until the subscriber drained everything.
        std::thread::sleep(Duration::from_millis(500));
        Ok(summary)
    });

    let summary = publisher
        .join()
        .map_err(|_| anyhow!("publisher panicked"))??;
    let got = subscriber
        .join()
        .map_err(|_| anyhow!("subscriber panicked"))??;
    assert_eq!(summary.discarded, 0);
    assert_eq!(summary.scans_sent, 120);
    assert_eq!(summary.odometry_sent, 300);
    assert_eq!(got.len(), events.len());
    let first_bad = events.iter().zip(&got).position(|(a, b)| !same(a, b));
    assert_eq!(first_bad, None, "merged stream differs from the sent one");
    Ok(())
}
