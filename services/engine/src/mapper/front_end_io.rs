//! What passes between the mapper and a front end for one scan: the input the mapper
//! builds, the output the front end returns (see [`super::front_end`]).

use super::frame::ScanFrame;
use crate::lines::ransac::ScanLine;
use crate::mapping::grid::OccupancyGrid;
use crate::scan_matching::odometry_noise::OdometryPath;
use crate::sketch::SketchPose;
use nalgebra::Matrix3;
use sketchslam_types::Pose2;

/// Everything the front end needs for one scan.
#[derive(Debug, Clone, Copy)]
pub struct FrontEndInput<'a> {
    /// The scan and its points.
    pub frame: &'a ScanFrame<'a>,
    /// Odometry motion since the last scan, robot frame.
    pub increment: Pose2,
    /// The path the odometry reported since the last scan (its readings' steps summed):
    /// how far off `increment` can be.
    pub path: OdometryPath,
    /// The last scan's map pose, as corrected by the back end if it moved the map since.
    pub last_pose: Pose2,
    /// `last_pose` carried forward by `increment`.
    pub predicted: Pose2,
    /// Corrections of the back end so far: what was built before the latest one is stale.
    pub map_revision: u64,
    /// The map so far, current (the mapper rebuilds it first for a front end that reads it).
    pub grid: &'a OccupancyGrid,
    /// `sketch` with [`super::config::SketchHeadingView::Warp`]: `predicted` carried onto
    /// the drawing through the warp fitted to the map, once a fit is in effect.
    pub drawing_view: Option<SketchPose>,
}

/// What the drawing side of a `sketch` front end reports for a scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SketchReport {
    /// MCL's estimate on the drawing.
    pub sketch_pose: SketchPose,
    /// Recoveries so far.
    pub recoveries: u32,
    /// Sketch lines observed at this scan (eq. 4).
    pub lines_observed: usize,
    /// MCL's localization score, 0..1.
    pub localization_score: f64,
}

/// A scan pose's covariance in (x, y, heading), translation on the map's axes, and how
/// much of it is the odometry's guess rather than the scan's measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanCovariance {
    /// The whole covariance.
    pub total: Matrix3<f64>,
    /// The odometry's share of `total`: its position variance along the directions the scan
    /// did not measure (a corridor's axis), and its heading variance when the scan did not
    /// measure the heading (zero there otherwise). `total − unmeasured` is what the match
    /// itself claims.
    pub unmeasured: Matrix3<f64>,
}

/// What the front end made of one scan.
#[derive(Debug, Clone)]
pub struct FrontEndOutput {
    /// The scan's map pose (may be non-finite: the mapper then skips the scan).
    pub pose: Pose2,
    /// How far off `pose` can be relative to the map the front end matched against, when
    /// the front end knows (keyframe ICP: `keyframe_icp::Aligned`).
    pub covariance: Option<ScanCovariance>,
    /// The scan's RANSAC lines (robot frame) when the front end extracted them, so the
    /// back end does not extract them a second time.
    pub scan_lines: Option<Vec<ScanLine>>,
    /// The drawing side's report (`sketch` only).
    pub sketch: Option<SketchReport>,
}

impl FrontEndOutput {
    pub(super) fn pose(pose: Pose2) -> Self {
        Self {
            pose,
            covariance: None,
            scan_lines: None,
            sketch: None,
        }
    }
}
