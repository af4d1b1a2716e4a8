//! Relation-based scoring of a trajectory (Kümmerle et al., "On measuring the accuracy of
//! SLAM algorithms", 2009): the error of estimated relative poses against reference ones,
//! which needs no global alignment and no ground-truth map.
//!
//! The evaluation of a dataset run reads the dataset's relations file with
//! [`read_relations`] and scores the service's `trajectory.csv` with [`score_relations`].
//!
//! A line of a relations file is `t1 t2 x y z roll pitch yaw`: the pose at `t2` seen from
//! the pose at `t1` (meters, radians). Its times are the log's timestamps plus the
//! dataset's `relations_time_offset`; [`parse_relations`] subtracts it, so relation times
//! are on the replay's clock (seconds of the log, as `trajectory.csv`). For each relation
//! the estimated relative pose `Δ_est = P(t1)⁻¹ ⊕ P(t2)` (poses interpolated with
//! [`metrics::pose_at`]) is compared with the reference Δ: translational error
//! `|t(Δ_est) − t(Δ)|` in meters, rotational error `|wrap(yaw_est − yaw)|` in degrees.

use crate::metrics::{self, StampedPose};
use anyhow::{Context, Result, bail};
use sketchslam_types::{Pose2, wrap_angle};
use std::path::Path;

/// One relation: the reference pose at `t2_s` seen from the pose at `t1_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relation {
    /// First time, seconds on the log's clock (offset removed).
    pub t1_s: f64,
    /// Second time, seconds on the log's clock.
    pub t2_s: f64,
    /// The relative pose (x, y, yaw).
    pub delta: Pose2,
}

/// The relation errors of a trajectory: means and (population) standard deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelationScore {
    /// Mean translational error, meters.
    pub trans_mean_m: f64,
    /// Standard deviation of the translational error, meters.
    pub trans_sd_m: f64,
    /// Mean rotational error, degrees.
    pub rot_mean_deg: f64,
    /// Standard deviation of the rotational error, degrees.
    pub rot_sd_deg: f64,
    /// Relations scored.
    pub used: usize,
    /// Relations skipped because a time falls outside the trajectory.
    pub skipped: usize,
}

/// Parses relations text; `time_offset_s` is subtracted from both times. Blank lines and
/// `#` comments are skipped; a malformed line is an error naming its 1-based number.
pub fn parse_relations(text: &str, time_offset_s: f64) -> Result<Vec<Relation>> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let values: Vec<f64> = t
            .split_whitespace()
            .map(|v| v.parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect::<Option<_>>()
            .with_context(|| format!("line {}: not all fields are finite numbers", n + 1))?;
        if values.len() != 8 {
            bail!(
                "line {}: expected 8 fields `t1 t2 x y z roll pitch yaw`, found {}",
                n + 1,
                values.len()
            );
        }
        out.push(Relation {
            t1_s: values[0] - time_offset_s,
            t2_s: values[1] - time_offset_s,
            delta: Pose2::new(values[2], values[3], values[7]),
        });
    }
    Ok(out)
}

/// Reads a relations file (see [`parse_relations`]).
pub fn read_relations(path: &Path, time_offset_s: f64) -> Result<Vec<Relation>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_relations(&text, time_offset_s).with_context(|| format!("parsing {}", path.display()))
}

/// Scores `estimate` (sorted by stamp) against `relations`; None when no relation falls
/// inside the trajectory.
pub fn score_relations(estimate: &[StampedPose], relations: &[Relation]) -> Option<RelationScore> {
    let mut trans = Vec::with_capacity(relations.len());
    let mut rot = Vec::with_capacity(relations.len());
    for r in relations {
        let (Some(p1), Some(p2)) = (
            metrics::pose_at(estimate, r.t1_s),
            metrics::pose_at(estimate, r.t2_s),
        ) else {
            continue;
        };
        let d = p1.between(&p2);
        trans.push((d.x - r.delta.x).hypot(d.y - r.delta.y));
        rot.push(
            wrap_angle(d.heading_rad - r.delta.heading_rad)
                .abs()
                .to_degrees(),
        );
    }
    if trans.is_empty() {
        return None;
    }
    let (trans_mean_m, trans_sd_m) = mean_sd(&trans);
    let (rot_mean_deg, rot_sd_deg) = mean_sd(&rot);
    Some(RelationScore {
        trans_mean_m,
        trans_sd_m,
        rot_mean_deg,
        rot_sd_deg,
        used: trans.len(),
        skipped: relations.len() - trans.len(),
    })
}

