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
use sketchslam_engine::registration::{
    ControlGrid, FitConfig, Similarity, Warp, WarpProblem, fit_warp_from, render_map_on_drawing,
};
use sketchslam_engine::sketch::SketchPose;
use sketchslam_simulator::dataset::Dataset;
use sketchslam_simulator::scenario::Scenario;
use sketchslam_simulator::world::World;
use sketchslam_tests::line_offset::{line_offsets, wall_faces};
use sketchslam_tests::metrics::StampedPose;
use sketchslam_tests::run::read_trajectory_csv;
use sketchslam_tests::run::sketch_prior;
use sketchslam_tests::sketch_truth::{
    DrawingTruth, SketchPoseScore, pair_by_stamp, score_sketch_poses,
};
use sketchslam_tests::warp_problem_file::{WARP_PROBLEM_FILE, WarpProblemFile};
use sketchslam_types::{Point2, Pose2};
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
    /// Also fit from the truth (a warp through the run's poses carried onto the drawing by
    /// `sketch-truth.toml`, on the finest grid) and print `E` there, after refitting from
    /// it, and at the fit found: whether a miss is the search's or the model's.
    #[arg(long)]
    truth_start: bool,
}

/// `--truth-start`'s figures.
#[derive(Debug, Clone, Copy, serde::Serialize)]
struct TruthCheck {
    energy_found: f64,
    energy_truth: f64,
    energy_refit: f64,
    /// Steps of the route the refit from the truth carries through a drawn wall.
    crossed_refit: usize,
    refit_median_m: f64,
    truth_median_m: f64,
}

