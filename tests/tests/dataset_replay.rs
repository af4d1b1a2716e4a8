//! The Intel log replayed through both `evaluate` modes — in-process, and through the real
//! `slam-service` and `simulator replay` processes (iceoryx2 lock-step + HTTP) — builds the
//! identical map and scores the same relations. Skipped with a note when the shared data
//! sets are not beside the checkout.

use sketchslam_simulator::dataset::{DATASET_FILE, Dataset};
use sketchslam_slam::mapper::Method;
use sketchslam_tests::dataset_run::{run_dataset_in_process, run_dataset_real_process};
use std::path::Path;

/// The first scans of the log: a few minutes of the robot's route.
const SCANS: u64 = 100;

#[test]
fn intel_replay_maps_the_same_in_both_modes() -> anyhow::Result<()> {
    let dir = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/datasets/intel-lab"
    ));
    if !dir.join(DATASET_FILE).is_file() {
        eprintln!("skipped: no shared dataset at {}", dir.display());
        return Ok(());
    }
    let dataset = Dataset::load(dir)?;
    let out = std::env::temp_dir().join(format!("sketchslam-replay-{}", std::process::id()));
    let (a_dir, b_dir) = (out.join("in-process"), out.join("processes"));
    let a = run_dataset_in_process(&dataset, Method::Icp, None, &a_dir, Some(SCANS), |_, _| {})?;
    let b = run_dataset_real_process(&dataset, Method::Icp, None, &b_dir, Some(SCANS), |_, _| {})?;
    assert_eq!(a.scans, SCANS);
    assert_eq!(b.scans, SCANS);
    assert!(
        std::fs::read(a_dir.join("map.pgm"))? == std::fs::read(b_dir.join("map.pgm"))?,
        "the two modes built different maps: see {}",
        out.display()
    );
    assert_eq!(
        std::fs::read(a_dir.join("truth.csv"))?,
        std::fs::read(b_dir.join("truth.csv"))?
    );
    assert_eq!(a.rel_trans_m, b.rel_trans_m);
    let used = a.relations.unwrap_or(0);
    assert!(
        used > 100,
        "only {used} relations inside the first {SCANS} scans"
    );
    assert!(a.ate_rmse_m.is_finite() && a.map_error_m.is_nan());
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}
