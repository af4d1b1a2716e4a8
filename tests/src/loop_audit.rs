//! Each loop of a simulated run's final pose graph against the truth: the relative pose the
//! loop holds beside the true relative pose of the two scans it joins. A diagnostic of the
//! loop closure (which loops bend a map), written by in-process runs as `loops.csv`.

use crate::metrics::{StampedPose, pose_at};
use sketchslam_engine::mapper::ClosedLoop;
use sketchslam_types::wrap_angle;
use std::fmt::Write;

/// A loop whose measurement is off the truth by more than this is counted as off, meters...
pub const OFF_M: f64 = 0.1;
/// ...or this, degrees.
pub const OFF_DEG: f64 = 1.0;

/// One loop and how far its measurement is from the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AuditedLoop {
    /// The loop as the back end holds it.
    pub closed: ClosedLoop,
    /// Translation of `measurement⁻¹ ⊕ truth`, meters.
    pub error_m: f64,
    /// Its heading, degrees.
    pub error_deg: f64,
}

impl AuditedLoop {
    /// True when the loop is off the truth by more than [`OFF_M`] or [`OFF_DEG`].
    pub fn is_off(&self) -> bool {
        self.error_m > OFF_M || self.error_deg.abs() > OFF_DEG
    }
}

/// The loops of `closed` whose two scans `truth` holds, each with its error.
pub fn audit(closed: &[ClosedLoop], truth: &[StampedPose]) -> Vec<AuditedLoop> {
    closed
        .iter()
        .filter_map(|l| {
            let from = pose_at(truth, l.from_stamp_ns as f64 * 1e-9)?;
            let to = pose_at(truth, l.to_stamp_ns as f64 * 1e-9)?;
            let error = l.measurement.between(&from.between(&to));
            Some(AuditedLoop {
                closed: *l,
                error_m: error.position().norm(),
                error_deg: wrap_angle(error.heading_rad).to_degrees(),
            })
        })
        .collect()
}

/// `loops.csv`: one row per loop, stamps in seconds; with the match's score and the chain
/// test each loop passed (its d², the chain's deviation in meters and in degrees, and the
/// heading deviation the loop claimed), so a wrong loop's row tells whether the match or
/// the test let it in, and through which slack.
pub fn loops_csv(loops: &[AuditedLoop]) -> String {
    let mut csv = String::from(
        "from_t,to_t,x,y,theta,error_m,error_deg,off,score,chain_d2,chain_sigma_m,\
         chain_sigma_deg,loop_sigma_deg\n",
    );
    for l in loops {
        let c = &l.closed;
        let m = c.measurement;
        let _ = writeln!(
            csv,
            "{:.6},{:.6},{:.4},{:.4},{:.5},{:.4},{:.3},{},{:.3},{:.3},{:.4},{:.3},{:.3}",
            c.from_stamp_ns as f64 * 1e-9,
            c.to_stamp_ns as f64 * 1e-9,
            m.x,
            m.y,
            m.heading_rad,
            l.error_m,
            l.error_deg,
            u8::from(l.is_off()),
            c.score,
            c.chain_d2,
            c.chain_sigma_m,
            c.chain_sigma_deg,
            c.loop_sigma_deg
        );
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::Pose2;

    #[test]
    fn a_loop_is_scored_against_the_true_relative_pose() {
        let truth = vec![
            StampedPose {
                t_s: 1.0,
                pose: Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2),
            },
            StampedPose {
                t_s: 2.0,
                pose: Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2),
            },
        ];
        // Truly 2 m straight ahead; the loop says 2.3 m ahead, turned 2°.
        let closed = ClosedLoop {
            from_stamp_ns: 1_000_000_000,
            to_stamp_ns: 2_000_000_000,
            measurement: Pose2::new(2.3, 0.0, 2f64.to_radians()),
            score: 0.9,
            chain_d2: 2.5,
            chain_sigma_m: 0.4,
            chain_sigma_deg: 1.5,
            loop_sigma_deg: 1.0,
        };
        let audited = audit(&[closed], &truth);
        assert_eq!(audited.len(), 1);
        assert!((audited[0].error_m - 0.3).abs() < 0.01, "{audited:?}");
        assert!((audited[0].error_deg + 2.0).abs() < 1e-9, "{audited:?}");
        assert!(audited[0].is_off());
        let right = ClosedLoop {
            measurement: Pose2::new(2.0, 0.0, 0.0),
            ..closed
        };
        assert!(!audit(&[right], &truth)[0].is_off());
        // A stamp outside the truth: not audited.
        let outside = ClosedLoop {
            to_stamp_ns: 5_000_000_000,
            ..closed
        };
        assert!(audit(&[outside], &truth).is_empty());
    }

    #[test]
    fn loops_csv_carries_the_match_score_and_the_chain_test() {
        let closed = ClosedLoop {
            from_stamp_ns: 1_500_000_000,
            to_stamp_ns: 9_250_000_000,
            measurement: Pose2::new(3.0, -0.25, 0.5),
            score: 0.8,
            chain_d2: 4.5,
            chain_sigma_m: 1.25,
            chain_sigma_deg: 5.25,
            loop_sigma_deg: 0.5,
        };
        let audited = AuditedLoop {
            closed,
            error_m: 3.25,
            error_deg: -0.5,
        };
        let csv = loops_csv(&[audited]);
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some(
                "from_t,to_t,x,y,theta,error_m,error_deg,off,score,chain_d2,chain_sigma_m,\
                 chain_sigma_deg,loop_sigma_deg"
            )
        );
        assert_eq!(
            lines.next(),
            Some(
                "1.500000,9.250000,3.0000,-0.2500,0.50000,3.2500,-0.500,1,0.800,4.500,1.2500,\
                 5.250,0.500"
            )
        );
        assert_eq!(lines.next(), None);
    }
}
