//! `evaluate`: maps scenarios with every method and drawing, and scores the results.
//!
//! By default every run launches the real `slam-service` and `simulator` processes;
//! `--in-process` runs both inside this one.
//!
//! `evaluate SCENARIO_DIR... [--method odometry,icp,graph,sketch] [--sketch NAME] [--out DIR]
//! [--json FILE] [--in-process]`: every scenario × method × sketch is one run whose
//! artifacts go to `OUT/SCENARIO/RUN/`; the metrics are printed as a table and written as
//! JSON.
//!
//! A folder holding `dataset.toml` instead of `scenario.toml` is real data: its log is
//! replayed (with the odometry drift the replay adds), the runs are scored by the ATE
//! against the log's corrected poses and by the dataset's relations (no map error or
//! completeness: no true walls), and the published relation errors are printed beside.
//! Both modes work on datasets (`simulator replay` in the real-process mode).

use anyhow::{Context, Result, bail};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use sketchslam_engine::mapper::Method;
use sketchslam_simulator::dataset::{DATASET_FILE, Dataset};
use sketchslam_simulator::scenario::{Scenario, SketchConfig};
use sketchslam_tests::dataset_run::{run_dataset_in_process, run_dataset_real_process};
use sketchslam_tests::real_process::run_real_process;
use sketchslam_tests::relations::published_relation_errors;
use sketchslam_tests::run::{RunResult, run_in_process, run_name};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(about = "Map scenarios with sketchslam and score the maps against the truth")]
struct Args {
    /// Scenario folders (each with a scenario.toml) or dataset folders (dataset.toml).
    #[arg(required = true)]
    scenarios: Vec<PathBuf>,
    /// Methods to run, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "odometry,icp,graph,sketch"
    )]
    method: Vec<String>,
    /// Only this sketch (by name) for the sketch method; default: every sketch.
    #[arg(long)]
    sketch: Option<String>,
    /// Where the artifacts go.
    #[arg(long, default_value = "out/evaluate")]
    out: PathBuf,
    /// Also write the results as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Map only the first N scans of each scenario (a quick look).
    #[arg(long)]
    max_scans: Option<u64>,
    /// Run the simulator and the engine inside this process instead of launching
    /// `slam-service` and `simulator` and going through iceoryx2 and HTTP.
    #[arg(long)]
    in_process: bool,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let methods: Vec<Method> = args
        .method
        .iter()
        .map(|m| m.parse())
        .collect::<Result<_, _>>()?;
    let mut plan = Vec::new();
    let mut datasets = Vec::new();
    for dir in &args.scenarios {
        let target = if dir.join(DATASET_FILE).is_file() {
            let dataset =
                Dataset::load(dir).with_context(|| format!("loading {}", dir.display()))?;
            datasets.push(dataset.clone());
            Target::Dataset(dataset)
        } else {
            Target::Scenario(
                Scenario::load(dir).with_context(|| format!("loading {}", dir.display()))?,
            )
        };
        for &method in &methods {
            if method == Method::Sketch {
                let sketches: Vec<_> = target
                    .sketches()
                    .iter()
                    .filter(|s| args.sketch.as_ref().is_none_or(|n| *n == s.name))
                    .map(|s| Some(s.name.clone()))
                    .collect();
                if sketches.is_empty() {
                    eprintln!("{}: no sketch to run the sketch method with", target.name());
                }
                plan.extend(sketches.into_iter().map(|s| (target.clone(), method, s)));
            } else {
                plan.push((target.clone(), method, None));
            }
        }
    }
    for dataset in &datasets {
        // Say once per dataset that the odometry is synthetic drift on corrected poses.
        match sketchslam_simulator::replay::Replay::new(dataset) {
            Ok(replay) => eprintln!("note: {}", replay.drift_note()),
            Err(e) => bail!("{}: {e}", dataset.name),
        }
    }
    let mut results: Vec<RunResult> = Vec::new();
    for (i, (target, method, sketch)) in plan.iter().enumerate() {
        let name = run_name(*method, sketch.as_deref());
        let bar = ProgressBar::new(0).with_style(
            ProgressStyle::with_template(
                "{prefix} [{bar:30}] {pos}/{len} scans {per_sec} eta {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(format!(
            "[{}/{}] {}/{}",
            i + 1,
            plan.len(),
            target.name(),
            name
        ));
        let out_dir = args.out.join(target.name()).join(&name);
        let sketch_cfg = sketch
            .as_deref()
            .and_then(|n| target.sketches().iter().find(|s| s.name == n));
        let progress = |done, total| {
            bar.set_length(total);
            bar.set_position(done);
        };
        let scenario = match target {
            Target::Dataset(dataset) => {
                let result = if args.in_process {
                    run_dataset_in_process(
                        dataset,
                        *method,
                        sketch_cfg,
                        &out_dir,
                        args.max_scans,
                        progress,
                    )
                } else {
                    run_dataset_real_process(
                        dataset,
                        *method,
                        sketch_cfg,
                        &out_dir,
                        args.max_scans,
                        progress,
                    )
                };
                bar.finish_and_clear();
                match result {
                    Ok(r) => results.push(r),
                    Err(e) => eprintln!("{}/{}: failed: {e:#}", dataset.name, name),
                }
                continue;
            }
            Target::Scenario(scenario) => scenario,
        };
        let result = if args.in_process {
            run_in_process(
                scenario,
                *method,
                sketch_cfg,
                &out_dir,
                args.max_scans,
                progress,
            )
        } else {
            run_real_process(
                scenario,
                *method,
                sketch_cfg,
                &out_dir,
                args.max_scans,
                progress,
            )
        };
        bar.finish_and_clear();
        match result {
            Ok(r) => results.push(r),
            Err(e) => eprintln!("{}/{}: failed: {e:#}", scenario.name, name),
        }
    }
    print_table(&results);
    print_relations(&results);
    if let Some(path) = &args.json {
        let json = serde_json::json!({ "runs": results });
        std::fs::write(path, serde_json::to_string_pretty(&json)?)?;
        println!("JSON: {}", path.display());
    }
    if results.len() < plan.len() {
        bail!(
            "{} of {} runs failed",
            plan.len() - results.len(),
            plan.len()
        );
    }
    Ok(())
}

