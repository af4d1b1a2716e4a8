//! What a mapper reports: the pose now, the trajectory, and how the session is doing.

use crate::sketch::SketchPose;
use serde::{Deserialize, Serialize};
use sketchslam_types::Pose2;
use sketchslam_types::trajectory_csv::{self, NumberFormat, StampedPose};

/// The current pose estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseEstimate {
    /// Stamp of the last message that moved the estimate, nanoseconds.
    pub stamp_ns: u64,
    /// Pose in the map frame.
    pub map: Pose2,
    /// Pose and scale on the drawing (`sketch` sessions only).
    pub sketch: Option<SketchPose>,
}

/// One pose of the trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryPoint {
    /// Stamp, nanoseconds.
    pub stamp_ns: u64,
    /// Pose in the map frame.
    pub pose: Pose2,
}

impl TrajectoryPoint {
    /// The point as a CSV row: its stamp in seconds.
    pub fn stamped(&self) -> StampedPose {
        StampedPose {
            t_s: self.stamp_ns as f64 * 1e-9,
            pose: self.pose,
        }
    }
}

/// A loop of the pose graph, by the stamps of the two scans it joins.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosedLoop {
    /// Stamp of the earlier keyframe's scan, nanoseconds.
    pub from_stamp_ns: u64,
    /// Stamp of the newer keyframe's scan, nanoseconds.
    pub to_stamp_ns: u64,
    /// The newer keyframe's pose in the earlier one's frame, as the match found it.
    pub measurement: Pose2,
    /// The match's score, 0..1.
    pub score: f64,
    /// The chain test's squared Mahalanobis distance when the loop was verified (against
    /// the loop closer's `consistency_chi2`, 11.34 by default).
    pub chain_d2: f64,
    /// The deviation the chain between the two keyframes was given in that test, meters.
    pub chain_sigma_m: f64,
    /// The chain's heading deviation in that test, degrees.
    pub chain_sigma_deg: f64,
    /// The heading deviation the loop claimed in that test, degrees.
    pub loop_sigma_deg: f64,
}

/// What gave a pose on the drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DrawingPoseSource {
    /// MCL on the drawing, at a scan.
    Mcl,
    /// MCL's estimate at the last scan carried forward by the odometry since (between scans).
    Odometry,
    /// The map pose carried onto the drawing through the warp fitted to the map
    /// ([`crate::registration`]), where the mapped walls hold it.
    Warp,
    /// The same where no mapped wall holds the warp yet (a room just entered): W's
    /// extrapolation from its neighbours.
    WarpExtrapolated,
}

impl DrawingPoseSource {
    /// The source's name, as the API writes it.
    pub fn as_str(&self) -> &'static str {
        match self {
            DrawingPoseSource::Mcl => "mcl",
            DrawingPoseSource::Odometry => "odometry",
            DrawingPoseSource::Warp => "warp",
            DrawingPoseSource::WarpExtrapolated => "warp_extrapolated",
        }
    }
}

/// One pose of a `sketch` session's trajectory on the drawing (beside the map-frame
/// [`TrajectoryPoint`] of the same stamp).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DrawingPoint {
    /// Stamp, nanoseconds.
    pub stamp_ns: u64,
    /// Pose and scale on the drawing.
    pub pose: SketchPose,
    /// What gave it.
    pub source: DrawingPoseSource,
}

/// How well the session is doing.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Health {
    /// Scans fused so far.
    pub scans_processed: u64,
    /// Scans refused (no usable return at all).
    pub scans_skipped: u64,
    /// Times MCL on the sketch broke down and was recovered.
    pub recoveries: u32,
    /// Sketch lines observed at the last scan (eq. 4).
    pub lines_observed: usize,
    /// Localization score in 0..1 (1 for the baselines once initialized).
    pub localization_score: f64,
    /// Estimated scale of the drawing, meters per pixel (`sketch` only).
    pub meters_per_pixel: Option<f64>,
    /// Loops closed so far (the methods with loop closure: `graph`, `sketch`).
    #[serde(default)]
    pub loop_closures: u32,
    /// Matched loops refused so far: they disagreed with the odometry chain or with the
    /// other loops, found no second view agreeing within a few meters, or were taken out
    /// of the graph after an optimization.
    #[serde(default)]
    pub loop_closures_rejected: u32,
    /// True once the first odometry message has arrived.
    pub initialized: bool,
}

/// Writes a trajectory as `trajectory.csv` text with the one codec
/// ([`sketchslam_types::trajectory_csv`]): header `t,x,y,theta`, seconds, meters, radians.
pub fn trajectory_csv(trajectory: &[TrajectoryPoint]) -> String {
    let rows: Vec<StampedPose> = trajectory.iter().map(|p| p.stamped()).collect();
    trajectory_csv::write(&rows, NumberFormat::Fixed)
}
