//! How a world point lands on a drawing: the formula of `sketch-truth.toml`, as the
//! evaluation (`tests/src/sketch_truth.rs`) applies it, so generated drawings score right.
//!
//! `u = fx(x)/s + 10`, `v = H − 10 − fy(y)/s`, `W = ceil(fx(X)/s) + 20`,
//! `H = ceil(fy(Y)/s) + 20`, with `fx`, `fy` piecewise linear through knots
//! `[world m, drawn m]`; a photographed drawing is then turned by `rotate_deg`
//! counter-clockwise (as seen) about the canvas centre into an enlarged canvas. The
//! arithmetic is the evaluation's, operation for operation, so canvas sizes agree to the
//! pixel. [`super::drawing`] renders through [`DrawingMap::to_canvas`] and
//! [`DrawingMap::rotate`]; the scenario's marked starts come from
//! [`DrawingMap::world_to_drawing`].

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::{Pose2, wrap_angle};

/// Margin around the drawn floor, pixels.
pub const MARGIN_PX: f64 = 10.0;
/// The person's guess of every drawing's scale, meters per pixel.
pub const METERS_PER_PIXEL: f64 = 0.1;

/// Piecewise linear `f(x)` through `knots` (sorted by x), and its slope at `x`; extended
/// beyond the end knots along the end segments.
pub fn piecewise(knots: &[[f64; 2]], x: f64) -> (f64, f64) {
    let last = knots.len() - 2;
    let k = knots[..=last]
        .iter()
        .rposition(|k| k[0] <= x)
        .unwrap_or(0)
        .min(last);
    let ([x0, y0], [x1, y1]) = (knots[k], knots[k + 1]);
    let slope = (y1 - y0) / (x1 - x0);
    (y0 + slope * (x - x0), slope)
}

/// How one drawing was made from the world (one `[[sketch]]` of `sketch-truth.toml`).
#[derive(Debug, Clone, PartialEq)]
pub struct DrawingMap {
    /// Knots `[world m, drawn m]` of the x warp, increasing in both.
    pub fx: Vec<[f64; 2]>,
    /// Knots of the y warp.
    pub fy: Vec<[f64; 2]>,
    /// Turn of the photographed paper, degrees counter-clockwise (0: a scan).
    pub rotate_deg: f64,
    /// Canvas before the turn, pixels.
    pub width_px: f64,
    /// Canvas height before the turn, pixels.
    pub height_px: f64,
}

/// `v` rounded to `step`, as `n / (1/step)` so that it prints short and parses back equal.
fn round_to(v: f64, per_unit: f64) -> f64 {
    (v * per_unit).round() / per_unit
}

/// Random monotone knots over `[0, size_m]`: 1–3 segments, each stretched or squeezed by
/// 10–35 %.
fn random_knots(size_m: f64, rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
    let segments = rng.random_range(1..=3);
    let mut xs = vec![0.0];
    for k in 1..segments {
        // Interior knots spread out: one per share of the span, jittered.
        let share = size_m / segments as f64;
        xs.push(round_to(
            share * (k as f64 + rng.random_range(-0.25..0.25)),
            10.0,
        ));
    }
    xs.push(size_m);
    let mut knots = vec![[0.0, 0.0]];
    let mut drawn = 0.0;
    for w in xs.windows(2) {
        let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let slope = 1.0 + sign * rng.random_range(0.10..0.35);
        drawn = round_to(drawn + slope * (w[1] - w[0]), 100.0);
        knots.push([w[1], drawn]);
    }
    knots
}

impl DrawingMap {
    /// A drawing of a `world_size_m` world with the given warps and turn.
    pub fn new(
        world_size_m: [f64; 2],
        fx: Vec<[f64; 2]>,
        fy: Vec<[f64; 2]>,
        rotate_deg: f64,
    ) -> DrawingMap {
        let mpp = METERS_PER_PIXEL;
        let [w_m, h_m] = world_size_m;
        DrawingMap {
            width_px: (piecewise(&fx, w_m).0 / mpp).ceil() + 2.0 * MARGIN_PX,
            height_px: (piecewise(&fy, h_m).0 / mpp).ceil() + 2.0 * MARGIN_PX,
            fx,
            fy,
            rotate_deg,
        }
    }

    /// A random drawing: warped both ways, turned by 2–8° either way when `photographed`.
    pub fn random(world_size_m: [f64; 2], photographed: bool, rng: &mut ChaCha8Rng) -> DrawingMap {
        let fx = random_knots(world_size_m[0], rng);
        let fy = random_knots(world_size_m[1], rng);
        let rotate_deg = if photographed {
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            round_to(sign * rng.random_range(2.0..8.0), 10.0)
        } else {
            0.0
        };
        DrawingMap::new(world_size_m, fx, fy, rotate_deg)
    }