/// What a folder holds: a scenario to simulate or a dataset to replay.
#[derive(Clone)]
enum Target {
    Scenario(Scenario),
    Dataset(Dataset),
}

impl Target {
    fn name(&self) -> &str {
        match self {
            Target::Scenario(s) => &s.name,
            Target::Dataset(d) => &d.name,
        }
    }

    fn sketches(&self) -> &[SketchConfig] {
        match self {
            Target::Scenario(s) => &s.sketches,
            Target::Dataset(d) => &d.sketches,
        }
    }
}

/// A number, or "-" when there is none (NaN: no true walls on real data).
fn num(v: f64, width: usize, decimals: usize) -> String {
    if v.is_nan() {
        format!("{:>width$}", "-")
    } else {
        format!("{v:>width$.decimals$}")
    }
}

/// Relation errors of the dataset runs, with the published figures beside.
fn print_relations(results: &[RunResult]) {
    let runs: Vec<&RunResult> = results.iter().filter(|r| r.relations.is_some()).collect();
    if runs.is_empty() {
        return;
    }
    println!();
    println!(
        "{:<12} {:<9} {:<10} {:>17} {:>17} {:>9}",
        "dataset", "method", "sketch", "rel. trans m", "rel. rot deg", "relations"
    );
    let pm = |m: Option<f64>, sd: Option<f64>| match (m, sd) {
        (Some(m), Some(sd)) => format!("{m:.3} ± {sd:.3}"),
        _ => "-".to_string(),
    };
    for r in &runs {
        println!(
            "{:<12} {:<9} {:<10} {:>17} {:>17} {:>9}",
            r.scenario,
            r.method,
            r.sketch.as_deref().unwrap_or("-"),
            pm(r.rel_trans_m, r.rel_trans_sd_m),
            pm(r.rel_rot_deg, r.rel_rot_sd_deg),
            r.relations.unwrap_or(0)
        );
    }
    let mut names: Vec<&str> = runs.iter().map(|r| r.scenario.as_str()).collect();
    names.dedup();
    for name in names {
        if let Some(figures) = published_relation_errors(name) {
            println!("published ({name}, same relations): {figures}");
        }
    }
}

fn print_table(results: &[RunResult]) {
    println!(
        "{:<12} {:<9} {:<8} {:>7} {:>8} {:>9} {:>7} {:>6} {:>7} {:>7} {:>8} {:>8} {:>6} {:>5} {:>5} {:>8} {:>6}",
        "scenario",
        "method",
        "sketch",
        "ATE m",
        "live m",
        "map err m",
        "compl.",
        "scans",
        "wall s",
        "scans/s",
        "ms/scan",
        "p99 ms",
        "RTF",
        "rec.",
        "loops",
        "drw med",
        "drw≤1m"
    );
    let opt = |v: Option<f64>, prec: usize| v.map_or("-".to_string(), |v| format!("{v:.prec$}"));
    for r in results {
        println!(
            "{:<12} {:<9} {:<8} {} {:>8} {} {} {:>6} {:>7.1} {:>7.0} {:>8} {:>8} {:>6} {:>5} {:>5} {:>8} {:>6}",
            r.scenario,
            r.method,
            r.sketch.as_deref().unwrap_or("-"),
            num(r.ate_rmse_m, 7, 3),
            opt(r.online_ate_rmse_m, 3),
            num(r.map_error_m, 9, 3),
            num(r.completeness, 7, 3),
            r.scans,
            r.wall_s,
            r.scans_per_s,
            opt(r.scan_ms_mean, 2),
            opt(r.scan_ms_p99, 2),
            opt(r.realtime_factor, 1),
            r.recoveries,
            r.loop_closures,
            opt(r.sketch_pose_median_m, 2),
            opt(r.sketch_pose_within_1m.map(|w| 100.0 * w), 0)
        );
    }
    if let Some(r) = results.first() {
        let root = r
            .out_dir
            .parent()
            .and_then(|p| p.parent())
            .unwrap_or(&r.out_dir);
        println!(
            "maps (map.pgm + map.yaml) and overlays (overlay.png) under {}",
            root.display()
        );
    }
    if results
        .iter()
        .any(|r| r.sketch_pose_median_m.is_some() || r.online_ate_rmse_m.is_some())
    {
        println!(
            "live m: ATE of each scan's pose as first published (before later loop closures), \
             under the final trajectory's alignment; drw med: median error of the pose on the drawing, meters at the drawing's scale; \
             drw≤1m: % of scans within 1 m of it (truth carried onto the drawing by \
             sketch-truth.toml; through the processes, the session's trajectory on the drawing)"
        );
    }
}
