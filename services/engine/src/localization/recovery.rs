//! Failure detection and recovery of MCL on the sketch, section 3.2 of Akiba et al.
//!
//! Where in the pipeline: after MCL's update of every scan. [`FailureDetector`] decides
//! whether localization on the drawing broke down — the estimate stands inside a drawn
//! wall, lies outside the drawing, or the scan stopped agreeing with the drawing for a few
//! frames. Then [`recover`] rebuilds the particle cloud around the places of the drawing
//! from which the sketch lines observed in the last good frame (eq. 4,
//! [`crate::localization::line_observation`]) are visible — precomputed once per sketch as
//! [`ObservationPoints`] — keeping the scale and heading estimates, and MCL runs again
//! ([`crate::localization::mcl::SketchMcl::restart_with`] counts it).

use crate::localization::mcl::{Particle, SketchMcl, gaussian};
use crate::sketch::raycast::SketchRaycaster;
use crate::sketch::{Sketch, SketchPose};
use rand::Rng;
use sketchslam_types::wrap_angle;

/// When MCL on the sketch counts as broken down.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FailureConfig {
    /// The estimate closer than this to a line stands in a wall, pixels (1.5).
    pub wall_clearance_px: f64,
    /// Score (see [`SketchMcl::score`]) below which a frame counts as collapsed (0.15).
    pub score_threshold: f64,
    /// Consecutive collapsed frames that make a failure (3): one bad scan (a person in
    /// front of the robot) is not a breakdown.
    pub low_score_frames: usize,
    /// Check that the estimate is inside the drawing's outer boundary (8 ray casts).
    pub check_inside_drawing: bool,
}

impl Default for FailureConfig {
    fn default() -> Self {
        Self {
            wall_clearance_px: 1.5,
            score_threshold: 0.15,
            low_score_frames: 3,
            check_inside_drawing: true,
        }
    }
}

/// Why MCL on the sketch broke down.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Failure {
    /// The estimate stands inside a drawn wall.
    InsideWall,
    /// The estimate lies outside the image or the drawing's outer boundary.
    OutsideDrawing,
    /// The score stayed below the threshold for this many consecutive frames.
    LikelihoodCollapse {
        /// Consecutive low-score frames.
        frames: usize,
    },
}

/// Section 3.2's breakdown test, with the count of consecutive low-score frames.
#[derive(Debug, Clone, Default)]
pub struct FailureDetector {
    config: FailureConfig,
    low_frames: usize,
}

impl FailureDetector {
    /// A detector with no low-score frame yet.
    pub fn new(config: FailureConfig) -> Self {
        Self {
            config,
            low_frames: 0,
        }
    }

    /// Checks one frame's estimate and score (call once per MCL update). A non-finite pose
    /// or score counts as a failure (outside the drawing / collapsed frame). O(1), plus 8
    /// casts when `check_inside_drawing`.
    pub fn detect_failure(
        &mut self,
        estimate: &SketchPose,
        score: f64,
        raycaster: &SketchRaycaster,
    ) -> Option<Failure> {
        if score.is_finite() && score >= self.config.score_threshold {
            self.low_frames = 0;
        } else {
            self.low_frames += 1;
        }
        // `contains` is false for non-finite coordinates.
        if !raycaster.contains(estimate.u_px, estimate.v_px) {
            return Some(Failure::OutsideDrawing);
        }
        if raycaster.distance_to_wall_px(estimate.u_px, estimate.v_px)
            < self.config.wall_clearance_px
        {
            return Some(Failure::InsideWall);
        }
        if self.config.check_inside_drawing
            && !raycaster.inside_drawing(estimate.u_px, estimate.v_px)
        {
            return Some(Failure::OutsideDrawing);
        }
        (self.low_frames >= self.config.low_score_frames.max(1)).then_some(
            Failure::LikelihoodCollapse {
                frames: self.low_frames,
            },
        )
    }

    /// Forgets the low-score frames (after a recovery).
    pub fn reset(&mut self) {
        self.low_frames = 0;
    }

    /// Consecutive low-score frames so far.
    pub fn low_score_frames(&self) -> usize {
        self.low_frames
    }
}

