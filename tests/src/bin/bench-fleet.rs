//! `bench-fleet`: how many robots one `slam-service` keeps up with in real time.
//!
//! For each fleet size K (`--robots 1,2,4,8`): a fresh service, K sessions (`--method
//! sketch|icp|odometry`; sketch A of `paper-env1`), and K simulators in real-time mode
//! (`--rate 1`, 20 Hz scans, robot ids r0..rK-1, `--max-scans` so each run lasts ~30 s).
//! Per robot: scans published (the simulator's truth rows), processed and lost (the
//! session's status); for the case: the scan processing time p50/p99 (from the service's
//! `sketchslam_scan_processing_seconds` histogram in `/metrics`) and the service's CPU use
//! (`utime + stime` from `/proc/PID/stat` over the run, in cores). Prints a table, one JSON
//! line per case, and the largest K with no scan lost.
//!
//! Run for numbers with `cargo run --release -p sketchslam-tests --bin bench-fleet`.

#[path = "bench_common/mod.rs"]
mod bench_common;

use anyhow::{Result, bail};
use bench_common::{
    case_dir, cpu_seconds, create_session, discarded_in_log, paper_env1, parse_method,
    spawn_simulator, start_service, truth_rows, wait_all, wait_settled,
};
use clap::Parser;
use serde_json::json;
use sketchslam_api::MappingMethod;
use sketchslam_tests::processes::{binary, unique_prefix};
use sketchslam_tests::service_histogram::{SCAN_PROCESSING, ServiceHistogram};
use std::time::{Duration, Instant};

#[derive(Debug, Parser)]
#[command(name = "bench-fleet", about = "robots per slam-service in real time")]
struct Args {
    /// Fleet sizes to run, comma-separated.
    #[arg(long, default_value = "1,2,4,8", value_delimiter = ',')]
    robots: Vec<usize>,
    /// Mapping method of every session: sketch, icp or odometry.
    #[arg(long, default_value = "sketch")]
    method: String,
    /// Scans per simulator (20 Hz: 600 = 30 s).
    #[arg(long, default_value_t = 600)]
    max_scans: u64,
    /// Simulator speed-up over real time.
    #[arg(long, default_value_t = 1.0)]
    rate: f64,
    /// Folder for logs and truth files.
    #[arg(long, default_value = "out/bench-fleet")]
    out: std::path::PathBuf,
}

