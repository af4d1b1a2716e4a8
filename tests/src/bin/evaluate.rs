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
//!
//! `evaluate --generated K [--seed S] [--kind office,corridor,hall] [--lidar good,cheap]
//! [--method graph,graph-open,...] [--jobs N]`: K worlds from the simulator's generator
//! (world i has seed S + i, kinds and LiDARs cycled), mapped in-process on N threads; besides
//! the table, each score's median, 90th percentile and worst per method, the worlds where
//! closing loops made the map worse than leaving them open (with `graph-open` in the
//! methods), and the worst worlds' folders kept for a look.
//!
//! `--keep-live-warps` (in-process): each `sketch` run keeps the problem of every live fit of
//! the warp in `RUN/live-warps/scan-N/`, for `bench-warp`.
//!
//! `--frame-turn-deg D` (in-process): the map frame of the methods without a drawing turned
//! `D` degrees from the robot's start heading, to see how much a result owes to the map's
//! axes lying along the walls.
//!
//! `--repeat N` (in-process): every run N times, sample `k` with the frame turned a further
//! 0, +1, −1, +2, … degrees (methods without a drawing) and the engine seeded with its seed +
//! `k`; besides the table of every sample, each run's median, best and worst
//! ([`sketchslam_tests::samples`]): one run is one draw, and the medians are what compare.

use anyhow::{Context, Result, bail};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use sketchslam_engine::back_end::loop_closure::{ChainShape, LoopHeadingSigma};
use sketchslam_engine::back_end::pose_graph::Preconditioning;
use sketchslam_engine::localization::observation_model::ObservationModel;
use sketchslam_engine::mapper::{KeyframeStepModel, Method, SketchHeadingView};
use sketchslam_simulator::dataset::{DATASET_FILE, Dataset};
use sketchslam_simulator::generate::{Kind, LidarGrade, generate};
use sketchslam_simulator::scenario::{Scenario, SketchConfig};
use sketchslam_tests::dataset_run::{
    dataset_relations, run_dataset_in_process, run_dataset_real_process,
};
use sketchslam_tests::generated::{
    loops_that_hurt, plan_worlds, summarize, summary_table, worst_worlds,
};
use sketchslam_tests::real_process::run_real_process;
use sketchslam_tests::relations::published_relation_errors;
use sketchslam_tests::replay_floor::{ReplayFloors, replay_floors};
use sketchslam_tests::run::{RunResult, run_in_process, run_name};
use sketchslam_tests::run_method::RunMethod;
use sketchslam_tests::samples::{samples_table, summarize_samples};
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

