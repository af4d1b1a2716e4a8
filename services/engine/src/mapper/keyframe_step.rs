//! The covariance of a keyframe step: how far the front end may have drifted between two
//! keyframes, the pose graph's sequential edge and the loop gate's chain both
//! ([`crate::back_end::loop_closure::LoopCloser::add_keyframe_with_step`]).
//!
//! Sits between the front end, which reports each scan's covariance and the odometry's
//! share of it (`FrontEndOutput::covariance`, a [`ScanCovariance`]), and the back end,
//! which gets one 3×3 covariance per keyframe step.
//!
//! Over scans `1..=k` since the last keyframe, `k` the new keyframe, with `C_i` scan `i`'s
//! covariance and `U_i` the odometry's share of it (the directions ICP did not measure, and
//! the heading when ICP held it; `keyframe_icp::Aligned`), three models
//! ([`KeyframeStepModel`]):
//!
//! ```text
//! Summed            Σ = Σ_{i=1..k} C_i
//! Anchored          Σ_xy = (C_k − U_k)_xy + Σ_i (U_i)_xy
//!                   σ²_θ = (C_k − U_k)_θθ + Σ_i (U_i)_θθ
//! MeasuredHeading   Σ_xy as Anchored
//!                   σ²_θ = Σ_{i: θ measured} (C_i)_θθ + (U_k)_θθ
//! ```
//!
//! with no heading–position cross terms in the last two. `Summed` treats every scan's error
//! as independent, a random walk. But keyframe ICP places each scan against a submap of
//! the last few meters, which holds the previous keyframe, so its position errors do not
//! add up: `Anchored` keeps the keyframe's own match against the submap and adds the
//! wheels' variance only along what the scans did not measure (their scale bias adds up
//! linearly along such a stretch; summed here as a random walk, not modelled yet), and
//! treats the heading alike: the keyframe's own match, plus the odometry's variance on
//! every scan whose heading ICP held. `MeasuredHeading` instead sums the headings ICP measured, whose errors carry as the submap
//! moves with the route, and drops the odometry's heading variance on a scan ICP did not
//! place in heading (not the keyframe), because the next scan it does place is matched
//! against the submap again: logged against the truth, such scans' heading jumps come back
//! at the next measured scan.
//!
//! Calibrated on 26 generated worlds (seeds 31–60, `graph-open`, README "A model of the
//! front end's drift", `docs/experiments/chain_calibration.py`): the mean of `e²/σ²_θ`, `e`
//! the actual relative heading error between two scans 8–128 m of route apart, is 0.11–0.15
//! with the good LiDAR and 0.28–0.49 with the cheap ones for `MeasuredHeading`, against
//! 0.02–0.05 and 0.06–0.14 for `Summed`: the better model, still conservative, and
//! heavy-tailed (medians 0.01–0.1; ICP's heading variance is Censi's first term, which
//! misses a slip now and then). Yet over 60 generated worlds the map is decided by the loop
//! gate reading it, not by its calibration: a tight chain refuses the loops that would mend a
//! front end's slip (good corridors), a loose one lets aliased loops through (cheap
//! corridors and halls); README, the table there.
//!
//! Pure and O(1) per scan.

use super::front_end_io::ScanCovariance;
use nalgebra::{Matrix2, Matrix3};
use serde::{Deserialize, Serialize};

/// How the scans' covariances since the last keyframe make the keyframe step's (module
/// doc, with the formulas and what each was measured to do).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KeyframeStepModel {
    /// Every scan's covariance summed, a random walk (the default: the others fail the
    /// MIT CSAIL log's whole-log test, README).
    #[default]
    Summed,
    /// The keyframe's own match plus the odometry's share of every scan.
    Anchored,
    /// Positions as `Anchored`; the headings ICP measured summed, the odometry's only for
    /// the keyframe's own.
    MeasuredHeading,
}

/// The scans since the last keyframe, accumulated as [`KeyframeStep::take`] needs them.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct KeyframeStep {
    /// Σ `C_i`.
    total: Matrix3<f64>,
    /// Σ `U_i`.
    unmeasured: Matrix3<f64>,
    /// Σ `(C_i)_θθ` over the scans whose heading ICP measured, rad².
    measured_heading_rad2: f64,
    /// Whether a scan reported a covariance since the last keyframe.
    reported: bool,
}

impl KeyframeStep {
    /// Adds a scan's covariance (its `unmeasured` heading variance zero when ICP measured
    /// the heading).
    pub fn add_scan(&mut self, covariance: &ScanCovariance) {
        self.total += covariance.total;
        self.unmeasured += covariance.unmeasured;
        if covariance.unmeasured[(2, 2)] <= 0.0 {
            self.measured_heading_rad2 += covariance.total[(2, 2)];
        }
        self.reported = true;
    }

