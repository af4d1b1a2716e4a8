//! `truth.csv`: the true pose at every scan of a run, for scoring the service's output.
//!
//! The simulator writes it next to a run (`simulator run --truth truth.csv`); the evaluation
//! reads it back and aligns the service's `trajectory.csv` (same format) to it by stamp.
//! Format: header `t,x,y,theta`, then one row per scan — seconds of simulated time, meters
//! and radians in the world frame. Numbers are written in Rust's shortest round-trip form,
//! so reading gives back exactly what was written.

use crate::error::SimError;
use crate::simulation::SimStep;
use sketchslam_types::SensorEvent;
use sketchslam_types::trajectory_csv::{self, NumberFormat, StampedPose};
use std::path::Path;

/// The header line of a truth (or trajectory) CSV file.
pub const TRUTH_HEADER: &str = trajectory_csv::HEADER;

/// Writes `rows` (time in seconds, pose in the world frame) as a truth CSV to `path`.
pub fn write_truth_csv(path: &Path, rows: &[StampedPose]) -> Result<(), SimError> {
    std::fs::write(path, trajectory_csv::write(rows, NumberFormat::RoundTrip)).map_err(|source| {
        SimError::Io {
            file: path.to_path_buf(),
            action: "cannot write",
            source,
        }
    })
}

/// Reads a truth CSV: the header `t,x,y,theta`, then rows of four finite numbers. Blank
/// lines are skipped; anything else malformed is an error naming the file and line.
/// Headings are wrapped to (−π, π].
pub fn read_truth_csv(path: &Path) -> Result<Vec<StampedPose>, SimError> {
    let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
        file: path.to_path_buf(),
        action: "cannot read",
        source,
    })?;
    let rows = trajectory_csv::parse(&text).map_err(|e| SimError::Csv {
        file: path.to_path_buf(),
        line: Some(e.line),
        message: e.message,
    })?;
    Ok(rows.into_iter().map(StampedPose::wrapped).collect())
}

/// Collects the truth rows of the scans in a stream of [`SimStep`]s.
#[derive(Debug, Clone, Default)]
pub struct TruthRecorder {
    rows: Vec<StampedPose>,
}

impl TruthRecorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records `step` if it is a scan (odometry steps are ignored).
    pub fn record(&mut self, step: &SimStep) {
        if let SensorEvent::Scan(_) = step.event {
            self.rows.push(StampedPose {
                t_s: step.t_s(),
                pose: step.truth,
            });
        }
    }

    /// The rows so far: one per scan, in order.
    pub fn rows(&self) -> &[StampedPose] {
        &self.rows
    }

    /// Writes the rows to `path` as a truth CSV.
    pub fn write(&self, path: &Path) -> Result<(), SimError> {
        write_truth_csv(path, &self.rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::Pose2;

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("sketchslam-truth-{}-{name}", std::process::id()))
    }

    #[test]
    fn round_trip_is_exact() {
        let rows: Vec<StampedPose> = [
            (0.0, Pose2::new(5.5, 5.5, 0.0)),
            (0.05, Pose2::new(5.54, 5.5, 0.1234567890123)),
            (1.0 / 3.0, Pose2::new(-1e-9, 1e6, -3.0)),
        ]
        .into_iter()
        .map(|(t_s, pose)| StampedPose { t_s, pose })
        .collect();
        let path = temp("rt.csv");
        write_truth_csv(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("t,x,y,theta\n"));
        assert_eq!(read_truth_csv(&path).unwrap(), rows);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn malformed_rows_name_the_line() {
        let path = temp("bad.csv");
        std::fs::write(&path, "t,x,y,theta\n0,1,2,3\n0.1,1,nan,3\n").unwrap();
        let e = read_truth_csv(&path).unwrap_err().to_string();
        assert!(e.contains(":3:") && e.contains("`y`"), "{e}");
        std::fs::write(&path, "time,x,y\n").unwrap();
        assert!(read_truth_csv(&path).is_err());
        let _ = std::fs::remove_file(&path);
    }
}