#[derive(Parser, Debug)]
#[command(about = "Map scenarios with sketchslam and score the maps against the truth")]
struct Args {
    /// Scenario folders (each with a scenario.toml) or dataset folders (dataset.toml).
    #[arg(required_unless_present = "generated")]
    scenarios: Vec<PathBuf>,
    /// Methods to run, comma-separated (`graph-open`: `graph` without loop closure,
    /// in-process only).
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
    /// Generate this many worlds (`simulator generate`) into `OUT/worlds/` and map them
    /// too (in-process); prints each score's distribution per method.
    #[arg(long)]
    generated: Option<usize>,
    /// Seed of the first generated world (world i has seed + i).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Kinds of generated worlds, comma-separated, cycled through.
    #[arg(long, value_delimiter = ',', default_value = "office,corridor,hall")]
    kind: Vec<String>,
    /// LiDAR grades of generated worlds, comma-separated, cycled through after the kinds.
    #[arg(long, value_delimiter = ',', default_value = "good,cheap")]
    lidar: Vec<String>,
    /// Runs at once (in-process runs only); default: the machine's cores.
    #[arg(long)]
    jobs: Option<usize>,
    /// Generated worlds: keep the run artifacts of this many worst worlds per method
    /// (by map error) and remove the others' (the worlds' folders stay).
    #[arg(long, default_value_t = 3)]
    keep_worst: usize,
    /// Turn the map frame of the methods without a drawing by this many degrees from the
    /// robot's start heading (in-process only): how much a result owes to the frame's
    /// angle to the walls. The scores are taken after alignment, so they compare.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    frame_turn_deg: f64,
    /// `sketch` runs (in-process only): keep every live fit of the warp, the map of its
    /// moment with its trajectory and truth, in the run's `live-warps/scan-N/` folders, for
    /// `bench-warp` to fit the partial maps again.
    #[arg(long)]
    keep_live_warps: bool,
    /// `sketch` runs (in-process only): MCL's observation model on the drawing,
    /// `ray_cast` (the paper's eq. 3, the default) or `likelihood_field`.
    #[arg(long, value_parser = parse_observation)]
    mcl_observation: Option<ObservationModel>,
    /// `sketch` runs (in-process): do not replay the service's warp worker (no `live drw`
    /// columns): a fit every 10 keyframes is most of a generated world's run time, and a
    /// sweep of MCL or of the map does not need it.
    #[arg(long)]
    no_live_warp: bool,
    /// `sketch` runs: where eq. (5) reads the drawn walls in view, `mcl` (the paper) or
    /// `warp` (the warp onto the drawing where the map holds it; in-process it needs the
    /// live warp). Real-process runs ask the session for it (`drawing_localization`).
    #[arg(long, value_parser = parse_heading_view)]
    sketch_heading_view: Option<SketchHeadingView>,
    /// `sketch` runs (in-process only): eq. (5)'s heading gain, 0..1 (0: the drawing does
    /// not touch the map; the default 0.05 otherwise), to measure what the pull adds.
    #[arg(long)]
    sketch_heading_gain: Option<f64>,
    /// `sketch` runs (in-process only): tie each keyframe's heading to the drawing's
    /// dominant wall directions with this standard deviation, degrees (the loop closer's
    /// `heading_prior_sigma_rad`, 2° by default); 0 leaves the priors out, to measure what
    /// they add.
    #[arg(long)]
    wall_heading_prior_deg: Option<f64>,
    /// `sketch` runs (in-process only): the start heading from the first scan's walls
    /// (`walls`) or as marked on the drawing (`mark`, the default).
    #[arg(long, value_parser = parse_sketch_start)]
    sketch_start: Option<bool>,
    /// In-process runs: the engine's seed (MCL, RANSAC) instead of the scenario's, to see
    /// how much a result owes to the draws.
    #[arg(long)]
    engine_seed: Option<u64>,
    /// In-process runs of the methods that close loops: how the pose graph's solves are
    /// preconditioned, `block_jacobi` (each node's block alone, the default) or `chain`
    /// (the odometry chain factored exactly: each Gauss–Newton step solved to the end).
    #[arg(long, value_parser = parse_preconditioning)]
    preconditioning: Option<Preconditioning>,
    /// In-process runs of `graph` and `sketch`: the keyframe ICP holds the odometry's
    /// prediction along a translation direction faced by fewer returns than this (a
    /// corridor's axis; the engine's `icp_min_constraining_points`, off by default); 0:
    /// never.
    #[arg(long)]
    icp_hold_min_points: Option<f64>,
    /// With `--icp-hold-min-points`: hold only where ICP slid farther than this many
    /// sigmas of the odometry's error over the step (the engine's `icp_hold_beyond_sigmas`).
    #[arg(long, requires = "icp_hold_min_points")]
    icp_hold_beyond_sigmas: Option<f64>,
    /// With `--icp-hold-beyond-sigmas`: judge the slide over the stretch since the last
    /// scan ICP placed in every direction, against the odometry dead-reckoned since then
    /// (the engine's `icp_hold_over_stretch`).
    #[arg(long, requires = "icp_hold_beyond_sigmas")]
    icp_hold_over_stretch: bool,
    /// In-process runs of `graph` and `sketch`: how the front end's covariances of the
    /// scans between two keyframes make the step's, which weighs the sequential edge and
    /// the loop gate's chain: `summed` (every scan's, the default), `anchored` (the
    /// keyframe's own match plus the odometry's share of every scan) or `measured_heading`
    /// (positions anchored, the headings ICP measured summed; the engine's
    /// `keyframe_step`).
    #[arg(long, value_parser = parse_keyframe_step)]
    keyframe_step: Option<KeyframeStepModel>,
    /// In-process runs of the methods that close loops: a loop gives up each position
    /// direction, and its heading, where it is looser than this many times the chain
    /// between its ends (the engine's `give_up_beyond_chain`); 0: never.
    #[arg(long)]
    give_up_beyond_chain: Option<f64>,
    /// In-process runs of the methods that close loops: a loop edge's heading deviation
    /// `set` (the engine's `loop_sigma_rad`, the default), read from the match's heading
    /// `plateau`, or the tighter of both, `plateau-within-set` (the engine's
    /// `loop_heading`).
    #[arg(long, value_parser = parse_loop_heading)]
    loop_heading: Option<LoopHeadingSigma>,
    /// In-process runs of the methods that close loops: the chain's uncertainty in the
    /// test of a loop against it, `isotropic` (the default) or `full` (each step's whole
    /// covariance carried to the loop's end; the engine's `chain_shape`).
    #[arg(long, value_parser = parse_chain_shape)]
    chain_shape: Option<ChainShape>,
    /// Tell the mapper each simulated world's own wheel error model (its scenario's
    /// `[odometry]`, as the session request's `odometry_noise`) instead of the service's
    /// default, as a user who knows their robot would; datasets keep the default.
    #[arg(long)]
    own_wheels: bool,
    /// In-process runs: map every run this many times, sample k with the frame of the
    /// methods without a drawing turned a further 0, +1, −1, +2, … degrees and the engine's
    /// seed + k, and print each run's median, best and worst over its samples.
    #[arg(long, default_value_t = 1)]
    repeat: usize,
}

