//! The `t,x,y,theta` CSV: one stamped pose per row, the format of a run's `trajectory.csv`
//! (the service's estimate, one row per processed scan) and `truth.csv` (the simulator's
//! true pose at every scan). The simulator and the service write it, the HTTP API serves
//! it, and the evaluation reads both back to align them by stamp.
//!
//! Header [`HEADER`], then one row per pose: seconds, meters, meters, radians. Two number
//! formats exist and both are kept byte for byte ([`NumberFormat`]): the trajectory's
//! fixed decimals (nanoseconds, micrometers, microradians) and the truth's shortest
//! round-trip form (reading gives back exactly what was written).
//!
//! [`parse`] is the one reader: the header, then rows of four finite numbers; blank lines
//! are skipped, anything else is a [`TrajectoryCsvError`] naming the 1-based line. Values
//! come back exactly as written — the heading is not re-wrapped, so that a parsed file
//! written again gives the same bytes; [`StampedPose::wrapped`] wraps it.

use crate::geometry::Pose2;
use std::fmt::Write as _;
use thiserror::Error;

/// The header line (without its newline).
pub const HEADER: &str = "t,x,y,theta";

/// The names of the four fields, in order, for messages.
const FIELDS: [&str; 4] = ["t", "x", "y", "theta"];

/// A pose with its stamp: one row of the CSV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Stamp, seconds.
    pub t_s: f64,
    /// The pose (meters, radians).
    pub pose: Pose2,
}

impl StampedPose {
    /// The same row with its heading wrapped to (−π, π] (a no-op for a heading already in
    /// that range, bit for bit).
    pub fn wrapped(self) -> StampedPose {
        StampedPose {
            t_s: self.t_s,
            pose: Pose2::new(self.pose.x, self.pose.y, self.pose.heading_rad),
        }
    }
}

/// How the numbers of a row are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NumberFormat {
    /// `trajectory.csv`: `t` with 9 decimals (nanoseconds), `x`, `y`, `theta` with 6.
    Fixed,
    /// `truth.csv`: Rust's shortest round-trip form of every `f64`.
    RoundTrip,
}

/// Why a CSV could not be read.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("line {line}: {message}")]
pub struct TrajectoryCsvError {
    /// 1-based line of the problem.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// The CSV text of `rows`: the header, then one line per row (each ending in `\n`).
pub fn write(rows: &[StampedPose], format: NumberFormat) -> String {
    let mut out = String::with_capacity(HEADER.len() + 1 + rows.len() * 48);
    out.push_str(HEADER);
    out.push('\n');
    for r in rows {
        let (t, x, y, th) = (r.t_s, r.pose.x, r.pose.y, r.pose.heading_rad);
        // Writing into a String cannot fail.
        let _ = match format {
            NumberFormat::Fixed => writeln!(out, "{t:.9},{x:.6},{y:.6},{th:.6}"),
            NumberFormat::RoundTrip => writeln!(out, "{t},{x},{y},{th}"),
        };
    }
    out
}

/// Parses CSV text: the header [`HEADER`] (surrounding blanks ignored), then rows of four
/// finite numbers; blank lines are skipped. Values are returned as written (see the module
/// documentation).
pub fn parse(text: &str) -> Result<Vec<StampedPose>, TrajectoryCsvError> {
    let error = |line: usize, message: String| TrajectoryCsvError { line, message };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header.trim() == HEADER => {}
        Some((_, header)) => {
            return Err(error(
                1,
                format!("expected the header {HEADER:?}, found {:?}", header.trim()),
            ));
        }
        None => return Err(error(1, format!("empty file, expected {HEADER:?}"))),
    }
    let mut rows = Vec::new();
    for (n, line) in lines {
        let line_no = n + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != FIELDS.len() {
            return Err(error(
                line_no,
                format!("expected 4 fields t,x,y,theta, found {}", fields.len()),
            ));
        }
        let mut values = [0.0f64; 4];
        for ((field, value), name) in fields.iter().zip(values.iter_mut()).zip(FIELDS) {
            *value = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    error(
                        line_no,
                        format!("field `{name}` is not a finite number: {field:?}"),
                    )
                })?;
        }
        let [t_s, x, y, heading_rad] = values;
        rows.push(StampedPose {
            t_s,
            pose: Pose2 { x, y, heading_rad },
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t_s: f64, x: f64, y: f64, th: f64) -> StampedPose {
        StampedPose {
            t_s,
            pose: Pose2::new(x, y, th),
        }
    }

    #[test]
    fn round_trip_form_reads_back_exactly() {
        let rows = vec![
            row(0.0, 5.5, 5.5, 0.0),
            row(0.05, 5.54, 5.5, 0.1234567890123),
            row(1.0 / 3.0, -1e-9, 1e6, -3.0),
        ];
        let text = write(&rows, NumberFormat::RoundTrip);
        assert!(text.starts_with("t,x,y,theta\n0,5.5,5.5,0\n"), "{text}");
        assert_eq!(parse(&text).unwrap(), rows);
    }

    #[test]
    fn fixed_form_has_nanosecond_and_micro_decimals() {
        let text = write(&[row(1.5, 2.0, -0.25, 0.1)], NumberFormat::Fixed);
        assert_eq!(
            text,
            "t,x,y,theta\n1.500000000,2.000000,-0.250000,0.100000\n"
        );
        // Parsed and written again: the same bytes, even for a heading rounded past π.
        let text = "t,x,y,theta\n0.000000000,1.000000,2.000000,3.141593\n";
        let rows = parse(text).unwrap();
        let written: f64 = "3.141593".parse().unwrap();
        assert_eq!(rows[0].pose.heading_rad, written);
        assert_eq!(write(&rows, NumberFormat::Fixed), text);
        assert!(rows[0].wrapped().pose.heading_rad < 0.0);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("t,x,y,theta\n0,1,2,3\n\n0.1,1,nan,3\n").unwrap_err();
        assert_eq!(e.line, 4);
        assert!(e.to_string().starts_with("line 4: field `y`"), "{e}");
        assert_eq!(parse("0,1,2,3\n").unwrap_err().line, 1);
        assert_eq!(parse("").unwrap_err().line, 1);
        let e = parse("t,x,y,theta\n0,1,2\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 2: expected 4 fields t,x,y,theta, found 3"
        );
        assert_eq!(parse(" t,x,y,theta \n").unwrap(), vec![]);
    }
}
