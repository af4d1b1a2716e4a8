//! `scan-probe`: a test subscriber process for the multi-process transport tests.
//!
//! Subscribes to one robot with `shared::ipc::RobotSubscriber`, receives until it has
//! `--max-scans` scans or nothing arrived for `--idle-timeout-ms` (after the first sample;
//! `--first-timeout-ms` before it), then prints one JSON summary line on stdout: counts,
//! whether sequences and stamps came in order, the first scan's header, the checksum of
//! every scan's ranges, and the gaps seen. `--delay-ms` makes it a slow consumer, and with
//! `--progress` it prints `scan <sequence>` lines as it goes, so a test can kill it midway.

use anyhow::{Context, Result};
use clap::Parser;
use serde_json::json;
use sketchslam_ipc::{IpcConfig, RobotSubscriber, ranges_checksum};
use sketchslam_types::SensorEvent;
use std::io::Write;
use std::time::{Duration, Instant};

#[derive(Debug, Parser)]
#[command(
    name = "scan-probe",
    about = "receive a robot's scans and summarize them as JSON"
)]
struct Args {
    /// The robot id to subscribe to.
    #[arg(long)]
    robot: String,
    /// The iceoryx2 prefix.
    #[arg(long, default_value = sketchslam_types::DEFAULT_PREFIX)]
    ipc_prefix: String,
    /// Stop after this many scans.
    #[arg(long, default_value_t = u64::MAX)]
    max_scans: u64,
    /// Stop when nothing arrived for this long after the first sample, milliseconds.
    #[arg(long, default_value_t = 3000)]
    idle_timeout_ms: u64,
    /// Stop when no first sample arrived for this long, milliseconds.
    #[arg(long, default_value_t = 60_000)]
    first_timeout_ms: u64,
    /// Sleep this long after each scan (a slow consumer), milliseconds.
    #[arg(long, default_value_t = 0)]
    delay_ms: u64,
    /// Print `scan <sequence>` on stdout after each scan.
    #[arg(long)]
    progress: bool,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let config = IpcConfig::new(&args.ipc_prefix)?;
    let mut subscriber = RobotSubscriber::new(&config, &args.robot).context("subscribing")?;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "subscribed")?;
    stdout.flush()?;

    let mut sequences: Vec<u64> = Vec::new();
    let mut checksums: Vec<String> = Vec::new();
    let mut first_header = None;
    let mut odometry = 0u64;
    let mut odometry_in_order = true;
    let mut last_odometry_sequence: Option<u64> = None;
    let mut stamps_in_order = true;
    let mut last_stamp: Option<u64> = None;
    let mut header_consistent = true;
    let started = Instant::now();
    let mut first_at: Option<Instant> = None;
    while (sequences.len() as u64) < args.max_scans {
        let timeout = Duration::from_millis(if first_at.is_some() {
            args.idle_timeout_ms
        } else {
            args.first_timeout_ms
        });
        let Some(event) = subscriber.receive_timeout(timeout)? else {
            break;
        };
        first_at.get_or_insert_with(Instant::now);
        let stamp = event.stamp_ns();
        if last_stamp.is_some_and(|l| stamp < l) {
            stamps_in_order = false;
        }
        last_stamp = Some(stamp);
        match event {
            SensorEvent::Odometry(o) => {
                if last_odometry_sequence.is_some_and(|l| o.sequence != l + 1) {
                    odometry_in_order = false;
                }
                last_odometry_sequence = Some(o.sequence);
                odometry += 1;
            }
            SensorEvent::Scan(scan) => {
                header_consistent &= scan.header.beam_count as usize == scan.ranges_m.len();
                first_header.get_or_insert(scan.header);
                sequences.push(scan.header.sequence);
                checksums.push(format!("{:016x}", ranges_checksum(&scan.ranges_m)));
                if args.progress {
                    writeln!(stdout, "scan {}", scan.header.sequence)?;
                    stdout.flush()?;
                }
                if args.delay_ms > 0 {
                    std::thread::sleep(Duration::from_millis(args.delay_ms));
                }
            }
        }
    }
    let in_order = sequences.windows(2).all(|w| w[1] == w[0] + 1);
    let stats = subscriber.stats();
    let gaps: Vec<_> = subscriber
        .take_gaps()
        .iter()
        .map(|g| json!({"topic": g.topic.as_str(), "expected": g.expected, "received": g.received}))
        .collect();
    let summary = json!({
        "scans": sequences.len(),
        "odometry": odometry,
        "first_sequence": sequences.first(),
        "last_sequence": sequences.last(),
        "sequences_in_order": in_order,
        "odometry_in_order": odometry_in_order,
        "stamps_in_order": stamps_in_order,
        "header_consistent": header_consistent,
        "first_header": first_header,
        "checksums": checksums,
        "gaps": gaps,
        "scans_lost": stats.scans_lost,
        "odometry_lost": stats.odometry_lost,
        "sequence_restarts": stats.sequence_restarts,
        "out_of_order": stats.out_of_order,
        "elapsed_s": started.elapsed().as_secs_f64(),
    });
    writeln!(stdout, "{summary}")?;
    Ok(())
}
