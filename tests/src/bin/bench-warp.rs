//! `bench-warp`: fits the drawing warp W again on what finished `sketch` runs fitted it to,
//! with other settings, and scores the pose on the drawing against the truth — the fit's
//! own benchmark, without mapping again.
//!
//! `bench-warp DIR... [--set key=value]...`: every `warp-problem.json` under the folders
//! (written by in-process `evaluate` runs, shared and generated scenarios alike) is fitted
//! with the default [`FitConfig`] changed by the `--set`s; the run's final trajectory
//! (`trajectory.csv`) is carried through W and scored against `truth.csv` carried onto the
//! drawing by the scenario's `sketch-truth.toml` (a real log's drawings have no truth: their
//! rows give only where W holds, its inliers and RMS). Prints a row per drawing and the
//! drawings' median, 90th percentile and worst of the median error, and the share of poses
//! within 1 m-equivalent; `--json FILE` writes the rows; `--render` draws each map over its
//! drawing through the new W.
//!
//! Run with `cargo run --release -p sketchslam-tests --bin bench-warp -- out/evaluate`.

use anyhow::{Context, Result, bail};
use clap::Parser;
use sketchslam_engine::registration::{FitConfig, render_map_on_drawing};
use sketchslam_simulator::dataset::Dataset;
use sketchslam_simulator::scenario::Scenario;
use sketchslam_tests::metrics::StampedPose;
use sketchslam_tests::run::read_trajectory_csv;
use sketchslam_tests::run::sketch_prior;
use sketchslam_tests::sketch_truth::{DrawingTruth, pair_by_stamp, score_sketch_poses};
use sketchslam_tests::warp_problem_file::{WARP_PROBLEM_FILE, WarpProblemFile};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

#[derive(Debug, Parser)]
#[command(about = "Fit the drawing warp again on finished runs and score it")]
struct Args {
    /// Folders searched for `warp-problem.json`.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// A fit setting changed from its default, `key=value` (FitConfig's field names).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// Fits at once; default: the machine's cores.
    #[arg(long)]
    jobs: Option<usize>,
    /// Also write the rows as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also draw each map over its drawing through the new W, as
    /// `RUN/bench-warp-overlay.png`.
    #[arg(long)]
    render: bool,
}

/// One drawing's figures.
#[derive(Debug, Clone, serde::Serialize)]
struct Row {
    run: String,
    median_m: Option<f64>,
    p95_m: Option<f64>,
    within_1m: Option<f64>,
    heading_median_deg: Option<f64>,
    /// Share of the final trajectory where mapped walls hold W.
    held: f64,
    inliers: usize,
    rms_px: f64,
    fit_s: f64,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let mut config = FitConfig::default();
    for set in &args.sets {
        apply_set(&mut config, set)?;
    }
    let mut files = Vec::new();
    for dir in &args.dirs {
        find_problems(dir, &mut files)?;
    }
    files.sort();
    if files.is_empty() {
        bail!("no {WARP_PROBLEM_FILE} under {:?}", args.dirs);
    }
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let next = Mutex::new(0usize);
    let rows = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| {
                loop {
                    let i = {
                        let mut n = next.lock().unwrap();
                        *n += 1;
                        *n - 1
                    };
                    let Some(path) = files.get(i) else { break };
                    match score(path, config, args.render) {
                        Ok(Some(row)) => rows.lock().unwrap().push(row),
                        Ok(None) => eprintln!("{}: nothing to score", path.display()),
                        Err(e) => eprintln!("{}: {e:#}", path.display()),
                    }
                }
            });
        }
    });
    let mut rows = rows.into_inner().unwrap();
    rows.sort_by(|a, b| a.run.cmp(&b.run));
    println!(
        "{:<48} {:>7} {:>7} {:>6} {:>6} {:>6} {:>7} {:>6} {:>6}",
        "run", "med m", "p95 m", "≤1m %", "hdg °", "held %", "inliers", "rms px", "fit s"
    );
    let opt = |v: Option<f64>, prec: usize| v.map_or("-".to_string(), |v| format!("{v:.prec$}"));
    for r in &rows {
        println!(
            "{:<48} {:>7} {:>7} {:>6} {:>6} {:>6.0} {:>7} {:>6.2} {:>6.2}",
            r.run,
            opt(r.median_m, 2),
            opt(r.p95_m, 2),
            opt(r.within_1m.map(|w| 100.0 * w), 0),
            opt(r.heading_median_deg, 1),
            100.0 * r.held,
            r.inliers,
            r.rms_px,
            r.fit_s
        );
    }
    let spread = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        (v[n / 2], v[(n * 9 / 10).min(n - 1)], v[n - 1])
    };
    let scored: Vec<&Row> = rows.iter().filter(|r| r.median_m.is_some()).collect();
    if !scored.is_empty() {
        let (med, p90, worst) = spread(scored.iter().filter_map(|r| r.median_m).collect());
        let (w_med, _, _) = spread(scored.iter().filter_map(|r| r.within_1m).collect());
        println!(
            "{} scored drawings: median error, median/p90/worst over drawings {med:.2}/{p90:.2}/{worst:.2} m; \
             within 1 m, median over drawings {:.0} %",
            scored.len(),
            100.0 * w_med
        );
    }
    let (fit_med, _, fit_worst) = spread(rows.iter().map(|r| r.fit_s).collect());
    println!(
        "fit {fit_med:.2} s median, {fit_worst:.2} s worst over {} drawings",
        rows.len()
    );
    if let Some(path) = &args.json {
        std::fs::write(path, serde_json::to_vec_pretty(&rows)?)?;
    }
    Ok(())
}

