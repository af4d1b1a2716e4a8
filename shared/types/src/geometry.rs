//! Rigid motions in the plane: `Point2` and `Pose2` (an element of SE(2)).
//!
//! A `Pose2` `p = (x, y, θ)` maps a point `q` of its local frame into the parent frame as
//! `p ⊕ q = R(θ)·q + t` with `R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]`, `t = (x, y)`.
//! Composition follows the same rule (`a ⊕ b`), the inverse is `(−Rᵀt, −θ)`. Headings are
//! kept wrapped to (−π, π]. Everything is O(1).

use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// Wraps an angle in radians to (−π, π].
pub fn wrap_angle(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let mut a = angle_rad % (2.0 * PI);
    if a <= -PI {
        a += 2.0 * PI;
    } else if a > PI {
        a -= 2.0 * PI;
    }
    a
}

/// Wraps an undirected angle difference (between two line directions, which are defined
/// modulo π) to (−π/2, π/2].
pub fn wrap_half_pi(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let mut a = angle_rad % PI;
    if a <= -FRAC_PI_2 {
        a += PI;
    } else if a > FRAC_PI_2 {
        a -= PI;
    }
    a
}

/// A point in the plane, in meters unless the holder says otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point2 {
    /// Abscissa.
    pub x: f64,
    /// Ordinate.
    pub y: f64,
}

impl Point2 {
    /// A point from its coordinates.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Euclidean distance to `other`.
    pub fn distance(&self, other: &Point2) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// Euclidean norm (distance to the origin).
    pub fn norm(&self) -> f64 {
        self.x.hypot(self.y)
    }

    /// The nearest point to `self` on the segment `a`–`b` (`a` itself when they coincide):
    /// the projection `a + t (b − a)`, `t` clamped to [0, 1].
    pub fn nearest_on_segment(&self, a: Point2, b: Point2) -> Point2 {
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 {
            (((self.x - a.x) * dx + (self.y - a.y) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Point2::new(a.x + t * dx, a.y + t * dy)
    }
}

/// A pose in the plane: position in meters and heading in radians, counter-clockwise
/// from the parent frame's +x axis, wrapped to (−π, π].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    /// Position along the parent's x axis, meters.
    pub x: f64,
    /// Position along the parent's y axis, meters.
    pub y: f64,
    /// Heading, radians in (−π, π].
    pub heading_rad: f64,
}

impl Pose2 {
    /// The identity pose.
    pub const IDENTITY: Pose2 = Pose2 {
        x: 0.0,
        y: 0.0,
        heading_rad: 0.0,
    };

    /// A pose; the heading is wrapped to (−π, π].
    pub fn new(x: f64, y: f64, heading_rad: f64) -> Self {
        Self {
            x,
            y,
            heading_rad: wrap_angle(heading_rad),
        }
    }

    /// The position as a point.
    pub fn position(&self) -> Point2 {
        Point2::new(self.x, self.y)
    }

    /// `self ⊕ other`: `other` expressed in `self`'s frame, brought to the parent frame.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (s, c) = self.heading_rad.sin_cos();
        Pose2::new(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            self.heading_rad + other.heading_rad,
        )
    }

    /// The inverse motion: `p ⊕ p.inverse() = identity`.
    pub fn inverse(&self) -> Pose2 {
        let (s, c) = self.heading_rad.sin_cos();
        Pose2::new(
            -(c * self.x + s * self.y),
            s * self.x - c * self.y,
            -self.heading_rad,
        )
    }

    /// `self⁻¹ ⊕ other`: the pose of `other` seen from `self` (an odometry increment).
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// Maps a point of this pose's local frame into the parent frame.
    pub fn transform_point(&self, p: &Point2) -> Point2 {
        let (s, c) = self.heading_rad.sin_cos();
        Point2::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }

    /// Maps a point of the parent frame into this pose's local frame.
    pub fn inverse_transform_point(&self, p: &Point2) -> Point2 {
        let (s, c) = self.heading_rad.sin_cos();
        let (dx, dy) = (p.x - self.x, p.y - self.y);
        Point2::new(c * dx + s * dy, -s * dx + c * dy)
    }

    /// The pose a share `u` of the way from `self` to `other`: positions linearly, the
    /// heading along the shorter turn (`u = 0` gives `self`, `u = 1` `other`).
    pub fn lerp(&self, other: &Pose2, u: f64) -> Pose2 {
        let turn = wrap_angle(other.heading_rad - self.heading_rad);
        Pose2::new(
            self.x + u * (other.x - self.x),
            self.y + u * (other.y - self.y),
            self.heading_rad + u * turn,
        )
    }

    /// True when every field is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.heading_rad.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_point_inside_and_beyond_a_segment() {
        let (a, b) = (Point2::new(0.0, 0.0), Point2::new(10.0, 0.0));
        assert_eq!(
            Point2::new(4.0, 3.0).nearest_on_segment(a, b),
            Point2::new(4.0, 0.0)
        );
        assert_eq!(
            Point2::new(-2.0, 1.0).nearest_on_segment(a, b),
            Point2::new(0.0, 0.0)
        );
        assert_eq!(Point2::new(5.0, 5.0).nearest_on_segment(a, a), a);
    }

