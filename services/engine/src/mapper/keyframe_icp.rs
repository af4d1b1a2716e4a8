//! Keyframe ICP: the position (and, below the paper's hard eq. (5), the heading) of a scan by
//! point-to-line ICP against a reference that is held for a few scans — the previous scan
//! when it was built, or the map around the robot (`MapperConfig::keyframe_icp_reference`).
//!
//! Step 4 of the `sketch` front end (eq. 6) and the whole front end of the `graph` method,
//! which is the same engine without the drawing. The reference is rebuilt every
//! [`REFERENCE_REFRESH_SCANS`] scans, once the robot is [`REFERENCE_REFRESH_M`] from where it
//! was built, and after the back end moved the map (a new `FrontEndInput::map_revision`).

use super::config::{IcpReference, MapperConfig};
use super::front_end_io::FrontEndInput;
use crate::mapping::grid::OccupancyGrid;
use crate::scan_matching::icp::{Icp, IcpConfig, IcpMode};
use sketchslam_types::{Point2, Pose2};

/// Map points farther than this from the robot are left out of the ICP reference, meters.
const ICP_REFERENCE_RADIUS_M: f64 = 50.0;

/// The ICP reference is rebuilt after this many scans...
pub const REFERENCE_REFRESH_SCANS: usize = 5;
/// ...or once the robot is this far from where it was built, meters.
pub const REFERENCE_REFRESH_M: f64 = 1.0;

/// Point-to-line ICP against a held reference.
pub(super) struct KeyframeIcp {
    icp: IcpConfig,
    reference_kind: IcpReference,
    /// The ICP reference, the pose it was built around and the map revision it was
    /// built at.
    reference: Option<(Icp, Pose2, u64)>,
    scans_since_reference: usize,
    /// The previous scan's points, robot frame (placed at the input's `last_pose`).
    previous_points: Vec<Point2>,
}

impl KeyframeIcp {
    /// A matcher with `config`'s ICP settings and reference.
    pub(super) fn new(config: &MapperConfig) -> Self {
        Self {
            icp: config.icp,
            reference_kind: config.keyframe_icp_reference,
            reference: None,
            scans_since_reference: 0,
            previous_points: Vec::new(),
        }
    }

    /// True when the reference comes from the grid.
    pub(super) fn reads_map(&self) -> bool {
        self.reference_kind == IcpReference::Map
    }

    /// Ends the scan whose robot-frame `points` were just aligned: they are the next
    /// reference's previous scan.
    pub(super) fn done(&mut self, points: &[Point2]) {
        self.previous_points = points.to_vec();
        self.scans_since_reference += 1;
    }

    /// Point-to-line ICP of the scan against the reference (map frame), from `guess`;
    /// the guess itself when there is too little to align with or ICP does not converge.
    pub(super) fn align(&mut self, input: &FrontEndInput, guess: Pose2, mode: IcpMode) -> Pose2 {
        let points = &input.frame.points[..];
        if points.len() < 10 {
            return guess;
        }
        let stale = self.reference.as_ref().is_none_or(|(_, at, revision)| {
            *revision != input.map_revision
                || self.scans_since_reference >= REFERENCE_REFRESH_SCANS
                || at.position().distance(&guess.position()) > REFERENCE_REFRESH_M
        });
        if stale {
            let centre = guess.position();
            // The previous scan where the map holds it now.
            let previous: Vec<Point2> = self
                .previous_points
                .iter()
                .map(|p| input.last_pose.transform_point(p))
                .collect();
            let grid: &OccupancyGrid = input.grid;
            let points = match self.reference_kind {
                IcpReference::PreviousScan => previous,
                IcpReference::Map => {
                    let mut pts = grid.occupied_points_near(centre, ICP_REFERENCE_RADIUS_M);
                    // The grid holds the last scans only once their cells pass the
                    // occupancy threshold: add the previous scan so a new area has support.
                    pts.extend_from_slice(&previous);
                    pts
                }
            };
            self.reference = Some((Icp::new(&points, self.icp), guess, input.map_revision));
            self.scans_since_reference = 0;
        }
        let Some((icp, _, _)) = &self.reference else {
            return guess;
        };
        if icp.len() < 10 {
            return guess;
        }
        let result = icp.align(points, guess, mode);
        if result.converged && result.pose.is_finite() {
            result.pose
        } else {
            guess
        }
    }
}