/// One drawing's figures.
#[derive(Debug, Clone, serde::Serialize)]
struct Row {
    run: String,
    median_m: Option<f64>,
    p95_m: Option<f64>,
    within_1m: Option<f64>,
    heading_median_deg: Option<f64>,
    /// Median offset of the drawing's lines from the truth's walls near the route
    /// ([`sketchslam_tests::line_offset`]): the floor under `median_m`.
    line_offset_median_m: Option<f64>,
    /// With `--truth-start`: `E` at the fit found, at the truth, refitted from the truth,
    /// and the refit's median error.
    truth: Option<TruthCheck>,
    /// Share of the final trajectory where mapped walls hold W.
    held: f64,
    inliers: usize,
    rms_px: f64,
    /// Steps of the route W carries through a drawn wall.
    crossed: usize,
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
                    match score(path, config, args.render, args.truth_start) {
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
        "{:<48} {:>7} {:>7} {:>6} {:>6} {:>7} {:>6} {:>7} {:>6} {:>5} {:>6}",
        "run",
        "med m",
        "p95 m",
        "≤1m %",
        "hdg °",
        "lines m",
        "held %",
        "inliers",
        "rms px",
        "cross",
        "fit s"
    );
    let opt = |v: Option<f64>, prec: usize| v.map_or("-".to_string(), |v| format!("{v:.prec$}"));
    for r in &rows {
        println!(
            "{:<48} {:>7} {:>7} {:>6} {:>6} {:>7} {:>6.0} {:>7} {:>6.2} {:>5} {:>6.2}",
            r.run,
            opt(r.median_m, 2),
            opt(r.p95_m, 2),
            opt(r.within_1m.map(|w| 100.0 * w), 0),
            opt(r.heading_median_deg, 1),
            opt(r.line_offset_median_m, 2),
            100.0 * r.held,
            r.inliers,
            r.rms_px,
            r.crossed,
            r.fit_s
        );
        if let Some(t) = &r.truth {
            println!(
                "    E found {:.0}, at the truth {:.0}, refitted from it {:.0} (median {:.2} m, {} steps through walls; the truth warp itself {:.2} m)",
                t.energy_found,
                t.energy_truth,
                t.energy_refit,
                t.refit_median_m,
                t.crossed_refit,
                t.truth_median_m
            );
        }
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
fn score(path: &Path, config: FitConfig, render: bool, truth_start: bool) -> Result<Option<Row>> {
    let run_dir = path.parent().context("a file has a folder")?;
    let file = WarpProblemFile::read(path)?;
    let problem = file.problem(config);
    let started = Instant::now();
    let Some(registration) = problem.solve() else {
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
        render_map_on_drawing(&prior.sketch, warp, &problem.walls, &route)
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
        line_offset_median_m: None,
        truth: None,
        held,
        inliers: registration.fit.inliers,
        rms_px: registration.fit.rms_px,
        crossed: registration.fit.walls_crossed,
        fit_s,
    };
    // Scored where the scenario says how the drawing was made (real logs' drawings: not).
    if let Some(drawing) = DrawingTruth::load(&file.scenario_dir, &file.sketch)? {
        let truth: Vec<StampedPose> = read_trajectory_csv(&run_dir.join("truth.csv"))?;
        if let Some(s) = score_through(warp, &trajectory, &truth, &drawing) {
            row.median_m = Some(s.median_m);
            row.p95_m = Some(s.p95_m);
            row.within_1m = Some(s.within_1m);
            row.heading_median_deg = Some(s.heading_median_deg);
        }
        row.line_offset_median_m = line_offset_median(&file, &problem, &truth, &drawing, config)?;
        if truth_start {
            row.truth = truth_check(&problem, config, warp, &trajectory, &truth, &drawing);
        }
    }
    Ok(Some(row))
}

/// The median offset of the drawing's lines from the truth's walls near the route
/// ([`line_offsets`]), at truth poses 1 m of route apart, within 1.5 finest cells of W
/// (what W's finest grid can follow) and W's last gate; `None` for a world without an image
/// (a real log's) or a route that sees no drawn wall.
fn line_offset_median(
    file: &WarpProblemFile,
    problem: &WarpProblem,
    truth: &[StampedPose],
    drawing: &DrawingTruth,
    config: FitConfig,
) -> Result<Option<f64>> {
    let Ok(scenario) = Scenario::load(&file.scenario_dir) else {
        return Ok(None);
    };
    let world = World::load(&scenario.world.image, scenario.world.resolution_m)?;
    let mut route: Vec<Pose2> = Vec::new();
    for t in truth {
        if route
            .last()
            .is_none_or(|last| last.position().distance(&t.pose.position()) >= 1.0)
        {
            route.push(t.pose);
        }
    }
    let mut offsets = line_offsets(
        &wall_faces(&world),
        drawing,
        &problem.lines,
        &route,
        1.5 * config.spacing_m,
        config.gate_m,
    );
    offsets.sort_by(f64::total_cmp);
    Ok(offsets.get(offsets.len() / 2).copied())
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
        "finished_starts" => config.finished_starts = n()?,
        "proportion_change" => config.proportion_change = f()?,
        "wall_spacing_m" => config.wall_spacing_m = f()?,
        _ => bail!("--set {key:?}: not a fit setting"),
    }
    Ok(())
}

/// The run's `trajectory` (map poses) carried onto the drawing through `warp`, scored against
/// `truth` carried there by `drawing`; `None` without a pose of the same stamp.
fn score_through(
    warp: &Warp,
    trajectory: &[StampedPose],
    truth: &[StampedPose],
    drawing: &DrawingTruth,
) -> Option<SketchPoseScore> {
    let published: Vec<_> = trajectory
        .iter()
        .map(|t| (t.t_s, warp.pose_on_drawing(&t.pose)))
        .collect();
    let (truth, estimate) = pair_by_stamp(truth, &published);
    score_sketch_poses(&truth, &estimate, drawing)
}

/// `--truth-start`: `E` at the fit found, at a warp through the truth, and refitted from it.
fn truth_check(
    problem: &WarpProblem,
    config: FitConfig,
    found: &Warp,
    trajectory: &[StampedPose],
    truth: &[StampedPose],
    drawing: &DrawingTruth,
) -> Option<TruthCheck> {
    // Each trajectory pose with its true place on the drawing (drawing frame: u, −v).
    let carried: Vec<(f64, SketchPose)> = truth
        .iter()
        .map(|t| (t.t_s, drawing.world_to_drawing(&t.pose)))
        .collect();
    let (map_poses, on_drawing) = pair_by_stamp(trajectory, &carried);
    let pairs: Vec<(Point2, Point2)> = map_poses
        .iter()
        .zip(&on_drawing)
        .map(|(m, d)| (m.pose.position(), Point2::new(d.u_px, -d.v_px)))
        .collect();
    let finite = problem
        .walls
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite());
    let (lo, hi) = finite.fold(
        (
            Point2::new(f64::MAX, f64::MAX),
            Point2::new(f64::MIN, f64::MIN),
        ),
        |(lo, hi), p| {
            (
                Point2::new(lo.x.min(p.x), lo.y.min(p.y)),
                Point2::new(hi.x.max(p.x), hi.y.max(p.y)),
            )
        },
    );
    let grid = ControlGrid::covering(lo, hi, config.spacing_m);
    let start = warp_through(&pairs, grid, problem.prior.scale_px_per_m())?;
    let fine = FitConfig {
        levels: 1,
        ..config
    };
    let still = FitConfig {
        similarity_iterations: 0,
        warp_iterations: 0,
        ..fine
    };
    let route = problem.route();
    let energy_at = |w: &Warp| {
        fit_warp_from(
            &problem.walls,
            &route,
            &problem.lines,
            problem.prior,
            &still,
            w.clone(),
        )
        .map(|f| f.1)
    };
    let median = |w: &Warp| score_through(w, trajectory, truth, drawing).map(|s| s.median_m);
    let (refit, energy_refit) = fit_warp_from(
        &problem.walls,
        &route,
        &problem.lines,
        problem.prior,
        &fine,
        start.clone(),
    )?;
    Some(TruthCheck {
        energy_found: energy_at(found)?,
        energy_truth: energy_at(&start)?,
        energy_refit,
        crossed_refit: refit.walls_crossed,
        refit_median_m: median(&refit.warp)?,
        truth_median_m: median(&start)?,
    })
}

