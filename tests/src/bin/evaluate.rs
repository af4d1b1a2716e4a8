//! `evaluate`: maps scenarios with every method and drawing, and scores the results.
//!
//! By default every run launches the real `slam-service` and `simulator` processes;
//! `--in-process` runs both inside this one.
//!
//! `evaluate SCENARIO_DIR... [--method odometry,icp,sketch] [--sketch NAME] [--out DIR]
//! [--json FILE] [--in-process]`: every scenario × method × sketch is one run whose
//! artifacts go to `OUT/SCENARIO/RUN/`; the metrics are printed as a table and written as
//! JSON.

use anyhow::{Context, Result, bail};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use sketchslam_simulator::scenario::Scenario;
use sketchslam_slam::mapper::Method;
use sketchslam_tests::real_process::run_real_process;
use sketchslam_tests::run::{RunResult, run_in_process, run_name};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(about = "Map scenarios with sketchslam and score the maps against the truth")]
struct Args {
    /// Scenario folders (each with a scenario.toml).
    #[arg(required = true)]
    scenarios: Vec<PathBuf>,
    /// Methods to run, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "odometry,icp,sketch")]
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
    for dir in &args.scenarios {
        let scenario = Scenario::load(dir).with_context(|| format!("loading {}", dir.display()))?;
        for &method in &methods {
            if method == Method::Sketch {
                let sketches: Vec<_> = scenario
                    .sketches
                    .iter()
                    .filter(|s| args.sketch.as_ref().is_none_or(|n| *n == s.name))
                    .map(|s| Some(s.name.clone()))
                    .collect();
                if sketches.is_empty() {
                    eprintln!("{}: no sketch to run the sketch method with", scenario.name);
                }
                plan.extend(sketches.into_iter().map(|s| (scenario.clone(), method, s)));
            } else {
                plan.push((scenario.clone(), method, None));
            }
        }
    }
    let mut results: Vec<RunResult> = Vec::new();
    for (i, (scenario, method, sketch)) in plan.iter().enumerate() {
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
            scenario.name,
            name
        ));
        let out_dir = args.out.join(&scenario.name).join(&name);
        let sketch_cfg = sketch.as_deref().and_then(|n| scenario.sketch(n));
        let progress = |done, total| {
            bar.set_length(total);
            bar.set_position(done);
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

fn print_table(results: &[RunResult]) {
    println!(
        "{:<12} {:<9} {:<10} {:>9} {:>11} {:>8} {:>6} {:>8} {:>8} {:>5}",
        "scenario",
        "method",
        "sketch",
        "ATE m",
        "map err m",
        "compl.",
        "scans",
        "wall s",
        "scans/s",
        "rec."
    );
    for r in results {
        println!(
            "{:<12} {:<9} {:<10} {:>9.3} {:>11.3} {:>8.3} {:>6} {:>8.1} {:>8.0} {:>5}",
            r.scenario,
            r.method,
            r.sketch.as_deref().unwrap_or("-"),
            r.ate_rmse_m,
            r.map_error_m,
            r.completeness,
            r.scans,
            r.wall_s,
            r.scans_per_s,
            r.recoveries
        );
    }
    if let Some(r) = results.first() {
        println!(
            "artifacts under {}",
            r.out_dir
                .parent()
                .and_then(|p| p.parent())
                .unwrap_or(&r.out_dir)
                .display()
        );
    }
}
