//! Directions a scan does not measure keep the odometry's prediction: ICP decides the
//! directions the scan constrains, the odometry the ones it does not (a corridor's axis).
//!
//! Sits after [`super::icp`] in the keyframe ICP of the `graph` and `sketch` front ends. In a
//! featureless corridor the point-to-line normal matrix `H = Σ w J Jᵀ`
//! ([`IcpResult::normal_matrix`]) is nearly singular along the axis: each unit normal adds
//! `(n · d)²` to the information along a direction `d`, so the eigenvalue `λ` of `H`'s
//! translation block along `d` counts the returns, weighted, whose walls face `d`. Along the
//! axis only the noise of the reference normals contributes, and the converged pose slides
//! there by centimetres per scan at random — over a corridor, a map shortened or stretched
//! along it.
//!
//! The remedy follows Zhang, Kaess, Singh, "On degeneracy of optimization-based state
//! estimation problems" (ICRA 2016), solution remapping: with `H_t = Σ λ_k v_k v_kᵀ`, every
//! eigen-direction with `λ_k` below `min_points` is degenerate, and the pose's translation
//! along it is replaced by the prediction's:
//!
//! `t = t_icp + Σ_{λ_k < min_points} v_k v_kᵀ (t_odo − t_icp)`
//!
//! The bound is a number of returns: fewer than about twenty returns facing a direction
//! (a door frame's edge is a few; a corridor's end wall at 20 m, a quarter-degree scanner,
//! some thirty) do not measure it against the normals' noise. It needs reference normals
//! from evenly spaced points ([`crate::mapper::IcpReference::Submap`] thins them): from a raw
//! scan's dense near returns the normals' noise alone can add tens. Cost: O(1).

use super::icp::IcpResult;
use nalgebra::Vector2;
use sketchslam_types::Pose2;

/// The default bound: a direction faced by fewer returns than this is not measured.
pub const DEFAULT_MIN_POINTS: f64 = 20.0;

/// What [`hold_unmeasured_directions`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    /// The pose: ICP's, with the degenerate directions' translation from the prediction.
    pub pose: Pose2,
    /// Directions held (0, 1 or 2).
    pub directions: usize,
    /// Directions the scan does not measure, held or not (0, 1 or 2).
    pub unmeasured: usize,
}

/// The module doc's remapping of `result`'s translation towards `predicted` along the
/// eigen-directions of `H` with fewer than `min_points` returns; the heading stays ICP's.
/// A non-finite prediction leaves ICP's pose.
pub fn hold_unmeasured_directions(result: &IcpResult, predicted: &Pose2, min_points: f64) -> Held {
    hold_unmeasured_slides(result, predicted, min_points, 0.0)
}

/// [`hold_unmeasured_directions`], holding a degenerate direction only where ICP moved the
/// pose along it farther than `beyond_m` from the prediction: within the odometry's own
/// error along a direction the scan does not measure, ICP's small moves stand (a hall's
/// one wall corrects the odometry's scale bias), and a slide the odometry cannot have made
/// (centimetres per scan, the scan reaching where the reference did not look) is the
/// prediction's. `beyond_m` = k·σ_t of the odometry over the step
/// ([`super::odometry_noise`]); 0 holds every degenerate direction.
pub fn hold_unmeasured_slides(
    result: &IcpResult,
    predicted: &Pose2,
    min_points: f64,
    beyond_m: f64,
) -> Held {
    remap_unmeasured(result, predicted, min_points, |slide_m| {
        if slide_m.abs() > beyond_m {
            slide_m
        } else {
            0.0
        }
    })
}

/// [`hold_unmeasured_directions`] against a prediction that may be far off, by
/// `window_m`: along a degenerate direction ICP's pose is kept within `window_m` of
/// `reckoned` and brought back to the window's edge where it lies beyond,
///
/// `t = t_icp + Σ_{λ_k < min_points} v_k · sign(s_k)·max(0, |s_k| − w)`, `s_k = v_kᵀ(t_odo − t_icp)`.
///
/// With `reckoned` the odometry dead-reckoned since the last scan ICP placed in every
/// direction and `window_m` k·σ of the odometry's error over that stretch
/// (Thrun's `α₃·D + α₄·Θ`, [`super::odometry_noise`]), ICP's step errors that undo each
/// other over the stretch stand, and a slide the odometry cannot have made over it is cut
/// to what it can. `window_m` = 0 is [`hold_unmeasured_directions`]. O(1).
pub fn clamp_unmeasured_slides(
    result: &IcpResult,
    reckoned: &Pose2,
    min_points: f64,
    window_m: f64,
) -> Held {
    remap_unmeasured(result, reckoned, min_points, |slide_m| {
        slide_m.signum() * (slide_m.abs() - window_m).max(0.0)
    })
}

