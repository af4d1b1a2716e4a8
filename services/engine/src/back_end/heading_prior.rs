//! The drawing's wall directions as a heading prior on keyframes.
//!
//! Between the front end and the loop closer: when a keyframe is due, the mapper asks this
//! for the map heading the drawing's dominant wall directions give the keyframe's scan
//! ([`crate::lines::wall_directions`]), and hands it to
//! [`LoopCloser::add_keyframe`](crate::back_end::loop_closure::LoopCloser::add_keyframe)
//! (used only when `LoopClosureConfig::heading_prior_sigma_rad` is set). The scan's RANSAC
//! lines are those the front end already extracted when it did, so RANSAC runs at most once
//! per scan; otherwise they are extracted here with this stage's own seeded stream.
//!
//! **The priors hold each wall family to where the route first saw it, not to the
//! drawing's axes.** The map frame has the drawing's axes and the robot starts at the
//! heading the person marked, a few degrees off (up to ~10° on the shared drawings), and
//! the pose graph's first keyframe is fixed there. Priors taken against the drawn
//! directions themselves would turn every later keyframe by the mark's error against the
//! fixed first one, and the chain between them would bend by it. And a person draws the
//! angle between two wall families only to a few degrees (the Intel Lab's drawings: 94.7°
//! and 96.5°), so a prior from the drawn angle would turn every keyframe that sees mostly
//! the second family by the drawing's error. So the drawing gives the families — how many,
//! and roughly where: the first keyframe whose walls give a reading (searched within two
//! standard deviations of the mark's heading error, as the start heading is:
//! [`crate::lines::wall_directions::heading_mode_to_directions`]) turns the drawn
//! directions by its reading `δ₀` into the map frame, `r_k = d_k − δ₀`; each family `k` is
//! then *placed* where the first keyframe that sees enough of its walls (within the
//! tolerance of `r_k`) sees them, and a placed family holds the keyframes after it. A
//! keyframe's prior is the turn onto the families placed before it; the keyframe that
//! places a family does so at its prior's heading, so a family seen first after some drift
//! inherits as little of it as the priors already removed. What the drawing then holds is
//! that walls seen anywhere on the route run along the walls of their family seen before
//! — the paper's premise without the mark's or the drawn angles' error.

use crate::lines::ransac::{RansacConfig, ScanLine, extract_lines};
use crate::lines::wall_directions::{
    DirectionMatchConfig, MIN_DOMINANT_SHARE, dominant_directions, heading_mode_to_directions,
    heading_to_directions,
};
use crate::sketch::SketchLine;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::{Point2, Pose2};
use std::f64::consts::PI;

/// The mark's heading error searched by the first reading, in its standard deviations.
const SEARCH_SIGMAS: f64 = 2.0;

/// Keyframe heading priors from a drawing's dominant wall directions.
#[derive(Debug, Clone)]
pub struct WallHeadingPrior {
    /// The drawing's dominant wall directions, radians in [0, π): on the drawing's axes
    /// until the first reading, then turned by it into the map frame (`r_k`).
    directions: Vec<f64>,
    /// Where each family's walls were first seen in the map frame, radians in [0, π);
    /// `None` until a keyframe saw enough of them.
    placed: Vec<Option<f64>>,
    /// The first reading's turn `δ₀` (radians), once read: the mark's heading error as
    /// the walls at the start tell it.
    frame_turn_rad: Option<f64>,
    /// How far the first reading searches, radians.
    first_reach_rad: f64,
    ransac: RansacConfig,
    matching: DirectionMatchConfig,
    rng: ChaCha8Rng,
}

