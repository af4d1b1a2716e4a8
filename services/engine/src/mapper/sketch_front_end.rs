//! The `sketch` method's front end: the paper's Fig. 2 pipeline for one scan, called once
//! per scan by the mapper (through [`super::front_end`]) with the odometry prediction:
//!
//! 1. MCL on the drawing with scale: predict with the odometry increment (eq. 1–2), weigh
//!    with the scan (eq. 3), detect breakdown and recover (section 3.2);
//! 2. the sketch lines the robot really observes, by the line observation probability
//!    (eq. 4) at the MCL estimate;
//! 3. RANSAC lines of the scan matched to them; the mean angle difference corrects the
//!    robot's heading in the map frame (eq. 5) — the map frame's axes are the drawing's, and
//!    a drawing's walls have the right directions even where its proportions are wrong, so
//!    the heading cannot drift;
//! 4. point-to-line ICP with that heading held corrects the position (eq. 6), against the
//!    submap of the last meters, the map built so far or the previous scan
//!    (`MapperConfig::keyframe_icp_reference`).
//!
//! It returns the pose, MCL's report and the scan lines it extracted; it never calls the
//! back end. When the back end has moved the map (`FrontEndInput::map_revision`), the ICP
//! reference built on the old poses is dropped and the previous scan is placed at the
//! corrected `last_pose`.

use super::config::{MapperConfig, SketchPrior};
use super::front_end_io::{FrontEndInput, FrontEndOutput, SketchReport};
use super::keyframe_icp::KeyframeIcp;
use crate::EngineError;
use crate::lines::matching::{HeadingAggregate, MatchConfig, heading_correction, match_lines};
use crate::lines::ransac::{RansacConfig, extract_lines};
use crate::localization::line_observation::{
    LineObservationConfig, observe_lines, observed_indices,
};
use crate::localization::mcl::{SketchMcl, StartSpread};
use crate::localization::recovery::{
    FailureConfig, FailureDetector, ObservationPoints, RecoveryConfig, recover_mcl,
};
use crate::scan_matching::icp::IcpMode;
use crate::sketch::raycast::SketchRaycaster;
use crate::sketch::{Sketch, SketchPose};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Pose2;
use std::sync::Arc;

/// Spacing of the recovery's candidate observation points, meters at the guessed scale.
const OBSERVATION_POINT_SPACING_M: f64 = 0.5;

/// MCL score from which its estimate picks the sketch lines for eq. (5).
const MIN_TRUSTED_SCORE: f64 = 0.6;

/// Distinct sketch lines that must be matched before eq. (5) is used: one wall alone
/// carries its own drawing error into the heading.
const MIN_DISTINCT_LINES: usize = 2;

/// Eq. (5) pairs farther than this from their median are left out of the mean, radians.
const HEADING_INLIER_TOLERANCE_RAD: f64 = 0.1;

/// The `sketch` method's front end.
pub(super) struct SketchFrontEnd {
    sketch: Arc<Sketch>,
    raycaster: SketchRaycaster,
    mcl: SketchMcl,
    detector: FailureDetector,
    /// Candidate observation points of the recovery, computed at the first breakdown.
    observation_points: Option<ObservationPoints>,
    /// Spacing of those points, pixels.
    observation_spacing_px: f64,
    /// Lines observed at the last frame where MCL was sound.
    last_good_lines: Vec<usize>,
    rng: ChaCha8Rng,
    observation: LineObservationConfig,
    ransac: RansacConfig,
    /// Step 4: point-to-line ICP against a keyframe (or the map).
    matcher: KeyframeIcp,
    /// Share of eq. (5)'s heading difference applied per scan (1 = the paper's hard
    /// correction with translation-only ICP).
    heading_gain: f64,
    /// Heading differences within this band are taken as drawing error, radians.
    heading_deadband_rad: f64,
}

