//! One scan as every stage of the mapper sees it: the header checked and the returns turned
//! into points once, before the front end, the back end and the grid take their turn.

use sketchslam_types::{Point2, Scan};

/// A scan with its returns as points in the robot frame, meters (built once per scan).
#[derive(Debug, Clone)]
pub struct ScanFrame<'a> {
    /// The scan as received.
    pub scan: &'a Scan,
    /// Its returns in the robot frame ([`Scan::points`]), in beam order.
    pub points: Vec<Point2>,
}

impl<'a> ScanFrame<'a> {
    /// The frame of `scan`; `None` when its header is unusable (beam count not the number
    /// of ranges, angles not finite). O(beams).
    pub fn new(scan: &'a Scan) -> Option<Self> {
        if scan.ranges_m.len() != scan.header.beam_count as usize
            || !scan.header.angle_min_rad.is_finite()
            || !scan.header.angle_increment_rad.is_finite()
        {
            return None;
        }
        Some(Self {
            scan,
            points: scan.points().map(|(_, p)| p).collect(),
        })
    }
}
