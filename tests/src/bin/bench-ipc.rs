//! `bench-ipc`: throughput and latency of 1 081-beam scans through `shared::ipc` between two
//! processes (this binary re-runs itself as the subscriber), in both delivery modes.
//!
//! Latency is publisher stamp to subscriber receive: the publisher writes
//! `CLOCK_MONOTONIC` nanoseconds into `ScanHeader::stamp_ns`, the subscriber reads the same
//! clock when `receive_timeout` hands it the owned scan (so the copy out of shared memory
//! and the stamp-order merge are included). Prints a table and one JSON line per case.

use anyhow::{Context, Result, bail};
use clap::Parser;
use serde_json::json;
use sketchslam_ipc::{Delivery, IpcConfig, RobotPublisher, RobotSubscriber};
use sketchslam_types::ScanHeader;
use sketchslam_types::SensorEvent;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[derive(Debug, Parser)]
#[command(name = "bench-ipc", about = "iceoryx2 scan transport benchmark")]
struct Args {
    /// Internal: run as the subscriber of a benchmark case.
    #[arg(long, hide = true)]
    subscriber: bool,
    /// Internal: the iceoryx2 prefix of the case.
    #[arg(long, hide = true, default_value = "bench")]
    prefix: String,
    /// Scans per unpaced case.
    #[arg(long, default_value_t = 20_000)]
    scans: u64,
    /// Scans per paced case.
    #[arg(long, default_value_t = 3_000)]
    paced_scans: u64,
    /// Rate of the paced cases, Hz.
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// Beams per scan.
    #[arg(long, default_value_t = 1081)]
    beams: usize,
}

const ROBOT: &str = "bench";

/// `CLOCK_MONOTONIC` now, nanoseconds (the same clock in both processes).
fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

