//! `truth.csv`: the true pose at every scan of a run, for scoring the service's output.
//!
//! The simulator writes it next to a run (`simulator run --truth truth.csv`); the evaluation
//! reads it back and aligns the service's `trajectory.csv` (same format) to it by stamp.
//! Format: header `t,x,y,theta`, then one row per scan — seconds of simulated time, meters
//! and radians in the world frame. Numbers are written in Rust's shortest round-trip form,
//! so reading gives back exactly what was written.

use crate::error::SimError;
use crate::simulation::SimStep;
use sketchslam_types::{Pose2, SensorEvent};
use std::io::{BufWriter, Write};
use std::path::Path;

/// The header line of a truth (or trajectory) CSV file.
pub const TRUTH_HEADER: &str = "t,x,y,theta";

/// Writes `rows` (time in seconds, pose in the world frame) as a truth CSV to `path`.
pub fn write_truth_csv(path: &Path, rows: &[(f64, Pose2)]) -> Result<(), SimError> {
    let io = |source| SimError::Io {
        file: path.to_path_buf(),
        action: "cannot write",
        source,
    };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = BufWriter::new(file);
    writeln!(out, "{TRUTH_HEADER}").map_err(io)?;
    for (t_s, pose) in rows {
        writeln!(out, "{},{},{},{}", t_s, pose.x, pose.y, pose.heading_rad).map_err(io)?;
    }
    out.flush().map_err(io)
}

/// Reads a truth CSV: the header `t,x,y,theta`, then rows of four finite numbers. Blank
/// lines are skipped; anything else malformed is an error naming the file and line.
pub fn read_truth_csv(path: &Path) -> Result<Vec<(f64, Pose2)>, SimError> {
    let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
        file: path.to_path_buf(),
        action: "cannot read",
        source,
    })?;
    let csv_error = |line: usize, message: String| SimError::Csv {
        file: path.to_path_buf(),
        line: Some(line),
        message,
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header.trim() == TRUTH_HEADER => {}
        Some((_, header)) => {
            return Err(csv_error(
                1,
                format!(
                    "expected the header {TRUTH_HEADER:?}, found {:?}",
                    header.trim()
                ),
            ));
        }
        None => {
            return Err(csv_error(
                1,
                format!("empty file, expected {TRUTH_HEADER:?}"),
            ));
        }
    }
    let mut rows = Vec::new();
    for (n, line) in lines {
        let line_no = n + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 4 {
            return Err(csv_error(
                line_no,
                format!("expected 4 fields t,x,y,theta, found {}", fields.len()),
            ));
        }
        let mut values = [0.0f64; 4];
        for (k, (field, value)) in fields.iter().zip(values.iter_mut()).enumerate() {
            let name = ["t", "x", "y", "theta"][k];
            *value = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    csv_error(
                        line_no,
                        format!("field `{name}` is not a finite number: {field:?}"),
                    )
                })?;
        }
        let [t_s, x, y, theta] = values;
        rows.push((t_s, Pose2::new(x, y, theta)));
    }
    Ok(rows)
}

/// Collects the truth rows of the scans in a stream of [`SimStep`]s.
#[derive(Debug, Clone, Default)]
pub struct TruthRecorder {
    rows: Vec<(f64, Pose2)>,
}

impl TruthRecorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records `step` if it is a scan (odometry steps are ignored).
    pub fn record(&mut self, step: &SimStep) {
        if let SensorEvent::Scan(_) = step.event {
            self.rows.push((step.t_s(), step.truth));
        }
    }

    /// The rows so far: one per scan, in order.
    pub fn rows(&self) -> &[(f64, Pose2)] {
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

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("sketchslam-truth-{}-{name}", std::process::id()))
    }

    #[test]
    fn round_trip_is_exact() {
        let rows = vec![
            (0.0, Pose2::new(5.5, 5.5, 0.0)),
            (0.05, Pose2::new(5.54, 5.5, 0.1234567890123)),
            (1.0 / 3.0, Pose2::new(-1e-9, 1e6, -3.0)),
        ];
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
