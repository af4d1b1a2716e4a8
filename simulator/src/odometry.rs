//! The wheel-odometry model: true motion increments in, a drifting dead-reckoned pose out.
//!
//! The simulator samples the true motion at the odometry rate and feeds each pair of
//! consecutive true poses to [`OdometryModel::step`]; the result is what a wheel-odometry
//! driver would publish (`Odometry` messages). A log replay uses the same model on the
//! log's (corrected) poses to add drift of its own.
//!
//! # Error model
//!
//! Per step the true increment `u = p_prev⁻¹ ⊕ p_now` (robot frame) is split into a travelled
//! distance `Δs = |(uₓ, u_y)|` in the direction `α = atan2(u_y, uₓ)` (0 when driving forward)
//! and a turned angle `Δθ = u_θ`. The odometry measures
//!
//! ```text
//! Δs' = Δs·(1 + trans_bias) + N(0, trans_noise²·|Δs|)
//! Δθ' = Δθ·(1 + rot_bias)   + N(0, rot_noise²·|Δθ|)
//! ```
//!
//! and integrates `pose ← pose ⊕ (Δs'·cos α, Δs'·sin α, Δθ')`.
//!
//! The variance grows with the distance (angle) of the step, not per step: the errors of
//! successive steps add up as a random walk in the travelled distance, so after driving
//! `D` meters the distance error is `N(trans_bias·D, trans_noise²·D)` whatever the rate.
//! That is how the scenario's "sd per meter travelled" is read: `trans_noise` is the
//! standard deviation after 1 m, in m/√m (likewise `rot_noise` after 1 rad, in rad/√rad).
//! With zero noise and bias the dead-reckoned pose equals the true one (expressed in the
//! odometry frame).
//!
//! The odometry frame is the robot's start pose: the dead-reckoned pose starts at the
//! identity, as a driver that zeroes its odometry at boot. Each step is O(1) and draws
//! exactly two standard normals, so a run is reproducible from its seed.

use crate::scenario::OdometryConfig;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use sketchslam_types::Pose2;

/// A dead-reckoning integrator with noisy, biased increments.
#[derive(Debug, Clone)]
pub struct OdometryModel<R: Rng = ChaCha8Rng> {
    trans_noise: f64,
    rot_noise: f64,
    trans_bias: f64,
    rot_bias: f64,
    pose: Pose2,
    rng: R,
}

impl<R: Rng> OdometryModel<R> {
    /// A model with `config`'s noise and bias, drawing from `rng`, starting at the identity.
    /// (`config.rate_hz` is the caller's business: it decides when to call `step`.)
    pub fn new(config: &OdometryConfig, rng: R) -> Self {
        Self {
            trans_noise: config.trans_noise,
            rot_noise: config.rot_noise,
            trans_bias: config.trans_bias,
            rot_bias: config.rot_bias,
            pose: Pose2::IDENTITY,
            rng,
        }
    }

    /// The same model starting at `pose` instead of the identity.
    pub fn with_start(mut self, pose: Pose2) -> Self {
        self.pose = pose;
        self
    }

    /// The current dead-reckoned pose.
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// Feeds the true motion from `true_prev` to `true_now` (consecutive true poses, any
    /// frame) and returns the new dead-reckoned pose. See the module doc for the model.
    pub fn step(&mut self, true_prev: Pose2, true_now: Pose2) -> Pose2 {
        let u = true_prev.between(&true_now);
        let ds_m = u.x.hypot(u.y);
        let direction_rad = if ds_m > 0.0 { u.y.atan2(u.x) } else { 0.0 };
        let dtheta_rad = u.heading_rad;

        let z_trans: f64 = self.rng.sample(StandardNormal);
        let z_rot: f64 = self.rng.sample(StandardNormal);
        let ds_meas_m =
            ds_m * (1.0 + self.trans_bias) + self.trans_noise * ds_m.abs().sqrt() * z_trans;
        let dtheta_meas_rad =
            dtheta_rad * (1.0 + self.rot_bias) + self.rot_noise * dtheta_rad.abs().sqrt() * z_rot;

        let (s, c) = direction_rad.sin_cos();
        let increment = Pose2::new(ds_meas_m * c, ds_meas_m * s, dtheta_meas_rad);
        if increment.is_finite() {
            self.pose = self.pose.compose(&increment);
        }
        self.pose
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn rng() -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(1)
    }

    fn config(noise: f64, bias: f64) -> OdometryConfig {
        OdometryConfig {
            rate_hz: 50.0,
            trans_noise: noise,
            rot_noise: noise,
            trans_bias: bias,
            rot_bias: bias,
        }
    }

    #[test]
    fn noise_free_odometry_follows_the_truth() {
        let mut m =
            OdometryModel::new(&config(0.0, 0.0), rng()).with_start(Pose2::new(1.0, 2.0, 0.3));
        let poses = [
            Pose2::new(1.0, 2.0, 0.3),
            Pose2::new(1.1, 2.05, 0.3),
            Pose2::new(1.1, 2.05, 0.9),
            Pose2::new(0.9, 2.3, 1.2),
        ];
        for w in poses.windows(2) {
            m.step(w[0], w[1]);
        }
        let p = m.pose();
        let t = poses[3];
        assert!((p.x - t.x).abs() < 1e-12 && (p.y - t.y).abs() < 1e-12);
        assert!((p.heading_rad - t.heading_rad).abs() < 1e-12);
    }

    #[test]
    fn bias_scales_distance() {
        let mut m = OdometryModel::new(&config(0.0, 0.1), rng());
        m.step(Pose2::IDENTITY, Pose2::new(2.0, 0.0, 0.0));
        assert!((m.pose().x - 2.2).abs() < 1e-12);
    }
}
