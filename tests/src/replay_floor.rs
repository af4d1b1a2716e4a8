//! The floors under a method's relation figures on a replayed log: what an estimate would
//! score that got the replay's truth exactly (its reference), and that got every *scan*
//! exactly but, like every mapper, only has the replay's odometry between scans.
//!
//! Beside [`crate::dataset_run`], printed by `evaluate` under the relation table. The Intel
//! log keeps 910 of the original 13 631 scans, and 95 % of the relations' stamps lie
//! between two of them, so a pose there is the odometry's. The replay adds drift to the
//! log's corrected odometry (`dataset.toml`): the second floor carries that drifted
//! odometry from the scans at both ends of each stretch and blends the two as the mapper
//! does ([`sketchslam_engine::mapper::blend_stretch`]), so it is the best figure a method
//! that places scans can expect here (below it only by the drift's luck).

use crate::metrics::StampedPose;
use crate::relations::{Relation, RelationScore, score_relations};
use sketchslam_engine::mapper::{TrajectoryPoint, blend_stretch};
use sketchslam_engine::scan_matching::odometry_noise::OdometryNoise;
use sketchslam_simulator::dataset::Dataset;
use sketchslam_simulator::replay::Replay;
use sketchslam_types::{Pose2, SensorEvent};

/// The two floors of a replay on the same relations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayFloors {
    /// The replay's own reference — the log's corrected poses at every scan and every
    /// odometry reading it publishes, before the drift it adds: what an estimate that
    /// recovered this replay's truth exactly would score (measured 2026-12-04 on the Intel
    /// log: 0.066 m, 2.3°, against GMapping's published 0.070 m on the whole log).
    pub reference: RelationScore,
    /// The reference at every scan, and between scans the replay's *published* (drifted)
    /// odometry carried from the scans at both ends and blended by the mapper's rule with
    /// the mapper's default error model: what a method that placed every scan exactly
    /// would score (measured 2026-12-05 on the Intel log: 0.074 m, 2.5°).
    pub exact_scans: RelationScore,
}

/// Both floors of `replay` on `relations`, in one pass over the log. `None` for a log
/// without reference poses (raw odometry: CSAIL) or when no relation falls inside.
pub fn replay_floors(
    dataset: &Dataset,
    replay: Replay,
    relations: &[Relation],
) -> Option<ReplayFloors> {
    if !dataset.has_reference_poses() {
        return None;
    }
    // One pose per stamp (a scan and its odometry reading share one), as the mapper keeps:
    // the reference's, with the published odometry reading at it.
    let mut points: Vec<TrajectoryPoint> = Vec::new();
    let mut odometry: Vec<Pose2> = Vec::new();
    let mut scans: Vec<usize> = Vec::new();
    let mut odometry_now = Pose2::IDENTITY;
    for step in replay {
        let stamp_ns = step.event.stamp_ns();
        if let SensorEvent::Odometry(o) = &step.event {
            odometry_now = o.pose();
        }
        let is_scan = matches!(step.event, SensorEvent::Scan(_));
        match points.last().map(|p| p.stamp_ns) {
            Some(t) if t == stamp_ns => {
                let i = points.len() - 1;
                odometry[i] = odometry_now;
                if is_scan && scans.last() != Some(&i) {
                    scans.push(i);
                }
            }
            Some(t) if t > stamp_ns => {}
            _ => {
                if is_scan {
                    scans.push(points.len());
                }
                points.push(TrajectoryPoint {
                    stamp_ns,
                    pose: step.truth,
                });
                odometry.push(odometry_now);
            }
        }
    }
    let reference = score_relations(&stamped(&points), relations)?;
    // The scans stay at the reference; after the last one the odometry is carried forward
    // from it, between two the mapper's blend.
    if let Some(&last) = scans.last() {
        for j in last + 1..points.len() {
            points[j].pose = points[last]
                .pose
                .compose(&odometry[last].between(&odometry[j]));
        }
    }
    let noise = OdometryNoise::default();
    for pair in scans.windows(2) {
        let (i0, i1) = (pair[0], pair[1]);
        blend_stretch(&mut points[i0..=i1], &odometry[i0..=i1], &noise);
    }
    let exact_scans = score_relations(&stamped(&points), relations)?;
    Some(ReplayFloors {
        reference,
        exact_scans,
    })
}

/// `points` as the scoring's stamped poses.
fn stamped(points: &[TrajectoryPoint]) -> Vec<StampedPose> {
    points
        .iter()
        .map(|p| StampedPose {
            t_s: p.stamp_ns as f64 * 1e-9,
            pose: p.pose,
        })
        .collect()
}

/// Checks against the shared Intel data set, which `.ci/run` keeps beside the checkout.
#[cfg(test)]
mod intel_tests {
    use super::*;
    use crate::dataset_run::dataset_relations;
    use std::path::Path;

    fn intel() -> Dataset {
        let dir = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../shared/datasets/intel-lab"
        ));
        Dataset::load(dir).unwrap_or_else(|e| {
            panic!(
                "the shared Intel data set belongs beside the checkout ({}): {e}",
                dir.display()
            )
        })
    }

    fn floors() -> ReplayFloors {
        let dataset = intel();
        let relations = dataset_relations(&dataset).unwrap();
        assert_eq!(relations.len(), 2984);
        replay_floors(&dataset, Replay::new(&dataset).unwrap(), &relations).unwrap()
    }

    /// The log's own poses, scored on the relations: the replay's clock and the relation
    /// times line up when this is near GMapping's published 0.070 m.
    #[test]
    fn the_replays_reference_scores_near_gmapping() {
        let reference = floors().reference;
        // Measured 2026-12-04: 0.066 m, 2.3°; the relations' stamps must be the log's, or
        // the reference would be off by the motion between them.
        assert!(
            (0.03..0.1).contains(&reference.trans_mean_m) && reference.rot_mean_deg < 4.0,
            "{reference:?}"
        );
        assert_eq!(reference.used, 2984);
    }

    /// Exact scans with drifted odometry between them: above the reference (the drift
    /// costs), but by less than odometry carried forward alone would cost.
    #[test]
    fn exact_scans_score_a_little_above_the_reference() {
        let ReplayFloors {
            reference,
            exact_scans,
        } = floors();
        println!("reference {reference:?}\nexact scans {exact_scans:?}");
        assert_eq!(exact_scans.used, reference.used);
        let above = exact_scans.trans_mean_m - reference.trans_mean_m;
        assert!((0.0..0.02).contains(&above), "{above}");
    }
}
