//! The warp W from the map (meters) to the drawing (pixels): a similarity plus a smooth
//! field of offsets on a control grid, so a drawing whose proportions are wrong in places
//! can still be laid over the map room by room.
//!
//! Sits between the map the LiDAR built and the uploaded drawing: [`super::fit`] estimates
//! it from the map's walls; the pose on the drawing, the overlay and the drawing's rooms in
//! map meters are read through it.
//!
//! Frames: map `p = (x, y)` meters; drawing frame `w = (x_d, y_d) = (u, −v)` pixels (the
//! sketch module's convention, so a drawing whose axes the map shares needs no reflection).
//!
//! `W(p) = A p + t + Σ_k β_k(p) o_k`, with `A = [[a, −b], [b, a]]` (scale `√(a² + b²)`
//! pixels per meter, rotation `atan2(b, a)`), `t` pixels, and `o_k` the offset (pixels) of
//! control node `k` on a square grid of `spacing_m` over the map; `β_k` are the bilinear
//! weights of the four nodes of the cell around `p` (Sederberg and Parry's free-form
//! deformation, at first order). W is linear in every parameter `(a, b, t, o)`, which
//! keeps its fit a least-squares problem. Outside the grid the nearest cell's weights are
//! extended (clamped). Cost: O(1) per point.

use crate::sketch::SketchPose;
use nalgebra::Matrix2;
use sketchslam_types::{Point2, Pose2};

/// The similarity part of W.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    /// `scale · cos(rotation)`, pixels per meter.
    pub a: f64,
    /// `scale · sin(rotation)`, pixels per meter.
    pub b: f64,
    /// Translation, drawing frame, pixels.
    pub t: Point2,
}

impl Similarity {
    /// From a scale (pixels per meter), a rotation (map to drawing frame, radians) and a
    /// translation (drawing frame, pixels).
    pub fn new(scale_px_per_m: f64, rotation_rad: f64, t: Point2) -> Self {
        let (sin, cos) = rotation_rad.sin_cos();
        Self {
            a: scale_px_per_m * cos,
            b: scale_px_per_m * sin,
            t,
        }
    }

    /// Pixels per meter.
    pub fn scale_px_per_m(&self) -> f64 {
        self.a.hypot(self.b)
    }

    /// Rotation from the map frame to the drawing frame, radians.
    pub fn rotation_rad(&self) -> f64 {
        self.b.atan2(self.a)
    }

    /// `A p + t`.
    pub fn apply(&self, p: Point2) -> Point2 {
        Point2::new(
            self.a * p.x - self.b * p.y + self.t.x,
            self.b * p.x + self.a * p.y + self.t.y,
        )
    }
}

/// The control grid: nodes at `origin + (i, j) · spacing_m`, `i < columns`, `j < rows`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlGrid {
    /// Map position of node (0, 0), meters.
    pub origin: Point2,
    /// Distance between neighbouring nodes, meters.
    pub spacing_m: f64,
    /// Nodes along x (at least 2).
    pub columns: usize,
    /// Nodes along y (at least 2).
    pub rows: usize,
}

