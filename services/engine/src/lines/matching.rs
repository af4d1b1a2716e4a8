//! Sketch lines ↔ scan lines, and the heading correction of eq. (5): step 4 of the pipeline.
//!
//! The sketch lines that the line observation probability (eq. 4) says are really seen at
//! this frame are brought into the robot frame through the MCL estimate on the drawing
//! ([`SketchPose`]: pixels → meters with its `meters_per_pixel`, sketch frame `x = u`,
//! `y = −v`, heading counter-clockwise from +u), then paired with the scan's RANSAC lines
//! ([`ScanLine`]) by
//! - angle: the undirected angle difference (modulo π) within `max_angle_diff_rad`;
//! - position: the perpendicular distance of the scan segment's midpoint to the sketch
//!   line within `max_distance_m` (generous: drawings are distorted), and the midpoint's
//!   foot on the sketch line within `max_overhang_m` of the sketch segment.
//!
//! Each scan line is paired with its best sketch line (smallest
//! `angle/max_angle + distance/max_distance`); a sketch line may pair with several scan
//! segments (a wall broken by a doorway). Cost O(M·L) for M sketch and L scan lines.
//!
//! Eq. (5): with `α` the direction of a line in the robot frame,
//! `Δθ = (1/N) Σ wrap_π(α_sketch − α_scan)`, wrapped to (−π/2, π/2]. The paper writes
//! `1/N` over `M` pairs; here `N` is the number of matched pairs (the mean over pairs).
//! If the heading used to bring the sketch into the robot frame is `θ`, the heading the
//! scan supports is `θ + Δθ` (a wall at direction `φ` is seen at `φ − θ_true` and drawn at
//! `φ − θ`, so `α_sketch − α_scan = θ_true − θ`).

use crate::lines::ransac::ScanLine;
use crate::sketch::{SketchLine, SketchPose};
use sketchslam_types::{Point2, Pose2, wrap_half_pi};

/// The robot's pose in the sketch's metric frame (`x = u·s`, `y = −v·s`, meters).
pub fn sketch_pose_metric(pose: &SketchPose) -> Pose2 {
    let s = pose.meters_per_pixel;
    Pose2::new(pose.u_px * s, -pose.v_px * s, pose.heading_rad)
}

/// The endpoints of a sketch line in the robot frame, meters: pixel `(u, v)` becomes
/// `(u·s, −v·s)` in the sketch's metric frame with `s = pose.meters_per_pixel`, then the
/// inverse of the robot's sketch pose applies.
pub fn sketch_line_in_robot_frame(line: &SketchLine, pose: &SketchPose) -> (Point2, Point2) {
    let s = pose.meters_per_pixel;
    let robot = sketch_pose_metric(pose);
    let to_robot = |p: &Point2| robot.inverse_transform_point(&Point2::new(p.x * s, -p.y * s));
    (to_robot(&line.a), to_robot(&line.b))
}

/// Thresholds of the correspondence search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchConfig {
    /// Largest undirected angle difference of a pair, radians. Default 10°.
    pub max_angle_diff_rad: f64,
    /// Largest perpendicular distance of the scan segment's midpoint to the sketch line,
    /// meters. Default 1.5 m (sketch distortion plus MCL error).
    pub max_distance_m: f64,
    /// How far beyond the sketch segment's ends the midpoint's foot may fall, meters.
    /// Default 3.0 m; `f64::INFINITY` compares with the infinite line only.
    pub max_overhang_m: f64,
    /// Scan lines shorter than this take no part, meters. Default 0.5 m.
    pub min_scan_length_m: f64,
}

impl Default for MatchConfig {
    fn default() -> Self {
        Self {
            max_angle_diff_rad: 10f64.to_radians(),
            max_distance_m: 1.5,
            max_overhang_m: 3.0,
            min_scan_length_m: 0.5,
        }
    }
}

/// One sketch line paired with one scan line.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LineMatch {
    /// The sketch line's `index` (its number in the sketch).
    pub sketch_index: usize,
    /// Position of the scan line in the slice given to [`match_lines`].
    pub scan_index: usize,
    /// `wrap_π(α_sketch − α_scan)` in the robot frame, radians in (−π/2, π/2].
    pub angle_diff_rad: f64,
    /// Perpendicular distance of the scan segment's midpoint to the sketch line, meters.
    pub distance_m: f64,
}

