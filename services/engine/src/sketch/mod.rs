//! The hand-drawn map: what an uploaded drawing becomes before localization uses it.
//!
//! Coordinates: pixel `(u, v)` from the image's top-left corner, `u` to the right, `v`
//! down; a pixel's centre is at `(col + 0.5, row + 0.5)`. Headings and line angles are
//! counter-clockwise from the image's +u axis *as the drawing is seen*, i.e. in the frame
//! `x = u`, `y = −v`: heading θ moves a point by `(du, dv) = (cos θ, −sin θ)`.

pub mod font;
pub mod hough;
pub mod ingest;
pub mod jpeg_check;
pub mod merge;
pub mod overlay;
pub mod raycast;
pub mod thinning;
pub mod threshold;

pub use hough::LineExtractionConfig;
pub use ingest::{SketchLimits, SketchOptions};
pub use overlay::{encode_png, render_overlay};
pub use threshold::ThresholdConfig;

use fixedbitset::FixedBitSet;
use sketchslam_types::Point2;

/// One straight wall of the drawing, in sketch pixels.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SketchLine {
    /// Index of the line in its sketch, from 0; the paper's line number.
    pub index: usize,
    /// First endpoint, `(u, v)` pixels (`x = u`, `y = v`).
    pub a: Point2,
    /// Second endpoint, `(u, v)` pixels.
    pub b: Point2,
    /// Direction of the line in the `x = u, y = −v` frame, radians in [0, π) (lines are
    /// undirected).
    pub angle_rad: f64,
}

impl SketchLine {
    /// A line from two endpoints in pixels; computes its angle.
    pub fn new(index: usize, a: Point2, b: Point2) -> Self {
        let mut angle_rad = (-(b.y - a.y)).atan2(b.x - a.x);
        if angle_rad < 0.0 {
            angle_rad += std::f64::consts::PI;
        }
        if angle_rad >= std::f64::consts::PI {
            angle_rad -= std::f64::consts::PI;
        }
        Self {
            index,
            a,
            b,
            angle_rad,
        }
    }

    /// Length in pixels.
    pub fn length_px(&self) -> f64 {
        self.a.distance(&self.b)
    }
}

/// A processed drawing: its size, which pixels are strokes, and its lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Sketch {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Row-major stroke mask, `width_px × height_px` bits: set where the person drew (one
    /// bit a pixel: a kept 16-megapixel drawing holds 2 MB, not 16).
    pub strokes: FixedBitSet,
    /// The extracted straight lines, `lines[i].index == i`.
    pub lines: Vec<SketchLine>,
}

impl Sketch {
    /// True when `(u, v)` (pixels) lies inside the image.
    pub fn contains(&self, u: f64, v: f64) -> bool {
        u >= 0.0 && v >= 0.0 && u < self.width_px as f64 && v < self.height_px as f64
    }

    /// True when the pixel holding `(u, v)` is a stroke; false outside the image.
    pub fn is_stroke(&self, u: f64, v: f64) -> bool {
        self.contains(u, v)
            && self
                .strokes
                .contains(v as usize * self.width_px as usize + u as usize)
    }

    /// A stroke mask from one flag a pixel, row-major.
    pub fn mask_from_flags(flags: &[bool]) -> FixedBitSet {
        let mut mask = FixedBitSet::with_capacity(flags.len());
        for (i, _) in flags.iter().enumerate().filter(|(_, s)| **s) {
            mask.insert(i);
        }
        mask
    }
}

/// A robot pose on the drawing with the drawing's scale: what MCL on the sketch estimates.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SketchPose {
    /// Column, pixels from the left edge.
    pub u_px: f64,
    /// Row, pixels from the top edge.
    pub v_px: f64,
    /// Heading, radians counter-clockwise from +u as the drawing is seen (`x = u, y = −v`).
    pub heading_rad: f64,
    /// The drawing's scale around this pose, meters per pixel (the paper's `s`).
    pub meters_per_pixel: f64,
}

impl SketchPose {
    /// Moves the pose by a robot-frame increment given in meters (forward `dx`, left `dy`,
    /// turn `dθ`), converting lengths with this pose's own scale — eq. (1)–(2) without noise.
    pub fn advanced(&self, dx_m: f64, dy_m: f64, dtheta_rad: f64) -> SketchPose {
        let (s, c) = self.heading_rad.sin_cos();
        let (dx_px, dy_px) = (dx_m / self.meters_per_pixel, dy_m / self.meters_per_pixel);
        // x = u, y = −v: a step along +y is a step towards smaller v.
        SketchPose {
            u_px: self.u_px + c * dx_px - s * dy_px,
            v_px: self.v_px - (s * dx_px + c * dy_px),
            heading_rad: sketchslam_types::wrap_angle(self.heading_rad + dtheta_rad),
            meters_per_pixel: self.meters_per_pixel,
        }
    }
}