impl ControlGrid {
    /// The smallest grid of `spacing_m` covering the box `lo`–`hi` (map meters).
    pub fn covering(lo: Point2, hi: Point2, spacing_m: f64) -> Self {
        let spacing_m = if spacing_m.is_finite() && spacing_m > 0.0 {
            spacing_m
        } else {
            4.0
        };
        let cells = |a: f64, b: f64| (((b - a) / spacing_m).ceil().max(1.0) as usize).min(512);
        Self {
            origin: lo,
            spacing_m,
            columns: cells(lo.x, hi.x) + 1,
            rows: cells(lo.y, hi.y) + 1,
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.columns * self.rows
    }

    /// True when the grid has no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The four nodes around `p` and their bilinear weights (summing to 1), clamped to
    /// the grid's cells outside it.
    pub fn weights(&self, p: Point2) -> [(usize, f64); 4] {
        let fx = (p.x - self.origin.x) / self.spacing_m;
        let fy = (p.y - self.origin.y) / self.spacing_m;
        let i = (fx.floor().max(0.0) as usize).min(self.columns.saturating_sub(2));
        let j = (fy.floor().max(0.0) as usize).min(self.rows.saturating_sub(2));
        let (u, v) = (
            (fx - i as f64).clamp(0.0, 1.0),
            (fy - j as f64).clamp(0.0, 1.0),
        );
        let k = j * self.columns + i;
        [
            (k, (1.0 - u) * (1.0 - v)),
            (k + 1, u * (1.0 - v)),
            (k + self.columns, (1.0 - u) * v),
            (k + self.columns + 1, u * v),
        ]
    }
}

impl ControlGrid {
    /// `∂β/∂x` and `∂β/∂y` (per meter) of the four weights of [`ControlGrid::weights`], in
    /// the same order; zero along an axis where `p` lies outside the grid.
    pub fn weight_gradients(&self, p: Point2) -> ([f64; 4], [f64; 4]) {
        let fx = (p.x - self.origin.x) / self.spacing_m;
        let fy = (p.y - self.origin.y) / self.spacing_m;
        let i = (fx.floor().max(0.0) as usize).min(self.columns.saturating_sub(2));
        let j = (fy.floor().max(0.0) as usize).min(self.rows.saturating_sub(2));
        let (u, v) = (fx - i as f64, fy - j as f64);
        let inside = |f: f64, n: usize| (0.0..=(n.saturating_sub(1)) as f64).contains(&f);
        let gx = if inside(fx, self.columns) {
            1.0 / self.spacing_m
        } else {
            0.0
        };
        let gy = if inside(fy, self.rows) {
            1.0 / self.spacing_m
        } else {
            0.0
        };
        let (u, v) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        (
            [-(1.0 - v) * gx, (1.0 - v) * gx, -v * gx, v * gx],
            [-(1.0 - u) * gy, -u * gy, (1.0 - u) * gy, u * gy],
        )
    }
}

/// The warp W of the module doc.
#[derive(Debug, Clone, PartialEq)]
pub struct Warp {
    /// `A`, `t`.
    pub similarity: Similarity,
    /// Where the offsets live.
    pub grid: ControlGrid,
    /// Offset of each node, drawing frame pixels (row-major, `grid.len()` of them).
    pub offsets: Vec<Point2>,
}

impl Warp {
    /// The similarity alone over `grid` (every offset zero).
    pub fn rigid(similarity: Similarity, grid: ControlGrid) -> Self {
        Self {
            similarity,
            grid,
            offsets: vec![Point2::new(0.0, 0.0); grid.len()],
        }
    }

    /// The same warp on another control grid: each new node takes the offset this warp
    /// has at its place (coarse to fine, exact for a grid that halves this one's cells).
    pub fn resampled(&self, grid: ControlGrid) -> Warp {
        let offsets = (0..grid.len())
            .map(|k| {
                let q = Point2::new(
                    grid.origin.x + (k % grid.columns) as f64 * grid.spacing_m,
                    grid.origin.y + (k / grid.columns) as f64 * grid.spacing_m,
                );
                let (w, s) = (self.apply(q), self.similarity.apply(q));
                Point2::new(w.x - s.x, w.y - s.y)
            })
            .collect();
        Warp {
            similarity: self.similarity,
            grid,
            offsets,
        }
    }

    /// `W(p)`, drawing frame pixels.
    pub fn apply(&self, p: Point2) -> Point2 {
        let s = self.similarity.apply(p);
        let (mut x, mut y) = (s.x, s.y);
        for (k, w) in self.grid.weights(p) {
            if let Some(o) = self.offsets.get(k) {
                x += w * o.x;
                y += w * o.y;
            }
        }
        Point2::new(x, y)
    }

