//! A mapper's settings, and the drawing a `sketch` session starts from.

use super::keyframe_step::KeyframeStepModel;
use crate::back_end::loop_closure::LoopClosureConfig;
use crate::localization::mcl::MclConfig;
use crate::mapping::grid::GridConfig;
use crate::registration::FitConfig;
use crate::scan_matching::icp::IcpConfig;
use crate::scan_matching::odometry_noise::OdometryNoise;
use crate::sketch::{Sketch, SketchPose};
use serde::{Deserialize, Serialize};
use sketchslam_types::Pose2;
use std::sync::Arc;

/// The drawing a `sketch` session localizes on, with the start a person marked on it.
#[derive(Debug, Clone)]
pub struct SketchPrior {
    /// The processed drawing.
    pub sketch: Arc<Sketch>,
    /// The start marked on the drawing and the person's guess of its scale.
    pub start: SketchPose,
}

/// Where ICP finds the reference points a new scan is aligned to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IcpReference {
    /// The previous scan, as the paper does.
    PreviousScan,
    /// Occupied cells of the map built so far (plus the previous scan).
    Map,
    /// A submap: the scans of the last few meters of route, each where the front end put
    /// it, thinned to a uniform density. A doorway's few points in one scan do not decide
    /// a pose, and the reference normals come from evenly spaced points.
    Submap,
}

/// Which pose on the drawing eq. (5) reads the drawn walls in view from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SketchHeadingView {
    /// MCL's estimate, trusted from a score of 0.6 (the paper's Fig. 2).
    #[default]
    Mcl,
    /// The predicted map pose carried onto the drawing through the warp W fitted to the
    /// map (once a fit is in effect, [`super::Mapper::warp_request`]): the walls in view are
    /// picked where the map says the robot is; the heading on the drawing is the map's (the
    /// map frame's axes are the drawing's, as with MCL's view). W is read where the map's
    /// walls do not hold it yet too (its extrapolation): eq. (4) keeps only the drawn walls
    /// the scan really sees from there. MCL's trusted estimate before the first fit takes
    /// effect.
    Warp,
}

