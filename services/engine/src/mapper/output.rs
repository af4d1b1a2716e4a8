//! What a mapper reports: the pose now, the trajectory, and how the session is doing.

use crate::sketch::SketchPose;
use serde::{Deserialize, Serialize};
use sketchslam_types::Pose2;

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
    /// Loops closed so far (`sketch` with loop closure only).
    #[serde(default)]
    pub loop_closures: u32,
    /// True once the first odometry message has arrived.
    pub initialized: bool,
}

/// Writes a trajectory as `trajectory.csv` text: header `t,x,y,theta`, seconds, meters,
/// radians.
pub fn trajectory_csv(trajectory: &[TrajectoryPoint]) -> String {
    let mut out = String::from("t,x,y,theta\n");
    for p in trajectory {
        out.push_str(&format!(
            "{:.9},{:.6},{:.6},{:.6}\n",
            p.stamp_ns as f64 * 1e-9,
            p.pose.x,
            p.pose.y,
            p.pose.heading_rad
        ));
    }
    out
}