fn percentile(sorted: &[u64], p: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

fn run_subscriber(args: &Args) -> Result<()> {
    let config = IpcConfig::new(&args.prefix)?;
    let mut sub = RobotSubscriber::new(&config, ROBOT)?;
    println!("ready");
    let mut latencies_ns = Vec::with_capacity(args.scans as usize);
    let mut first: Option<Instant> = None;
    let mut last = Instant::now();
    let timeout = Duration::from_secs(30);
    while (latencies_ns.len() as u64) < args.scans {
        let wait = if first.is_some() {
            Duration::from_secs(2)
        } else {
            timeout
        };
        let Some(event) = sub.receive_timeout(wait)? else {
            break;
        };
        let now_ns = monotonic_ns();
        if let SensorEvent::Scan(scan) = event {
            latencies_ns.push(now_ns.saturating_sub(scan.header.stamp_ns));
            first.get_or_insert_with(Instant::now);
            last = Instant::now();
        }
    }
    let received = latencies_ns.len();
    let span_s = first.map_or(0.0, |f| (last - f).as_secs_f64());
    latencies_ns.sort_unstable();
    let stats = sub.stats();
    println!(
        "{}",
        json!({
            "received": received,
            "lost": stats.scans_lost,
            "span_s": span_s,
            "p50_us": percentile(&latencies_ns, 0.5) as f64 / 1e3,
            "p99_us": percentile(&latencies_ns, 0.99) as f64 / 1e3,
            "max_us": latencies_ns.last().copied().unwrap_or(0) as f64 / 1e3,
        })
    );
    Ok(())
}

struct Case {
    name: &'static str,
    delivery: Delivery,
    rate_hz: Option<f64>,
    scans: u64,
}

fn run_case(args: &Args, case: &Case) -> Result<serde_json::Value> {
    let prefix = format!("bench{}x{}", std::process::id(), monotonic_ns() % 1_000_000);
    let exe = std::env::current_exe()?;
    let mut child = Command::new(exe)
        .args(["--subscriber", "--prefix", &prefix, "--scans"])
        .arg(case.scans.to_string())
        .stdout(Stdio::piped())
        .spawn()
        .context("starting the subscriber process")?;
    let result = (|| -> Result<serde_json::Value> {
        let stdout = child.stdout.take().context("no stdout")?;
        let mut lines = BufReader::new(stdout).lines();
        match lines.next() {
            Some(Ok(l)) if l == "ready" => {}
            other => bail!("subscriber did not start: {other:?}"),
        }
        let config = IpcConfig::new(&prefix)?;
        let mut publisher = RobotPublisher::new(&config, ROBOT, case.delivery)?;
        // Both modes start after the handshake, so no case loses its first samples.
        if !publisher.wait_for_subscribers(1, Duration::from_secs(10))? {
            bail!("subscriber did not connect");
        }
        let ranges: Vec<f32> = (0..args.beams).map(|i| 1.0 + i as f32 * 1e-3).collect();
        let mut header = ScanHeader {
            angle_min_rad: -2.356,
            angle_increment_rad: 0.004_363_3,
            range_min_m: 0.05,
            range_max_m: 50.0,
            beam_count: args.beams as u32,
            ..Default::default()
        };
        let start = Instant::now();
        for i in 0..case.scans {
            if let Some(rate) = case.rate_hz {
                let due = start + Duration::from_secs_f64(i as f64 / rate);
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                }
            }
            header.sequence = i;
            header.stamp_ns = monotonic_ns();
            publisher.publish_scan(&header, &ranges)?;
        }
        let publish_s = start.elapsed().as_secs_f64();
        let stats = publisher.stats();
        let line = lines.next().context("subscriber printed no result")??;
        let sub: serde_json::Value = serde_json::from_str(&line)?;
        let received = sub["received"].as_u64().unwrap_or(0);
        let span_s = sub["span_s"].as_f64().unwrap_or(0.0);
        Ok(json!({
            "case": case.name,
            "beams": args.beams,
            "sent": case.scans,
            "received": received,
            "discarded": stats.discarded,
            "publish_s": publish_s,
            "scans_per_s": if span_s > 0.0 { received as f64 / span_s } else { 0.0 },
            "p50_us": sub["p50_us"],
            "p99_us": sub["p99_us"],
            "max_us": sub["max_us"],
        }))
    })();
    let _ = child.kill();
    let _ = child.wait();
    result
}

fn main() -> Result<()> {
    let args = Args::parse();
    if args.subscriber {
        return run_subscriber(&args);
    }
    let cases = [
        Case {
            name: "lockstep-unpaced",
            delivery: Delivery::lock_step(),
            rate_hz: None,
            scans: args.scans,
        },
        Case {
            name: "realtime-unpaced",
            delivery: Delivery::RealTime,
            rate_hz: None,
            scans: args.scans,
        },
        Case {
            name: "lockstep-paced",
            delivery: Delivery::lock_step(),
            rate_hz: Some(args.rate_hz),
            scans: args.paced_scans,
        },
        Case {
            name: "realtime-paced",
            delivery: Delivery::RealTime,
            rate_hz: Some(args.rate_hz),
            scans: args.paced_scans,
        },
    ];
    println!(
        "{:<18} {:>7} {:>9} {:>9} {:>11} {:>9} {:>9} {:>9}",
        "case", "sent", "received", "discarded", "scans/s", "p50 µs", "p99 µs", "max µs"
    );
    let mut rows = Vec::new();
    for case in &cases {
        let r = run_case(&args, case)?;
        println!(
            "{:<18} {:>7} {:>9} {:>9} {:>11.0} {:>9.1} {:>9.1} {:>9.1}",
            case.name,
            r["sent"],
            r["received"],
            r["discarded"],
            r["scans_per_s"].as_f64().unwrap_or(0.0),
            r["p50_us"].as_f64().unwrap_or(0.0),
            r["p99_us"].as_f64().unwrap_or(0.0),
            r["max_us"].as_f64().unwrap_or(0.0),
        );
        rows.push(r);
    }
    println!("{}", json!({ "bench": "ipc", "cases": rows }));
    Ok(())
}
