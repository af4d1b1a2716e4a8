//! How far the odometry's guess of a scan's pose can be off, and so whether ICP's local
//! descent can start from it or a correlative search must find the basin first.
//!
//! Sits before [`super::icp`] in the keyframe ICP of the `graph` and `sketch` front ends
//! ([`crate::mapper`]). ICP converges from a guess within its basin — about its first
//! correspondence gate in translation and a few degrees in heading (a point 10 m away moves
//! 0.87 m under 5°). At 20 Hz the odometry's increment is centimetres and a fraction of a
//! degree, and its error far smaller. A log that keeps one scan a second (GMapping's and the
//! benchmark's `.gfs` files, the Intel and CSAIL logs) moves a meter and turns up to 60°
//! between scans, and raw wheel odometry's heading is off by several degrees per such step:
//! ICP then slides into the wrong basin and the map breaks.
//!
//! The error model is the odometry motion model of Thrun, Burgard, Fox, *Probabilistic
//! Robotics* (2005), §5.4 (the `alpha1..4` of ROS's AMCL), over the path the odometry
//! reported since the last scan ([`OdometryPath`]): `Θ = Σ|Δθ|` radians turned and
//! `D = Σ|Δp|` meters travelled, summed over its readings:
//!
//! ```text
//! σ_θ = α₁·Θ + α₂·D        σ_t = α₃·D + α₄·Θ
//! ```
//!
//! Summed, not the net increment: wheels slip on every turn, also on one that is turned
//! back (on the CSAIL log the robot swings 56° and back 21° between two scans 1.3 s apart,
//! and its odometry ends 25° off a net turn of 4°).
//!
//! and the search covers ±3σ around the guess whenever that exceeds ICP's basin. The α's
//! are properties of the robot's wheels and floor, not of a map. Cost: O(1).

use sketchslam_types::Pose2;

/// The odometry's error per increment (Thrun et al. 2005, §5.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryNoise {
    /// α₁: heading sd per radian turned. Default 0.1 (10 % of a turn: worn wheels on
    /// carpet; AMCL's default 0.2 is its particles' spread, wider than the error).
    pub rot_per_rad: f64,
    /// α₂: heading sd per meter travelled, radians. Default 0.05 (~3° per meter).
    pub rot_per_m: f64,
    /// α₃: translation sd per meter travelled. Default 0.1.
    pub trans_per_m: f64,
    /// α₄: translation sd per radian turned, meters. Default 0.05.
    pub trans_per_rad: f64,
}

impl Default for OdometryNoise {
    fn default() -> Self {
        Self {
            rot_per_rad: 0.1,
            rot_per_m: 0.05,
            trans_per_m: 0.1,
            trans_per_rad: 0.05,
        }
    }
}

/// What the odometry reported between two scans: the sums of its readings' steps.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometryPath {
    /// `Σ|Δp|`, meters.
    pub travelled_m: f64,
    /// `Σ|Δθ|`, radians.
    pub turned_rad: f64,
}

impl OdometryPath {
    /// The path of one step `increment` (robot frame).
    pub fn of_increment(increment: &Pose2) -> Self {
        Self {
            travelled_m: increment.position().norm(),
            turned_rad: increment.heading_rad.abs(),
        }
    }

    /// This path followed by the step `increment`.
    pub fn then(&self, increment: &Pose2) -> Self {
        self.plus(&Self::of_increment(increment))
    }

    /// This path followed by `next`: the sums of both.
    pub fn plus(&self, next: &OdometryPath) -> Self {
        Self {
            travelled_m: self.travelled_m + next.travelled_m,
            turned_rad: self.turned_rad + next.turned_rad,
        }
    }
}

/// The standard deviations of one increment's error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IncrementSigma {
    /// Of the position, along each axis, meters.
    pub position_m: f64,
    /// Of the heading, radians.
    pub heading_rad: f64,
}