impl SketchFrontEnd {
    /// A front end on `prior`'s drawing, starting at its marked start and scale guess.
    pub(super) fn new(prior: SketchPrior, config: &MapperConfig) -> Result<Self, EngineError> {
        let start = prior.start;
        let finite = start.u_px.is_finite()
            && start.v_px.is_finite()
            && start.heading_rad.is_finite()
            && start.meters_per_pixel.is_finite();
        if !finite || start.meters_per_pixel <= 0.0 {
            return Err(EngineError::InvalidParameter {
                name: "start",
                reason: "the start and the scale must be finite, the scale positive".into(),
            });
        }
        if !prior.sketch.contains(start.u_px, start.v_px) {
            return Err(EngineError::InvalidParameter {
                name: "start",
                reason: format!(
                    "({:.1}, {:.1}) is outside the {}×{} drawing",
                    start.u_px, start.v_px, prior.sketch.width_px, prior.sketch.height_px
                ),
            });
        }
        if prior.sketch.lines.is_empty() {
            return Err(EngineError::NoLines);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        let raycaster = SketchRaycaster::new(&prior.sketch);
        let mcl = SketchMcl::new(config.mcl.clone(), start, StartSpread::default(), &mut rng)?;
        Ok(Self {
            raycaster,
            mcl,
            detector: FailureDetector::new(FailureConfig::default()),
            observation_points: None,
            observation_spacing_px: (OBSERVATION_POINT_SPACING_M / start.meters_per_pixel).max(2.0),
            last_good_lines: Vec::new(),
            rng,
            observation: LineObservationConfig::default(),
            ransac: RansacConfig::default(),
            matcher: KeyframeIcp::new(config),
            heading_gain: config.sketch_heading_gain.clamp(0.0, 1.0),
            heading_deadband_rad: config.sketch_heading_band_rad(),
            sketch: prior.sketch,
        })
    }

    /// MCL's current estimate on the drawing.
    pub(super) fn sketch_pose(&self) -> SketchPose {
        self.mcl.estimate()
    }

    /// True when the ICP reference comes from the grid.
    pub(super) fn reads_map(&self) -> bool {
        self.matcher.reads_map()
    }

    /// One scan: steps 1–4 of the module docs.
    pub(super) fn track(&mut self, input: &FrontEndInput) -> FrontEndOutput {
        let FrontEndInput {
            frame,
            increment,
            predicted,
            ..
        } = *input;
        let (scan, points) = (frame.scan, &frame.points[..]);
        // 1. MCL on the drawing (eq. 1–3, section 3.2).
        self.mcl.predict(increment, &mut self.rng);
        let outcome = self.mcl.update(scan, &self.raycaster);
        let failed = outcome.beams > 0
            && self
                .detector
                .detect_failure(&self.mcl.estimate(), outcome.score, &self.raycaster)
                .is_some();
        if failed {
            let spacing = self.observation_spacing_px;
            let points = self.observation_points.get_or_insert_with(|| {
                ObservationPoints::precompute(&self.sketch, &self.raycaster, spacing)
            });
            let recovery = RecoveryConfig {
                particles: self.mcl.particles().len(),
                ..RecoveryConfig::default()
            };
            if recover_mcl(
                &mut self.mcl,
                points,
                &self.last_good_lines,
                &recovery,
                &mut self.rng,
            ) {
                self.detector.reset();
                // Weigh the new cloud with this scan before trusting its estimate.
                self.mcl.update(scan, &self.raycaster);
            }
        }
        let sketch_pose = self.mcl.estimate();

        // 2. Lines really observed (eq. 4).
        let observed = observed_indices(&observe_lines(
            &sketch_pose,
            scan,
            &self.raycaster,
            &self.observation,
        ));
        if !failed && !observed.is_empty() {
            self.last_good_lines.clone_from(&observed);
        }

        // 3. Heading (eq. 5): the sketch lines are brought into the robot frame with the
        // predicted map heading (the map frame's axes are the drawing's), so the correction
        // is the heading's error, not MCL's.
        let mut delta_rad = None;
        let mut scan_lines = None;
        // With a view through the warp fitted to the map, the walls in view are those seen
        // from where W puts the robot. Without, only a sound localization on the drawing
        // picks the right lines: a lost MCL pairs scan walls with the wrong sketch walls and
        // would steer the heading.
        let from_warp = input.drawing_view.map(|view| {
            let in_view = observe_lines(&view, scan, &self.raycaster, &self.observation);
            (view, observed_indices(&in_view))
        });
        let (view, in_view, trusted): (SketchPose, &[usize], bool) = match &from_warp {
            Some((view, in_view)) => (*view, in_view, true),
            None => (
                SketchPose {
                    heading_rad: predicted.heading_rad,
                    ..sketch_pose
                },
                &observed,
                !failed && self.mcl.score() >= MIN_TRUSTED_SCORE,
            ),
        };
        if trusted && !in_view.is_empty() && points.len() >= 10 {
            let extracted = extract_lines(points, &self.ransac, &mut self.rng);
            let lines: Vec<_> = in_view.iter().map(|&i| self.sketch.lines[i]).collect();
            let pairs = match_lines(&lines, &view, &extracted, &MatchConfig::default());
            let aggregate = HeadingAggregate::InlierMean {
                tolerance_rad: HEADING_INLIER_TOLERANCE_RAD,
            };
            let distinct = pairs
                .iter()
                .map(|p| p.sketch_index)
                .collect::<std::collections::BTreeSet<_>>();
            if distinct.len() >= MIN_DISTINCT_LINES {
                delta_rad = heading_correction(&pairs, aggregate);
            }
            scan_lines = Some(extracted);
        }

        // 4. Position (eq. 6) by point-to-line ICP. With the paper's hard correction
        // (gain 1) the heading of eq. (5) is held and ICP solves the translation only;
        // with a gain below 1, ICP solves the full pose against the map and the sketch's
        // heading pulls it by that fraction of eq. (5)'s difference per scan.
        let hard = self.heading_gain >= 1.0;
        let guess = match delta_rad {
            Some(d) if hard => Pose2::new(predicted.x, predicted.y, predicted.heading_rad + d),
            _ => predicted,
        };
        let mode = if hard {
            IcpMode::TranslationOnly
        } else {
            IcpMode::Full
        };
        let matched = self.matcher.align(input, guess, mode);
        let aligned = matched.pose;
        let map_pose = match delta_rad {
            // eq. (5)'s difference measured at the prediction, re-referred to the ICP heading.
            Some(d) if !hard => {
                let residual = predicted.heading_rad + d - aligned.heading_rad;
                let residual = sketchslam_types::wrap_half_pi(residual);
                // Only the part beyond the drawing's own angular error is evidence of drift.
                let excess =
                    residual.signum() * (residual.abs() - self.heading_deadband_rad).max(0.0);
                Pose2::new(
                    aligned.x,
                    aligned.y,
                    aligned.heading_rad + self.heading_gain * excess,
                )
            }
            _ => aligned,
        };
        self.matcher.done(points);
        FrontEndOutput {
            pose: map_pose,
            covariance: Some(matched.covariance),
            scan_lines,
            sketch: Some(SketchReport {
                sketch_pose,
                recoveries: self.mcl.recoveries() as u32,
                lines_observed: observed.len(),
                localization_score: self.mcl.score(),
            }),
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::mapper::frame::ScanFrame;
    use crate::mapping::grid::OccupancyGrid;
    use crate::scan_matching::odometry_noise::OdometryPath;
    use crate::sketch::SketchLine;
    use sketchslam_types::{Point2, Scan};

    /// A 10 × 6 m room with a 2 × 1 m pillar drawn at 0.05 m per pixel, map point (x, y)
    /// at pixel (10 + x / 0.05, 130 − y / 0.05).
    pub(in crate::mapper) fn room() -> Sketch {
        let px = |x: f64, y: f64| Point2::new(10.0 + x / 0.05, 130.0 - y / 0.05);
        let walls = [
            ((0.0, 0.0), (10.0, 0.0)),
            ((10.0, 0.0), (10.0, 6.0)),
            ((10.0, 6.0), (0.0, 6.0)),
            ((0.0, 6.0), (0.0, 0.0)),
            ((4.0, 2.5), (6.0, 2.5)),
            ((6.0, 2.5), (6.0, 3.5)),
            ((6.0, 3.5), (4.0, 3.5)),
            ((4.0, 3.5), (4.0, 2.5)),
        ];
        Sketch {
            width_px: 220,
            height_px: 140,
            strokes: fixedbitset::FixedBitSet::with_capacity(220 * 140),
            lines: walls
                .iter()
                .enumerate()
                .map(|(i, (a, b))| SketchLine::new(i, px(a.0, a.1), px(b.0, b.1)))
                .collect(),
        }
    }

    /// The scan of a 270° LiDAR (271 beams, 15 m) at map pose `at` in [`room`], ray-cast
    /// by `raycaster` on it.
    pub(in crate::mapper) fn scan_at(raycaster: &SketchRaycaster, at: Pose2) -> Scan {
        let fov = 270f64.to_radians();
        let ranges = (0..271)
            .map(|i| {
                let a = at.heading_rad - fov / 2.0 + i as f64 * fov / 270.0;
                raycaster
                    .cast(10.0 + at.x / 0.05, 130.0 - at.y / 0.05, a, 300.0)
                    .map_or(f32::INFINITY, |h| (h.range_px * 0.05) as f32)
            })
            .collect();
        Scan::centred(fov, 0.05, 15.0, ranges)
    }

    /// With the paper's hard correction, one scan whose predicted heading is 6° off: the
    /// heading eq. (5) gives it, with and without a view on the drawing from the warp. MCL
    /// starts 6 m and 90° from the robot, so it cannot pick the walls itself.
    fn corrected_heading_deg(view_from_warp: bool) -> (f64, f64) {
        let sketch = Arc::new(room());
        let truth = Pose2::new(2.0, 1.5, 0.0);
        let config = MapperConfig {
            sketch_heading_gain: 1.0,
            ..MapperConfig::default()
        };
        let far_start = SketchPose {
            u_px: 10.0 + 8.0 / 0.05,
            v_px: 130.0 - 1.5 / 0.05,
            heading_rad: std::f64::consts::FRAC_PI_2,
            meters_per_pixel: 0.05,
        };
        let prior = SketchPrior {
            sketch: sketch.clone(),
            start: far_start,
        };
        let mut front_end = SketchFrontEnd::new(prior, &config).unwrap();
        let scan = scan_at(&SketchRaycaster::new(&sketch), truth);
        let frame = ScanFrame::new(&scan).unwrap();
        let predicted = Pose2::new(truth.x, truth.y, 6f64.to_radians());
        let grid = OccupancyGrid::new(config.grid);
        // An exact warp's view: the true position, the predicted heading (W turns nothing).
        let view = SketchPose {
            u_px: 10.0 + truth.x / 0.05,
            v_px: 130.0 - truth.y / 0.05,
            heading_rad: predicted.heading_rad,
            meters_per_pixel: 0.05,
        };
        let input = FrontEndInput {
            frame: &frame,
            increment: Pose2::IDENTITY,
            path: OdometryPath::default(),
            last_pose: predicted,
            predicted,
            map_revision: 0,
            grid: &grid,
            drawing_view: view_from_warp.then_some(view),
        };
        let out = front_end.track(&input);
        let score = out.sketch.unwrap().localization_score;
        (out.pose.heading_rad.to_degrees(), score)
    }

    #[test]
    fn the_warps_view_picks_the_walls_where_mcl_is_lost() {
        let (through_warp, score) = corrected_heading_deg(true);
        assert!(score < MIN_TRUSTED_SCORE, "MCL is not lost: score {score}");
        assert!(
            through_warp.abs() < 0.5,
            "heading {through_warp}° (truth 0°)"
        );
        // Without the view, the lost MCL picks nothing and the 6° stay.
        let (through_mcl, _) = corrected_heading_deg(false);
        assert!((through_mcl - 6.0).abs() < 1e-9, "heading {through_mcl}°");
    }
}