/// Every `warp-problem.json` under `dir`.
fn find_problems(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let path = entry?.path();
        if path.is_dir() {
            find_problems(&path, out)?;
        } else if path.file_name().is_some_and(|n| n == WARP_PROBLEM_FILE) {
            out.push(path);
        }
    }
    Ok(())
}

/// Fits the problem at `path` with `config` and scores the run's final trajectory through it.
fn score(path: &Path, config: FitConfig, render: bool) -> Result<Option<Row>> {
    let run_dir = path.parent().context("a file has a folder")?;
    let file = WarpProblemFile::read(path)?;
    let started = Instant::now();
    let Some(registration) = file.problem(config).solve() else {
        return Ok(None);
    };
    let fit_s = started.elapsed().as_secs_f64();
    let trajectory = read_trajectory_csv(&run_dir.join("trajectory.csv"))?;
    let warp = registration.warp();
    if render {
        let sketches = match Scenario::load(&file.scenario_dir) {
            Ok(scenario) => scenario.sketches,
            Err(_) => Dataset::load(&file.scenario_dir)?.sketches,
        };
        let cfg = sketches
            .iter()
            .find(|s| s.name == file.sketch)
            .with_context(|| {
                format!(
                    "no sketch {:?} in {}",
                    file.sketch,
                    file.scenario_dir.display()
                )
            })?;
        let prior = sketch_prior(cfg)?;
        let route: Vec<_> = trajectory.iter().map(|t| t.pose).collect();
        render_map_on_drawing(&prior.sketch, warp, &file.problem(config).walls, &route)
            .save(run_dir.join("bench-warp-overlay.png"))?;
    }
    let held = trajectory
        .iter()
        .filter(|t| registration.holds_at(t.pose.position()))
        .count() as f64
        / trajectory.len().max(1) as f64;
    let run = run_dir
        .components()
        .rev()
        .take(2)
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect::<Vec<_>>();
    let mut row = Row {
        run: format!("{}/{}", run[1], run[0]),
        median_m: None,
        p95_m: None,
        within_1m: None,
        heading_median_deg: None,
        held,
        inliers: registration.fit.inliers,
        rms_px: registration.fit.rms_px,
        fit_s,
    };
    // Scored where the scenario says how the drawing was made (real logs' drawings: not).
    if let Some(drawing) = DrawingTruth::load(&file.scenario_dir, &file.sketch)? {
        let truth: Vec<StampedPose> = read_trajectory_csv(&run_dir.join("truth.csv"))?;
        let published: Vec<_> = trajectory
            .iter()
            .map(|t| (t.t_s, warp.pose_on_drawing(&t.pose)))
            .collect();
        let (truth, estimate) = pair_by_stamp(&truth, &published);
        if let Some(s) = score_sketch_poses(&truth, &estimate, &drawing) {
            row.median_m = Some(s.median_m);
            row.p95_m = Some(s.p95_m);
            row.within_1m = Some(s.within_1m);
            row.heading_median_deg = Some(s.heading_median_deg);
        }
    }
    Ok(Some(row))
}

/// Changes one [`FitConfig`] field, `key=value`.
fn apply_set(config: &mut FitConfig, set: &str) -> Result<()> {
    let (key, value) = set
        .split_once('=')
        .with_context(|| format!("--set {set:?}: expected key=value"))?;
    let f = || -> Result<f64> {
        value
            .parse::<f64>()
            .with_context(|| format!("--set {key}: {value:?} is not a number"))
    };
    let n = || -> Result<usize> {
        value
            .parse::<usize>()
            .with_context(|| format!("--set {key}: {value:?} is not a count"))
    };
    match key {
        "spacing_m" => config.spacing_m = f()?,
        "line_sigma_m" => config.line_sigma_m = f()?,
        "proportion_error" => config.proportion_error = f()?,
        "scale_error" => config.scale_error = f()?,
        "rotation_error_deg" => config.rotation_error_rad = f()?.to_radians(),
        "translation_error_m" => config.translation_error_m = f()?,
        "start_gate_m" => config.start_gate_m = f()?,
        "gate_m" => config.gate_m = f()?,
        "direction_tolerance_deg" => config.direction_tolerance_rad = f()?.to_radians(),
        "similarity_iterations" => config.similarity_iterations = n()?,
        "warp_iterations" => config.warp_iterations = n()?,
        "levels" => config.levels = n()?,
        "search_sigmas" => config.search_sigmas = f()?,
        "search_starts" => config.search_starts = n()?,
        "proportion_change" => config.proportion_change = f()?,
        _ => bail!("--set {key:?}: not a fit setting"),
    }
    Ok(())
}
