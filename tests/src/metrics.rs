//! Accuracy of a run, as docs/architecture.md defines it ("Files, and how a run is scored").
//!
//! 1. The estimated trajectory is aligned to the truth by the best rigid motion in the
//!    plane (Umeyama 1991, "Least-squares estimation of transformation parameters between
//!    two point patterns", restricted to SE(2): no scale), matching poses by stamp.
//! 2. **ATE** is the RMSE of the aligned positions.
//! 3. **Map error** is the mean distance from each occupied map cell, moved by the same
//!    alignment, to the nearest true wall pixel (0 inside a wall) — the paper's "average
//!    deviation of the constructed map from the truth".
//! 4. **Completeness** is the share of the true wall pixels the sensor saw that lie within
//!    0.25 m of an occupied (aligned) map cell, so an empty map cannot score well.
//!
//! Nearest-neighbour queries go through kd-trees (kiddo): O(n log m) for n queries into m
//! points.

use kiddo::{KdTree, SquaredEuclidean};
use sketchslam_types::{Point2, Pose2};

/// Distance within which a seen wall pixel counts as mapped, meters.
pub const COMPLETENESS_RADIUS_M: f64 = 0.25;

/// A stamped pose, stamp in seconds: a row of the `t,x,y,theta` CSV.
pub use sketchslam_types::StampedPose;

/// The truth's walls as a grid: row 0 at the top of the image, origin of the world frame
/// at the image's bottom-left corner.
#[derive(Debug, Clone)]
pub struct WallGrid {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Meters per pixel.
    pub resolution_m: f64,
    /// Row-major, true for a wall pixel.
    pub walls: Vec<bool>,
}

impl WallGrid {
    /// Walls from an image: pixels darker than 128 are walls.
    pub fn from_image(img: &image::GrayImage, resolution_m: f64) -> WallGrid {
        let (w, h) = img.dimensions();
        let walls = img.pixels().map(|p| p.0[0] < 128).collect();
        WallGrid {
            width: w as usize,
            height: h as usize,
            resolution_m,
            walls,
        }
    }

    /// The pixel holding world point `p`, if inside.
    pub fn pixel_of(&self, p: Point2) -> Option<(usize, usize)> {
        let col = (p.x / self.resolution_m).floor();
        let row = self.height as f64 - 1.0 - (p.y / self.resolution_m).floor();
        if col < 0.0 || row < 0.0 || col >= self.width as f64 || row >= self.height as f64 {
            return None;
        }
        Some((col as usize, row as usize))
    }

    /// The world-frame centre of pixel `(col, row)`.
    pub fn centre_of(&self, col: usize, row: usize) -> Point2 {
        Point2::new(
            (col as f64 + 0.5) * self.resolution_m,
            (self.height - row) as f64 * self.resolution_m - 0.5 * self.resolution_m,
        )
    }

    /// True when `(col, row)` is a wall.
    pub fn is_wall(&self, col: usize, row: usize) -> bool {
        self.walls[row * self.width + col]
    }

    /// Wall pixels with a free 4-neighbour: the only ones a nearest-wall query can end on
    /// from free space.
    pub fn boundary_pixels(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for row in 0..self.height {
            for col in 0..self.width {
                if !self.is_wall(col, row) {
                    continue;
                }
                let free_beside =
                    [(0i64, 1i64), (0, -1), (1, 0), (-1, 0)]
                        .iter()
                        .any(|(dc, dr)| {
                            let (c, r) = (col as i64 + dc, row as i64 + dr);
                            c >= 0
                                && r >= 0
                                && (c as usize) < self.width
                                && (r as usize) < self.height
                                && !self.is_wall(c as usize, r as usize)
                        });
                if free_beside {
                    out.push((col, row));
                }
            }
        }
        out
    }
}

/// The rigid motion `T` minimising `Σ |T·p_i − q_i|²` (Umeyama, SE(2)); None for fewer
/// than two pairs.
pub fn umeyama_se2(pairs: &[(Point2, Point2)]) -> Option<Pose2> {
    if pairs.len() < 2 {
        return None;
    }
    let n = pairs.len() as f64;
    let (mut px, mut py, mut qx, mut qy) = (0.0, 0.0, 0.0, 0.0);
    for (p, q) in pairs {
        px += p.x;
        py += p.y;
        qx += q.x;
        qy += q.y;
    }
    let (px, py, qx, qy) = (px / n, py / n, qx / n, qy / n);
    // H = Σ p' q'ᵀ; θ = atan2(H01 − H10, H00 + H11).
    let (mut h00, mut h01, mut h10, mut h11) = (0.0, 0.0, 0.0, 0.0);
    for (p, q) in pairs {
        let (ax, ay, bx, by) = (p.x - px, p.y - py, q.x - qx, q.y - qy);
        h00 += ax * bx;
        h01 += ax * by;
        h10 += ay * bx;
        h11 += ay * by;
    }
    let theta = (h01 - h10).atan2(h00 + h11);
    let (s, c) = theta.sin_cos();
    Some(Pose2::new(
        qx - (c * px - s * py),
        qy - (s * px + c * py),
        theta,
    ))
}

