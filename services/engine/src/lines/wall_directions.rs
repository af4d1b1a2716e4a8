//! The drawing's wall directions as a heading reference that does not need MCL.
//!
//! The paper's premise is that a sketch's walls have the right directions even where its
//! proportions are wrong. Eq. (5) uses it through the lines MCL says are in view, so it
//! needs a sound localization on the drawing; when MCL is lost (long corridors, 180° scans
//! seconds apart) the heading drifts and the map bends. This module keeps the premise
//! without the localization: the drawing's *dominant* directions (length-weighted modes of
//! its line angles, modulo π) are few — two for a rectangular building — and every long
//! wall the robot sees should run along one of them. The mean difference between the
//! scan's long lines (in the map frame) and their nearest dominant direction corrects the
//! heading; the mapper gives it to the pose graph as a heading prior of each keyframe.
//!
//! Sits between the sketch side (its lines, once per drawing) and the loop-closure back end
//! ([`crate::back_end::loop_closure`]), per keyframe.

use crate::lines::ransac::ScanLine;
use crate::sketch::SketchLine;
use sketchslam_types::wrap_half_pi;
use std::f64::consts::PI;

/// A direction holding less than this share of a drawing's line length is not dominant
/// (the keyframe heading prior's and the start heading's [`dominant_directions`]).
pub const MIN_DOMINANT_SHARE: f64 = 0.1;

/// Half width of the window that gathers a direction's lines, radians.
const CLUSTER_HALF_WIDTH_RAD: f64 = 7.5 * PI / 180.0;

/// The dominant directions of a drawing's lines, radians in [0, π), strongest first: modes
/// of the length-weighted angle distribution, each the length-weighted mean (on doubled
/// angles, so 179° and 1° average to 0°) of the lines within 7.5° of it, kept while a mode
/// holds at least `min_share` of the total length. O(lines · modes).
pub fn dominant_directions(lines: &[SketchLine], min_share: f64) -> Vec<f64> {
    let mut remaining: Vec<(f64, f64)> = lines
        .iter()
        .map(|l| (l.angle_rad, l.a.distance(&l.b)))
        .filter(|(a, w)| a.is_finite() && w.is_finite() && *w > 0.0)
        .collect();
    let total: f64 = remaining.iter().map(|(_, w)| w).sum();
    let mut directions = Vec::new();
    while !remaining.is_empty() && total > 0.0 {
        // The mode: the line whose ±7.5° window holds the most length.
        let support = |centre: f64| -> f64 {
            remaining
                .iter()
                .filter(|(a, _)| wrap_half_pi(a - centre).abs() <= CLUSTER_HALF_WIDTH_RAD)
                .map(|(_, w)| w)
                .sum()
        };
        let (centre, weight) = remaining.iter().map(|(a, _)| (*a, support(*a))).fold(
            (0.0, f64::NEG_INFINITY),
            |b, c| if c.1 > b.1 { c } else { b },
        );
        if weight < min_share * total {
            break;
        }
        let (mut s, mut c) = (0.0, 0.0);
        for (a, w) in &remaining {
            if wrap_half_pi(a - centre).abs() <= CLUSTER_HALF_WIDTH_RAD {
                s += w * (2.0 * a).sin();
                c += w * (2.0 * a).cos();
            }
        }
        let mean = (0.5 * s.atan2(c)).rem_euclid(PI);
        directions.push(mean);
        remaining.retain(|(a, _)| wrap_half_pi(a - centre).abs() > CLUSTER_HALF_WIDTH_RAD);
    }
    directions
}

/// Settings of [`heading_to_directions`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionMatchConfig {
    /// Scan lines shorter than this are left out, meters.
    pub min_line_m: f64,
    /// Lines farther than this from every dominant direction are other walls, radians.
    pub tolerance_rad: f64,
    /// Least total length of agreeing lines for a correction, meters.
    pub min_support_m: f64,
}

impl Default for DirectionMatchConfig {
    fn default() -> Self {
        Self {
            min_line_m: 1.0,
            tolerance_rad: 8f64.to_radians(),
            min_support_m: 3.0,
        }
    }
}

