//! The trajectory between two placed scans: the odometry carried from both ends, blended.
//!
//! Last step of the mapper's per-scan flow and of every back-end correction (see
//! [`super`]): the trajectory holds a pose at every odometry message, but only scans are
//! placed by the front end and moved by the back end. A pose between the scans at `t₀` and
//! `t₁` (map poses `x₀`, `x₁`; odometry `o₀`, `o₁`; its own odometry `o(t)`) is carried
//! forward from the first and back from the second, and the two are blended by how much of
//! the odometry's heading error had grown by then:
//!
//! ```text
//! x(t) = lerp(x₀ ⊕ (o₀⁻¹ ⊕ o(t)),  x₁ ⊕ (o₁⁻¹ ⊕ o(t)),  u = σ_θ(o₀ → o(t)) / σ_θ(o₀ → o₁))
//! ```
//!
//! with `σ_θ` the odometry's heading sigma over the path driven so far
//! ([`OdometryNoise::sigma`]: per radian turned and per meter travelled), so the correction
//! the second scan made spreads over the stretch before it as the odometry's error grew
//! along it, instead of landing at once at the scan: a robot that turned and then stood
//! still took all of it during the turn. A stretch without motion blends by time. At 20 Hz
//! it moves poses by millimetres; a log keeping one scan a second (the Intel and CSAIL
//! benchmark logs) holds a second of raw odometry between two placed scans, off by
//! degrees. Measured 2026-12-04 against blending by time (graph, relations): MIT CSAIL
//! 0.0505 → 0.0501 m, Intel 0.0762 → 0.0760 m. Cost: O(poses in the stretch).

use super::output::TrajectoryPoint;
use crate::scan_matching::odometry_noise::{OdometryNoise, OdometryPath};
use sketchslam_types::Pose2;

/// Blends the interior of `stretch` (a placed scan at each end) as the module doc says;
/// `odometry[i]` is the odometry reading of `stretch[i]`. Ends, and stretches of fewer
/// than three poses or no time, are left as they are; a non-finite blend keeps the pose.
pub fn blend_stretch(stretch: &mut [TrajectoryPoint], odometry: &[Pose2], noise: &OdometryNoise) {
    let n = stretch.len().min(odometry.len());
    if n < 3 {
        return;
    }
    let (first, last) = (stretch[0], stretch[n - 1]);
    if last.stamp_ns <= first.stamp_ns {
        return;
    }
    let span_ns = (last.stamp_ns - first.stamp_ns) as f64;
    let (o0, o1) = (odometry[0], odometry[n - 1]);
    // The heading error the odometry accumulated from the first scan to each pose.
    let mut grown = Vec::with_capacity(n);
    let mut path = OdometryPath::default();
    grown.push(0.0);
    for pair in odometry[..n].windows(2) {
        path = path.then(&pair[0].between(&pair[1]));
        grown.push(noise.sigma(&path).heading_rad);
    }
    let total = grown[n - 1];
    for (k, (point, odom)) in stretch[1..n - 1]
        .iter_mut()
        .zip(&odometry[1..n - 1])
        .enumerate()
    {
        let forward = first.pose.compose(&o0.between(odom));
        let backward = last.pose.compose(&o1.between(odom));
        let u = if total > 0.0 && total.is_finite() {
            grown[k + 1] / total
        } else {
            (point.stamp_ns.saturating_sub(first.stamp_ns) as f64 / span_ns).clamp(0.0, 1.0)
        };
        let pose = forward.lerp(&backward, u);
        if pose.is_finite() {
            point.pose = pose;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(stamp_ns: u64, pose: Pose2) -> TrajectoryPoint {
        TrajectoryPoint { stamp_ns, pose }
    }

    /// The trajectory of `odometry` read every quarter second, each pose where the odometry
    /// puts it.
    fn every_quarter_second(odometry: &[Pose2]) -> Vec<TrajectoryPoint> {
        odometry
            .iter()
            .enumerate()
            .map(|(k, o)| point(k as u64 * 250_000_000, *o))
            .collect()
    }

    #[test]
    fn a_scan_correction_spreads_over_the_stretch_before_it() {
        // Odometry: straight along x, 1 m per second. The second scan was placed 0.4 m
        // further and turned 0.2 rad more than the odometry says.
        let odometry: Vec<Pose2> = (0..5)
            .map(|k| Pose2::new(k as f64 * 0.25, 0.0, 0.0))
            .collect();
        let mut stretch = every_quarter_second(&odometry);
        stretch[4].pose = Pose2::new(1.4, 0.0, 0.2);
        blend_stretch(&mut stretch, &odometry, &OdometryNoise::default());
        // At t = 0.5 s: forward (0.5, 0, 0); backward 0.5 m behind the second scan along
        // its heading, (1.4 − 0.5 cos 0.2, −0.5 sin 0.2, 0.2); halfway between them.
        let mid = stretch[2].pose;
        let (s, c) = 0.2f64.sin_cos();
        assert!(
            (mid.x - 0.5 * (0.5 + 1.4 - 0.5 * c)).abs() < 1e-12,
            "{mid:?}"
        );
        assert!((mid.y - 0.5 * (-0.5 * s)).abs() < 1e-12, "{mid:?}");
        assert!((mid.heading_rad - 0.1).abs() < 1e-12, "{mid:?}");
        // The ends stay; a quarter of the way the forward pose weighs three quarters.
        assert_eq!(stretch[0].pose, odometry[0]);
        assert_eq!(stretch[4].pose, Pose2::new(1.4, 0.0, 0.2));
        assert!((stretch[1].pose.heading_rad - 0.05).abs() < 1e-12);
    }

    #[test]
    fn a_turn_then_a_stop_takes_the_whole_correction_during_the_turn() {
        // Odometry: a 0.4 rad turn in place during the first quarter second, then still.
        // The second scan was placed turned 0.1 rad more than the odometry says.
        let odometry: Vec<Pose2> = [0.0, 0.4, 0.4, 0.4, 0.4]
            .iter()
            .map(|&h| Pose2::new(0.0, 0.0, h))
            .collect();
        let mut stretch = every_quarter_second(&odometry);
        stretch[4].pose = Pose2::new(0.0, 0.0, 0.5);
        blend_stretch(&mut stretch, &odometry, &OdometryNoise::default());
        // The heading error had all grown by the end of the turn: every pose after it is
        // carried back from the second scan (0.5 rad); by time the first would be 0.425.
        for p in &stretch[1..4] {
            assert!((p.pose.heading_rad - 0.5).abs() < 1e-12, "{p:?}");
        }
    }

    #[test]
    fn odometry_that_agrees_with_the_scans_changes_nothing() {
        let odometry: Vec<Pose2> = (0..4)
            .map(|k| Pose2::new(k as f64, 0.5 * k as f64, 0.1 * k as f64))
            .collect();
        // The map frame is the odometry's, turned and shifted: both ends agree with it.
        let frame = Pose2::new(3.0, -2.0, 1.0);
        let mut stretch: Vec<TrajectoryPoint> = odometry
            .iter()
            .enumerate()
            .map(|(k, o)| point(k as u64 * 100, frame.compose(o)))
            .collect();
        let before = stretch.clone();
        blend_stretch(&mut stretch, &odometry, &OdometryNoise::default());
        for (a, b) in stretch.iter().zip(&before) {
            assert!(a.pose.position().distance(&b.pose.position()) < 1e-12);
            assert!((a.pose.heading_rad - b.pose.heading_rad).abs() < 1e-12);
        }
    }
}