/// The warp on `grid` through `pairs` (map meters → drawing frame pixels) by least squares: a
/// similarity, then the offsets of the residuals, smoothed between neighbouring nodes
/// (`scale_px_per_m` sets the smoothing's units) so nodes far from the pairs follow theirs.
fn warp_through(
    pairs: &[(Point2, Point2)],
    grid: ControlGrid,
    scale_px_per_m: f64,
) -> Option<Warp> {
    use nalgebra::{DMatrix, DVector, Matrix4, Vector4};
    if pairs.len() < 3 {
        return None;
    }
    let (mut h, mut g) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
    for (p, q) in pairs {
        for (row, y) in [
            (Vector4::new(p.x, -p.y, 1.0, 0.0), q.x),
            (Vector4::new(p.y, p.x, 0.0, 1.0), q.y),
        ] {
            h += row * row.transpose();
            g += row * y;
        }
    }
    let x = h.cholesky()?.solve(&g);
    let similarity = Similarity {
        a: x[0],
        b: x[1],
        t: Point2::new(x[2], x[3]),
    };
    let n = grid.len();
    let mut m = DMatrix::<f64>::zeros(n, n);
    let (mut bx, mut by) = (DVector::<f64>::zeros(n), DVector::<f64>::zeros(n));
    for (p, q) in pairs {
        let s = similarity.apply(*p);
        let w = grid.weights(*p);
        for &(k, wk) in &w {
            bx[k] += wk * (q.x - s.x);
            by[k] += wk * (q.y - s.y);
            for &(l, wl) in &w {
                m[(k, l)] += wk * wl;
            }
        }
    }
    // A membrane between neighbours, weak against the pairs (a pose a meter apart counts more).
    let lambda = 1.0;
    let ridge = 1e-6 * scale_px_per_m.max(1e-9).recip();
    for k in 0..n {
        let (i, j) = (k % grid.columns, k / grid.columns);
        let mut neighbours = Vec::new();
        if i + 1 < grid.columns {
            neighbours.push(k + 1);
        }
        if j + 1 < grid.rows {
            neighbours.push(k + grid.columns);
        }
        for l in neighbours {
            m[(k, k)] += lambda;
            m[(l, l)] += lambda;
            m[(k, l)] -= lambda;
            m[(l, k)] -= lambda;
        }
        m[(k, k)] += ridge;
    }
    let chol = m.cholesky()?;
    let (ox, oy) = (chol.solve(&bx), chol.solve(&by));
    let mut warp = Warp::rigid(similarity, grid);
    for (k, o) in warp.offsets.iter_mut().enumerate() {
        *o = Point2::new(ox[k], oy[k]);
    }
    Some(warp)
}