/// The heading correction that turns the scan's long lines (robot frame, seen from
/// `heading_rad`) onto their nearest dominant direction: the length-weighted mean of
/// `d − (θ + φ)` wrapped to (−π/2, π/2] over lines within the tolerance, the analogue of
/// eq. (5) with the drawing's directions in place of the lines in view. `None` when too
/// little wall length agrees.
pub fn heading_to_directions(
    scan_lines: &[ScanLine],
    heading_rad: f64,
    directions: &[f64],
    config: &DirectionMatchConfig,
) -> Option<f64> {
    let (mut sum, mut weight) = (0.0, 0.0);
    for line in scan_lines {
        let length_m = line.length_m();
        if length_m < config.min_line_m {
            continue;
        }
        let nearest = nearest_direction_rad(directions, heading_rad + line.angle_rad);
        if let Some(r) = nearest.filter(|r| r.abs() <= config.tolerance_rad) {
            sum += length_m * r;
            weight += length_m;
        }
    }
    (weight >= config.min_support_m && weight > 0.0).then(|| sum / weight)
}

/// The turn from a line at map angle `angle_rad` onto its nearest of `directions`, wrapped
/// to (−π/2, π/2]; `None` without directions.
fn nearest_direction_rad(directions: &[f64], angle_rad: f64) -> Option<f64> {
    directions
        .iter()
        .map(|d| wrap_half_pi(d - angle_rad))
        .min_by(|a, b| a.abs().total_cmp(&b.abs()))
}

/// Half width of [`heading_mode_to_directions`]' kernel, radians: a drawn wall's direction
/// error (a person draws a wall within a degree or two of its neighbours).
const MODE_KERNEL_RAD: f64 = 2.0 * PI / 180.0;

/// Step of [`heading_mode_to_directions`]' search, radians (an eighth of the kernel).
const MODE_STEP_RAD: f64 = MODE_KERNEL_RAD / 8.0;

