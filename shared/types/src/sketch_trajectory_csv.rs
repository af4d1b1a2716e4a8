//! `sketch-trajectory.csv`: a `sketch` session's trajectory on the drawing, one row per stamp.
//!
//! Header `t,u,v,heading,meters_per_pixel`: seconds; pixels from the drawing's top-left
//! corner (u right, v down); radians counter-clockwise from +u as the drawing is seen; the
//! drawing's estimated scale there in meters per pixel. Written by the service
//! (`GET …/trajectory?frame=sketch&format=csv`) and by `evaluate`'s in-process runs with the
//! same [`write()`], so both give the same bytes; [`parse`] reads it back (what it wrote, to
//! the written precision: 9 decimals of seconds, 3 of pixels, 6 of radians and scale).

use std::fmt::Write as _;
use thiserror::Error;

/// The header line (without its newline).
pub const HEADER: &str = "t,u,v,heading,meters_per_pixel";

/// One row: a pose on the drawing with its stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawingRow {
    /// Stamp, seconds.
    pub t_s: f64,
    /// Column, pixels from the left edge.
    pub u_px: f64,
    /// Row, pixels from the top edge.
    pub v_px: f64,
    /// Heading on the drawing, radians.
    pub heading_rad: f64,
    /// Scale, meters per pixel.
    pub meters_per_pixel: f64,
}

/// Why a `sketch-trajectory.csv` could not be read.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("line {line}: {message}")]
pub struct DrawingCsvError {
    /// 1-based line of the problem.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// The CSV text of `rows`: the header, then one line per row.
pub fn write(rows: &[DrawingRow]) -> String {
    let mut out = String::with_capacity(HEADER.len() + 1 + rows.len() * 48);
    out.push_str(HEADER);
    out.push('\n');
    for r in rows {
        // Writing into a String cannot fail.
        let _ = writeln!(
            out,
            "{:.9},{:.3},{:.3},{:.6},{:.6}",
            r.t_s, r.u_px, r.v_px, r.heading_rad, r.meters_per_pixel
        );
    }
    out
}

/// Parses CSV text: the header [`HEADER`], then rows of five finite numbers; blank lines
/// are skipped.
pub fn parse(text: &str) -> Result<Vec<DrawingRow>, DrawingCsvError> {
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == HEADER => {}
        _ => {
            return Err(DrawingCsvError {
                line: 1,
                message: format!("the header is not {HEADER}"),
            });
        }
    }
    let mut rows = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let err = |message: String| DrawingCsvError {
            line: i + 1,
            message,
        };
        let v: Vec<f64> = line
            .split(',')
            .map(|f| f.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| err(format!("not a number: {e}")))?;
        let [t_s, u_px, v_px, heading_rad, meters_per_pixel] = v[..] else {
            return Err(err(format!("expected 5 fields, found {}", v.len())));
        };
        if !v.iter().all(|x| x.is_finite()) {
            return Err(err("every field must be a finite number".into()));
        }
        rows.push(DrawingRow {
            t_s,
            u_px,
            v_px,
            heading_rad,
            meters_per_pixel,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_rows_read_back_and_write_the_same_bytes() {
        let rows = [
            DrawingRow {
                t_s: 1.05,
                u_px: 67.026_267,
                v_px: 315.046_047,
                heading_rad: 0.135_854,
                meters_per_pixel: 0.102_360,
            },
            DrawingRow {
                t_s: 1_134_864_642.914_187,
                u_px: -3.5,
                v_px: 0.0,
                heading_rad: -2.5,
                meters_per_pixel: 0.06,
            },
        ];
        let text = write(&rows);
        assert_eq!(
            text.lines().nth(1),
            Some("1.050000000,67.026,315.046,0.135854,0.102360")
        );
        let back = parse(&text).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(write(&back), text);
        assert!((back[1].t_s - 1_134_864_642.914_187).abs() < 1e-6);
    }

    #[test]
    fn bad_text_names_its_line() {
        assert_eq!(parse("t,x,y,theta\n").unwrap_err().line, 1);
        let e = parse(&format!("{HEADER}\n1,2,3,4\n")).unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("5 fields"));
        let e = parse(&format!("{HEADER}\n\n1,2,3,4,NaN\n")).unwrap_err();
        assert_eq!(e.line, 3);
    }
}
