//! `bench-http`: does HTTP load slow down mapping?
//!
//! Two phases, each on a fresh `slam-service` with one session (`--method`, sketch A of
//! `paper-env1` by default) fed by the simulator in real time (`--rate 1`, 20 Hz):
//! - `baseline`: no HTTP load;
//! - `load`: once the session maps, a bounded load generator (tokio + reqwest, `--clients`
//!   concurrent clients on loopback, at most `--requests` requests in all and `--time-cap-s`
//!   seconds) alternates `GET /v1/sessions/{id}/pose` and `GET /v1/sessions/{id}/map.png`.
//!
//! Reports, per endpoint, requests per second and latency p50/p99 (and errors); per phase,
//! scans published/processed/lost, the scan processing time p50/p99 from `/metrics` and the
//! service's CPU use — so the two phases show whether serving slowed mapping or lost scans.
//! Prints tables and one JSON line.
//!
//! Run for numbers with `cargo run --release -p sketchslam-tests --bin bench-http`.

#[path = "bench_common/mod.rs"]
mod bench_common;

use anyhow::{Context, Result, bail};
use bench_common::{
    case_dir, cpu_seconds, create_session, paper_env1, parse_method, percentile, spawn_simulator,
    start_service, truth_rows, wait_all, wait_settled,
};
use clap::Parser;
use serde_json::{Value, json};
use sketchslam_tests::processes::{binary, unique_prefix};
use sketchslam_tests::service_histogram::{SCAN_PROCESSING, ServiceHistogram};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

#[derive(Debug, Parser)]
#[command(
    name = "bench-http",
    about = "HTTP load against a mapping slam-service"
)]
struct Args {
    /// Concurrent HTTP clients.
    #[arg(long, default_value_t = 16)]
    clients: usize,
    /// Requests in all (half pose, half map.png).
    #[arg(long, default_value_t = 20_000)]
    requests: u64,
    /// The load stops after this many seconds at the latest.
    #[arg(long, default_value_t = 30.0)]
    time_cap_s: f64,
    /// Scans the simulator publishes (20 Hz: 600 = 30 s).
    #[arg(long, default_value_t = 600)]
    max_scans: u64,
    /// Simulator speed-up over real time.
    #[arg(long, default_value_t = 1.0)]
    rate: f64,
    /// Mapping method: sketch, icp or odometry.
    #[arg(long, default_value = "sketch")]
    method: String,
    /// Folder for logs and truth files.
    #[arg(long, default_value = "out/bench-http")]
    out: std::path::PathBuf,
}

const ENDPOINTS: [&str; 2] = ["pose", "map.png"];

/// Latencies (seconds) of successful requests and the error count of one endpoint.
#[derive(Default)]
struct EndpointStats {
    latencies: Vec<f64>,
    errors: u64,
    bytes: u64,
}