/// A candidate place of the drawing and the sketch lines visible from it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObservationPoint {
    /// Column, pixels.
    pub u_px: f64,
    /// Row, pixels.
    pub v_px: f64,
    /// Indices of the lines hit by at least one of the probe rays, ascending.
    pub visible_lines: Vec<usize>,
}

/// How observation points are laid out and probed.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObservationPointsConfig {
    /// Grid spacing, pixels.
    pub spacing_px: f64,
    /// Probe rays per point, evenly spaced over 360° (72: every 5°).
    pub rays: usize,
    /// Probe range, pixels (`None`: the image diagonal).
    pub max_range_px: Option<f64>,
    /// Share of probe rays that must hit a line for the point to be inside the drawing
    /// (0.75: a point outside the outer walls sees lines only on one side).
    pub min_enclosure: f64,
    /// Smallest distance from a point to any line, pixels (2).
    pub clearance_px: f64,
}

impl ObservationPointsConfig {
    /// Defaults for a grid `spacing_px` apart.
    pub fn with_spacing(spacing_px: f64) -> Self {
        Self {
            spacing_px,
            rays: 72,
            max_range_px: None,
            min_enclosure: 0.75,
            clearance_px: 2.0,
        }
    }
}

/// Candidate observation points over the drawing's free space (section 3.2), precomputed
/// once per sketch.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ObservationPoints {
    /// Grid spacing used, pixels.
    pub spacing_px: f64,
    /// The points, row by row.
    pub points: Vec<ObservationPoint>,
}

/// At most this many grid points are probed (the spacing grows to fit).
const MAX_GRID_POINTS: f64 = 250_000.0;

impl ObservationPoints {
    /// Points on a `spacing_px` grid that are free and inside the drawing, with the lines
    /// each sees; see [`ObservationPointsConfig::with_spacing`] for the other defaults.
    pub fn precompute(sketch: &Sketch, raycaster: &SketchRaycaster, spacing_px: f64) -> Self {
        Self::precompute_with(
            sketch,
            raycaster,
            &ObservationPointsConfig::with_spacing(spacing_px),
        )
    }

    /// As [`ObservationPoints::precompute`] with every parameter given. Cost:
    /// `O(W·H / spacing² · rays · C)`, `C` one ray cast. A non-positive or non-finite
    /// spacing gives no points.
    pub fn precompute_with(
        sketch: &Sketch,
        raycaster: &SketchRaycaster,
        config: &ObservationPointsConfig,
    ) -> Self {
        let (w, h) = (sketch.width_px as f64, sketch.height_px as f64);
        if !(config.spacing_px.is_finite() && config.spacing_px > 0.0) || config.rays == 0 {
            return Self::default();
        }
        let spacing = config
            .spacing_px
            .max((w * h / MAX_GRID_POINTS).sqrt())
            .max(0.5);
        let max_px = config
            .max_range_px
            .filter(|r| r.is_finite() && *r > 0.0)
            .unwrap_or_else(|| w.hypot(h));
        let mut points = Vec::new();
        let mut v = spacing / 2.0;
        while v < h {
            let mut u = spacing / 2.0;
            while u < w {
                if raycaster.distance_to_wall_px(u, v) >= config.clearance_px {
                    let mut seen = Vec::new();
                    let mut hits = 0usize;
                    for k in 0..config.rays {
                        let a = k as f64 * std::f64::consts::TAU / config.rays as f64;
                        if let Some(hit) = raycaster.cast(u, v, a, max_px) {
                            hits += 1;
                            seen.push(hit.line_index);
                        }
                    }
                    if hits as f64 >= config.min_enclosure * config.rays as f64 {
                        seen.sort_unstable();
                        seen.dedup();
                        points.push(ObservationPoint {
                            u_px: u,
                            v_px: v,
                            visible_lines: seen,
                        });
                    }
                }
                u += spacing;
            }
            v += spacing;
        }
        Self {
            spacing_px: spacing,
            points,
        }
    }
}

/// How the cloud is rebuilt.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RecoveryConfig {
    /// Particles in the new cloud (500).
    pub particles: usize,
    /// At most this many best points share the particles (250).
    pub max_points: usize,
    /// Position sd around each point, in grid spacings (0.5).
    pub position_sd_spacings: f64,
    /// Heading sd around the current heading estimate, radians (0.15).
    pub heading_sd_rad: f64,
    /// Sd of ln s around the current scale estimate (0.05).
    pub scale_sd_rel: f64,
}