    /// `W(p)` as image pixels `(u, v)`.
    pub fn to_pixel(&self, p: Point2) -> Point2 {
        let w = self.apply(p);
        Point2::new(w.x, -w.y)
    }

    /// `∂W/∂p` at `p` (drawing pixels per map meter): `A + Σ_k o_k ∂β_k/∂p`, the bilinear
    /// weights' derivatives in the cell around `p` (zero along an axis where `p` lies
    /// outside the grid, whose offsets are held constant there). The local scale and
    /// rotation of the drawing at `p`.
    pub fn jacobian(&self, p: Point2) -> Matrix2<f64> {
        let s = &self.similarity;
        let mut j = Matrix2::new(s.a, -s.b, s.b, s.a);
        let (dbx, dby) = self.grid.weight_gradients(p);
        for ((k, _), (gx, gy)) in self.grid.weights(p).iter().zip(dbx.iter().zip(dby)) {
            if let Some(o) = self.offsets.get(*k) {
                j[(0, 0)] += o.x * gx;
                j[(0, 1)] += o.x * gy;
                j[(1, 0)] += o.y * gx;
                j[(1, 1)] += o.y * gy;
            }
        }
        j
    }

    /// A map heading (radians, map frame) as a heading on the drawing (drawing frame),
    /// turned by W's local rotation at `p`.
    pub fn heading_on_drawing(&self, p: Point2, heading_rad: f64) -> f64 {
        let d = self.jacobian(p) * nalgebra::Vector2::new(heading_rad.cos(), heading_rad.sin());
        d.y.atan2(d.x)
    }

    /// A map pose on the drawing: its pixel, its heading turned by W's local rotation, and
    /// the drawing's local scale `1 / √|det J|` meters per pixel (an area's mean).
    pub fn pose_on_drawing(&self, pose: &Pose2) -> SketchPose {
        let p = pose.position();
        let px = self.to_pixel(p);
        let det = self.jacobian(p).determinant().abs();
        SketchPose {
            u_px: px.x,
            v_px: px.y,
            heading_rad: self.heading_on_drawing(p, pose.heading_rad),
            meters_per_pixel: if det > 0.0 {
                1.0 / det.sqrt()
            } else {
                f64::NAN
            },
        }
    }
}

impl Warp {
    /// `W⁻¹(w)`: the map point that W carries to drawing-frame `w` (pixels), by Newton's
    /// method from the similarity's inverse, `p ← p − J(p)⁻¹ (W(p) − w)` with
    /// [`Warp::jacobian`]. `None` where W folds (`det J ≤ 0` on the way) or Newton does not
    /// reach 10⁻⁶ px in `INVERSE_ITERATIONS` (30) steps (a point W cannot reach). W is
    /// bilinear per cell, so Newton converges in a few steps inside a cell. O(iterations).
    pub fn invert(&self, w: Point2) -> Option<Point2> {
        let s = &self.similarity;
        let n2 = s.a * s.a + s.b * s.b;
        if !(n2 > 0.0 && n2.is_finite() && w.x.is_finite() && w.y.is_finite()) {
            return None;
        }
        // A⁻¹ (w − t), A⁻¹ = [[a, b], [−b, a]] / (a² + b²).
        let (dx, dy) = (w.x - s.t.x, w.y - s.t.y);
        let mut p = Point2::new((s.a * dx + s.b * dy) / n2, (-s.b * dx + s.a * dy) / n2);
        for _ in 0..INVERSE_ITERATIONS {
            let at = self.apply(p);
            let r = nalgebra::Vector2::new(at.x - w.x, at.y - w.y);
            if r.norm() < 1e-6 {
                return Some(p);
            }
            let j = self.jacobian(p);
            if j.determinant() <= 0.0 {
                return None;
            }
            let step = j.try_inverse()? * r;
            p = Point2::new(p.x - step.x, p.y - step.y);
        }
        (self.apply(p).distance(&w) < 1e-6).then_some(p)
    }

