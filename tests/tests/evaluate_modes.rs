//! `evaluate`'s two modes on the same seed: the in-process run and the run through the
//! real `slam-service` and `simulator` processes (iceoryx2 lock-step + HTTP) must build the
//! identical map, byte for byte, and score the same.

use sketchslam_engine::mapper::Method;
use sketchslam_simulator::scenario::Scenario;
use sketchslam_tests::processes::bundled_scenario;
use sketchslam_tests::real_process::run_real_process;
use sketchslam_tests::run::run_in_process;

/// Long enough for MCL, line matching and ICP to have shaped the map.
const SCANS: u64 = 400;

#[test]
fn in_process_and_real_processes_build_the_same_map() -> anyhow::Result<()> {
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    let sketch = scenario.sketch("A").expect("sketch A is bundled");
    let out = std::env::temp_dir().join(format!("sketchslam-modes-{}", std::process::id()));
    let (a_dir, b_dir) = (out.join("in-process"), out.join("processes"));
    let a = run_in_process(
        &scenario,
        Method::Sketch,
        Some(sketch),
        &a_dir,
        Some(SCANS),
        |_, _| {},
    )?;
    let b = run_real_process(
        &scenario,
        Method::Sketch,
        Some(sketch),
        &b_dir,
        Some(SCANS),
        |_, _| {},
    )?;
    assert_eq!(a.scans, SCANS);
    assert_eq!(b.scans, SCANS);
    let map_a = std::fs::read(a_dir.join("map.pgm"))?;
    let map_b = std::fs::read(b_dir.join("map.pgm"))?;
    assert!(
        map_a == map_b,
        "the two modes built different maps: see {}",
        out.display()
    );
    assert_eq!(
        std::fs::read(a_dir.join("map.yaml"))?,
        std::fs::read(b_dir.join("map.yaml"))?
    );
    assert_eq!(a.map_error_m, b.map_error_m);
    // The service reports the loops its session closed, as the in-process mapper counts them.
    assert_eq!(a.loop_closures, b.loop_closures);
    // Generous bounds on the first 20 m of the route (completeness counts the walls the
    // sensor saw in those scans only).
    eprintln!(
        "map error {:.3} m, completeness {:.3}, {} loops closed",
        a.map_error_m, a.completeness, a.loop_closures
    );
    assert!(a.map_error_m <= 0.25, "map error {}", a.map_error_m);
    assert!(a.completeness >= 0.8, "completeness {}", a.completeness);
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}