    /// The world point `(x_m, y_m)` on the canvas before the turn, pixels.
    pub fn to_canvas(&self, x_m: f64, y_m: f64) -> (f64, f64) {
        let s = METERS_PER_PIXEL;
        let (fx, _) = piecewise(&self.fx, x_m);
        let (fy, _) = piecewise(&self.fy, y_m);
        (fx / s + MARGIN_PX, self.height_px - MARGIN_PX - fy / s)
    }

    /// The canvas size after the turn, pixels.
    pub fn rotated_size(&self) -> (f64, f64) {
        let r = self.rotate_deg.to_radians();
        if r == 0.0 {
            return (self.width_px, self.height_px);
        }
        let (c, si) = (r.cos(), r.sin());
        let (w, h) = (self.width_px, self.height_px);
        (
            (w * c.abs() + h * si.abs() - 1e-9).ceil(),
            (w * si.abs() + h * c.abs() - 1e-9).ceil(),
        )
    }

    /// A canvas pixel position after the turn.
    pub fn rotate(&self, u: f64, v: f64) -> (f64, f64) {
        let r = self.rotate_deg.to_radians();
        if r == 0.0 {
            return (u, v);
        }
        let (c, si) = (r.cos(), r.sin());
        let (new_w, new_h) = self.rotated_size();
        let (du, dv) = (u - 0.5 * self.width_px, v - 0.5 * self.height_px);
        (
            0.5 * new_w + du * c + dv * si,
            0.5 * new_h - du * si + dv * c,
        )
    }

    /// The inverse of [`DrawingMap::rotate`]: a pixel of the turned image on the canvas.
    pub fn unrotate(&self, u: f64, v: f64) -> (f64, f64) {
        let r = self.rotate_deg.to_radians();
        if r == 0.0 {
            return (u, v);
        }
        let (c, si) = (r.cos(), r.sin());
        let (new_w, new_h) = self.rotated_size();
        let (du, dv) = (u - 0.5 * new_w, v - 0.5 * new_h);
        (
            0.5 * self.width_px + du * c - dv * si,
            0.5 * self.height_px + du * si + dv * c,
        )
    }

    /// The world pose on the final drawing: `(u_px, v_px, heading_rad)`, the heading
    /// counter-clockwise from +u as the drawing is seen.
    pub fn world_to_drawing(&self, pose: &Pose2) -> (f64, f64, f64) {
        let (u, v) = self.to_canvas(pose.x, pose.y);
        let (_, dfx) = piecewise(&self.fx, pose.x);
        let (_, dfy) = piecewise(&self.fy, pose.y);
        let heading = (dfy * pose.heading_rad.sin()).atan2(dfx * pose.heading_rad.cos())
            + self.rotate_deg.to_radians();
        let (u, v) = self.rotate(u, v);
        (u, v, wrap_angle(heading))
    }

    /// The segments' stretch factors, for the scenario's comment: `(x, y)` lists.
    pub fn stretches(&self) -> (Vec<f64>, Vec<f64>) {
        let f = |k: &[[f64; 2]]| {
            k.windows(2)
                .map(|w| (w[1][1] - w[0][1]) / (w[1][0] - w[0][0]))
                .collect()
        };
        (f(&self.fx), f(&self.fy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_env1_sketch_b_corner_lands_where_the_evaluation_puts_it() {
        let m = DrawingMap::new(
            [50.0, 36.0],
            vec![[0.0, 0.0], [16.0, 11.0], [50.0, 45.0]],
            vec![[0.0, 0.0], [36.0, 36.0]],
            0.0,
        );
        let (u, v, _) = m.world_to_drawing(&Pose2::new(16.0, 36.0, 0.0));
        assert!(
            (u - 120.0).abs() < 1e-9 && (v - 10.0).abs() < 1e-9,
            "{u} {v}"
        );
    }

    #[test]
    fn rotate_and_unrotate_are_inverse() {
        let m = DrawingMap::new(
            [50.0, 36.0],
            vec![[0.0, 0.0], [50.0, 52.0]],
            vec![[0.0, 0.0], [36.0, 37.0]],
            5.3,
        );
        let (u, v) = m.rotate(100.0, 200.0);
        let (a, b) = m.unrotate(u, v);
        assert!((a - 100.0).abs() < 1e-9 && (b - 200.0).abs() < 1e-9);
    }
}