fn parse_loop_heading(s: &str) -> Result<LoopHeadingSigma, String> {
    by_wire_name(s, "set, plateau or plateau-within-set")
}

fn parse_chain_shape(s: &str) -> Result<ChainShape, String> {
    by_wire_name(s, "isotropic or full")
}

fn parse_sketch_start(s: &str) -> Result<bool, String> {
    match s {
        "walls" => Ok(true),
        "mark" => Ok(false),
        _ => Err(format!("{s:?}: walls or mark")),
    }
}

fn parse_heading_view(s: &str) -> Result<SketchHeadingView, String> {
    by_wire_name(s, "mcl or warp")
}

fn parse_preconditioning(s: &str) -> Result<Preconditioning, String> {
    by_wire_name(s, "chain or block_jacobi")
}

fn parse_keyframe_step(s: &str) -> Result<KeyframeStepModel, String> {
    by_wire_name(s, "summed, anchored or measured_heading")
}

fn parse_observation(s: &str) -> Result<ObservationModel, String> {
    by_wire_name(s, "likelihood_field or ray_cast")
}

/// The value of a serde enum whose wire name is `s`; the error names the `expected` ones.
fn by_wire_name<T: serde::de::DeserializeOwned>(s: &str, expected: &str) -> Result<T, String> {
    serde_json::from_value(serde_json::Value::String(s.to_string()))
        .map_err(|_| format!("{s:?}: {expected}"))
}

/// One run of the plan.
type PlannedRun = (Target, RunMethod, Option<String>);

/// What a flag's value must be (said in its error) and the test of it.
type Valid<T> = (&'static str, fn(&T) -> bool);

/// Any value of the flag's type.
fn any<T>() -> Valid<T> {
    ("", |_| true)
}

/// The methods of the run, for flags that only in-process runs can honour (they reach the
/// engine's configuration, which a service's session request does not carry).
struct InProcessFlags<'a> {
    in_process: bool,
    methods: &'a mut Vec<RunMethod>,
}

impl InProcessFlags<'_> {
    /// Applies `flag`'s `value`, when given, to every method with `set`; an error naming the
    /// flag when the run is not in-process or the value fails `valid`.
    fn apply<T>(
        &mut self,
        flag: &str,
        value: Option<T>,
        valid: Valid<T>,
        set: impl Fn(&mut RunMethod, &T),
    ) -> Result<()> {
        let Some(value) = value else {
            return Ok(());
        };
        let (what, test) = valid;
        if !(self.in_process && test(&value)) {
            let sep = if what.is_empty() { "" } else { ", " };
            bail!("{flag}: {what}{sep}in-process only (add --in-process)");
        }
        for m in self.methods.iter_mut() {
            set(m, &value);
        }
        Ok(())
    }
}

