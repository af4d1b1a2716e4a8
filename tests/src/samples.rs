//! Repeated runs of one scenario: `evaluate --repeat N` maps every scenario × method ×
//! drawing N times, each a different draw of what the result should not depend on, and
//! reports each score's median with its best and worst.
//!
//! Why: one run of paper-env2 or school is one draw from a spread of up to 10× (measured
//! 2026-12-05: the same `sketch` session maps paper-env2 D at 0.015–0.152 m over three engine
//! seeds; `graph` maps school at 0.012–0.069 m with its map frame turned −2…+3°), so a
//! single-run comparison of two methods or two settings is mostly noise. Sample `k` of a run
//! turns the map frame of the methods without a drawing by [`sample_turn_deg`]`(k)` (the grid's
//! axes against the walls, the one thing their result should not owe anything to) and seeds
//! the engine with its seed + `k` (MCL's and RANSAC's draws: `sketch`). Pure bookkeeping
//! here; the evaluation binary runs the samples.

use crate::generated::spread;
use crate::run::RunResult;
use serde::Serialize;

/// The map frame's turn of sample `k`, degrees: 0, +1, −1, +2, −2, … (sample 0 is the plain
/// run).
pub fn sample_turn_deg(k: usize) -> f64 {
    let step = k.div_ceil(2) as f64;
    if k % 2 == 1 { step } else { -step }
}

/// Median, best and worst of one score over the samples of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Range {
    /// The median (of an even count, the worse of the middle two).
    pub median: f64,
    /// The best sample's value.
    pub best: f64,
    /// The worst sample's value.
    pub worst: f64,
}

/// The [`Range`] of `values` (NaN left out), lower is better. `None` without a value.
fn range(values: &[f64]) -> Option<Range> {
    let s = spread(values, false)?;
    let best = values
        .iter()
        .copied()
        .filter(|v| !v.is_nan())
        .fold(f64::INFINITY, f64::min);
    Some(Range {
        median: s.median,
        best,
        worst: s.worst,
    })
}

/// One run's scores over its samples.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SampleSummary {
    /// Scenario or dataset.
    pub scenario: String,
    /// Method.
    pub method: String,
    /// Drawing, for `sketch` runs.
    pub sketch: Option<String>,
    /// Samples pooled.
    pub samples: usize,
    /// Map error, meters.
    pub map_error_m: Option<Range>,
    /// ATE, meters.
    pub ate_m: Option<Range>,
    /// ATE of the live trajectory, meters.
    pub live_ate_m: Option<Range>,
    /// Datasets: mean translational relation error, meters.
    pub rel_trans_m: Option<Range>,
    /// Median error of the final trajectory on the drawing through W, meters at the
    /// drawing's scale.
    pub warp_pose_median_m: Option<Range>,
}

/// The runs of `results` grouped by scenario, method and drawing (in first-seen order),
/// each group's scores as [`Range`]s.
pub fn summarize_samples(results: &[RunResult]) -> Vec<SampleSummary> {
    let mut groups: Vec<(SampleSummary, Vec<&RunResult>)> = Vec::new();
    for r in results {
        let same = |s: &SampleSummary| {
            s.scenario == r.scenario && s.method == r.method && s.sketch == r.sketch
        };
        match groups.iter_mut().find(|(s, _)| same(s)) {
            Some((_, runs)) => runs.push(r),
            None => groups.push((
                SampleSummary {
                    scenario: r.scenario.clone(),
                    method: r.method.clone(),
                    sketch: r.sketch.clone(),
                    samples: 0,
                    map_error_m: None,
                    ate_m: None,
                    live_ate_m: None,
                    rel_trans_m: None,
                    warp_pose_median_m: None,
                },
                vec![r],
            )),
        }
    }
    groups
        .into_iter()
        .map(|(mut s, runs)| {
            let col = |f: &dyn Fn(&RunResult) -> Option<f64>| -> Option<Range> {
                range(&runs.iter().filter_map(|r| f(r)).collect::<Vec<_>>())
            };
            s.samples = runs.len();
            s.map_error_m = col(&|r| Some(r.map_error_m));
            s.ate_m = col(&|r| Some(r.ate_rmse_m));
            s.live_ate_m = col(&|r| r.online_ate_rmse_m);
            s.rel_trans_m = col(&|r| r.rel_trans_m);
            s.warp_pose_median_m = col(&|r| r.warp_pose_median_m);
            s
        })
        .collect()
}

/// The summaries as a table: one row per run, `median [best–worst]` per score.
pub fn samples_table(summaries: &[SampleSummary]) -> String {
    let cell = |r: &Option<Range>| match r {
        Some(r) => format!("{:.3} [{:.3}–{:.3}]", r.median, r.best, r.worst),
        None => "-".to_string(),
    };
    let row = |cols: [&str; 9]| {
        format!(
            "{:<12} {:<9} {:<8} {:>7} {:>21} {:>21} {:>21} {:>21} {:>21}\n",
            cols[0], cols[1], cols[2], cols[3], cols[4], cols[5], cols[6], cols[7], cols[8]
        )
    };
    let mut out = row([
        "scenario",
        "method",
        "sketch",
        "samples",
        "map err m",
        "ATE m",
        "live m",
        "rel. trans m",
        "W med m",
    ]);
    for s in summaries {
        out.push_str(&row([
            &s.scenario,
            &s.method,
            s.sketch.as_deref().unwrap_or("-"),
            &s.samples.to_string(),
            &cell(&s.map_error_m),
            &cell(&s.ate_m),
            &cell(&s.live_ate_m),
            &cell(&s.rel_trans_m),
            &cell(&s.warp_pose_median_m),
        ]));
    }
    out.push_str(
        "each cell: median [best–worst] over the samples; sample k turns the map frame of the \
         methods without a drawing by 0, +1, −1, +2, −2, … degrees and seeds the engine with its \
         seed + k\n",
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(scenario: &str, method: &str, map_error_m: f64) -> RunResult {
        RunResult {
            scenario: scenario.into(),
            method: method.into(),
            map_error_m,
            ..RunResult::default()
        }
    }

    #[test]
    fn turns_alternate_around_the_plain_run() {
        let turns: Vec<f64> = (0..5).map(sample_turn_deg).collect();
        assert_eq!(turns, vec![0.0, 1.0, -1.0, 2.0, -2.0]);
    }

    #[test]
    fn samples_group_by_run_with_median_best_and_worst() {
        let results = vec![
            result("school", "graph", 0.045),
            result("school", "sketch", 0.040),
            result("school", "graph", 0.012),
            result("school", "graph", 0.069),
            result("school", "sketch", f64::NAN),
        ];
        let s = summarize_samples(&results);
        assert_eq!(s.len(), 2);
        assert_eq!((s[0].method.as_str(), s[0].samples), ("graph", 3));
        let m = s[0].map_error_m.unwrap();
        assert_eq!((m.median, m.best, m.worst), (0.045, 0.012, 0.069));
        // A NaN score (no true walls) is left out, not counted as a value.
        let m = s[1].map_error_m.unwrap();
        assert_eq!(
            (s[1].samples, m.median, m.best, m.worst),
            (2, 0.040, 0.040, 0.040)
        );
        assert!(s[0].rel_trans_m.is_none());
        let table = samples_table(&s);
        assert!(table.contains("0.045 [0.012–0.069]"), "{table}");
    }
}