impl IncrementSigma {
    /// True when a position found by matching lies within `sigmas` of [`Self::position_m`]
    /// (plus `floor_m`, the matcher's own resolution) of the odometry's prediction:
    /// `|Δp| ≤ k·σ_t + f`, with `deviation` the prediction's `between` the match. A NaN
    /// deviation is not admitted. O(1).
    ///
    /// Position only: a heading correction of a few degrees is what scan matching is for
    /// (the previous pose's heading error against the reference, which the odometry's
    /// increment knows nothing of), while a position many σ away is another basin.
    pub fn admits_position(&self, deviation: &Pose2, sigmas: f64, floor_m: f64) -> bool {
        deviation.x.hypot(deviation.y) <= sigmas * self.position_m + floor_m
    }
}

impl OdometryNoise {
    /// True when every factor is finite and at least 0 (a standard deviation).
    pub fn is_valid(&self) -> bool {
        [
            self.rot_per_rad,
            self.rot_per_m,
            self.trans_per_m,
            self.trans_per_rad,
        ]
        .iter()
        .all(|f| f.is_finite() && *f >= 0.0)
    }

    /// The module doc's σ_t and σ_θ over `path`; a non-finite path gives infinite sigmas.
    pub fn sigma(&self, path: &OdometryPath) -> IncrementSigma {
        let (d, turn) = (path.travelled_m, path.turned_rad);
        if !(d.is_finite() && turn.is_finite()) {
            return IncrementSigma {
                position_m: f64::INFINITY,
                heading_rad: f64::INFINITY,
            };
        }
        IncrementSigma {
            position_m: self.trans_per_m * d + self.trans_per_rad * turn,
            heading_rad: self.rot_per_rad * turn + self.rot_per_m * d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_by_hand() {
        let noise = OdometryNoise {
            rot_per_rad: 0.1,
            rot_per_m: 0.05,
            trans_per_m: 0.2,
            trans_per_rad: 0.04,
        };
        // 3-4-5 m, half a radian: σ_t = 0.2·5 + 0.04·0.5, σ_θ = 0.1·0.5 + 0.05·5.
        let path = OdometryPath::of_increment(&Pose2::new(3.0, -4.0, -0.5));
        let s = noise.sigma(&path);
        assert!((s.position_m - 1.02).abs() < 1e-12, "{s:?}");
        assert!((s.heading_rad - 0.3).abs() < 1e-12, "{s:?}");
        let still = noise.sigma(&OdometryPath::default());
        assert_eq!((still.position_m, still.heading_rad), (0.0, 0.0));
        let nan = OdometryPath::of_increment(&Pose2::new(f64::NAN, 0.0, 0.0));
        assert!(noise.sigma(&nan).heading_rad.is_infinite());
    }

    #[test]
    fn admits_position_by_hand() {
        // A turn in place of 0.53 rad with the defaults: σ_t = 0.05·0.53 = 0.0265 m;
        // 5σ plus a 5 cm floor admits 0.1825 m.
        let sigma = OdometryNoise::default().sigma(&OdometryPath {
            travelled_m: 0.0,
            turned_rad: 0.53,
        });
        let admits =
            |x: f64, y: f64, h: f64| sigma.admits_position(&Pose2::new(x, y, h), 5.0, 0.05);
        assert!(admits(0.18, 0.0, 0.0));
        assert!(admits(0.11, 0.11, 0.5)); // 0.156 m; the heading is not judged
        assert!(!admits(0.14, 0.14, 0.0)); // 0.198 m
        // The Intel log's slide of 2026-12-05: 0.84 m while turning in place.
        assert!(!admits(0.6, 0.6, 0.0));
        assert!(!admits(f64::NAN, 0.0, 0.0));
    }

    #[test]
    fn a_turn_turned_back_counts_both_ways() {
        let noise = OdometryNoise::default();
        // 0.5 rad left, then 0.4 rad back: net 0.1 rad, turned 0.9 rad.
        let path = OdometryPath::default()
            .then(&Pose2::new(0.0, 0.0, 0.5))
            .then(&Pose2::new(0.0, 0.0, -0.4));
        assert!((path.turned_rad - 0.9).abs() < 1e-12);
        let s = noise.sigma(&path);
        assert!(
            (s.heading_rad - noise.rot_per_rad * 0.9).abs() < 1e-12,
            "{s:?}"
        );
    }
}