    #[test]
    fn wrap_half_pi_range() {
        assert!((wrap_half_pi(PI) - 0.0).abs() < 1e-12);
        assert!((wrap_half_pi(FRAC_PI_2) - FRAC_PI_2).abs() < 1e-12);
        assert!((wrap_half_pi(-FRAC_PI_2) - FRAC_PI_2).abs() < 1e-12);
        assert!((wrap_half_pi(3.0) - (3.0 - PI)).abs() < 1e-12);
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn wraps_to_half_open_interval() {
        assert!(close(wrap_angle(PI), PI));
        assert!(close(wrap_angle(-PI), PI));
        assert!(close(wrap_angle(3.0 * PI), PI));
        assert!(close(wrap_angle(2.5 * PI), 0.5 * PI));
        assert!(close(wrap_angle(-0.5 * PI), -0.5 * PI));
    }

    #[test]
    fn compose_by_hand() {
        // Facing +y at (1, 2); one meter ahead and one to the left is (0, 3).
        let a = Pose2::new(1.0, 2.0, FRAC_PI_2);
        let b = Pose2::new(1.0, 1.0, FRAC_PI_2);
        let c = a.compose(&b);
        assert!(close(c.x, 0.0) && close(c.y, 3.0) && close(c.heading_rad, PI));
    }

    #[test]
    fn inverse_undoes_compose() {
        let a = Pose2::new(-3.0, 0.5, 2.7);
        let id = a.compose(&a.inverse());
        assert!(id.x.abs() < 1e-12 && id.y.abs() < 1e-12 && id.heading_rad.abs() < 1e-12);
        let b = Pose2::new(0.3, -1.2, -2.0);
        let d = a.between(&a.compose(&b));
        assert!(close(d.x, b.x) && close(d.y, b.y) && close(d.heading_rad, b.heading_rad));
    }

    #[test]
    fn point_round_trip() {
        let a = Pose2::new(2.0, -1.0, 0.7);
        let p = Point2::new(0.4, 5.0);
        let q = a.inverse_transform_point(&a.transform_point(&p));
        assert!(close(p.x, q.x) && close(p.y, q.y));
    }

    #[test]
    fn lerp_takes_the_shorter_turn() {
        // From 170° to −170° is 20° through 180°, not 340° back through 0°.
        let a = Pose2::new(0.0, 0.0, 170f64.to_radians());
        let b = Pose2::new(2.0, -4.0, (-170f64).to_radians());
        let m = a.lerp(&b, 0.25);
        assert!((m.x - 0.5).abs() < 1e-12 && (m.y + 1.0).abs() < 1e-12);
        assert!((m.heading_rad - 175f64.to_radians()).abs() < 1e-12, "{m:?}");
        assert_eq!(a.lerp(&b, 0.0), a);
        assert!((a.lerp(&b, 1.0).heading_rad - b.heading_rad).abs() < 1e-12);
    }
}