/// The estimated pose at `t_s`: the pose with that stamp, or linear interpolation between
/// the two around it; None outside the trajectory's span. `estimate` is sorted by stamp.
pub fn pose_at(estimate: &[StampedPose], t_s: f64) -> Option<Pose2> {
    const TOL_S: f64 = 1e-6;
    let i = estimate.partition_point(|p| p.t_s < t_s - TOL_S);
    let after = estimate.get(i)?;
    if (after.t_s - t_s).abs() <= TOL_S {
        return Some(after.pose);
    }
    let before = estimate.get(i.checked_sub(1)?)?;
    let f = (t_s - before.t_s) / (after.t_s - before.t_s);
    Some(before.pose.lerp(&after.pose, f))
}

/// Pairs (estimated position, true position) matched by stamp.
pub fn match_by_stamp(estimate: &[StampedPose], truth: &[StampedPose]) -> Vec<(Point2, Point2)> {
    truth
        .iter()
        .filter_map(|t| pose_at(estimate, t.t_s).map(|e| (e.position(), t.pose.position())))
        .collect()
}

/// The trajectory scores of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectoryScore {
    /// Estimated frame → truth frame.
    pub alignment: Pose2,
    /// RMSE of the aligned positions, meters.
    pub ate_rmse_m: f64,
    /// Poses matched.
    pub matched: usize,
}

/// Aligns `estimate` to `truth` and computes the ATE; None with fewer than two matches.
pub fn score_trajectory(
    estimate: &[StampedPose],
    truth: &[StampedPose],
) -> Option<TrajectoryScore> {
    let pairs = match_by_stamp(estimate, truth);
    let alignment = umeyama_se2(&pairs)?;
    Some(TrajectoryScore {
        alignment,
        ate_rmse_m: aligned_rmse_m(&pairs, &alignment)?,
        matched: pairs.len(),
    })
}

/// RMS distance of the estimated positions of `pairs` moved by `alignment` to their true
/// positions; None without a pair.
fn aligned_rmse_m(pairs: &[(Point2, Point2)], alignment: &Pose2) -> Option<f64> {
    if pairs.is_empty() {
        return None;
    }
    let sq: f64 = pairs
        .iter()
        .map(|(p, q)| alignment.transform_point(p).distance(q).powi(2))
        .sum();
    Some((sq / pairs.len() as f64).sqrt())
}

/// The ATE of `estimate` against `truth` moved by a given `alignment` (not fitted to this
/// estimate): how far the live poses were, in the frame the final trajectory was aligned
/// with. None without a pose matched by stamp.
pub fn ate_with_alignment(
    estimate: &[StampedPose],
    truth: &[StampedPose],
    alignment: &Pose2,
) -> Option<f64> {
    aligned_rmse_m(&match_by_stamp(estimate, truth), alignment)
}

fn tree_of(points: impl Iterator<Item = Point2>) -> KdTree<f64, 2> {
    let mut tree: KdTree<f64, 2> = KdTree::new();
    for (i, p) in points.enumerate() {
        tree.add(&[p.x, p.y], i as u64);
    }
    tree
}

/// The map scores of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapScore {
    /// Mean distance of aligned occupied cells to the nearest true wall, meters.
    pub map_error_m: f64,
    /// Share of seen wall pixels within 0.25 m of an occupied cell, 0..1.
    pub completeness: f64,
    /// Occupied cells scored.
    pub occupied_cells: usize,
}

