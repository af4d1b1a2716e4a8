//! `evaluate`'s two modes on the same seed: the in-process run and the run through the
//! real `slam-service` and `simulator` processes (iceoryx2 lock-step + HTTP) must build the
//! identical map, byte for byte, and score the same.

use sketchslam_engine::mapper::{Method, SketchHeadingView};
use sketchslam_simulator::scenario::Scenario;
use sketchslam_tests::processes::bundled_scenario;
use sketchslam_tests::real_process::run_real_process;
use sketchslam_tests::run::{RunResult, run_in_process};
use sketchslam_tests::run_method::RunMethod;

/// Long enough for MCL, line matching and ICP to have shaped the map.
const SCANS: u64 = 400;

/// Long enough for the loop-closing baseline to close loops (9 by scan 2 600), so the
/// service rebuilds its map after corrections, on its mapping thread, before serving it.
const GRAPH_SCANS: u64 = 2600;

/// Maps the first `scans` scans of paper-env1 with `method` in both modes; fails unless
/// the maps are the same bytes and score the same. Returns the in-process and the
/// real-process results.
fn both_modes_agree(
    method: impl Into<RunMethod>,
    sketch_name: Option<&str>,
    scans: u64,
) -> anyhow::Result<(RunResult, RunResult)> {
    let run_method: RunMethod = method.into();
    let method = run_method.method;
    let scenario = Scenario::load(&bundled_scenario("paper-env1"))?;
    let sketch = sketch_name.map(|n| scenario.sketch(n).expect("the sketch is bundled"));
    let out = std::env::temp_dir().join(format!(
        "sketchslam-modes-{method}-{:?}-{}",
        run_method.sketch_heading_view,
        std::process::id()
    ));
    let (a_dir, b_dir) = (out.join("in-process"), out.join("processes"));
    let a = run_in_process(
        &scenario,
        run_method,
        sketch,
        &a_dir,
        Some(scans),
        |_, _| {},
    )?;
    let b = run_real_process(
        &scenario,
        run_method,
        sketch,
        &b_dir,
        Some(scans),
        |_, _| {},
    )?;
    assert_eq!(a.scans, scans);
    assert_eq!(b.scans, scans);
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
    eprintln!(
        "{method}: map error {:.3} m, completeness {:.3}, {} loops closed",
        a.map_error_m, a.completeness, a.loop_closures
    );
    for dir in [&a_dir, &b_dir] {
        assert_eq!(
            dir.join("sketch-trajectory.csv").is_file(),
            method == Method::Sketch,
            "{}",
            dir.display()
        );
        assert_eq!(
            dir.join("live-sketch-trajectory.csv").is_file(),
            method == Method::Sketch,
            "{}",
            dir.display()
        );
    }
    if method == Method::Sketch {
        // The service's trajectory on the drawing is the in-process mapper's, byte for byte.
        assert_eq!(
            std::fs::read(a_dir.join("sketch-trajectory.csv"))?,
            std::fs::read(b_dir.join("sketch-trajectory.csv"))?
        );
    }
    let _ = std::fs::remove_dir_all(&out);
    Ok((a, b))
}

#[test]
fn in_process_and_real_processes_build_the_same_map() -> anyhow::Result<()> {
    let (a, b) = both_modes_agree(Method::Sketch, Some("A"), SCANS)?;
    // The pose on the drawing is scored in both modes: in-process from the mapper after each
    // scan, through the processes from the session's live event stream.
    let (da, db) = (a.sketch_pose_median_m, b.sketch_pose_median_m);
    assert!(da.is_some() && db.is_some(), "{da:?} {db:?}");
    assert_eq!(da, db);
    // So is the live trajectory, each scan's pose as first published.
    let (la, lb) = (a.online_ate_rmse_m, b.online_ate_rmse_m);
    assert!(la.is_some() && lb.is_some(), "{la:?} {lb:?}");
    assert!((la.unwrap() - lb.unwrap()).abs() < 0.05, "{la:?} {lb:?}");
    // And the live pose on the drawing, through the warp each mode held at the scan (the
    // service's worker fits when it gets to it, the in-process loop at the scan the rule
    // names): both within a meter-equivalent of the truth at the median on this drawing.
    let (wa, wb) = (a.live_sketch_pose_median_m, b.live_sketch_pose_median_m);
    assert!(
        wa.is_some_and(|m| m < 1.0) && wb.is_some_and(|m| m < 1.0),
        "{wa:?} {wb:?}"
    );
    // Generous bounds on the first 20 m of the route (completeness counts the walls the
    // sensor saw in those scans only).
    assert!(a.map_error_m <= 0.25, "map error {}", a.map_error_m);
    assert!(a.completeness >= 0.8, "completeness {}", a.completeness);
    Ok(())
}

/// The front end reads the warp onto the drawing, fitted on the service's worker thread
/// whenever it gets to it: the session waits for a fit it is due to read, so the map is
/// still the in-process one, byte for byte.
#[test]
fn reading_the_drawing_through_the_warp_builds_the_same_map_in_both_modes() -> anyhow::Result<()> {
    let warp = RunMethod {
        sketch_heading_view: SketchHeadingView::Warp,
        ..RunMethod::from(Method::Sketch)
    };
    let (a, _) = both_modes_agree(warp, Some("A"), SCANS)?;
    assert!(a.map_error_m <= 0.25, "map error {}", a.map_error_m);
    Ok(())
}

#[test]
fn the_graph_baseline_builds_the_same_map_over_http_and_in_process() -> anyhow::Result<()> {
    let (a, _) = both_modes_agree(Method::Graph, None, GRAPH_SCANS)?;
    assert!(
        a.loop_closures >= 1,
        "no loop closed in {GRAPH_SCANS} scans"
    );
    assert!(a.map_error_m <= 0.25, "map error {}", a.map_error_m);
    assert!(a.completeness >= 0.8, "completeness {}", a.completeness);
    Ok(())
}
