//! A session's map registered on its drawing: the fitted warp W with where it holds, and
//! what users read through it — a map pose on the drawing, a pixel they point at as a map
//! pose, the drawing's lines (rooms not yet visited included) in map meters.
//!
//! Sits after [`super::fit`]: the mapper hands out a [`WarpProblem`] (the keyframes' walls at
//! their current poses, the drawing, the prior) that is solved off the scan path (the
//! service fits it on an HTTP worker, outside the mapper's lock) into a
//! [`DrawingRegistration`], which the service caches until the map has moved or grown.
//!
//! Where W holds: a control node is held by the wall points W was fitted to near it
//! ([`WarpFit::support`], each point's bilinear weight on the node); a map point is
//! *registered* where the interpolated support reaches [`MIN_SUPPORT_POINTS`] — one meter of
//! mapped wall at the fit's 0.1 m thinning. Elsewhere (a room not yet seen) W is the
//! regularizer's extrapolation of its neighbours: the best guess, flagged as such.

use super::fit::{FitConfig, WarpFit, fit_warp};
use super::warp::{Similarity, Warp};
use crate::sketch::{SketchLine, SketchPose};
use sketchslam_types::{Point2, Pose2};

/// Interpolated support at which a map point counts as registered: 10 wall points, one
/// meter of mapped wall at the fit's thinning.
pub const MIN_SUPPORT_POINTS: f64 = 10.0;

/// A drawn line carried into the map is sampled every this many drawing pixels (W bends a
/// straight stroke), at least its two ends.
pub const LINE_SAMPLE_PX: f64 = 5.0;

/// Everything the fit needs, copied out of the mapper so that it runs without it.
#[derive(Debug, Clone)]
pub struct WarpProblem {
    /// The keyframes' wall points at their current poses, map meters, thinned.
    pub walls: Vec<Point2>,
    /// The drawing's lines, pixels.
    pub lines: Vec<SketchLine>,
    /// The start mark and scale guess as a similarity.
    pub prior: Similarity,
    /// The fit's settings.
    pub config: FitConfig,
    /// Keyframes the walls come from.
    pub keyframes: usize,
    /// The mapper's map revision when copied.
    pub map_revision: u64,
    /// The keyframes' poses the walls were placed at (map frame, the mapper's own, in
    /// keyframe order): the frame W is fitted in, kept so that a pose read through W after
    /// later corrections moved the map can be taken back to it
    /// (`Mapper::pose_on_drawing_through`).
    pub anchors: Vec<Pose2>,
}

impl WarpProblem {
    /// The robot's route the fit checks against the drawn walls: the keyframes' positions
    /// ([`WarpProblem::anchors`]), in order.
    pub fn route(&self) -> Vec<Point2> {
        self.anchors.iter().map(|k| k.position()).collect()
    }

    /// [`fit_warp`] on the copied walls and route; `None` when nothing can be fitted yet.
    pub fn solve(&self) -> Option<DrawingRegistration> {
        let fit = fit_warp(
            &self.walls,
            &self.route(),
            &self.lines,
            self.prior,
            &self.config,
        )?;
        Some(DrawingRegistration {
            fit,
            keyframes: self.keyframes,
            map_revision: self.map_revision,
            anchors: self.anchors.clone(),
        })
    }
}

/// The fitted warp, and the state of the map it was fitted to.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawingRegistration {
    /// W, its inliers and its support.
    pub fit: WarpFit,
    /// Keyframes the walls came from.
    pub keyframes: usize,
    /// The mapper's map revision at the fit.
    pub map_revision: u64,
    /// [`WarpProblem::anchors`] of the fit (empty for a registration read back from its
    /// parameters: it is read in whatever frame the map is in then).
    pub anchors: Vec<Pose2>,
}

impl DrawingRegistration {
    /// The warp.
    pub fn warp(&self) -> &Warp {
        &self.fit.warp
    }

    /// Wall points holding W at map point `p`: the nodes' support, bilinearly
    /// interpolated. O(1).
    pub fn support_at(&self, p: Point2) -> f64 {
        let support = &self.fit.support;
        self.fit
            .warp
            .grid
            .weights(p)
            .iter()
            .map(|(k, w)| w * support.get(*k).copied().unwrap_or(0.0))
            .sum()
    }

    /// True where W is held by the map's walls ([`MIN_SUPPORT_POINTS`]).
    pub fn holds_at(&self, p: Point2) -> bool {
        self.support_at(p) >= MIN_SUPPORT_POINTS
    }

    /// A map pose `now` of the map whose keyframes lie at `keyframes` now, taken back to
    /// the map W was fitted to. A loop closure after the fit moves the keyframes, and the
    /// pose with them; read through the old W, the moved pose lands where the old map had
    /// another place. Relative to the newest keyframe the fit knew, `K`, placed where `K`
    /// was then: `p_fit = K_fit ⊕ (K_now⁻¹ ⊕ p_now)`. `now` unchanged when the fit knew no
    /// keyframe ([`DrawingRegistration::anchors`] empty). O(1).
    pub fn pose_at_fit(&self, keyframes: &[Pose2], now: &Pose2) -> Pose2 {
        let k = self.anchors.len().min(keyframes.len());
        match k.checked_sub(1) {
            Some(i) => self.anchors[i].compose(&keyframes[i].inverse().compose(now)),
            None => *now,
        }
    }

    /// A map pose on the drawing, and whether W holds there.
    pub fn to_drawing(&self, pose: &Pose2) -> (SketchPose, bool) {
        (
            self.fit.warp.pose_on_drawing(pose),
            self.holds_at(pose.position()),
        )
    }