#[tokio::main(flavor = "multi_thread", worker_threads = 4)]
async fn main() -> Result<()> {
    let args = Args::parse();
    if args.clients == 0 || !args.time_cap_s.is_finite() || args.time_cap_s <= 0.0 {
        bail!("--clients and --time-cap-s must be positive");
    }
    binary("sketchslam-simulator", "simulator")?;
    binary("sketchslam-slam", "slam-service")?;
    std::fs::create_dir_all(&args.out)?;
    let baseline = run_phase(&args, false).await?;
    let load = run_phase(&args, true).await?;

    println!(
        "\n{:<9} {:>9} {:>9} {:>5} {:>10} {:>10} {:>7}",
        "phase", "published", "processed", "lost", "proc p50", "proc p99", "cores"
    );
    for p in [&baseline, &load] {
        println!(
            "{:<9} {:>9} {:>9} {:>5} {:>8.1}ms {:>8.1}ms {:>7.2}",
            p["phase"].as_str().unwrap_or_default(),
            p["published"].as_u64().unwrap_or(0),
            p["processed"].as_u64().unwrap_or(0),
            p["lost"].as_u64().unwrap_or(0),
            p["processing_p50_ms"].as_f64().unwrap_or(f64::NAN),
            p["processing_p99_ms"].as_f64().unwrap_or(f64::NAN),
            p["service_cores"].as_f64().unwrap_or(f64::NAN),
        );
    }
    println!(
        "\n{:<8} {:>8} {:>7} {:>8} {:>9} {:>9} {:>10}",
        "endpoint", "requests", "errors", "req/s", "p50", "p99", "avg bytes"
    );
    if let Some(eps) = load["endpoints"].as_array() {
        for e in eps {
            println!(
                "{:<8} {:>8} {:>7} {:>8.0} {:>7.2}ms {:>7.2}ms {:>10}",
                e["endpoint"].as_str().unwrap_or_default(),
                e["requests"].as_u64().unwrap_or(0),
                e["errors"].as_u64().unwrap_or(0),
                e["rps"].as_f64().unwrap_or(0.0),
                e["p50_ms"].as_f64().unwrap_or(f64::NAN),
                e["p99_ms"].as_f64().unwrap_or(f64::NAN),
                e["avg_bytes"].as_u64().unwrap_or(0),
            );
        }
    }
    println!(
        "load: {} requests in {:.1} s = {:.0} req/s with {} clients",
        load["requests"].as_u64().unwrap_or(0),
        load["load_s"].as_f64().unwrap_or(0.0),
        load["rps"].as_f64().unwrap_or(0.0),
        args.clients
    );
    let slowed = load["lost"].as_u64() > baseline["lost"].as_u64()
        || load["processed"].as_u64() < baseline["processed"].as_u64();
    println!(
        "mapping under load: {}",
        if slowed {
            "lost or unprocessed scans"
        } else {
            "no scan lost, every scan processed"
        }
    );
    println!(
        "{}",
        json!({"bench": "http", "clients": args.clients, "baseline": baseline, "load": load,
               "mapping_degraded": slowed})
    );
    Ok(())
}

