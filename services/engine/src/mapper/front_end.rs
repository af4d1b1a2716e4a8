//! The front end: one scan's map pose, from the odometry prediction and the scan itself.
//!
//! First stage of the mapper's per-scan flow (see [`super`]): the mapper hands it a
//! [`FrontEndInput`] and gets a [`FrontEndOutput`] back; it never calls back into the
//! mapper or the back end. After the back end corrects the map, the input's
//! `map_revision` changes and a front end drops what it built on the old poses.
//!
//! - `odometry`: the prediction itself;
//! - `icp`: frame-to-frame point-to-line ICP seeded by the odometry increment (the paper's
//!   "conventional ICP-SLAM");
//! - `graph`: keyframe ICP ([`super::keyframe_icp`]), the `sketch` front end without the
//!   drawing;
//! - `sketch`: the paper's method ([`super::sketch_front_end`]).

use super::front_end_io::{FrontEndInput, FrontEndOutput};
use super::keyframe_icp::KeyframeIcp;
use super::sketch_front_end::SketchFrontEnd;
use crate::scan_matching::icp::{Icp, IcpConfig, IcpMode};
use crate::sketch::SketchPose;
use sketchslam_types::Point2;

/// One session's front end.
pub(super) enum FrontEnd {
    /// Dead reckoning.
    Odometry,
    /// Frame-to-frame ICP; holds the previous scan's points, robot frame.
    Icp {
        config: IcpConfig,
        previous_points: Option<Vec<Point2>>,
    },
    /// Keyframe ICP, no drawing (boxed like the sketch front end: the ICP reference with
    /// its k-d tree is large beside the other variants).
    Graph(Box<KeyframeIcp>),
    /// The paper's method on a drawing.
    Sketch(Box<SketchFrontEnd>),
}

impl FrontEnd {
    /// The map pose of `input`'s scan.
    pub(super) fn track(&mut self, input: &FrontEndInput) -> FrontEndOutput {
        match self {
            FrontEnd::Odometry => FrontEndOutput::pose(input.predicted),
            FrontEnd::Icp {
                config,
                previous_points,
            } => {
                let points = &input.frame.points;
                let pose = match previous_points.as_deref() {
                    Some(reference) if reference.len() >= 10 && points.len() >= 10 => {
                        let icp = Icp::new(reference, *config);
                        let result = icp.align(points, input.increment, IcpMode::Full);
                        if result.converged {
                            input.last_pose.compose(&result.pose)
                        } else {
                            input.predicted
                        }
                    }
                    _ => input.predicted,
                };
                *previous_points = Some(points.clone());
                FrontEndOutput::pose(pose)
            }
            FrontEnd::Graph(matcher) => {
                let aligned = matcher.align(input, input.predicted, IcpMode::Full);
                matcher.done(&input.frame.points);
                FrontEndOutput {
                    covariance: Some(aligned.covariance),
                    ..FrontEndOutput::pose(aligned.pose)
                }
            }
            FrontEnd::Sketch(front_end) => front_end.track(input),
        }
    }

    /// True when [`FrontEnd::track`] reads the grid (it must then be current).
    pub(super) fn reads_map(&self) -> bool {
        match self {
            FrontEnd::Graph(matcher) => matcher.reads_map(),
            FrontEnd::Sketch(front_end) => front_end.reads_map(),
            _ => false,
        }
    }

    /// MCL's current estimate on the drawing (`sketch` only).
    pub(super) fn sketch_pose(&self) -> Option<SketchPose> {
        match self {
            FrontEnd::Sketch(front_end) => Some(front_end.sketch_pose()),
            _ => None,
        }
    }
}