fn main() -> Result<()> {
    let args = Args::parse();
    let mut methods: Vec<RunMethod> = args
        .method
        .iter()
        .map(|m| m.parse().map_err(anyhow::Error::msg))
        .collect::<Result<_>>()?;
    let in_process = args.in_process || args.generated.is_some();
    if args.no_live_warp {
        if args.keep_live_warps {
            bail!("--no-live-warp and --keep-live-warps: choose one");
        }
        for m in &mut methods {
            m.live_warp = false;
        }
    }
    if let Some(view) = args.sketch_heading_view {
        if view == SketchHeadingView::Warp && args.no_live_warp {
            bail!("--sketch-heading-view warp reads the live warp: drop --no-live-warp");
        }
        for m in &mut methods {
            m.sketch_heading_view = view;
        }
    }
    let mut only = InProcessFlags {
        in_process,
        methods: &mut methods,
    };
    only.apply(
        "--frame-turn-deg",
        (args.frame_turn_deg != 0.0).then_some(args.frame_turn_deg),
        ("a finite angle", |d| d.is_finite()),
        |m, &d| m.frame_turn_rad = d.to_radians(),
    )?;
    only.apply(
        "--keep-live-warps",
        args.keep_live_warps.then_some(()),
        any(),
        |m, _| m.keep_live_warps = true,
    )?;
    only.apply("--mcl-observation", args.mcl_observation, any(), |m, &o| {
        m.mcl_observation = o
    })?;
    only.apply(
        "--sketch-heading-gain",
        args.sketch_heading_gain,
        ("0..1", |g| (0.0..=1.0).contains(g)),
        |m, &g| m.sketch_heading_gain = Some(g),
    )?;
    only.apply(
        "--wall-heading-prior-deg",
        args.wall_heading_prior_deg,
        ("0 (none) or above", |d| *d >= 0.0 && d.is_finite()),
        |m, &d| m.wall_heading_prior_rad = Some(d.to_radians()),
    )?;
    only.apply("--sketch-start", args.sketch_start, any(), |m, &w| {
        m.sketch_start_from_walls = Some(w)
    })?;
    only.apply("--engine-seed", args.engine_seed, any(), |m, &seed| {
        m.engine_seed = Some(seed)
    })?;
    only.apply("--preconditioning", args.preconditioning, any(), |m, &p| {
        m.preconditioning = Some(p)
    })?;
    only.apply("--keyframe-step", args.keyframe_step, any(), |m, &k| {
        m.keyframe_step = Some(k)
    })?;
    only.apply(
        "--give-up-beyond-chain",
        args.give_up_beyond_chain,
        ("0 (never) or above", |r| *r >= 0.0 && r.is_finite()),
        |m, &r| m.give_up_beyond_chain = Some(r),
    )?;
    only.apply("--loop-heading", args.loop_heading, any(), |m, &h| {
        m.loop_heading = Some(h)
    })?;
    only.apply("--chain-shape", args.chain_shape, any(), |m, &c| {
        m.chain_shape = Some(c)
    })?;

    only.apply(
        "--icp-hold-min-points",
        args.icp_hold_min_points,
        ("a count of returns, 0 or more", |p| *p >= 0.0),
        |m, &points| {
            m.icp_hold_min_points = Some(points);
            m.icp_hold_beyond_sigmas = args.icp_hold_beyond_sigmas;
            m.icp_hold_over_stretch = args.icp_hold_over_stretch;
        },
    )?;
    for m in methods.iter_mut() {
        m.own_wheels = args.own_wheels;
    }
    if args.repeat == 0 || (args.repeat > 1 && !in_process) {
        bail!("--repeat: 1 or more samples, in-process only (add --in-process)");
    }
    if let Some(open) = methods.iter().find(|m| !m.loop_closure && !in_process) {
        bail!("{open}: loops can only be left open in-process (add --in-process)");
    }
    let mut targets = Vec::new();
    let mut datasets = Vec::new();
    for dir in &args.scenarios {
        if dir.join(DATASET_FILE).is_file() {
            let dataset =
                Dataset::load(dir).with_context(|| format!("loading {}", dir.display()))?;
            datasets.push(dataset.clone());
            targets.push(Target::Dataset(dataset));
        } else {
            targets.push(Target::Scenario(
                Scenario::load(dir).with_context(|| format!("loading {}", dir.display()))?,
            ));
        }
    }
    let mut generated_names = Vec::new();
    if let Some(count) = args.generated {
        for world in generate_worlds(&args, count)? {
            generated_names.push(world.name.clone());
            targets.push(Target::Scenario(world));
        }
    }
    let samples: Vec<RunMethod> = methods
        .iter()
        .flat_map(|&m| (0..args.repeat).map(move |sample| RunMethod { sample, ..m }))
        .collect();
    let mut plan: Vec<PlannedRun> = Vec::new();
    for target in &targets {
        for &method in &samples {
            if method.method == Method::Sketch {
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
    // Per dataset, once: say that the odometry is synthetic drift on corrected poses, and
    // score the replay's own reference on the relations (the floor printed beside them).
    let mut floors = Vec::new();
    for dataset in &datasets {
        let replay = match sketchslam_simulator::replay::Replay::new(dataset) {
            Ok(replay) => replay,
            Err(e) => bail!("{}: {e}", dataset.name),
        };
        eprintln!("note: {}", replay.drift_note());
        let relations = dataset_relations(dataset)?;
        if let Some(floor) = replay_floors(dataset, replay, &relations) {
            floors.push((dataset.name.clone(), floor));
        }
    }
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let results = if in_process && jobs > 1 && plan.len() > 1 {
        run_parallel(&args, &plan, jobs)
    } else {
        run_sequential(&args, &plan, in_process)
    };
    print_table(&results);
    print_relations(&results, &floors);
    let sampled = summarize_samples(&results);
    if args.repeat > 1 {
        println!();
        print!("{}", samples_table(&sampled));
    }
    let generated: Vec<RunResult> = results
        .iter()
        .filter(|r| generated_names.contains(&r.scenario))
        .cloned()
        .collect();
    let summaries = summarize(&generated);
    if !generated.is_empty() {
        println!();
        println!(
            "generated worlds: {} (seeds {}..{}, kinds {}, lidar {})",
            generated_names.len(),
            args.seed,
            args.seed + generated_names.len() as u64,
            args.kind.join(","),
            args.lidar.join(",")
        );
        print!("{}", summary_table(&summaries));
        for method in methods.iter().filter(|m| m.loop_closure) {
            let name = method.to_string();
            if methods
                .iter()
                .any(|m| m.to_string() == format!("{name}-open"))
            {
                let hurt = loops_that_hurt(&generated, &name, 0.005);
                println!(
                    "{name}: closing loops made the map worse (by > 5 mm) on {} of {} worlds{}",
                    hurt.len(),
                    generated_names.len(),
                    hurt.iter()
                        .map(|(w, c, o)| format!("\n  {w}: {c:.3} m closed vs {o:.3} m open"))
                        .collect::<String>()
                );
            }
        }
        keep_worst_artifacts(&args, &generated, &methods);
    }
    if let Some(path) = &args.json {
        let json =
            serde_json::json!({ "runs": results, "generated": summaries, "samples": sampled });
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

/// Generates `count` worlds of `args`' plan into `OUT/worlds/` and loads them.
fn generate_worlds(args: &Args, count: usize) -> Result<Vec<Scenario>> {
    let kinds: Vec<Kind> = args
        .kind
        .iter()
        .map(|k| k.parse())
        .collect::<Result<_, _>>()?;
    let lidars: Vec<LidarGrade> = args
        .lidar
        .iter()
        .map(|l| l.parse())
        .collect::<Result<_, _>>()?;
    let mut worlds = Vec::new();
    for options in plan_worlds(count, args.seed, &kinds, &lidars) {
        let kind = options.kind.resolve(options.seed);
        let dir = args
            .out
            .join("worlds")
            .join(format!("gen-{kind}-{}-{}", options.lidar, options.seed));
        let world = generate(&options, &dir)
            .with_context(|| format!("generating world {options:?} into {}", dir.display()))?;
        let mut scenario = Scenario::load(&world.dir)?;
        // One name per world (the same seed can be generated with both LiDARs).
        scenario.name = dir
            .file_name()
            .map_or(world.name.clone(), |n| n.to_string_lossy().into_owned());
        eprintln!(
            "generated {} ({} m of route)",
            scenario.name,
            world.route.length_m.round()
        );
        worlds.push(scenario);
    }
    Ok(worlds)
}

/// One run of the plan: in this process or through the real processes.
fn run_one(
    args: &Args,
    (target, method, sketch): &PlannedRun,
    in_process: bool,
    progress: impl FnMut(u64, u64),
) -> Result<RunResult> {
    let name = run_name(method, sketch.as_deref());
    let mut out_dir = args.out.join(target.name()).join(&name);
    let sample = (args.repeat > 1).then_some(method.sample);
    if let Some(k) = sample {
        out_dir = out_dir.join(format!("sample-{k}"));
    }
    let sketch_cfg = sketch
        .as_deref()
        .and_then(|n| target.sketches().iter().find(|s| s.name == n));
    let result = match (target, in_process) {
        (Target::Dataset(dataset), true) => run_dataset_in_process(
            dataset,
            *method,
            sketch_cfg,
            &out_dir,
            args.max_scans,
            progress,
        ),
        (Target::Dataset(dataset), false) => run_dataset_real_process(
            dataset,
            method.method,
            sketch_cfg,
            &out_dir,
            args.max_scans,
            progress,
        ),
        (Target::Scenario(scenario), true) => run_in_process(
            scenario,
            *method,
            sketch_cfg,
            &out_dir,
            args.max_scans,
            progress,
        ),
        (Target::Scenario(scenario), false) => run_real_process(
            scenario,
            *method,
            sketch_cfg,
            &out_dir,
            args.max_scans,
            progress,
        ),
    };
    result.map(|r| RunResult { sample, ..r })
}

/// The plan one run after the other, with a progress bar each.
fn run_sequential(args: &Args, plan: &[PlannedRun], in_process: bool) -> Vec<RunResult> {
    let mut results = Vec::new();
    for (i, run) in plan.iter().enumerate() {
        let name = run_name(run.1, run.2.as_deref());
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
            run.0.name(),
            name
        ));
        let progress = |done, total| {
            bar.set_length(total);
            bar.set_position(done);
        };
        let result = run_one(args, run, in_process, progress);
        bar.finish_and_clear();
        match result {
            Ok(r) => results.push(r),
            Err(e) => eprintln!("{}/{}: failed: {e:#}", run.0.name(), name),
        }
    }
    results
}

/// The plan on `jobs` threads (in-process runs), a line on stderr per finished run; the
/// results in plan order.
fn run_parallel(args: &Args, plan: &[PlannedRun], jobs: usize) -> Vec<RunResult> {
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<RunResult>>> = plan.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..jobs.min(plan.len()) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(run) = plan.get(i) else { break };
                    let name = run_name(run.1, run.2.as_deref());
                    let result = run_one(args, run, true, |_, _| {});
                    let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                    match result {
                        Ok(r) => {
                            eprintln!(
                                "[{n}/{}] {}/{name}: map error {:.3} m, ATE {:.3} m, {} loops ({} rejected{})",
                                plan.len(),
                                run.0.name(),
                                r.map_error_m,
                                r.ate_rmse_m,
                                r.loop_closures,
                                r.loop_closures_rejected,
                                r.loops_off_truth.map_or(String::new(), |off| format!(
                                    "; {off} in the graph off the truth, loops.csv"
                                ))
                            );
                            if let Ok(mut slot) = slots[i].lock() {
                                *slot = Some(r);
                            }
                        }
                        Err(e) => eprintln!("[{n}/{}] {}/{name}: failed: {e:#}", plan.len(), run.0.name()),
                    }
                }
            });
        }
    });
    slots
        .into_iter()
        .filter_map(|s| s.into_inner().ok().flatten())
        .collect()
}