    /// [`Warp::invert`] of an image pixel `(u, v)` (the drawing frame is `(u, −v)`).
    pub fn from_pixel(&self, px: Point2) -> Option<Point2> {
        self.invert(Point2::new(px.x, -px.y))
    }

    /// A pose on the drawing (image pixel, heading in the drawing frame) as a map pose: the
    /// pixel through W⁻¹, the heading turned back by W's local rotation there (the
    /// direction `J⁻¹ d`). The inverse of [`Warp::pose_on_drawing`]'s position and heading.
    pub fn pose_from_drawing(&self, px: Point2, heading_rad: f64) -> Option<Pose2> {
        let p = self.from_pixel(px)?;
        let d = self.jacobian(p).try_inverse()?
            * nalgebra::Vector2::new(heading_rad.cos(), heading_rad.sin());
        let pose = Pose2::new(p.x, p.y, d.y.atan2(d.x));
        pose.is_finite().then_some(pose)
    }
}

/// Newton steps of [`Warp::invert`] at most.
const INVERSE_ITERATIONS: usize = 30;

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> ControlGrid {
        ControlGrid::covering(Point2::new(0.0, 0.0), Point2::new(8.0, 4.0), 4.0)
    }

    #[test]
    fn the_grid_covers_the_box_with_whole_cells() {
        let g = grid();
        assert_eq!((g.columns, g.rows), (3, 2));
        let g = ControlGrid::covering(Point2::new(0.0, 0.0), Point2::new(8.5, 0.1), 4.0);
        assert_eq!((g.columns, g.rows), (4, 2));
    }

    #[test]
    fn a_cell_centre_takes_a_quarter_of_each_corner() {
        // Cell (0, 0) has nodes 0, 1 (row 0) and 3, 4 (row 1); its centre is (2, 2).
        let w = grid().weights(Point2::new(2.0, 2.0));
        assert_eq!(w.map(|(k, _)| k), [0, 1, 3, 4]);
        for (_, b) in w {
            assert!((b - 0.25).abs() < 1e-12);
        }
        // A node takes all of its own offset; outside the grid the edge cell is clamped.
        let w = grid().weights(Point2::new(4.0, 0.0));
        assert_eq!(w.iter().find(|(k, _)| *k == 1).map(|(_, b)| *b), Some(1.0));
        let w = grid().weights(Point2::new(-3.0, 9.0));
        assert_eq!(w.iter().find(|(k, _)| *k == 3).map(|(_, b)| *b), Some(1.0));
    }

