//! The line observation probability, eq. (4) of Akiba et al.: which sketch lines the robot
//! really observes from the pose MCL estimated on the drawing.
//!
//! Where in the pipeline: step 3 of every scan of a `sketch` session, after MCL
//! ([`crate::localization::mcl`]). The observed lines are matched with the scan's RANSAC lines
//! (eq. 5, heading correction) and used by point-to-line ICP (eq. 6); the set observed in the
//! last good frame is what recovery ([`crate::localization::recovery`]) restarts from.
//!
//! # Eq. (4)
//! From the estimate `x = (u, v, θ, s)`, every beam `i` is ray-traced on the sketch: it hits
//! line `L(i)` at pseudo-range `l_i` (pixels). For line `j` with the beams
//! `B_j = { i : L(i) = j }` that hit it, the probability that the robot really observes it is
//!
//! `P_j = (1 / |B_j|) · Σ_{i ∈ B_j} exp(−(r_i − s·l_i)² / (2σ²))`
//!
//! with `r_i` the measured range (meters) and σ the sensor's uncertainty. Line `j` counts as
//! observed when `|B_j| ≥ min_beams` and `P_j ≥ threshold`.
//!
//! Where the paper is vague we chose:
//! - **which beams**: every `beam_stride`-th beam of the scan (default: all), so short lines
//!   get enough beams; a beam with no return, or whose ray hits no line, counts for no line;
//! - **σ**: a constant plus a part proportional to the range, like MCL's σ(r), because a
//!   sketch's length errors grow with distance (defaults 0.2 m + 5 %);
//! - **line of a beam**: the line the ray crosses first (exact intersection) rather than a
//!   nearest-neighbour search around the ray's end, which is the same line except at corners;
//! - **averaging**: the mean over `B_j` (a line partly hidden by an obstacle gets a lower
//!   probability, in proportion to the hidden part);
//! - **min_beams** 5 and **threshold** 0.5: one or two grazing beams do not make a line
//!   observed.
//!
//! Cost: `B / beam_stride` ray casts + O(B + lines).

use crate::sketch::SketchPose;
use crate::sketch::raycast::SketchRaycaster;
use sketchslam_types::Scan;

/// Parameters of eq. (4).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LineObservationConfig {
    /// Constant part of σ, meters (0.2).
    pub sigma_m: f64,
    /// Range-proportional part of σ: σ(r) = `sigma_m` + `sigma_rel`·r (0.05).
    pub sigma_rel: f64,
    /// Use every `beam_stride`-th beam (1: all).
    pub beam_stride: usize,
    /// Fewest beams on a line for it to count as observed (5).
    pub min_beams: usize,
    /// Probability at or above which a line counts as observed (0.5).
    pub threshold: f64,
    /// Range cap when the scan's own is not a positive finite number, meters (30).
    pub fallback_range_max_m: f64,
}

impl Default for LineObservationConfig {
    fn default() -> Self {
        Self {
            sigma_m: 0.2,
            sigma_rel: 0.05,
            beam_stride: 1,
            min_beams: 5,
            threshold: 0.5,
            fallback_range_max_m: 30.0,
        }
    }
}

/// Eq. (4) for one sketch line.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LineObservation {
    /// Index of the line in the sketch.
    pub index: usize,
    /// `P_j` of eq. (4), 0..1.
    pub probability: f64,
    /// Indices (in the scan) of the beams whose pseudo-range hit this line.
    pub beams: Vec<usize>,
    /// True when `beams.len() ≥ min_beams` and `probability ≥ threshold`.
    pub observed: bool,
}

/// Eq. (4) for every sketch line that at least one beam's pseudo-range hits from `pose`,
/// sorted by line index. Lines no beam reaches (behind walls, out of the field of view)
/// are absent. An invalid pose (non-finite, non-positive scale, outside the image) gives
/// an empty result.
pub fn observe_lines(
    pose: &SketchPose,
    scan: &Scan,
    raycaster: &SketchRaycaster,
    config: &LineObservationConfig,
) -> Vec<LineObservation> {
    let s = pose.meters_per_pixel;
    let valid = pose.u_px.is_finite()
        && pose.v_px.is_finite()
        && pose.heading_rad.is_finite()
        && s.is_finite()
        && s > 0.0
        && raycaster.contains(pose.u_px, pose.v_px);
    if !valid {
        return Vec::new();
    }
    let n_lines = raycaster.lines().len();
    let mut sums = vec![0.0f64; n_lines];
    let mut beams: Vec<Vec<usize>> = vec![Vec::new(); n_lines];
    let max_px = scan.range_max_m_or(config.fallback_range_max_m) / s;
    let stride = config.beam_stride.max(1);
    for i in (0..scan.ranges_m.len()).step_by(stride) {
        if !scan.is_return(i) {
            continue;
        }
        let angle = pose.heading_rad + scan.beam_angle_rad(i);
        let Some(hit) = raycaster.cast(pose.u_px, pose.v_px, angle, max_px) else {
            continue;
        };
        let r = scan.ranges_m[i] as f64;
        let sigma = (config.sigma_m + config.sigma_rel * r).max(1e-6);
        let e = (r - s * hit.range_px) / sigma;
        sums[hit.line_index] += (-0.5 * e * e).exp();
        beams[hit.line_index].push(i);
    }
    beams
        .into_iter()
        .enumerate()
        .filter(|(_, b)| !b.is_empty())
        .map(|(index, beams)| {
            let probability = sums[index] / beams.len() as f64;
            LineObservation {
                index,
                probability,
                observed: beams.len() >= config.min_beams && probability >= config.threshold,
                beams,
            }
        })
        .collect()
}

/// The indices of the observed lines, ascending.
pub fn observed_indices(observations: &[LineObservation]) -> Vec<usize> {
    observations
        .iter()
        .filter(|o| o.observed)
        .map(|o| o.index)
        .collect()
}
