//! `trace_sketch SCENARIO SKETCH [EVERY] [LIMIT]`: per-scan trace of the sketch method against
//! the truth (map pose, sketch pose, scale, lines observed, score, recoveries), for looking
//! into a run. `GAIN=` overrides the heading gain, `PREV=1` uses the previous scan as ICP
//! reference.
use sketchslam_engine::mapper::{Mapper, MapperConfig, Method};
use sketchslam_simulator::scenario::Scenario;
use sketchslam_simulator::simulation::Simulation;
use sketchslam_types::SensorEvent;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let scenario = Scenario::load(std::path::Path::new(&args[1]))?;
    let sketch = scenario.sketch(&args[2]).unwrap();
    let every: usize = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(100);
    let limit: usize = args
        .get(4)
        .map(|s| s.parse().unwrap())
        .unwrap_or(usize::MAX);
    let prior = sketchslam_tests::run::sketch_prior(sketch)?;
    let gain: f64 = std::env::var("GAIN")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.05);
    let reference = if std::env::var("PREV").is_ok() {
        sketchslam_engine::mapper::IcpReference::PreviousScan
    } else {
        sketchslam_engine::mapper::IcpReference::Map
    };
    let mut m = Mapper::new(
        Method::Sketch,
        Some(prior),
        MapperConfig {
            seed: scenario.seed,
            sketch_heading_gain: gain,
            keyframe_icp_reference: reference,
            lidar_mount: scenario.lidar.mount,
            ..Default::default()
        },
    )?;
    let start = scenario.robot.start;
    let mut n = 0;
    for step in Simulation::new(&scenario)? {
        m.on_event(&step.event);
        if let SensorEvent::Scan(_) = step.event {
            n += 1;
            if n % every == 0 {
                let t = start.between(&step.truth);
                let p = m.pose();
                let h = m.health();
                let sk = p.sketch.unwrap();
                println!(
                    "{n:5} truth({:7.2},{:7.2},{:6.1}) map({:7.2},{:7.2},{:6.1}) sk({:6.1},{:6.1},{:6.1},s={:.4}) lines={} score={:.2} rec={}",
                    t.x,
                    t.y,
                    t.heading_rad.to_degrees(),
                    p.map.x,
                    p.map.y,
                    p.map.heading_rad.to_degrees(),
                    sk.u_px,
                    sk.v_px,
                    sk.heading_rad.to_degrees(),
                    sk.meters_per_pixel,
                    h.lines_observed,
                    h.localization_score,
                    h.recoveries
                );
            }
            if n >= limit {
                break;
            }
        }
    }
    Ok(())
}
