//! `warp-problem.json`: what a `sketch` run's final warp W was fitted to (the keyframes'
//! walls at their final poses and those poses, the drawing's lines, the prior from the start
//! mark and scale guess), with the scenario and drawing it came from, so that `bench-warp` can fit
//! W again with other settings and score it against the truth without mapping again.
//!
//! Written by in-process `evaluate` runs beside `trajectory.csv` and `truth.csv`; read by
//! `bench-warp`. Plain JSON: map meters and drawing pixels.

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use sketchslam_engine::registration::{FitConfig, Similarity, WarpProblem};
use sketchslam_engine::sketch::SketchLine;
use sketchslam_types::{Point2, Pose2};
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
    /// Their poses, map frame `[x, y, heading_rad]` (the sensor's, as the mapper keeps them):
    /// the route W carries onto the drawing, for a fit that asks whether it runs through
    /// drawn walls. Empty in files written before it was kept.
    #[serde(default)]
    pub keyframe_poses: Vec<[f64; 3]>,
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
            keyframe_poses: problem
                .anchors
                .iter()
                .map(|k| [k.x, k.y, k.heading_rad])
                .collect(),
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
            anchors: self
                .keyframe_poses
                .iter()
                .map(|k| Pose2::new(k[0], k[1], k[2]))
                .collect(),
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

#[cfg(test)]
mod tests {
    use super::*;

    fn problem() -> WarpProblem {
        WarpProblem {
            walls: vec![Point2::new(1.0, 2.0), Point2::new(3.5, -0.25)],
            lines: vec![SketchLine::new(
                0,
                Point2::new(10.0, 20.0),
                Point2::new(110.0, 20.0),
            )],
            prior: Similarity::new(10.0, 0.0, Point2::new(5.0, -7.0)),
            config: FitConfig::default(),
            keyframes: 2,
            map_revision: 3,
            anchors: vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(0.5, 0.1, 0.2)],
        }
    }

    #[test]
    fn a_problem_comes_back_from_its_file_with_its_keyframe_route() {
        let dir = std::env::temp_dir().join(format!("sketchslam-wpf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = problem();
        WarpProblemFile::new(&p, Path::new("/scenario"), "A")
            .write(&dir)
            .unwrap();
        let file = WarpProblemFile::read(&dir.join(WARP_PROBLEM_FILE)).unwrap();
        let back = file.problem(FitConfig::default());
        assert_eq!((file.sketch.as_str(), back.keyframes), ("A", 2));
        assert_eq!(back.walls, p.walls);
        assert_eq!(back.anchors, p.anchors);
        assert_eq!(
            (back.lines[0].a, back.lines[0].b),
            (p.lines[0].a, p.lines[0].b)
        );
        assert_eq!(back.prior, p.prior);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_written_before_the_route_was_kept_still_reads() {
        let old = r#"{"scenario_dir":"/s","sketch":"B","walls":[[1.0,2.0]],
            "lines":[[0.0,0.0,10.0,0.0]],"prior":[10.0,0.0,0.0,0.0],"keyframes":1}"#;
        let file: WarpProblemFile = serde_json::from_str(old).unwrap();
        assert!(file.problem(FitConfig::default()).anchors.is_empty());
    }
}