    /// A pixel of the drawing (image `(u, v)`) with a heading on the drawing as a map pose,
    /// and whether W holds there; `None` where W cannot be inverted.
    pub fn to_map(&self, px: Point2, heading_rad: f64) -> Option<(Pose2, bool)> {
        let pose = self.fit.warp.pose_from_drawing(px, heading_rad)?;
        Some((pose, self.holds_at(pose.position())))
    }

    /// Each drawn line carried into the map through W⁻¹, as a polyline sampled every
    /// [`LINE_SAMPLE_PX`] (W bends straight strokes); samples W cannot invert are left out,
    /// and a line with fewer than two left is empty. O(Σ length / step).
    pub fn lines_in_map(&self, lines: &[SketchLine]) -> Vec<Vec<Point2>> {
        lines
            .iter()
            .map(|l| {
                let (a, b) = (l.a, l.b);
                let n = ((a.distance(&b) / LINE_SAMPLE_PX).ceil() as usize).clamp(1, 10_000);
                let points: Vec<Point2> = (0..=n)
                    .filter_map(|i| {
                        let t = i as f64 / n as f64;
                        let px = Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y));
                        self.fit.warp.from_pixel(px)
                    })
                    .collect();
                if points.len() >= 2 {
                    points
                } else {
                    Vec::new()
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registration::warp::ControlGrid;

    /// W = 10 px/m, no turn, the map origin at pixel (100, 200), on a 4 m grid over
    /// 0–8 × 0–4 m, node 0 held by 40 points and the others by none.
    fn registration() -> DrawingRegistration {
        let grid = ControlGrid::covering(Point2::new(0.0, 0.0), Point2::new(8.0, 4.0), 4.0);
        let warp = Warp::rigid(Similarity::new(10.0, 0.0, Point2::new(100.0, -200.0)), grid);
        let mut support = vec![0.0; grid.len()];
        support[0] = 40.0;
        DrawingRegistration {
            fit: WarpFit {
                warp,
                inliers: 40,
                rms_px: 0.5,
                support,
                walls_crossed: 0,
            },
            keyframes: 3,
            map_revision: 0,
            anchors: Vec::new(),
        }
    }

    #[test]
    fn a_pose_after_a_correction_is_read_where_the_fitted_map_had_it() {
        // Fitted with keyframes at (0, 0, 0) and (4, 0, 0); a closure since moved the second
        // to (4, 1, 90°), and the robot 0.5 m ahead of it, at (4, 1.5, 90°).
        let mut r = registration();
        r.anchors = vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(4.0, 0.0, 0.0)];
        let q = std::f64::consts::FRAC_PI_2;
        let now = [
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(4.0, 1.0, q),
            Pose2::new(4.0, 2.0, q),
        ];
        // 0.5 m ahead of the fitted second keyframe: (4.5, 0, 0), pixel (145, 200).
        let back = r.pose_at_fit(&now, &Pose2::new(4.0, 1.5, q));
        assert!(back.position().distance(&Point2::new(4.5, 0.0)) < 1e-12);
        assert!(back.heading_rad.abs() < 1e-12);
        let (on, _) = r.to_drawing(&back);
        assert!((on.u_px - 145.0).abs() < 1e-9 && (on.v_px - 200.0).abs() < 1e-9);
        // A registration that knows no keyframe reads the pose as it is.
        r.anchors.clear();
        assert_eq!(
            r.pose_at_fit(&now, &Pose2::new(4.0, 1.5, q)),
            Pose2::new(4.0, 1.5, q)
        );
    }

    #[test]
    fn a_pose_goes_onto_the_drawing_and_back() {
        let r = registration();
        // Map (1, 2) → drawing frame (110, −180) → pixel (110, 180).
        let (on, holds) = r.to_drawing(&Pose2::new(1.0, 2.0, 0.5));
        assert!((on.u_px - 110.0).abs() < 1e-9 && (on.v_px - 180.0).abs() < 1e-9);
        assert!((on.meters_per_pixel - 0.1).abs() < 1e-12);
        // Support at (1, 2): node 0's 40 × (1 − 1/4)(1 − 2/4) = 15 points.
        assert!((r.support_at(Point2::new(1.0, 2.0)) - 15.0).abs() < 1e-9);
        assert!(holds);
        let (back, holds) = r.to_map(Point2::new(110.0, 180.0), 0.5).unwrap();
        assert!(back.position().distance(&Point2::new(1.0, 2.0)) < 1e-9 && holds);
        assert!((back.heading_rad - 0.5).abs() < 1e-12);
        // Far from node 0 nothing holds W: (7, 3) has support 0.
        assert!(!r.to_drawing(&Pose2::new(7.0, 3.0, 0.0)).1);
    }

    #[test]
    fn a_drawn_line_lands_in_the_map_as_a_sampled_polyline() {
        let r = registration();
        // Pixels (100, 200)–(120, 200) are map (0, 0)–(2, 0): 20 px in 5 px steps, 5 samples.
        let line = SketchLine {
            index: 0,
            a: Point2::new(100.0, 200.0),
            b: Point2::new(120.0, 200.0),
            angle_rad: 0.0,
        };
        let lines = r.lines_in_map(&[line]);
        assert_eq!(lines[0].len(), 5);
        assert!(lines[0][0].distance(&Point2::new(0.0, 0.0)) < 1e-9);
        assert!(lines[0][4].distance(&Point2::new(2.0, 0.0)) < 1e-9);
        assert!(lines[0][2].distance(&Point2::new(1.0, 0.0)) < 1e-9);
    }
}