/// Settings of a mapper; the defaults are the ones the evaluation reports.
#[derive(Debug, Clone)]
pub struct MapperConfig {
    /// The occupancy grid.
    pub grid: GridConfig,
    /// MCL on the sketch.
    pub mcl: MclConfig,
    /// ICP (the `icp` baseline and the keyframe ICP of `sketch` and `graph`).
    pub icp: IcpConfig,
    /// Reference of the keyframe ICP of the `sketch` and `graph` methods.
    pub keyframe_icp_reference: IcpReference,
    /// Keyframe ICP: a translation direction faced by fewer returns than this (weighted,
    /// [`crate::scan_matching::icp::IcpResult::normal_matrix`]) is not measured by the scan,
    /// and the odometry's prediction stands along it (a corridor's axis;
    /// [`crate::scan_matching::motion_prior`]); `None` takes ICP's pose as it converged.
    ///
    /// Off by default, measured: on 15 generated cheap-LiDAR worlds holding at
    /// [`crate::scan_matching::motion_prior::DEFAULT_MIN_POINTS`] against the submap took
    /// the median map error from 0.025 to 0.053 m (worst 0.073 to 0.170 m): along a hall's
    /// one visible wall the odometry's scale bias (2–3.5 %) becomes the map's, which no
    /// loop closure can see, while the submap's slide is already small.
    pub icp_min_constraining_points: Option<f64>,
    /// With `icp_min_constraining_points`: hold a direction the scan does not measure only
    /// where ICP moved the pose along it farther than this many sigmas of the odometry's
    /// error over the step (`odometry_noise`; [`crate::scan_matching::motion_prior::
    /// hold_unmeasured_slides`]); `None` (or no `odometry_noise`) holds every such
    /// direction. Measured 2026-12-06 at 3
    /// with `icp_min_constraining_points` 20 (`graph`, 30 generated worlds): with the chain
    /// preconditioner map error 0.011 / 0.059 / 0.100 m, completeness worst 0.797 (against
    /// 0.011 / 0.042 / 0.143 m, 0.543 without a hold and 0.015 / 0.065 / 0.184 m, 0.655 with
    /// the plain hold), with block Jacobi 0.016 / 0.070 / 0.107 m, 0.824 (against the
    /// default's 0.014 / 0.046 / 0.073 m, 0.888): it mends a dead end's turn-round slide
    /// (corridor 26) but costs cheap halls and offices, so it stays off.
    pub icp_hold_beyond_sigmas: Option<f64>,
    /// With `icp_hold_beyond_sigmas`: judge the slide over the stretch since the last scan
    /// ICP placed in every direction instead of over the step — ICP's pose along a
    /// direction the scan does not measure is kept within k σ of the odometry dead-reckoned
    /// since then (σ over that stretch's path) and cut to that window's edge beyond it
    /// ([`crate::scan_matching::motion_prior::clamp_unmeasured_slides`]). ICP against a
    /// submap is anchored, so its step errors undo each other over the next scans, while
    /// the odometry's add up; a stretch's window lets the first stand and cuts a slide.
    ///
    /// Off by default, measured 2026-12-07 (`graph`, chain preconditioner, 30 generated
    /// worlds): at k = 1 map error 0.010 / 0.036 / 0.071 m, completeness worst 0.894, every
    /// figure at least the default's, but school 0.121 m and the MIT CSAIL log 0.140 m (the
    /// default model's one σ is tighter than real wheels); at k = 3 the logs hold and a
    /// corridor's slide passes (worst 0.103 m). It wants the robot's own wheel model.
    pub icp_hold_over_stretch: bool,
    /// Keyframe ICP: the odometry's error model; when its ±3σ around the guess exceeds
    /// ICP's basin (scans a second and a meter apart) a correlative search finds the basin
    /// first ([`crate::scan_matching::odometry_noise`]). `None` always starts ICP from the
    /// odometry's guess.
    pub odometry_noise: Option<OdometryNoise>,
    /// Keyframe ICP: a converged match whose position lies farther from the odometry's
    /// guess than this many sigmas (plus one submap cell, 5 cm) is refused, and the scan
    /// keeps the guess: ICP slid into another basin (a robot turning in place on the Intel
    /// log matched 0.84 m away while its odometry could be 3 cm off). σ combines
    /// `odometry_noise` over the path since the last scan with the variance of the scans
    /// the reference is made of (see `mapper::keyframe_icp`). Heading is not judged
    /// ([`crate::scan_matching::odometry_noise::IncrementSigma::admits_position`]). `None`
    /// (or no `odometry_noise`) takes every converged match.
    ///
    /// Off by default, measured 2026-12-05 (`graph`, `Some(5.0)`): Intel relations 0.076 →
    /// 0.074 m, CSAIL 0.0501 → 0.049 m, the shared worlds unchanged — but on the 30
    /// generated worlds 3 maps worse and 1 better (cheap corridor 23 0.036 → 0.086 m,
    /// completeness 0.78, closing loops now worse than not; worst 0.078 → 0.086 m).
    pub icp_odometry_gate_sigmas: Option<f64>,
    /// Share of the eq. (5) heading correction applied per scan, 0..1. 1 is the paper:
    /// the heading is replaced and ICP solves the translation only. Below 1 ICP solves
    /// the full pose against the map and the sketch's line directions pull its heading by
    /// this share of their difference per scan — a drawn wall a few degrees off then
    /// bends the map less.
    pub sketch_heading_gain: f64,
    /// With a gain below 1: heading differences within this band are taken as the
    /// drawing's own angular error and ignored, radians (a person draws a wall's direction
    /// within a few degrees).
    pub sketch_heading_deadband_rad: f64,
    /// Where eq. (5) reads which drawn walls are in view and at what heading: MCL's
    /// estimate (the paper) or the warp from the map onto the drawing
    /// ([`SketchHeadingView`]).
    pub sketch_heading_view: SketchHeadingView,
    /// `sketch` sessions: the start heading is read from the first scan's walls against
    /// the drawing's wall directions, within two standard deviations of the mark's heading
    /// error (`registration.rotation_error_rad`), and the marked start is turned onto them
    /// when the reading exceeds `sketch_heading_deadband_rad` (any reading at a gain of 1):
    /// the turn eq. (5) would make while mapping, bending the map
    /// (`mapper/start_heading.rs`); false keeps the mark.
    ///
    /// Off by default, measured 2026-12-05: it fixes paper-env1 C (marked 9.3° off: map
    /// 0.013–0.065 → 0.006 m over three seeds), but on the Intel Lab, whose drawings' walls
    /// are not square, it turned person-2's and the CAD plan's hand-set marks by 5.3° and
    /// 4.2° and person-2's relations went 0.076 → 0.134 m at every seed.
    pub sketch_start_from_walls: bool,
    /// The map frame of a session without a drawing (`odometry`, `icp`, `graph`) is the
    /// robot's start pose turned by this much, radians: at 0 the map's x axis is the
    /// robot's start heading. A measurement knob: how a result depends on the frame's
    /// angle to the walls (`evaluate --frame-turn-deg`); measured 2026-12-04, turning it
    /// 3° changes `graph` on paper-env2 from 0.041 to 0.008 m. A `sketch` session's frame
    /// is the drawing's and ignores it.
    pub frame_turn_rad: f64,
    /// How the front end's covariances of the scans between two keyframes make the step's,
    /// which weighs the pose graph's sequential edge and the loop gate's chain
    /// (`mapper/keyframe_step.rs`, with the formulas and what each does over 60 generated
    /// worlds and the logs).
    pub keyframe_step: KeyframeStepModel,
    /// Loop closure of the `graph` and `sketch` methods; `None` keeps their front ends
    /// alone. `odometry` and `icp` never close loops (`icp` is the paper's frame-to-frame
    /// ICP-SLAM).
    pub loop_closure: Option<LoopClosureConfig>,
    /// `sketch` sessions: the fit of the warp from the map onto the drawing
    /// ([`crate::registration`], [`super::Mapper::drawing_registration`]).
    pub registration: FitConfig,
    /// Seed of every random draw of the session.
    pub seed: u64,
    /// Where the LiDAR sits on the robot: the robot→LiDAR transform (forward, left, yaw),
    /// the pose of the scan's origin in the robot frame. Every method runs on the LiDAR's
    /// poses (scans are rays from it, odometry is carried to it) and reports the robot's.
    pub lidar_mount: Pose2,
}

