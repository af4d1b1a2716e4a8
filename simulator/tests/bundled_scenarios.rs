//! The bundled scenarios load, simulate with the expected number of messages in stamp
//! order, are deterministic for a seed, and render.

use sketchslam_simulator::render::{render_scenario, save_png};
use sketchslam_simulator::truth::{TruthRecorder, read_truth_csv};
use sketchslam_simulator::{Scenario, Simulation};
use sketchslam_types::SensorEvent;
use std::path::{Path, PathBuf};

fn scenario_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
}

/// Runs the whole scenario and checks the stream's invariants.
fn check_run(name: &str, sketches: &[&str]) {
    let scenario = Scenario::load(&scenario_dir(name)).unwrap();
    assert_eq!(scenario.name, name);
    for s in sketches {
        assert!(scenario.sketch(s).is_some(), "{name}: sketch {s} missing");
    }
    let sim = Simulation::new(&scenario).unwrap();
    let duration_s = sim.duration_s();
    let expected_scans = (duration_s * scenario.lidar.rate_hz).floor() as u64 + 1;
    let expected_odom = (duration_s * scenario.odometry.rate_hz).floor() as u64 + 1;
    assert_eq!(sim.scan_count(), expected_scans);
    assert_eq!(sim.odometry_count(), expected_odom);
    let end = sim.motion().end();

    let (mut scans, mut odoms) = (0u64, 0u64);
    let mut last_stamp = 0u64;
    let mut last_kind_was_scan = false;
    let mut recorder = TruthRecorder::new();
    let mut last_truth = None;
    let mut last_odom = None;
    for step in sim {
        let stamp = step.event.stamp_ns();
        assert!(stamp >= last_stamp, "{name}: stamps go back");
        match &step.event {
            SensorEvent::Odometry(o) => {
                assert_eq!(o.sequence, odoms);
                // Odometry before a scan of the same stamp.
                assert!(
                    !(last_kind_was_scan && stamp == last_stamp),
                    "{name}: odometry after a scan with the same stamp"
                );
                odoms += 1;
                last_kind_was_scan = false;
                last_odom = Some(o.pose());
            }
            SensorEvent::Scan(s) => {
                assert_eq!(s.header.sequence, scans);
                assert_eq!(s.header.beam_count as usize, s.ranges_m.len());
                assert_eq!(s.ranges_m.len(), scenario.lidar.beams);
                assert!(s.ranges_m.iter().all(|r| *r >= 0.0 && !r.is_nan()));
                // Indoors most beams hit something.
                let returns = (0..s.ranges_m.len()).filter(|&i| s.is_return(i)).count();
                assert!(
                    returns > s.ranges_m.len() / 2,
                    "{name}: scan {scans} nearly empty"
                );
                scans += 1;
                last_kind_was_scan = true;
            }
        }
        last_stamp = stamp;
        recorder.record(&step);
        last_truth = Some(step.truth);
    }
    assert_eq!(scans, expected_scans);
    assert_eq!(odoms, expected_odom);
    assert!((scans as f64 - duration_s * scenario.lidar.rate_hz).abs() <= 1.0);
    assert!(last_stamp as f64 * 1e-9 <= duration_s + 1e-9);
    let truth = last_truth.unwrap();
    assert!(
        truth.position().distance(&end.position())
            < 0.8 / scenario.lidar.rate_hz.min(scenario.odometry.rate_hz) + 1e-6
    );

    // Dead reckoning drifts, but by meters, not tens of meters, over a few hundred meters.
    let odom = last_odom.unwrap();
    let start = scenario.robot.start;
    let truth_in_odom = start.between(&truth);
    let drift_m = odom.position().distance(&truth_in_odom.position());
    assert!(
        drift_m > 0.01 && drift_m < 30.0,
        "{name}: drift {drift_m} m"
    );

    // Truth file: one row per scan.
    assert_eq!(recorder.rows().len() as u64, scans);
    let path = std::env::temp_dir().join(format!(
        "sketchslam-truth-{}-{name}.csv",
        std::process::id()
    ));
    recorder.write(&path).unwrap();
    assert_eq!(read_truth_csv(&path).unwrap(), recorder.rows());
    let _ = std::fs::remove_file(&path);
}

#[test]
fn paper_env1_runs() {
    check_run("paper-env1", &["A", "B", "C"]);
}

#[test]
fn paper_env2_runs() {
    check_run("paper-env2", &["D", "E", "F"]);
}

#[test]
fn school_runs() {
    check_run("school", &["rough", "squeezed"]);
}

#[test]
fn runs_are_deterministic_for_a_seed() {
    let mut scenario = Scenario::load(&scenario_dir("paper-env1")).unwrap();
    let a: Vec<_> = Simulation::new(&scenario).unwrap().take(300).collect();
    let b: Vec<_> = Simulation::new(&scenario).unwrap().take(300).collect();
    assert_eq!(a, b);
    scenario.seed += 1;
    let c: Vec<_> = Simulation::new(&scenario).unwrap().take(300).collect();
    assert_ne!(a, c);
    // Same truth, other noise.
    assert!(a.iter().zip(&c).all(|(x, y)| x.truth == y.truth));
}

#[test]
fn scenarios_render() {
    for name in ["paper-env1", "paper-env2", "school"] {
        let scenario = Scenario::load(&scenario_dir(name)).unwrap();
        let img = render_scenario(&scenario, 6).unwrap();
        let (w, h) = image::image_dimensions(&scenario.world.image).unwrap();
        assert_eq!(img.dimensions(), (w, h));
        let path = std::env::temp_dir().join(format!("render-{name}.png"));
        save_png(&img, &path).unwrap();
    }
}