    /// The step's covariance under `model` (module doc), `own` the keyframe's scan's, added
    /// last by [`KeyframeStep::add_scan`] (when the keyframe has none, its own share counts
    /// as zero); `None` when no scan reported one. Starts the next step.
    pub fn take(
        &mut self,
        model: KeyframeStepModel,
        own: Option<&ScanCovariance>,
    ) -> Option<Matrix3<f64>> {
        let step = std::mem::take(self);
        if !step.reported {
            return None;
        }
        let own_measured = own.map_or_else(Matrix3::zeros, |c| c.total - c.unmeasured);
        let own_unmeasured_heading = own.map_or(0.0, |c| c.unmeasured[(2, 2)]);
        let heading_rad2 = match model {
            KeyframeStepModel::Summed => return Some(step.total),
            KeyframeStepModel::Anchored => own_measured[(2, 2)] + step.unmeasured[(2, 2)],
            KeyframeStepModel::MeasuredHeading => {
                step.measured_heading_rad2 + own_unmeasured_heading
            }
        };
        let xy: Matrix2<f64> =
            own_measured.fixed_view::<2, 2>(0, 0) + step.unmeasured.fixed_view::<2, 2>(0, 0);
        let mut out = Matrix3::zeros();
        out.fixed_view_mut::<2, 2>(0, 0).copy_from(&xy);
        out[(2, 2)] = heading_rad2;
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn diag(x: f64, y: f64, h: f64) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::new(x, y, h))
    }

    fn scan(total: Matrix3<f64>, unmeasured: Matrix3<f64>) -> ScanCovariance {
        ScanCovariance { total, unmeasured }
    }

    const MODELS: [KeyframeStepModel; 3] = [
        KeyframeStepModel::Summed,
        KeyframeStepModel::Anchored,
        KeyframeStepModel::MeasuredHeading,
    ];

    #[test]
    fn nothing_reported_gives_none() {
        let own = scan(diag(1.0, 1.0, 1.0), Matrix3::zeros());
        for model in MODELS {
            assert_eq!(KeyframeStep::default().take(model, Some(&own)), None);
        }
    }

    /// Three scans down a corridor along x. Scan 1 is measured in every direction (xy 1e-4,
    /// heading 1e-6); scan 2 not along x (the odometry's 4e-4 there, within its total 5e-4)
    /// and its heading held (the odometry's 1e-5); the keyframe, scan 3, like scan 1 but
    /// heading 2e-6. By hand:
    /// - Summed: (1 + 5 + 1, 1 + 9 + 1)·1e-4, (1 + 10 + 2)·1e-6;
    /// - Anchored: xy the keyframe's own (1e-4, 1e-4) + scan 2's unmeasured 4e-4 along x,
    ///   heading the keyframe's own 2e-6 + scan 2's odometry 1e-5;
    /// - MeasuredHeading: xy the same, heading the measured ones 1e-6 + 2e-6 (scan 2's 1e-5
    ///   does not carry).
    #[test]
    fn corridor_step_by_hand() {
        let scans = [
            scan(diag(1e-4, 1e-4, 1e-6), Matrix3::zeros()),
            scan(diag(5e-4, 9e-4, 1e-5), diag(4e-4, 0.0, 1e-5)),
            scan(diag(1e-4, 1e-4, 2e-6), Matrix3::zeros()),
        ];
        let want = [
            diag(7e-4, 11e-4, 13e-6),
            diag(5e-4, 1e-4, 12e-6),
            diag(5e-4, 1e-4, 3e-6),
        ];
        for (model, want) in MODELS.into_iter().zip(want) {
            let mut step = KeyframeStep::default();
            for s in &scans {
                step.add_scan(s);
            }
            let cov = step.take(model, scans.last()).unwrap();
            assert!((cov - want).abs().max() < 1e-15, "{model:?}: {cov}");
            // The next step starts empty.
            assert_eq!(step, KeyframeStep::default());
        }
    }

    /// A keyframe whose own heading ICP could not measure keeps the odometry's variance for
    /// it in every model.
    #[test]
    fn unmeasured_keyframe_heading_is_kept() {
        for model in MODELS {
            let mut step = KeyframeStep::default();
            step.add_scan(&scan(diag(1e-4, 1e-4, 1e-6), Matrix3::zeros()));
            let own = scan(diag(1e-4, 1e-4, 3e-5), diag(0.0, 0.0, 3e-5));
            step.add_scan(&own);
            let cov = step.take(model, Some(&own)).unwrap();
            assert!(cov[(2, 2)] >= 3e-5 - 1e-15, "{model:?}: {cov}");
        }
    }

    /// Every scan measured in every direction: the anchored models' position is the
    /// keyframe's own match (against a submap that holds the previous keyframe), not the
    /// sum; `MeasuredHeading`'s heading is the sum, `Anchored`'s the keyframe's own.
    #[test]
    fn fully_measured_step() {
        let each = scan(diag(2e-4, 3e-4, 1e-6), Matrix3::zeros());
        let want = [
            diag(2e-3, 3e-3, 1e-5),
            diag(2e-4, 3e-4, 1e-6),
            diag(2e-4, 3e-4, 1e-5),
        ];
        for (model, want) in MODELS.into_iter().zip(want) {
            let mut step = KeyframeStep::default();
            for _ in 0..10 {
                step.add_scan(&each);
            }
            let cov = step.take(model, Some(&each)).unwrap();
            assert!((cov - want).abs().max() < 1e-15, "{model:?}: {cov}");
        }
    }
}
