//! MCL on a real hand-drawn sketch of the bundled scenario paper-env1: sketch C, whose
//! path up to the upper room is drawn far too long, so localization on the drawing breaks
//! down there; the breakdown must be detected and the recovery of section 3.2 must run.
//!
//! The simulator (`sketchslam_simulator::Simulation`) drives the robot and produces the
//! odometry and scans; the sketch goes through the real ingestion
//! (`Sketch::from_image_bytes`). Deterministic for the scenario's seed.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_engine::localization::line_observation::{
    LineObservationConfig, observe_lines, observed_indices,
};
use sketchslam_engine::localization::mcl::{MclConfig, SketchMcl, StartSpread};
use sketchslam_engine::localization::recovery::{
    FailureConfig, FailureDetector, ObservationPoints, RecoveryConfig, recover_mcl,
};
use sketchslam_engine::sketch::raycast::SketchRaycaster;
use sketchslam_engine::sketch::{Sketch, SketchPose};
use sketchslam_simulator::{Scenario, Simulation};
use sketchslam_types::{Pose2, SensorEvent};
use std::path::Path;

/// What a run of MCL with recovery over a scenario did.
#[derive(Debug, Default)]
struct RunSummary {
    updates: usize,
    failures: usize,
    recoveries: usize,
    low_score_updates: usize,
    mean_score: f64,
}

fn run(scenario_name: &str, sketch_name: &str, every_nth_scan: usize) -> RunSummary {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../simulator/scenarios")
        .join(scenario_name);
    let scenario = Scenario::load(&dir).unwrap();
    let sk = scenario.sketch(sketch_name).unwrap().clone();
    let bytes = std::fs::read(&sk.image).unwrap();
    let sketch = Sketch::from_image_bytes(&bytes).unwrap();
    let rc = SketchRaycaster::new(&sketch);
    let points = ObservationPoints::precompute(&sketch, &rc, 6.0);
    let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let start = SketchPose {
        u_px: sk.start_u_px,
        v_px: sk.start_v_px,
        heading_rad: sk.start_heading_rad,
        meters_per_pixel: sk.meters_per_pixel,
    };
    let mut mcl = SketchMcl::new(
        MclConfig::default(),
        start,
        StartSpread::default(),
        &mut rng,
    )
    .unwrap();
    let mut detector = FailureDetector::new(FailureConfig::default());
    let line_cfg = LineObservationConfig::default();
    let mut last_good_lines: Vec<usize> = Vec::new();
    let mut odom_at_last_update: Option<Pose2> = None;
    let mut odom_now: Option<Pose2> = None;
    let mut summary = RunSummary::default();
    let mut score_sum = 0.0;
    let mut scan_k = 0usize;
    for step in Simulation::new(&scenario).unwrap() {
        match step.event {
            SensorEvent::Odometry(o) => odom_now = Some(o.pose()),
            SensorEvent::Scan(scan) => {
                scan_k += 1;
                if !scan_k.is_multiple_of(every_nth_scan) {
                    continue;
                }
                let Some(now) = odom_now else { continue };
                let delta = odom_at_last_update.map_or(Pose2::IDENTITY, |p| p.between(&now));
                odom_at_last_update = Some(now);
                mcl.predict(delta, &mut rng);
                mcl.update(&scan, &rc);
                summary.updates += 1;
                score_sum += mcl.score();
                if mcl.score() < 0.15 {
                    summary.low_score_updates += 1;
                }
                let est = mcl.estimate();
                if detector.detect_failure(&est, mcl.score(), &rc).is_some() {
                    summary.failures += 1;
                    if recover_mcl(
                        &mut mcl,
                        &points,
                        &last_good_lines,
                        &RecoveryConfig::default(),
                        &mut rng,
                    ) {
                        detector.reset();
                    }
                } else {
                    let lines = observed_indices(&observe_lines(&est, &scan, &rc, &line_cfg));
                    if !lines.is_empty() {
                        last_good_lines = lines;
                    }
                }
            }
        }
    }
    summary.recoveries = mcl.recoveries();
    summary.mean_score = score_sum / summary.updates.max(1) as f64;
    summary
}

#[test]
fn sketch_c_breakdown_is_detected_and_recovered_from() {
    let s = run("paper-env1", "C", 4);
    println!("paper-env1 sketch C: {s:?}");
    assert!(s.updates > 100);
    assert!(s.failures >= 1, "no breakdown detected: {s:?}");
    assert!(s.recoveries >= 1, "no recovery ran: {s:?}");
    assert!(s.mean_score.is_finite());
}
