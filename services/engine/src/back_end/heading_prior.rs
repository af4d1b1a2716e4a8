//! The drawing's wall directions as a heading prior on keyframes.
//!
//! Between the front end and the loop closer: when a keyframe is due, the mapper asks this
//! for the map heading the drawing's dominant wall directions give the keyframe's scan
//! ([`crate::lines::wall_directions`]), and hands it to
//! [`LoopCloser::add_keyframe`](crate::back_end::loop_closure::LoopCloser::add_keyframe)
//! (used only when `LoopClosureConfig::heading_prior_sigma_rad` is set). The scan's RANSAC
//! lines are those the front end already extracted when it did, so RANSAC runs at most once
//! per scan; otherwise they are extracted here with this stage's own seeded stream.

use crate::lines::ransac::{RansacConfig, ScanLine, extract_lines};
use crate::lines::wall_directions::{
    DirectionMatchConfig, MIN_DOMINANT_SHARE, dominant_directions, heading_to_directions,
};
use crate::sketch::SketchLine;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::{Point2, Pose2};

/// Keyframe heading priors from a drawing's dominant wall directions.
#[derive(Debug, Clone)]
pub struct WallHeadingPrior {
    /// The drawing's dominant wall directions in the map frame, radians in [0, π).
    directions: Vec<f64>,
    ransac: RansacConfig,
    matching: DirectionMatchConfig,
    rng: ChaCha8Rng,
}

impl WallHeadingPrior {
    /// The prior of a drawing with `lines`; `seed` drives the RANSAC this stage runs
    /// itself.
    pub fn new(lines: &[SketchLine], seed: u64) -> Self {
        Self {
            directions: dominant_directions(lines, MIN_DOMINANT_SHARE),
            ransac: RansacConfig::default(),
            matching: DirectionMatchConfig::default(),
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The map heading of a keyframe at `pose` whose scan has `points` (robot frame) and,
    /// when the front end extracted them, `lines`; `None` when the drawing has no dominant
    /// direction or too little of the scan's walls agree with one.
    pub fn heading_rad(
        &mut self,
        points: &[Point2],
        lines: Option<&[ScanLine]>,
        pose: &Pose2,
    ) -> Option<f64> {
        if self.directions.is_empty() || points.len() < 10 {
            return None;
        }
        let extracted;
        let lines = match lines {
            Some(lines) => lines,
            None => {
                extracted = extract_lines(points, &self.ransac, &mut self.rng);
                &extracted
            }
        };
        heading_to_directions(lines, pose.heading_rad, &self.directions, &self.matching)
            .map(|correction| pose.heading_rad + correction)
    }
}