impl Default for RecoveryConfig {
    fn default() -> Self {
        Self {
            particles: 500,
            max_points: 250,
            position_sd_spacings: 0.5,
            heading_sd_rad: 0.15,
            scale_sd_rel: 0.05,
        }
    }
}

/// Section 3.2's recovery: a new particle cloud around the observation points that see the
/// lines observed in the last good frame.
///
/// Each point is ranked by its overlap `|V ∩ O| / |O|` with the last observed lines `O`
/// (`V` its visible lines); among the points of best overlap, those whose visible set is
/// closest to `O` (Jaccard `|V ∩ O| / |V ∪ O|`) and then nearest to the current estimate
/// come first; the first `max_points` share the particles equally. Particles are Gaussian
/// around their point, with the current heading and scale plus noise. Returns an empty
/// cloud (nothing to recover from) when `O` or `points` is empty, no point sees any line
/// of `O`, or `current` has a non-positive or non-finite scale. O(P·|V| + P log P).
pub fn recover(
    points: &ObservationPoints,
    last_observed_lines: &[usize],
    current: &SketchPose,
    config: &RecoveryConfig,
    rng: &mut impl Rng,
) -> Vec<Particle> {
    let s = current.meters_per_pixel;
    if last_observed_lines.is_empty()
        || points.points.is_empty()
        || config.particles == 0
        || !(s.is_finite() && s > 0.0)
    {
        return Vec::new();
    }
    let mut observed = last_observed_lines.to_vec();
    observed.sort_unstable();
    observed.dedup();
    let heading = if current.heading_rad.is_finite() {
        current.heading_rad
    } else {
        0.0
    };
    let (cu, cv) = (current.u_px, current.v_px);
    let mut ranked: Vec<(f64, f64, f64, usize)> = points
        .points
        .iter()
        .enumerate()
        .filter_map(|(k, p)| {
            let common = observed
                .iter()
                .filter(|l| p.visible_lines.binary_search(l).is_ok())
                .count();
            if common == 0 {
                return None;
            }
            let union = observed.len() + p.visible_lines.len() - common;
            let dist = (p.u_px - cu).hypot(p.v_px - cv);
            let dist = if dist.is_finite() { dist } else { 0.0 };
            Some((
                common as f64 / observed.len() as f64,
                common as f64 / union as f64,
                dist,
                k,
            ))
        })
        .collect();
    if ranked.is_empty() {
        return Vec::new();
    }
    let best = ranked.iter().map(|r| r.0).fold(0.0, f64::max);
    ranked.retain(|r| r.0 >= best - 1e-9);
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.2.total_cmp(&b.2)));
    ranked.truncate(config.max_points.max(1));
    let sd_px = config.position_sd_spacings.max(0.0) * points.spacing_px;
    let w = 1.0 / config.particles as f64;
    (0..config.particles)
        .map(|i| {
            let p = &points.points[ranked[i % ranked.len()].3];
            Particle {
                pose: SketchPose {
                    u_px: p.u_px + gaussian(rng, sd_px),
                    v_px: p.v_px + gaussian(rng, sd_px),
                    heading_rad: wrap_angle(heading + gaussian(rng, config.heading_sd_rad)),
                    meters_per_pixel: s * gaussian(rng, config.scale_sd_rel).exp(),
                },
                weight: w,
            }
        })
        .collect()
}

/// Recovers `mcl` in place: [`recover`] from its current estimate, then
/// [`SketchMcl::restart_with`] (which counts the recovery). Returns false when there was
/// nothing to recover from; `mcl` is then unchanged.
pub fn recover_mcl(
    mcl: &mut SketchMcl,
    points: &ObservationPoints,
    last_observed_lines: &[usize],
    config: &RecoveryConfig,
    rng: &mut impl Rng,
) -> bool {
    let current = mcl.estimate();
    let cloud = recover(points, last_observed_lines, &current, config, rng);
    !cloud.is_empty() && mcl.restart_with(cloud)
}