/// The heading correction within `±max_error_rad` that lays the most of the scan's long
/// lines (robot frame, seen from `heading_rad`) on the drawing's dominant `directions`,
/// for a heading known only that well (a start marked by hand). Each correction `δ` is
/// scored `J(δ) = Σ ℓ_j · max(0, 1 − (r_j(δ) / κ)²)`, `r_j(δ)` the line's angle at
/// `heading_rad + δ` from its nearest direction (wrapped to (−π/2, π/2]), `ℓ_j` its length
/// and `κ` = 2° a drawn wall's direction error; the best `δ` on a grid of κ/8 is refined by
/// [`heading_to_directions`] at the kernel's width. `max_error_rad` is clipped to below
/// half the smallest angle between two directions, where a correction is unambiguous (45°
/// for a rectangular building). `None` when the best `δ` lays less than
/// `config.min_support_m` of wall on a direction. Cost O(lines · directions · steps).
pub fn heading_mode_to_directions(
    scan_lines: &[ScanLine],
    heading_rad: f64,
    directions: &[f64],
    max_error_rad: f64,
    config: &DirectionMatchConfig,
) -> Option<f64> {
    let long: Vec<&ScanLine> = scan_lines
        .iter()
        .filter(|l| l.length_m() >= config.min_line_m)
        .collect();
    if long.is_empty() || directions.is_empty() {
        return None;
    }
    let mut min_gap = PI;
    for (i, a) in directions.iter().enumerate() {
        for b in &directions[i + 1..] {
            min_gap = min_gap.min(wrap_half_pi(a - b).abs());
        }
    }
    let reach = max_error_rad.min(0.49 * min_gap).max(0.0);
    let score = |delta: f64| -> f64 {
        long.iter()
            .map(|l| {
                let r = nearest_direction_rad(directions, heading_rad + delta + l.angle_rad);
                let z = r.unwrap_or(PI) / MODE_KERNEL_RAD;
                l.length_m() * (1.0 - z * z).max(0.0)
            })
            .sum()
    };
    let steps = (reach / MODE_STEP_RAD).floor() as i64;
    let (best, _) = (-steps..=steps)
        .map(|i| i as f64 * MODE_STEP_RAD)
        .map(|delta| (delta, score(delta)))
        .fold(
            (0.0, f64::NEG_INFINITY),
            |b, c| if c.1 > b.1 { c } else { b },
        );
    let refine = DirectionMatchConfig {
        tolerance_rad: MODE_KERNEL_RAD,
        ..*config
    };
    heading_to_directions(scan_lines, heading_rad + best, directions, &refine)
        .map(|fine| best + fine)
        .filter(|delta| delta.abs() <= reach + MODE_KERNEL_RAD)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::Point2;

    /// A scan wall of `len_m` from (0, 1) at `angle` in the robot frame.
    fn along(angle: f64, len_m: f64) -> ScanLine {
        let (s, c) = angle.sin_cos();
        ScanLine::from_endpoints(
            Point2::new(0.0, 1.0),
            Point2::new(len_m * c, 1.0 + len_m * s),
            50,
        )
        .unwrap()
    }

    fn sketch_line(i: usize, a: (f64, f64), b: (f64, f64)) -> SketchLine {
        SketchLine::new(i, Point2::new(a.0, a.1), Point2::new(b.0, b.1))
    }

    #[test]
    fn a_wobbly_rectangle_has_two_directions() {
        // Sides drawn 2° off either way (pixels, v downwards): they average out.
        let t = 2f64.to_radians().tan();
        let lines = [
            sketch_line(0, (0.0, 0.0), (100.0, 100.0 * t)),
            sketch_line(1, (0.0, 50.0), (100.0, 50.0 - 100.0 * t)),
            sketch_line(2, (0.0, 0.0), (0.0, 50.0)),
            sketch_line(3, (100.0, 0.0), (100.0, 50.0)),
            sketch_line(4, (10.0, 10.0), (14.0, 14.0)), // a short diagonal scribble
        ];
        let d = dominant_directions(&lines, 0.1);
        assert_eq!(d.len(), 2, "{d:?}");
        // Horizontal first (200 px against 100 px), then vertical.
        assert!(wrap_half_pi(d[0]).abs() < 1e-9, "{d:?}");
        assert!((d[1] - PI / 2.0).abs() < 1e-9, "{d:?}");
    }

    #[test]
    fn a_start_marked_twelve_degrees_off_is_found_from_the_walls() {
        // The robot really stands at 12° while the mark says 0°: its walls along x and y
        // run at −12° and 78° in its frame. Beyond [`heading_to_directions`]' 8° tolerance,
        // within the mode search's reach (±20°).
        let e = 12f64.to_radians();
        // Two long walls, a short one, and a 3 m shelf at 25° that no drawing shows.
        let lines = [
            along(-e, 5.0),
            along(PI / 2.0 - e, 3.0),
            along(0.3, 0.5),
            along(25f64.to_radians(), 3.0),
        ];
        let d = [0.0, PI / 2.0];
        let config = DirectionMatchConfig::default();
        assert!(heading_to_directions(&lines, 0.0, &d, &config).is_none());
        let c = heading_mode_to_directions(&lines, 0.0, &d, 20f64.to_radians(), &config).unwrap();
        assert!((c - e).abs() < 1e-9, "{}", c.to_degrees());
        // Outside the reach, or with too little wall, no correction.
        assert!(heading_mode_to_directions(&lines, 0.0, &d, 8f64.to_radians(), &config).is_none());
        assert!(
            heading_mode_to_directions(&lines[2..3], 0.0, &d, 20f64.to_radians(), &config)
                .is_none()
        );
        // Directions 30° apart: the reach shrinks below 15°, where 12° is still unambiguous.
        let tri = [0.0, 30f64.to_radians()];
        let c = heading_mode_to_directions(&lines[..1], 0.0, &tri, 20f64.to_radians(), &config);
        assert!(c.is_some_and(|c| (c - e).abs() < 1e-9), "{c:?}");
    }

    #[test]
    fn scan_walls_give_the_heading_error() {
        // Walls along x and y seen from a heading believed to be 0 while the robot is
        // really turned by +3°: in its frame the walls run at −3° and 87°.
        let e = 3f64.to_radians();
        let lines = [along(-e, 4.0), along(PI / 2.0 - e, 2.0), along(0.7, 0.5)];
        let d = [0.0, PI / 2.0];
        let c = heading_to_directions(&lines, 0.0, &d, &DirectionMatchConfig::default()).unwrap();
        // Correction +3°: the heading is 3° more than believed.
        assert!((c - e).abs() < 1e-9, "{}", c.to_degrees());
        // Too little wall: no correction.
        assert!(
            heading_to_directions(&lines[1..], 0.0, &d, &DirectionMatchConfig::default()).is_none()
        );
        // A wall 20° off every direction is not evidence.
        let skew = [along(20f64.to_radians(), 5.0)];
        assert!(heading_to_directions(&skew, 0.0, &d, &DirectionMatchConfig::default()).is_none());
    }
}