/// Removes the run artifacts of the generated worlds that are not among the `keep_worst`
/// worst of some method (the worlds' own folders stay, to map them again).
fn keep_worst_artifacts(args: &Args, generated: &[RunResult], methods: &[RunMethod]) {
    let mut keep: Vec<String> = Vec::new();
    for m in methods {
        for w in worst_worlds(generated, &m.to_string(), args.keep_worst) {
            if !keep.contains(&w) {
                keep.push(w);
            }
        }
    }
    let mut names: Vec<&str> = generated.iter().map(|r| r.scenario.as_str()).collect();
    names.dedup();
    for name in names {
        if !keep.iter().any(|k| k == name) {
            let _ = std::fs::remove_dir_all(args.out.join(name));
        }
    }
    println!(
        "worst worlds kept for a look (runs under {}, worlds under {}): {}",
        args.out.display(),
        args.out.join("worlds").display(),
        keep.join(", ")
    );
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

/// The method column: the method, and `#k` for sample `k` of `--repeat`.
fn method_label(r: &RunResult) -> String {
    match r.sample {
        Some(k) => format!("{} #{k}", r.method),
        None => r.method.clone(),
    }
}

/// Relation errors of the dataset runs, with the published figures beside.
fn print_relations(results: &[RunResult], floors: &[(String, ReplayFloors)]) {
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
            method_label(r),
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
        if let Some((_, floor)) = floors.iter().find(|(n, _)| n == name) {
            let (r, e) = (&floor.reference, &floor.exact_scans);
            println!(
                "floor ({name}): the replay's own reference (the log's corrected poses at its scans \
                 and odometry, no drift) on the same relations: {} m, {} deg, what an estimate \
                 that recovered the replay's truth exactly would score",
                pm(Some(r.trans_mean_m), Some(r.trans_sd_m)),
                pm(Some(r.rot_mean_deg), Some(r.rot_sd_deg)),
            );
            println!(
                "floor with exact scans ({name}): the reference at every scan, the \
                 replay's drifted odometry between scans blended as the mapper does: {} m, \
                 {} deg, the best a method that places scans can expect",
                pm(Some(e.trans_mean_m), Some(e.trans_sd_m)),
                pm(Some(e.rot_mean_deg), Some(e.rot_sd_deg)),
            );
        }
    }
}