impl MapperConfig {
    /// The heading difference eq. (5) leaves alone, radians: `sketch_heading_deadband_rad`
    /// (a drawn wall's own angular error), or none with the paper's hard correction
    /// (`sketch_heading_gain` 1). The `sketch` front end's deadband and the start heading's
    /// tolerance (`mapper/start_heading.rs`).
    pub fn sketch_heading_band_rad(&self) -> f64 {
        if self.sketch_heading_gain >= 1.0 {
            0.0
        } else {
            self.sketch_heading_deadband_rad.max(0.0)
        }
    }
}

impl Default for MapperConfig {
    fn default() -> Self {
        Self {
            grid: GridConfig::default(),
            mcl: MclConfig::default(),
            icp: IcpConfig::default(),
            keyframe_icp_reference: IcpReference::Submap,
            icp_min_constraining_points: None,
            icp_hold_beyond_sigmas: None,
            icp_hold_over_stretch: false,
            odometry_noise: Some(OdometryNoise::default()),
            icp_odometry_gate_sigmas: None,
            sketch_heading_gain: 0.05,
            sketch_heading_deadband_rad: 4f64.to_radians(),
            sketch_heading_view: SketchHeadingView::default(),
            sketch_start_from_walls: false,
            frame_turn_rad: 0.0,
            keyframe_step: KeyframeStepModel::default(),
            loop_closure: Some(LoopClosureConfig::default()),
            registration: FitConfig::default(),
            seed: 1,
            lidar_mount: Pose2::IDENTITY,
        }
    }
}
