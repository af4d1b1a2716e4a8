//! The `sketch` method's per-scan step (the paper's Fig. 2 pipeline), between the mapper
//! and the pure algorithms:
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
//!    map built so far or the previous scan (`MapperConfig::sketch_icp_reference`).

use super::{IcpReference, MapperConfig};
use crate::EngineError;
use crate::grid::OccupancyGrid;
use crate::icp::{Icp, IcpConfig, IcpMode};
use crate::line_match::{HeadingAggregate, MatchConfig, heading_correction, match_lines};
use crate::line_observation::{LineObservationConfig, observe_lines, observed_indices};
use crate::mcl::{SketchMcl, StartSpread};
use crate::ransac::{RansacConfig, extract_lines};
use crate::recovery::{
    FailureConfig, FailureDetector, ObservationPoints, RecoveryConfig, recover_mcl,
};
use crate::sketch::raycast::SketchRaycaster;
use crate::sketch::{Sketch, SketchPose};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_shared::{Point2, Pose2, Scan};
use std::sync::Arc;

use super::SketchPrior;

/// Map points farther than this from the robot are left out of the ICP reference, meters.
const ICP_REFERENCE_RADIUS_M: f64 = 20.0;

/// Spacing of the recovery's candidate observation points, meters at the guessed scale.
const OBSERVATION_POINT_SPACING_M: f64 = 0.5;

/// Eq. (5) pairs farther than this from their median are left out of the mean, radians.
const HEADING_INLIER_TOLERANCE_RAD: f64 = 0.1;

/// What one scan did to the sketch method's state.
pub(super) struct TrackOutput {
    /// Corrected pose in the map frame.
    pub map_pose: Pose2,
    /// MCL's estimate on the drawing.
    pub sketch_pose: SketchPose,
    /// Recoveries so far.
    pub recoveries: u32,
    /// Sketch lines observed at this scan.
    pub lines_observed: usize,
    /// MCL's localization score, 0..1.
    pub localization_score: f64,
}

/// The `sketch` method's state.
pub(super) struct SketchTracker {
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
    icp: IcpConfig,
    reference: IcpReference,
    /// The previous scan's points in the map frame.
    previous_points: Vec<Point2>,
}

impl SketchTracker {
    /// A tracker on `prior`'s drawing, starting at its marked start and scale guess.
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
            sketch: prior.sketch,
            raycaster,
            mcl,
            detector: FailureDetector::new(FailureConfig::default()),
            observation_points: None,
            observation_spacing_px: (OBSERVATION_POINT_SPACING_M / start.meters_per_pixel).max(2.0),
            last_good_lines: Vec::new(),
            rng,
            observation: LineObservationConfig::default(),
            ransac: RansacConfig::default(),
            icp: config.icp.clone(),
            reference: config.sketch_icp_reference,
            previous_points: Vec::new(),
        })
    }

    /// MCL's current estimate on the drawing.
    pub(super) fn sketch_pose(&self) -> SketchPose {
        self.mcl.estimate()
    }

    /// One scan: `increment` is the odometry motion since the last scan (robot frame),
    /// `predicted` the last corrected map pose carried forward by it.
    pub(super) fn on_scan(
        &mut self,
        scan: &Scan,
        points: &[Point2],
        increment: Pose2,
        _map_at_fix: Pose2,
        predicted: Pose2,
        grid: &OccupancyGrid,
    ) -> TrackOutput {
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
        let mut heading_rad = predicted.heading_rad;
        if !observed.is_empty() && points.len() >= 10 {
            let scan_lines = extract_lines(points, &self.ransac, &mut self.rng);
            let lines: Vec<_> = observed.iter().map(|&i| self.sketch.lines[i]).collect();
            let view = SketchPose {
                heading_rad: predicted.heading_rad,
                ..sketch_pose
            };
            let pairs = match_lines(&lines, &view, &scan_lines, &MatchConfig::default());
            let aggregate = HeadingAggregate::InlierMean {
                tolerance_rad: HEADING_INLIER_TOLERANCE_RAD,
            };
            if let Some(delta) = heading_correction(&pairs, aggregate) {
                heading_rad = predicted.heading_rad + delta;
            }
        }
        let guess = Pose2::new(predicted.x, predicted.y, heading_rad);

        // 4. Position (eq. 6) by point-to-line ICP with the heading held.
        let reference = self.reference_points(grid, &guess);
        let map_pose = if reference.len() >= 10 && points.len() >= 10 {
            let icp = Icp::new(&reference, self.icp.clone());
            let result = icp.align(points, guess, IcpMode::TranslationOnly);
            if result.converged {
                Pose2::new(result.pose.x, result.pose.y, heading_rad)
            } else {
                guess
            }
        } else {
            guess
        };
        self.previous_points = points.iter().map(|p| map_pose.transform_point(p)).collect();
        TrackOutput {
            map_pose,
            sketch_pose,
            recoveries: self.mcl.recoveries() as u32,
            lines_observed: observed.len(),
            localization_score: self.mcl.score(),
        }
    }

    /// The ICP reference in the map frame: the map near the robot (with the previous scan,
    /// which the grid already holds) or the previous scan alone.
    fn reference_points(&self, grid: &OccupancyGrid, around: &Pose2) -> Vec<Point2> {
        match self.reference {
            IcpReference::PreviousScan => self.previous_points.clone(),
            IcpReference::Map => {
                let centre = around.position();
                grid.occupied_points()
                    .into_iter()
                    .filter(|p| p.distance(&centre) <= ICP_REFERENCE_RADIUS_M)
                    .collect()
            }
        }
    }
}