impl WallHeadingPrior {
    /// The prior of a drawing with `lines`, for a start mark whose heading error has
    /// standard deviation `mark_sigma_rad`; `seed` drives the RANSAC this stage runs
    /// itself.
    pub fn new(lines: &[SketchLine], mark_sigma_rad: f64, seed: u64) -> Self {
        let directions = dominant_directions(lines, MIN_DOMINANT_SHARE);
        Self {
            placed: vec![None; directions.len()],
            directions,
            frame_turn_rad: None,
            first_reach_rad: SEARCH_SIGMAS * mark_sigma_rad.max(0.0),
            ransac: RansacConfig::default(),
            matching: DirectionMatchConfig::default(),
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The first reading's turn, radians (the mark's heading error as the start's walls
    /// tell it); `None` until a keyframe's walls gave one.
    pub fn frame_turn_rad(&self) -> Option<f64> {
        self.frame_turn_rad
    }

    /// Where each wall family was placed in the map frame (radians in [0, π)), strongest
    /// first; `None` for a family not yet seen.
    pub fn placed_rad(&self) -> &[Option<f64>] {
        &self.placed
    }

    /// The map heading of a keyframe at `pose` whose scan has `points` (robot frame) and,
    /// when the front end extracted them, `lines`; `None` when the drawing has no dominant
    /// direction or too little of the scan's walls lie along a placed family (the first
    /// reading's keyframe holds nothing: nothing is placed before it). Places the families
    /// this keyframe is the first to see. O(lines · families).
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
        if self.frame_turn_rad.is_none() {
            let turn = heading_mode_to_directions(
                lines,
                pose.heading_rad,
                &self.directions,
                self.first_reach_rad,
                &self.matching,
            )?;
            // Walls at heading θ + δ₀ lie on d, so at θ they lie on d − δ₀.
            for d in &mut self.directions {
                *d = (*d - turn).rem_euclid(PI);
            }
            self.frame_turn_rad = Some(turn);
        }
        let placed: Vec<f64> = self.placed.iter().flatten().copied().collect();
        let held = heading_to_directions(lines, pose.heading_rad, &placed, &self.matching)
            .map(|correction| pose.heading_rad + correction);
        let heading_rad = held.unwrap_or(pose.heading_rad);
        for (k, slot) in self.placed.iter_mut().enumerate() {
            if slot.is_some() {
                continue;
            }
            // The lines near family k's rough direction turned onto it by `c`: their map
            // angle is `r_k − c`.
            let r = self.directions[k];
            if let Some(c) = heading_to_directions(lines, heading_rad, &[r], &self.matching) {
                *slot = Some((r - c).rem_euclid(PI));
            }
        }
        held
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Walls seen by a robot at heading `true_rad` in the middle of a 10 × 6 m room (map
    /// frame, the room axis-aligned), in the robot frame: its long walls (along x), its
    /// short ones (along y), or both.
    fn walls_seen_from(true_rad: f64, along_x: bool, along_y: bool) -> Vec<Point2> {
        let mut world = Vec::new();
        for i in (0..=100).filter(|_| along_x) {
            let x = -5.0 + 0.1 * i as f64;
            world.push(Point2::new(x, 3.0));
            world.push(Point2::new(x, -3.0));
        }
        for i in (0..=60).filter(|_| along_y) {
            let y = -3.0 + 0.1 * i as f64;
            world.push(Point2::new(5.0, y));
            world.push(Point2::new(-5.0, y));
        }
        let robot = Pose2::new(0.0, 0.0, true_rad);
        world
            .iter()
            .map(|p| robot.inverse().transform_point(p))
            .collect()
    }

    fn room_seen_from(true_rad: f64) -> Vec<Point2> {
        walls_seen_from(true_rad, true, true)
    }

    /// A drawn stroke's two ends, pixels.
    type Stroke = ((f64, f64), (f64, f64));

    fn drawn(segments: &[Stroke]) -> Vec<SketchLine> {
        segments
            .iter()
            .enumerate()
            .map(|(i, (a, b))| SketchLine::new(i, Point2::new(a.0, a.1), Point2::new(b.0, b.1)))
            .collect()
    }

    #[test]
    fn the_priors_hold_headings_to_the_first_reading_not_to_the_marks_error() {
        // The room drawn axis-aligned (pixels); the robot really at 0° in the room, but
        // the mark says 5°, so the map frame is turned 5° from the walls: every heading the
        // front end gives is 5° more than the walls' truth.
        let lines = drawn(&[
            ((0.0, 0.0), (100.0, 0.0)),
            ((100.0, 0.0), (100.0, 60.0)),
            ((100.0, 60.0), (0.0, 60.0)),
            ((0.0, 60.0), (0.0, 0.0)),
        ]);
        let mark_error = 5f64.to_radians();
        let mut prior = WallHeadingPrior::new(&lines, 10f64.to_radians(), 7);
        // The first keyframe reads the frame and holds nothing.
        let first = prior.heading_rad(
            &room_seen_from(0.0),
            None,
            &Pose2::new(0.0, 0.0, mark_error),
        );
        assert!(first.is_none());
        let turn = prior
            .frame_turn_rad()
            .expect("the start's walls read the mark");
        assert!(
            (turn + mark_error).abs() < 0.2f64.to_radians(),
            "{}",
            turn.to_degrees()
        );
        // A later keyframe, truly at 30°, which the front end has drifted 1.5° to 31.5°
        // (+5° of frame): the prior brings it back to 35°, the frame's 30°, not to the
        // drawing's 30°.
        let drifted = Pose2::new(0.0, 0.0, mark_error + 31.5f64.to_radians());
        let held = prior
            .heading_rad(&room_seen_from(30f64.to_radians()), None, &drifted)
            .expect("a room's walls give a prior");
        let want = mark_error + 30f64.to_radians();
        assert!(
            (held - want).abs() < 0.2f64.to_radians(),
            "{}",
            (held - want).to_degrees()
        );
    }

    #[test]
    fn without_a_first_reading_nothing_is_held() {
        let l = |i, a: (f64, f64), b: (f64, f64)| {
            SketchLine::new(i, Point2::new(a.0, a.1), Point2::new(b.0, b.1))
        };
        let lines = [
            l(0, (0.0, 0.0), (100.0, 0.0)),
            l(1, (100.0, 0.0), (100.0, 60.0)),
        ];
        let mut prior = WallHeadingPrior::new(&lines, 10f64.to_radians(), 7);
        // A handful of points reads nothing, and the next keyframe is the first reading.
        let few = &room_seen_from(0.0)[..5];
        assert!(
            prior
                .heading_rad(few, None, &Pose2::new(0.0, 0.0, 0.0))
                .is_none()
        );
        assert!(prior.frame_turn_rad().is_none());
        assert!(
            prior
                .heading_rad(&room_seen_from(0.0), None, &Pose2::new(0.0, 0.0, 0.0))
                .is_none()
        );
        assert!(prior.frame_turn_rad().is_some());
    }

    #[test]
    fn a_wall_family_drawn_five_degrees_off_square_holds_where_it_was_seen() {
        // The room drawn with its short walls 95° from its long ones (a hand's error; pixels,
        // v down), the world square, the mark right. Both families are seen at the start.
        let lines = drawn(&[
            ((0.0, 0.0), (100.0, 0.0)),
            ((0.0, 60.0), (100.0, 60.0)),
            ((0.0, 0.0), (5.2, -59.8)),
            ((100.0, 0.0), (105.2, -59.8)),
        ]);
        let mut prior = WallHeadingPrior::new(&lines, 10f64.to_radians(), 7);
        assert!(
            prior
                .heading_rad(&room_seen_from(0.0), None, &Pose2::new(0.0, 0.0, 0.0))
                .is_none()
        );
        let placed: Vec<f64> = prior.placed_rad().iter().map(|p| p.unwrap()).collect();
        assert_eq!(placed.len(), 2);
        // Placed where the walls are (0° and 90°), not where the drawing has them (95°).
        let off = |a: f64, b: f64| sketchslam_types::wrap_half_pi(a - b).abs().to_degrees();
        assert!(placed.iter().any(|&p| off(p, 0.0) < 0.2), "{placed:?}");
        assert!(placed.iter().any(|&p| off(p, PI / 2.0) < 0.2), "{placed:?}");
        // Later, only the short walls in view and the heading drifted 1.5°: the prior
        // takes back the 1.5°, not 1.5° plus the drawing's 5°.
        let drifted = Pose2::new(0.0, 0.0, 1.5f64.to_radians());
        let held = prior
            .heading_rad(&walls_seen_from(0.0, false, true), None, &drifted)
            .expect("the short walls' family is placed");
        assert!(held.to_degrees().abs() < 0.2, "{}", held.to_degrees());
    }
}