/// Scores the occupied cells of a map (map frame) against the true walls, after moving
/// them by `alignment`. `seen_walls` are the wall pixels the sensor saw.
pub fn score_map(
    occupied_map_frame: &[Point2],
    alignment: &Pose2,
    walls: &WallGrid,
    seen_walls: &[(usize, usize)],
) -> MapScore {
    let boundary = tree_of(
        walls
            .boundary_pixels()
            .into_iter()
            .map(|(c, r)| walls.centre_of(c, r)),
    );
    let aligned: Vec<Point2> = occupied_map_frame
        .iter()
        .map(|p| alignment.transform_point(p))
        .collect();
    let mut total = 0.0;
    for p in &aligned {
        let inside_wall = walls.pixel_of(*p).is_some_and(|(c, r)| walls.is_wall(c, r));
        if !inside_wall {
            let nn = boundary.nearest_one::<SquaredEuclidean>(&[p.x, p.y]);
            // Distance to the wall pixel's edge, not its centre.
            total += (nn.distance.sqrt() - 0.5 * walls.resolution_m).max(0.0);
        }
    }
    let map_error_m = if aligned.is_empty() {
        f64::NAN
    } else {
        total / aligned.len() as f64
    };
    let completeness = if seen_walls.is_empty() || aligned.is_empty() {
        0.0
    } else {
        let occupied = tree_of(aligned.iter().copied());
        let r2 = COMPLETENESS_RADIUS_M * COMPLETENESS_RADIUS_M;
        let hit = seen_walls
            .iter()
            .filter(|(c, r)| {
                let p = walls.centre_of(*c, *r);
                occupied
                    .nearest_one::<SquaredEuclidean>(&[p.x, p.y])
                    .distance
                    <= r2
            })
            .count();
        hit as f64 / seen_walls.len() as f64
    };
    MapScore {
        map_error_m,
        completeness,
        occupied_cells: aligned.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn umeyama_recovers_a_known_motion() {
        let t = Pose2::new(3.0, -2.0, 0.7);
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(0.0, 2.0),
            Point2::new(-1.0, 5.0),
        ];
        let pairs: Vec<_> = pts.iter().map(|p| (*p, t.transform_point(p))).collect();
        let est = umeyama_se2(&pairs).unwrap();
        assert!((est.x - 3.0).abs() < 1e-9 && (est.y + 2.0).abs() < 1e-9);
        assert!((est.heading_rad - 0.7).abs() < 1e-9);
    }

    #[test]
    fn ate_of_a_shifted_noisy_copy() {
        // Truth along x; the estimate is the truth rotated and shifted, with ±0.1 m in y
        // alternating: after alignment the RMSE is 0.1 m exactly (the alternation has zero
        // mean and does not rotate the best fit).
        let truth: Vec<_> = (0..100)
            .map(|i| StampedPose {
                t_s: i as f64,
                pose: Pose2::new(i as f64 * 0.1, 0.0, 0.0),
            })
            .collect();
        let motion = Pose2::new(5.0, 1.0, 1.0);
        let est: Vec<_> = truth
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let dy = if i % 2 == 0 { 0.1 } else { -0.1 };
                let p = motion.transform_point(&Point2::new(t.pose.x, dy));
                StampedPose {
                    t_s: t.t_s,
                    pose: Pose2::new(p.x, p.y, 0.0),
                }
            })
            .collect();
        let s = score_trajectory(&est, &truth).unwrap();
        assert_eq!(s.matched, 100);
        assert!((s.ate_rmse_m - 0.1).abs() < 1e-3, "{}", s.ate_rmse_m);
    }

    #[test]
    fn interpolates_between_stamps() {
        let est = [
            StampedPose {
                t_s: 0.0,
                pose: Pose2::new(0.0, 0.0, 0.0),
            },
            StampedPose {
                t_s: 1.0,
                pose: Pose2::new(2.0, 0.0, 0.0),
            },
        ];
        let p = pose_at(&est, 0.25).unwrap();
        assert!((p.x - 0.5).abs() < 1e-12);
        assert!(pose_at(&est, 1.5).is_none());
    }

    #[test]
    fn map_on_the_walls_scores_zero_and_complete() {
        // A 20×20 px room (0.1 m/px) with a one-pixel wall ring.
        let (w, h) = (20usize, 20usize);
        let walls: Vec<bool> = (0..w * h)
            .map(|i| {
                let (c, r) = (i % w, i / w);
                c == 0 || r == 0 || c == w - 1 || r == h - 1
            })
            .collect();
        let g = WallGrid {
            width: w,
            height: h,
            resolution_m: 0.1,
            walls,
        };
        let seen = g.boundary_pixels();
        let on_walls: Vec<Point2> = seen.iter().map(|(c, r)| g.centre_of(*c, *r)).collect();
        let s = score_map(&on_walls, &Pose2::IDENTITY, &g, &seen);
        assert!(s.map_error_m.abs() < 1e-12 && (s.completeness - 1.0).abs() < 1e-12);
        // Cells of the left wall's middle rows (≥ 0.5 m from the top and bottom walls)
        // shifted 0.35 m inwards now sit 0.3 m from its edge (0.35 − half a pixel).
        let left: Vec<Point2> = (5..15).map(|r| g.centre_of(0, r)).collect();
        let shifted = Pose2::new(0.35, 0.0, 0.0);
        let s = score_map(&left, &shifted, &g, &seen);
        assert!((s.map_error_m - 0.3).abs() < 1e-9, "{}", s.map_error_m);
    }
}