struct RobotRow {
    robot: String,
    published: u64,
    processed: u64,
    /// Published − processed, or the service's count if larger.
    lost: u64,
    /// The session's own `scans_lost` (sequence gaps).
    reported_lost: u64,
    discarded: Option<u64>,
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() -> Result<()> {
    let args = Args::parse();
    if args.robots.is_empty() || args.robots.contains(&0) {
        bail!("--robots needs positive fleet sizes");
    }
    let method = parse_method(&args.method)?;
    std::fs::create_dir_all(&args.out)?;
    // Built before any clock starts.
    binary("sketchslam-simulator", "simulator")?;
    binary("sketchslam-slam", "slam-service")?;
    let mut summaries = Vec::new();
    for &k in &args.robots {
        let summary = run_case(&args, method, k).await?;
        summaries.push(summary);
    }
    let best = summaries
        .iter()
        .filter(|s| s["no_loss"].as_bool() == Some(true))
        .filter_map(|s| s["robots"].as_u64())
        .max();
    match best {
        Some(k) => println!("largest fleet with no scan lost: K = {k} ({})", args.method),
        None => println!("every fleet size lost scans ({})", args.method),
    }
    println!(
        "{}",
        json!({"bench": "fleet", "method": args.method, "largest_k_no_loss": best, "cases": summaries})
    );
    Ok(())
}

async fn run_case(args: &Args, method: MappingMethod, k: usize) -> Result<serde_json::Value> {
    let dir = case_dir(&args.out, &format!("{}-k{k}", args.method))?;
    let prefix = unique_prefix("fleet");
    let (_, cfg) = paper_env1()?;
    let mut service = start_service(&dir.join("data"), &prefix, &dir.join("service.log")).await?;
    let client = service.client.clone();
    let sketch_id = if method == MappingMethod::Sketch {
        Some(
            client
                .upload_sketch(std::fs::read(&cfg.image)?, Some("A"))
                .await?
                .id,
        )
    } else {
        None
    };
    let robots: Vec<String> = (0..k).map(|i| format!("r{i}")).collect();
    let mut ids = Vec::new();
    for r in &robots {
        ids.push(
            create_session(&client, r, method, sketch_id.as_deref(), &cfg)
                .await?
                .id,
        );
    }
    let pid = service.guard.id();
    let cpu0 = cpu_seconds(pid)?;
    let started = Instant::now();
    let mut sims = Vec::new();
    for r in &robots {
        sims.push(spawn_simulator(
            &prefix,
            r,
            args.rate,
            args.max_scans,
            &dir.join(format!("truth-{r}.csv")),
            &dir.join(format!("sim-{r}.log")),
        )?);
    }
    let run_s = args.max_scans as f64 / 20.0 / args.rate;
    wait_all(&mut sims, Duration::from_secs_f64(run_s + 120.0)).await?;
    let sim_wall = started.elapsed().as_secs_f64();
    let infos = wait_settled(
        &client,
        &ids,
        Duration::from_secs(2),
        Duration::from_secs(120),
    )
    .await?;
    let wall = started.elapsed().as_secs_f64();
    let cpu = cpu_seconds(pid)? - cpu0;
    let hist = ServiceHistogram::parse(&client.metrics().await?, SCAN_PROCESSING);
    let p50 = hist.as_ref().and_then(|h| h.quantile(0.5));
    let p99 = hist.as_ref().and_then(|h| h.quantile(0.99));
    service.guard.terminate(Duration::from_secs(10));

    let mut rows = Vec::new();
    for (r, info) in robots.iter().zip(&infos) {
        let published = truth_rows(&dir.join(format!("truth-{r}.csv")))?;
        rows.push(RobotRow {
            robot: r.clone(),
            published,
            processed: info.scans_processed,
            lost: info
                .scans_lost
                .max(published.saturating_sub(info.scans_processed)),
            reported_lost: info.scans_lost,
            discarded: discarded_in_log(&dir.join(format!("sim-{r}.log"))),
        });
    }
    let lost_total: u64 = rows.iter().map(|r| r.lost).sum();
    let ms = |v: Option<f64>| v.map_or("-".to_string(), |s| format!("{:.1}", s * 1e3));
    println!(
        "\nK = {k}, method {}, {} scans per robot at rate {} ({sim_wall:.1} s publishing, {wall:.1} s until drained)",
        args.method, args.max_scans, args.rate
    );
    println!(
        "{:<6} {:>9} {:>9} {:>6} {:>9} {:>9}",
        "robot", "published", "processed", "lost", "svc-lost", "discarded"
    );
    for r in &rows {
        println!(
            "{:<6} {:>9} {:>9} {:>6} {:>9} {:>9}",
            r.robot,
            r.published,
            r.processed,
            r.lost,
            r.reported_lost,
            r.discarded.map_or("-".into(), |d| d.to_string())
        );
    }
    println!(
        "processing p50 {} ms, p99 {} ms; service CPU {cpu:.1} s = {:.2} cores over {wall:.1} s",
        ms(p50),
        ms(p99),
        cpu / wall
    );
    let summary = json!({
        "robots": k,
        "method": args.method,
        "rate": args.rate,
        "max_scans": args.max_scans,
        "published": rows.iter().map(|r| r.published).sum::<u64>(),
        "processed": rows.iter().map(|r| r.processed).sum::<u64>(),
        "lost": lost_total,
        "no_loss": lost_total == 0,
        "per_robot": rows.iter().map(|r| json!({
            "robot": r.robot, "published": r.published, "processed": r.processed,
            "lost": r.lost, "reported_lost": r.reported_lost, "discarded": r.discarded,
        })).collect::<Vec<_>>(),
        "processing_p50_ms": p50.map(|s| s * 1e3),
        "processing_p99_ms": p99.map(|s| s * 1e3),
        "service_cpu_s": cpu,
        "service_cores": cpu / wall,
        "wall_s": wall,
    });
    println!("{summary}");
    Ok(summary)
}
