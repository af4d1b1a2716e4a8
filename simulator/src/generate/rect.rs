//! Axis-aligned rectangles on the world grid (0.05 m per pixel), and the distances the
//! generator's clearance rules are made of.
//!
//! Everything a layout places ([`super::floor`]) is a [`Rect`] snapped to the grid, so the
//! world image carves it exactly and every number prints short in `scenario.toml`.

use sketchslam_types::Point2;

/// Pixels (cells) per meter of the world image: 0.05 m per pixel.
pub const PX_PER_M: f64 = 20.0;

/// Meters per pixel of the world image.
pub const RESOLUTION_M: f64 = 1.0 / PX_PER_M;

/// `v_m` rounded to the world grid (a multiple of 0.05 m, as `n / 20` so it prints short).
pub fn snap(v_m: f64) -> f64 {
    (v_m * PX_PER_M).round() / PX_PER_M
}

/// An axis-aligned rectangle, meters; `x0_m < x1_m`, `y0_m < y1_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x0_m: f64,
    /// Bottom edge.
    pub y0_m: f64,
    /// Right edge.
    pub x1_m: f64,
    /// Top edge.
    pub y1_m: f64,
}

impl Rect {
    /// The rectangle spanned by two corners, snapped to the grid.
    pub fn new(xa_m: f64, ya_m: f64, xb_m: f64, yb_m: f64) -> Rect {
        Rect {
            x0_m: snap(xa_m.min(xb_m)),
            y0_m: snap(ya_m.min(yb_m)),
            x1_m: snap(xa_m.max(xb_m)),
            y1_m: snap(ya_m.max(yb_m)),
        }
    }

    /// Width (x extent), meters.
    pub fn width_m(&self) -> f64 {
        self.x1_m - self.x0_m
    }

    /// Height (y extent), meters.
    pub fn height_m(&self) -> f64 {
        self.y1_m - self.y0_m
    }

    /// The centre point.
    pub fn centre(&self) -> Point2 {
        Point2::new(0.5 * (self.x0_m + self.x1_m), 0.5 * (self.y0_m + self.y1_m))
    }

    /// The four corners, counter-clockwise from the bottom-left.
    pub fn corners(&self) -> [Point2; 4] {
        [
            Point2::new(self.x0_m, self.y0_m),
            Point2::new(self.x1_m, self.y0_m),
            Point2::new(self.x1_m, self.y1_m),
            Point2::new(self.x0_m, self.y1_m),
        ]
    }

    /// True when `p` is inside the rectangle shrunk by `margin_m` on every side.
    pub fn contains(&self, p: Point2, margin_m: f64) -> bool {
        p.x >= self.x0_m + margin_m
            && p.x <= self.x1_m - margin_m
            && p.y >= self.y0_m + margin_m
            && p.y <= self.y1_m - margin_m
    }

    /// The rectangle grown by `d_m` on every side (not snapped).
    pub fn expanded(&self, d_m: f64) -> Rect {
        Rect {
            x0_m: self.x0_m - d_m,
            y0_m: self.y0_m - d_m,
            x1_m: self.x1_m + d_m,
            y1_m: self.y1_m + d_m,
        }
    }

    /// The overlap of two rectangles when it has a positive area.
    pub fn intersection(&self, other: &Rect) -> Option<Rect> {
        let r = Rect {
            x0_m: self.x0_m.max(other.x0_m),
            y0_m: self.y0_m.max(other.y0_m),
            x1_m: self.x1_m.min(other.x1_m),
            y1_m: self.y1_m.min(other.y1_m),
        };
        (r.x0_m < r.x1_m && r.y0_m < r.y1_m).then_some(r)
    }

    /// Moved by `(dx_m, dy_m)`.
    pub fn translated(&self, dx_m: f64, dy_m: f64) -> Rect {
        Rect::new(
            self.x0_m + dx_m,
            self.y0_m + dy_m,
            self.x1_m + dx_m,
            self.y1_m + dy_m,
        )
    }

    /// Distance from the rectangle (filled) to the point `p`, 0 inside.
    pub fn distance_to_point(&self, p: Point2) -> f64 {
        let dx = (self.x0_m - p.x).max(p.x - self.x1_m).max(0.0);
        let dy = (self.y0_m - p.y).max(p.y - self.y1_m).max(0.0);
        dx.hypot(dy)
    }

    /// Distance from the rectangle (filled) to the segment `a → b`, 0 when they meet.
    pub fn distance_to_segment(&self, a: Point2, b: Point2) -> f64 {
        if self.meets_segment(a, b) {
            return 0.0;
        }
        // Apart: the nearest pair involves an endpoint of the segment or a corner.
        let ends = self.distance_to_point(a).min(self.distance_to_point(b));
        self.corners()
            .iter()
            .map(|&c| point_segment_distance(c, a, b))
            .fold(ends, f64::min)
    }

    /// True when the segment `a → b` has a point in the rectangle (Liang-Barsky clip).
    fn meets_segment(&self, a: Point2, b: Point2) -> bool {
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-dx, a.x - self.x0_m),
            (dx, self.x1_m - a.x),
            (-dy, a.y - self.y0_m),
            (dy, self.y1_m - a.y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let t = q / p;
                if p < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        t0 <= t1
    }
}

/// Distance from the point `p` to the segment `a → b`.
pub fn point_segment_distance(p: Point2, a: Point2, b: Point2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.x - a.x) * dx + (p.y - a.y) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(&Point2::new(a.x + t * dx, a.y + t * dy))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_and_rectangles_measure_their_distance() {
        let r = Rect::new(1.0, 1.0, 2.0, 2.0);
        assert_eq!(
            r.distance_to_segment(Point2::new(0.0, 1.5), Point2::new(3.0, 1.5)),
            0.0
        );
        let d = r.distance_to_segment(Point2::new(0.0, 3.0), Point2::new(3.0, 3.0));
        assert!((d - 1.0).abs() < 1e-12);
        let d = r.distance_to_segment(Point2::new(3.0, 0.0), Point2::new(4.0, -1.0));
        assert!((d - 2f64.sqrt()).abs() < 1e-12);
    }
}