/// Mean and population standard deviation of a non-empty slice.
fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// The relations of `truth` between consecutive poses (for tests and sanity checks).
pub fn consecutive_relations(truth: &[StampedPose]) -> Vec<Relation> {
    truth
        .windows(2)
        .map(|w| Relation {
            t1_s: w[0].t_s,
            t2_s: w[1].t_s,
            delta: w[0].pose.between(&w[1].pose),
        })
        .collect()
}

/// The mean translational (and, where given, rotational) relation errors the literature
/// reports for a shared dataset's relations, as printed beside ours; `None` for a dataset
/// without published figures. Sources: Kümmerle et al., "On measuring the accuracy of SLAM
/// algorithms", Autonomous Robots 27(4), 2009; Hess et al., "Real-time loop closure in 2D
/// LIDAR SLAM", ICRA 2016 (each dataset's `PROVENANCE.md` cites them).
pub fn published_relation_errors(dataset: &str) -> Option<&'static str> {
    match dataset {
        "intel-lab" => Some(
            "scan matching 0.220 ± 0.296 m, GMapping (RBPF) 0.070 ± 0.083 m, graph mapping \
             0.031 ± 0.026 m (Kümmerle et al. 2009); Cartographer 0.0229 ± 0.0239 m, \
             0.453 ± 1.335° (Hess et al. 2016)",
        ),
        "mit-csail" => Some(
            "scan matching 0.106 ± 0.325 m, GMapping (RBPF) 0.049 ± 0.049 m, graph mapping \
             0.004 ± 0.009 m (Kümmerle et al. 2009); Cartographer 0.0319 ± 0.0363 m \
             (Hess et al. 2016)",
        ),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_lines_and_removes_the_time_offset() {
        let text = "976052905.167303 976052911.885496 -0.056990 -0.128430 0.000000 0.000000 0.000000 -1.682210\n\n";
        let r = parse_relations(text, 976052857.337).unwrap();
        assert_eq!(r.len(), 1);
        assert!((r[0].t1_s - 47.830303).abs() < 1e-6);
        assert!((r[0].t2_s - 54.548496).abs() < 1e-6);
        assert_eq!(r[0].delta, Pose2::new(-0.05699, -0.12843, -1.68221));
        let e = parse_relations("1 2 3\n", 0.0).unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
        assert!(parse_relations("1 2 3 4 5 6 7 x\n", 0.0).is_err());
    }

    /// A turning path: steps of 1 m, turning 0.3 rad each.
    fn truth() -> Vec<StampedPose> {
        let mut pose = Pose2::new(1.0, 2.0, 0.2);
        let mut out = vec![StampedPose { t_s: 0.0, pose }];
        for k in 1..20 {
            pose = pose.compose(&Pose2::new(1.0, 0.0, 0.3));
            out.push(StampedPose {
                t_s: k as f64,
                pose,
            });
        }
        out
    }

    #[test]
    fn the_truth_scores_zero_and_skips_relations_outside() {
        let t = truth();
        let mut rel = consecutive_relations(&t);
        rel.push(Relation {
            t1_s: 18.5,
            t2_s: 25.0,
            delta: Pose2::IDENTITY,
        });
        let s = score_relations(&t, &rel).unwrap();
        assert_eq!(s.used, 19);
        assert_eq!(s.skipped, 1);
        assert!(s.trans_mean_m < 1e-12 && s.rot_mean_deg < 1e-9);
        assert!(score_relations(&t[..1], &rel).is_none());
    }

    #[test]
    fn steps_scaled_by_1_1_give_a_known_error() {
        let t = truth();
        let rel = consecutive_relations(&t);
        // Every relative step 10 % longer, headings unchanged; a 2° heading bias per step.
        let mut est = vec![t[0]];
        for w in t.windows(2) {
            let d = w[0].pose.between(&w[1].pose);
            let scaled = Pose2::new(1.1 * d.x, 1.1 * d.y, d.heading_rad + 2f64.to_radians());
            let last = est.last().unwrap().pose;
            est.push(StampedPose {
                t_s: w[1].t_s,
                pose: last.compose(&scaled),
            });
        }
        let s = score_relations(&est, &rel).unwrap();
        assert_eq!(s.used, 19);
        assert!((s.trans_mean_m - 0.1).abs() < 1e-9, "{s:?}");
        assert!(s.trans_sd_m < 1e-9);
        assert!((s.rot_mean_deg - 2.0).abs() < 1e-9, "{s:?}");
        assert!(s.rot_sd_deg < 1e-9);
    }
}