/// The eigen-directions of `result`'s translation information with fewer than
/// `min_points` returns, each moved by `shift(s)` of the slide `s = vᵀ(predicted − icp)`
/// from ICP's pose towards `predicted`; a non-finite prediction leaves ICP's pose.
fn remap_unmeasured(
    result: &IcpResult,
    predicted: &Pose2,
    min_points: f64,
    shift_of: impl Fn(f64) -> f64,
) -> Held {
    let icp = result.pose;
    let weak = result.unmeasured_directions(min_points);
    let unmeasured = weak.clone().count();
    if !predicted.is_finite() {
        return Held {
            pose: icp,
            directions: 0,
            unmeasured,
        };
    }
    let d = Vector2::new(predicted.x - icp.x, predicted.y - icp.y);
    let mut shift = Vector2::zeros();
    let mut directions = 0;
    for v in weak {
        let moved_m = shift_of(v.dot(&d));
        if moved_m != 0.0 {
            shift += v * moved_m;
            directions += 1;
        }
    }
    Held {
        pose: Pose2::new(icp.x + shift.x, icp.y + shift.y, icp.heading_rad),
        directions,
        unmeasured,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// A match in a corridor along x: 3 returns face x, 500 face y.
    fn corridor() -> IcpResult {
        result(Matrix3::from_diagonal(&nalgebra::Vector3::new(
            3.0, 500.0, 100.0,
        )))
    }

    /// A match in a room: 300 returns face x, 500 face y.
    fn room() -> IcpResult {
        result(Matrix3::from_diagonal(&nalgebra::Vector3::new(
            300.0, 500.0, 100.0,
        )))
    }

    fn result(normal_matrix: Matrix3<f64>) -> IcpResult {
        IcpResult {
            pose: Pose2::new(10.0, 2.0, 0.1),
            iterations: 5,
            inliers: 100,
            rms_m: 0.02,
            converged: true,
            normal_matrix,
        }
    }

    #[test]
    fn a_corridor_keeps_the_prediction_along_its_axis_and_icp_across() {
        // A corridor along x: 500 returns face y, 3 face x.
        let r = corridor();
        let held = hold_unmeasured_directions(&r, &Pose2::new(10.3, 2.3, 0.0), 20.0);
        assert_eq!(held.directions, 1);
        assert!((held.pose.x - 10.3).abs() < 1e-12 && (held.pose.y - 2.0).abs() < 1e-12);
        assert_eq!(held.pose.heading_rad, 0.1);
    }

    #[test]
    fn only_a_slide_beyond_the_odometrys_error_is_held() {
        // A corridor along x: ICP moved the pose 0.3 m along it from the prediction.
        let r = corridor();
        let predicted = Pose2::new(10.3, 2.3, 0.0);
        // The odometry can be 0.5 m off: ICP's move stands.
        let kept = hold_unmeasured_slides(&r, &predicted, 20.0, 0.5);
        assert_eq!(kept.directions, 0);
        assert_eq!(kept.pose, r.pose);
        // It can be 0.1 m off: the slide is the prediction's, across stays ICP's.
        let held = hold_unmeasured_slides(&r, &predicted, 20.0, 0.1);
        assert_eq!(held.directions, 1);
        assert!((held.pose.x - 10.3).abs() < 1e-12 && (held.pose.y - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_slide_beyond_the_stretchs_window_is_cut_to_its_edge() {
        // A corridor along x; the dead-reckoned pose 0.3 m behind ICP's along it, 0.1 m
        // to its side.
        let r = corridor();
        let reckoned = Pose2::new(9.7, 2.1, 0.0);
        // The odometry can be 0.5 m off over the stretch: ICP's pose stands.
        let kept = clamp_unmeasured_slides(&r, &reckoned, 20.0, 0.5);
        assert_eq!(
            (kept.pose, kept.directions, kept.unmeasured),
            (r.pose, 0, 1)
        );
        // 0.2 m: along the axis ICP's pose comes back to 9.7 + 0.2, across it stays.
        let cut = clamp_unmeasured_slides(&r, &reckoned, 20.0, 0.2);
        assert_eq!((cut.directions, cut.unmeasured), (1, 1));
        assert!((cut.pose.x - 9.9).abs() < 1e-12 && (cut.pose.y - 2.0).abs() < 1e-12);
        // Ahead instead of behind, the same by symmetry; a zero window holds the
        // reckoning.
        let ahead = clamp_unmeasured_slides(&r, &Pose2::new(10.3, 2.1, 0.0), 20.0, 0.2);
        assert!((ahead.pose.x - 10.1).abs() < 1e-12, "{ahead:?}");
        let zero = clamp_unmeasured_slides(&r, &reckoned, 20.0, 0.0);
        assert!((zero.pose.x - 9.7).abs() < 1e-12, "{zero:?}");
        // A room: nothing unmeasured, nothing moved.
        let room = room();
        let held = clamp_unmeasured_slides(&room, &reckoned, 20.0, 0.0);
        assert_eq!(
            (held.pose, held.directions, held.unmeasured),
            (room.pose, 0, 0)
        );
    }

    #[test]
    fn a_turned_corridor_is_held_along_its_own_axis() {
        // The axis at 30°: H = 500 n nᵀ with n the axis' normal (−sin 30°, cos 30°).
        let (s, c) = 30f64.to_radians().sin_cos();
        let mut h = Matrix3::zeros();
        h[(0, 0)] = 500.0 * s * s;
        h[(0, 1)] = -500.0 * s * c;
        h[(1, 0)] = -500.0 * s * c;
        h[(1, 1)] = 500.0 * c * c;
        let r = result(h);
        // The prediction is 1 m ahead along the axis and 0.2 m to its side: only the
        // first is taken.
        let predicted = Pose2::new(10.0 + c - 0.2 * s, 2.0 + s + 0.2 * c, 0.0);
        let held = hold_unmeasured_directions(&r, &predicted, 20.0);
        assert!((held.pose.x - (10.0 + c)).abs() < 1e-9, "{held:?}");
        assert!((held.pose.y - (2.0 + s)).abs() < 1e-9, "{held:?}");
    }

    #[test]
    fn a_room_and_a_bad_prediction_keep_icp() {
        let r = room();
        let held = hold_unmeasured_directions(&r, &Pose2::new(10.3, 2.3, 0.0), 20.0);
        assert_eq!((held.pose, held.directions), (r.pose, 0));
        let nan = Pose2::new(f64::NAN, 0.0, 0.0);
        assert_eq!(hold_unmeasured_directions(&r, &nan, 20.0).pose, r.pose);
    }
}