    #[test]
    fn the_warp_is_the_similarity_plus_interpolated_offsets() {
        // 20 px/m turned 90°: map (1, 0) → drawing (0, 20), then + (5, 5).
        let s = Similarity::new(20.0, std::f64::consts::FRAC_PI_2, Point2::new(5.0, 5.0));
        let mut w = Warp::rigid(s, grid());
        let p = w.apply(Point2::new(1.0, 0.0));
        assert!(
            (p.x - 5.0).abs() < 1e-9 && (p.y - 25.0).abs() < 1e-9,
            "{p:?}"
        );
        // Node 4 at map (4, 4) moved 8 px along x: the centre of cell (0, 0) moves 2 px.
        w.offsets[4] = Point2::new(8.0, 0.0);
        let c = w.apply(Point2::new(2.0, 2.0));
        let r = s.apply(Point2::new(2.0, 2.0));
        assert!((c.x - r.x - 2.0).abs() < 1e-9 && (c.y - r.y).abs() < 1e-9);
        assert!((s.scale_px_per_m() - 20.0).abs() < 1e-9);
        assert!((s.rotation_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Image pixels flip the drawing frame's y.
        assert_eq!(w.to_pixel(Point2::new(1.0, 0.0)).y, -25.0);
    }

    #[test]
    fn a_finer_grid_carries_the_same_warp() {
        let s = Similarity::new(20.0, 0.1, Point2::new(3.0, 4.0));
        let mut w = Warp::rigid(s, grid());
        w.offsets[4] = Point2::new(8.0, -2.0);
        w.offsets[2] = Point2::new(-3.0, 1.0);
        let fine = w.resampled(ControlGrid::covering(
            Point2::new(0.0, 0.0),
            Point2::new(8.0, 4.0),
            2.0,
        ));
        assert_eq!((fine.grid.columns, fine.grid.rows), (5, 3));
        for (x, y) in [(0.3, 0.2), (2.0, 2.0), (5.1, 3.7), (7.9, 0.1), (4.0, 4.0)] {
            let p = Point2::new(x, y);
            assert!(w.apply(p).distance(&fine.apply(p)) < 1e-9, "({x}, {y})");
        }
    }

    #[test]
    fn the_jacobian_reads_the_local_scale_and_turn() {
        let s = Similarity::new(10.0, 0.3, Point2::new(0.0, 0.0));
        let w = Warp::rigid(s, grid());
        let j = w.jacobian(Point2::new(3.0, 1.0));
        assert!((j[(0, 0)] - 10.0 * 0.3f64.cos()).abs() < 1e-9, "{j}");
        assert!((j[(1, 0)] - 10.0 * 0.3f64.sin()).abs() < 1e-9, "{j}");
        assert!((w.heading_on_drawing(Point2::new(3.0, 1.0), 0.2) - 0.5).abs() < 1e-9);
        // On the drawing: (3, 1) turned 0.3 rad at 10 px/m, v = −y.
        let on = w.pose_on_drawing(&Pose2::new(3.0, 1.0, 0.2));
        let at = s.apply(Point2::new(3.0, 1.0));
        assert!((on.u_px - at.x).abs() < 1e-9 && (on.v_px + at.y).abs() < 1e-9);
        assert!((on.heading_rad - 0.5).abs() < 1e-9 && (on.meters_per_pixel - 0.1).abs() < 1e-9);
    }

    #[test]
    fn the_inverse_carries_a_drawn_point_back_to_the_map() {
        // 10 px/m turned 0.2 rad, node 4 moved 6 px: W is no similarity any more.
        let s = Similarity::new(10.0, 0.2, Point2::new(30.0, -40.0));
        let mut w = Warp::rigid(s, grid());
        w.offsets[4] = Point2::new(6.0, -3.0);
        w.offsets[1] = Point2::new(-2.0, 4.0);
        for (x, y) in [(0.5, 0.5), (2.0, 2.0), (3.9, 0.1), (6.0, 3.0), (-2.0, 5.0)] {
            let p = Point2::new(x, y);
            let back = w.from_pixel(w.to_pixel(p)).expect("W is invertible here");
            assert!(back.distance(&p) < 1e-6, "({x}, {y}) → {back:?}");
            let pose = Pose2::new(x, y, 0.7);
            let on = w.pose_on_drawing(&pose);
            let again = w
                .pose_from_drawing(Point2::new(on.u_px, on.v_px), on.heading_rad)
                .unwrap();
            assert!(again.position().distance(&p) < 1e-6);
            assert!((again.heading_rad - 0.7).abs() < 1e-6, "{again:?}");
        }
        // By hand, the similarity alone: drawing (30 + 10 cos 0.2, −40 + 10 sin 0.2) is (1, 0).
        let r = Warp::rigid(s, grid());
        let q = Point2::new(30.0 + 10.0 * 0.2f64.cos(), -40.0 + 10.0 * 0.2f64.sin());
        assert!(r.invert(q).unwrap().distance(&Point2::new(1.0, 0.0)) < 1e-9);
        // A folded warp (a node pushed past its neighbour) has no inverse there.
        let mut folded = Warp::rigid(Similarity::new(10.0, 0.0, Point2::new(0.0, 0.0)), grid());
        folded.offsets[1] = Point2::new(-60.0, 0.0);
        folded.offsets[4] = Point2::new(-60.0, 0.0);
        assert_eq!(folded.invert(Point2::new(20.0, 20.0)), None);
    }
}
