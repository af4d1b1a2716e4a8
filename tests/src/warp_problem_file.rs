//! `warp-problem.json`: what a `sketch` run's final warp W was fitted to (the keyframes'
//! walls at their final poses, the drawing's lines, the prior from the start mark and
//! scale guess), with the scenario and drawing it came from, so that `bench-warp` can fit
//! W again with other settings and score it against the truth without mapping again.
//!
//! Written by in-process `evaluate` runs beside `trajectory.csv` and `truth.csv`; read by
//! `bench-warp`. Plain JSON: map meters and drawing pixels.

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use sketchslam_engine::registration::{FitConfig, Similarity, WarpProblem};
use sketchslam_engine::sketch::SketchLine;
use sketchslam_types::Point2;
use std::path::{Path, PathBuf};

/// The file's name in a run's folder.
pub const WARP_PROBLEM_FILE: &str = "warp-problem.json";

/// The file's contents.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct WarpProblemFile {
    /// The scenario's folder (where `sketch-truth.toml` is).
    pub scenario_dir: PathBuf,
    /// The drawing's name in the scenario.
    pub sketch: String,
    /// Wall points, map meters `[x, y]`.
    pub walls: Vec<[f64; 2]>,
    /// The drawing's lines, pixels `[u_a, v_a, u_b, v_b]`.
    pub lines: Vec<[f64; 4]>,
    /// The prior similarity `(a, b, t_x, t_y)` (pixels per meter, drawing frame `(u, −v)`).
    pub prior: [f64; 4],
    /// Keyframes the walls came from.
    pub keyframes: usize,
}

impl WarpProblemFile {
    /// The file for `problem`, mapped in `scenario_dir` with the drawing `sketch`.
    pub fn new(problem: &WarpProblem, scenario_dir: &Path, sketch: &str) -> Self {
        let p = &problem.prior;
        Self {
            scenario_dir: scenario_dir.to_path_buf(),
            sketch: sketch.to_string(),
            walls: problem.walls.iter().map(|w| [w.x, w.y]).collect(),
            lines: problem
                .lines
                .iter()
                .map(|l| [l.a.x, l.a.y, l.b.x, l.b.y])
                .collect(),
            prior: [p.a, p.b, p.t.x, p.t.y],
            keyframes: problem.keyframes,
        }
    }

    /// The problem again, fitted with `config`.
    pub fn problem(&self, config: FitConfig) -> WarpProblem {
        WarpProblem {
            walls: self.walls.iter().map(|w| Point2::new(w[0], w[1])).collect(),
            lines: self
                .lines
                .iter()
                .enumerate()
                .map(|(i, l)| SketchLine::new(i, Point2::new(l[0], l[1]), Point2::new(l[2], l[3])))
                .collect(),
            prior: Similarity {
                a: self.prior[0],
                b: self.prior[1],
                t: Point2::new(self.prior[2], self.prior[3]),
            },
            config,
            keyframes: self.keyframes,
            map_revision: 0,
            anchors: Vec::new(),
        }
    }

    /// Writes the file into `out_dir`.
    pub fn write(&self, out_dir: &Path) -> Result<()> {
        let path = out_dir.join(WARP_PROBLEM_FILE);
        std::fs::write(&path, serde_json::to_vec(self)?)
            .with_context(|| format!("writing {}", path.display()))
    }

    /// Reads the file at `path`.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        serde_json::from_slice(&text).with_context(|| format!("parsing {}", path.display()))
    }
}