/// Pairs scan lines with the observed sketch lines (see the module docs). Sketch lines with
/// a degenerate image (zero length, non-finite after the transform) and non-finite scan
/// lines are skipped. Returns the pairs in scan-line order.
pub fn match_lines(
    sketch_lines: &[SketchLine],
    pose: &SketchPose,
    scan_lines: &[ScanLine],
    config: &MatchConfig,
) -> Vec<LineMatch> {
    if !(pose.meters_per_pixel.is_finite() && pose.meters_per_pixel > 0.0) {
        return Vec::new();
    }
    // (index, a, unit direction, length, angle in robot frame)
    let sketch: Vec<(usize, Point2, Point2, f64, f64)> = sketch_lines
        .iter()
        .filter_map(|l| {
            let (a, b) = sketch_line_in_robot_frame(l, pose);
            let (dx, dy) = (b.x - a.x, b.y - a.y);
            let len = dx.hypot(dy);
            (len.is_finite() && len > 1e-9 && a.x.is_finite() && a.y.is_finite()).then(|| {
                (
                    l.index,
                    a,
                    Point2::new(dx / len, dy / len),
                    len,
                    dy.atan2(dx),
                )
            })
        })
        .collect();
    let mut out = Vec::new();
    for (k, sl) in scan_lines.iter().enumerate() {
        let m = sl.midpoint();
        if !(m.x.is_finite() && m.y.is_finite() && sl.angle_rad.is_finite())
            || sl.length_m() < config.min_scan_length_m
        {
            continue;
        }
        let mut best: Option<(f64, LineMatch)> = None;
        for &(index, a, d, len, angle) in &sketch {
            let diff = wrap_half_pi(angle - sl.angle_rad);
            if diff.abs() > config.max_angle_diff_rad {
                continue;
            }
            let (rx, ry) = (m.x - a.x, m.y - a.y);
            let along = rx * d.x + ry * d.y;
            let dist = (rx * d.y - ry * d.x).abs();
            let overhang = if along < 0.0 {
                -along
            } else if along > len {
                along - len
            } else {
                0.0
            };
            if dist > config.max_distance_m || overhang > config.max_overhang_m {
                continue;
            }
            let cost = diff.abs() / config.max_angle_diff_rad.max(1e-12)
                + dist / config.max_distance_m.max(1e-12);
            if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                best = Some((
                    cost,
                    LineMatch {
                        sketch_index: index,
                        scan_index: k,
                        angle_diff_rad: diff,
                        distance_m: dist,
                    },
                ));
            }
        }
        if let Some((_, m)) = best {
            out.push(m);
        }
    }
    out
}

/// How eq. (5) combines the per-pair angle differences.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum HeadingAggregate {
    /// The mean over the matched pairs: eq. (5) as written (with N = number of pairs).
    #[default]
    Mean,
    /// The median: robust to a minority of wrong pairs.
    Median,
    /// The mean of the pairs within `tolerance` of the median (an inlier mean).
    InlierMean {
        /// Largest distance to the median, radians.
        tolerance_rad: f64,
    },
}

/// Heading correction Δθ of eq. (5) from the matched pairs: the mean (or the robust
/// aggregate chosen) of `wrap_π(α_sketch − α_scan)`, in (−π/2, π/2]; add it to the heading
/// used to bring the sketch lines into the robot frame. `None` when there is no pair (or
/// none with a finite difference).
pub fn heading_correction(matches: &[LineMatch], aggregate: HeadingAggregate) -> Option<f64> {
    let mut d: Vec<f64> = matches
        .iter()
        .map(|m| m.angle_diff_rad)
        .filter(|a| a.is_finite())
        .collect();
    if d.is_empty() {
        return None;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    // Eq. (5): Δθ = (1/N) Σ_{pairs} (α_sketch − α_scan).
    Some(match aggregate {
        HeadingAggregate::Mean => mean(&d),
        HeadingAggregate::Median => median(&mut d),
        HeadingAggregate::InlierMean { tolerance_rad } => {
            let med = median(&mut d);
            let inl: Vec<f64> = d
                .iter()
                .copied()
                .filter(|a| (a - med).abs() <= tolerance_rad)
                .collect();
            if inl.is_empty() { med } else { mean(&inl) }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn sketch_line_to_robot_frame_by_hand() {
        // Robot at pixel (100, 200) facing +u, 0.1 m/px; a pixel 10 px up (v − 10) is 1 m to
        // its left.
        let pose = SketchPose {
            u_px: 100.0,
            v_px: 200.0,
            heading_rad: 0.0,
            meters_per_pixel: 0.1,
        };
        let line = SketchLine::new(0, Point2::new(90.0, 190.0), Point2::new(120.0, 190.0));
        let (a, b) = sketch_line_in_robot_frame(&line, &pose);
        assert!((a.x + 1.0).abs() < 1e-9 && (a.y - 1.0).abs() < 1e-9);
        assert!((b.x - 2.0).abs() < 1e-9 && (b.y - 1.0).abs() < 1e-9);
        // Facing up (+90°): the same line is now 1 m ahead, running to the right (−y).
        let up = SketchPose {
            heading_rad: FRAC_PI_2,
            ..pose
        };
        let (a, b) = sketch_line_in_robot_frame(&line, &up);
        assert!((a.x - 1.0).abs() < 1e-9 && (a.y - 1.0).abs() < 1e-9);
        assert!((b.x - 1.0).abs() < 1e-9 && (b.y + 2.0).abs() < 1e-9);
    }
}