fn print_table(results: &[RunResult]) {
    println!(
        "{:<12} {:<9} {:<8} {:>7} {:>8} {:>9} {:>7} {:>6} {:>7} {:>7} {:>8} {:>8} {:>6} {:>7} {:>5} {:>5} {:>5} {:>8} {:>6} {:>6} {:>5} {:>6} {:>8} {:>7} {:>7} {:>6}",
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
        "heap MB",
        "rec.",
        "loops",
        "rej.",
        "drw med",
        "drw≤1m",
        "W med",
        "W≤1m",
        "W held",
        "live drw",
        "ldrw≤1m",
        "MCL med",
        "MCL≤1m"
    );
    let opt = |v: Option<f64>, prec: usize| v.map_or("-".to_string(), |v| format!("{v:.prec$}"));
    for r in results {
        let method = method_label(r);
        println!(
            "{:<12} {:<9} {:<8} {} {:>8} {} {} {:>6} {:>7.1} {:>7.0} {:>8} {:>8} {:>6} {:>7} {:>5} {:>5} {:>5} {:>8} {:>6} {:>6} {:>5} {:>6} {:>8} {:>7} {:>7} {:>6}",
            r.scenario,
            method,
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
            opt(r.session_heap_mb, 1),
            r.recoveries,
            r.loop_closures,
            r.loop_closures_rejected,
            opt(r.sketch_pose_median_m, 2),
            opt(r.sketch_pose_within_1m.map(|w| 100.0 * w), 0),
            opt(r.warp_pose_median_m, 2),
            opt(r.warp_pose_within_1m.map(|w| 100.0 * w), 0),
            opt(r.warp_held.map(|w| 100.0 * w), 0),
            opt(r.live_sketch_pose_median_m, 2),
            opt(r.live_sketch_pose_within_1m.map(|w| 100.0 * w), 0),
            opt(r.mcl_pose_median_m, 2),
            opt(r.mcl_pose_within_1m.map(|w| 100.0 * w), 0)
        );
    }
    if let Some(r) = results.first() {
        // OUT/SCENARIO/RUN[/sample-k]
        let up = if r.sample.is_some() { 3 } else { 2 };
        let root = r.out_dir.ancestors().nth(up).unwrap_or(&r.out_dir);
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
             sketch-truth.toml; through the processes, the session's trajectory on the drawing); \
             W med, W≤1m: the same for the final trajectory carried onto the drawing through the \
             warp fitted to the final map (through the processes, by the session's POST …/transform); \
             W held: % of the served trajectory on the drawing where mapped walls hold W; \
             live drw, ldrw≤1m: the same as drw for each scan's pose on the drawing as the \
             session first published it, through the warp it held then (through the processes: \
             the event stream, the service's warp worker; in-process: W refitted at the scan the \
             map grew by the worker's 10 keyframes); MCL med, MCL≤1m: the same for MCL's own \
             estimate after each scan (in-process), the localization model alone"
        );
    }
    if results.iter().any(|r| r.scan_ms_mean.is_some()) {
        println!(
            "ms/scan, p99 ms: engine time per scan (in-process: timed around the mapper; \
             through the processes: the service's sketchslam_scan_processing_seconds histogram, \
             the p99 interpolated in its bucket as Prometheus' histogram_quantile does); \
             RTF: the stream's duration over the summed engine time; heap MB: what grows with \
             the session (scan log, trajectory, grid, keyframes) at its end, 10⁶ bytes"
        );
    }
}