async fn run_phase(args: &Args, with_load: bool) -> Result<Value> {
    let phase = if with_load { "load" } else { "baseline" };
    let dir = case_dir(&args.out, phase)?;
    let prefix = unique_prefix("benchhttp");
    let method = parse_method(&args.method)?;
    let (_, cfg) = paper_env1()?;
    let mut service = start_service(&dir.join("data"), &prefix, &dir.join("service.log")).await?;
    let client = service.client.clone();
    let sketch_id = match method {
        sketchslam_api::MappingMethod::Sketch => Some(
            client
                .upload_sketch(std::fs::read(&cfg.image)?, Some("A"))
                .await?
                .id,
        ),
        _ => None,
    };
    let session = create_session(&client, "r0", method, sketch_id.as_deref(), &cfg).await?;
    let pid = service.guard.id();
    let cpu0 = cpu_seconds(pid)?;
    let started = Instant::now();
    let truth = dir.join("truth.csv");
    let mut sims = vec![spawn_simulator(
        &prefix,
        "r0",
        args.rate,
        args.max_scans,
        &truth,
        &dir.join("sim.log"),
    )?];

    let mut load_result = None;
    if with_load {
        // Load only while the session maps.
        let deadline = Instant::now() + Duration::from_secs(30);
        while client.get_session(&session.id).await?.scans_processed == 0 {
            if Instant::now() > deadline {
                bail!("the session did not start mapping within 30 s");
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let stop = Arc::new(AtomicBool::new(false));
        let load = tokio::spawn(generate_load(
            service.base.clone(),
            session.id.clone(),
            args.clients,
            args.requests,
            Duration::from_secs_f64(args.time_cap_s),
            stop.clone(),
        ));
        let run_s = args.max_scans as f64 / 20.0 / args.rate;
        let waited = wait_all(&mut sims, Duration::from_secs_f64(run_s + 120.0)).await;
        stop.store(true, Ordering::Relaxed);
        waited?;
        load_result = Some(load.await??);
    } else {
        let run_s = args.max_scans as f64 / 20.0 / args.rate;
        wait_all(&mut sims, Duration::from_secs_f64(run_s + 120.0)).await?;
    }
    let info = wait_settled(
        &client,
        std::slice::from_ref(&session.id),
        Duration::from_secs(2),
        Duration::from_secs(120),
    )
    .await?
    .pop()
    .context("no session status")?;
    let wall = started.elapsed().as_secs_f64();
    let cpu = cpu_seconds(pid)? - cpu0;
    let hist = ServiceHistogram::parse(&client.metrics().await?, SCAN_PROCESSING);
    service.guard.terminate(Duration::from_secs(10));
    let published = truth_rows(&truth)?;
    let mut out = json!({
        "phase": phase,
        "method": args.method,
        "published": published,
        "processed": info.scans_processed,
        "lost": info.scans_lost.max(published.saturating_sub(info.scans_processed)),
        "reported_lost": info.scans_lost,
        "processing_p50_ms": hist.as_ref().and_then(|h| h.quantile(0.5)).map(|s| s * 1e3),
        "processing_p99_ms": hist.as_ref().and_then(|h| h.quantile(0.99)).map(|s| s * 1e3),
        "service_cpu_s": cpu,
        "service_cores": cpu / wall,
        "wall_s": wall,
    });
    if let Some((stats, load_s)) = load_result {
        let mut eps = Vec::new();
        let mut total = 0u64;
        for (name, s) in ENDPOINTS.iter().zip(stats) {
            let mut l = s.latencies.clone();
            l.sort_by(f64::total_cmp);
            let n = l.len() as u64 + s.errors;
            total += n;
            eps.push(json!({
                "endpoint": name,
                "requests": n,
                "errors": s.errors,
                "rps": n as f64 / load_s,
                "p50_ms": percentile(&l, 0.5) * 1e3,
                "p99_ms": percentile(&l, 0.99) * 1e3,
                "avg_bytes": s.bytes / (l.len() as u64).max(1),
            }));
        }
        out["endpoints"] = json!(eps);
        out["requests"] = json!(total);
        out["load_s"] = json!(load_s);
        out["rps"] = json!(total as f64 / load_s);
    }
    println!("{out}");
    Ok(out)
}

/// `clients` tasks share a request budget; each alternates the endpoints until the budget,
/// the time cap or `stop` ends the load. Returns per-endpoint stats and the load's duration.
async fn generate_load(
    base: String,
    session: String,
    clients: usize,
    requests: u64,
    cap: Duration,
    stop: Arc<AtomicBool>,
) -> Result<(Vec<EndpointStats>, f64)> {
    let http = reqwest::Client::builder()
        .timeout(Duration::from_secs(10))
        .pool_max_idle_per_host(clients)
        .build()?;
    let issued = Arc::new(AtomicU64::new(0));
    let started = Instant::now();
    let mut tasks = Vec::new();
    for _ in 0..clients {
        let (http, base, session, issued, stop) = (
            http.clone(),
            base.clone(),
            session.clone(),
            issued.clone(),
            stop.clone(),
        );
        tasks.push(tokio::spawn(async move {
            let mut stats: Vec<EndpointStats> =
                ENDPOINTS.iter().map(|_| EndpointStats::default()).collect();
            loop {
                if stop.load(Ordering::Relaxed) || started.elapsed() >= cap {
                    break;
                }
                let i = issued.fetch_add(1, Ordering::Relaxed);
                if i >= requests {
                    break;
                }
                let e = (i % ENDPOINTS.len() as u64) as usize;
                let url = format!("{base}/v1/sessions/{session}/{}", ENDPOINTS[e]);
                let t0 = Instant::now();
                let ok = match http.get(&url).send().await {
                    Ok(r) if r.status().is_success() => r.bytes().await.ok(),
                    _ => None,
                };
                match ok {
                    Some(body) => {
                        stats[e].latencies.push(t0.elapsed().as_secs_f64());
                        stats[e].bytes += body.len() as u64;
                    }
                    None => stats[e].errors += 1,
                }
            }
            stats
        }));
    }
    let mut merged: Vec<EndpointStats> =
        ENDPOINTS.iter().map(|_| EndpointStats::default()).collect();
    for t in tasks {
        for (m, s) in merged.iter_mut().zip(t.await?) {
            m.latencies.extend(s.latencies);
            m.errors += s.errors;
            m.bytes += s.bytes;
        }
    }
    Ok((merged, started.elapsed().as_secs_f64()))
}
