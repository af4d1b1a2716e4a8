//! The `POST /v1/sessions` body for a drawing of a scenario or dataset: the start marked on
//! it and its scale guess, as the API takes them (degrees on the wire, radians in the
//! scenario). Used by `evaluate`'s real-process runs, the benchmarks and the multi-process
//! tests, so all of them start a sketch session the same way.

use sketchslam_api::{CreateSessionRequest, MappingMethod, SketchStart};
use sketchslam_simulator::scenario::SketchConfig;

/// The start on the drawing of `cfg`, in the API's units.
pub fn sketch_start(cfg: &SketchConfig) -> SketchStart {
    SketchStart {
        u: cfg.start_u_px,
        v: cfg.start_v_px,
        heading_deg: cfg.start_heading_rad.to_degrees(),
    }
}

/// A `sketch` session for `robot_id` on the uploaded drawing `sketch_id` (the image of
/// `cfg`), started where `cfg` marks it, with `seed` (the service's default when `None`).
pub fn sketch_session(
    robot_id: &str,
    sketch_id: &str,
    cfg: &SketchConfig,
    seed: Option<u64>,
) -> CreateSessionRequest {
    CreateSessionRequest {
        sketch_id: Some(sketch_id.into()),
        start: Some(sketch_start(cfg)),
        meters_per_pixel: Some(cfg.meters_per_pixel),
        seed,
        ..CreateSessionRequest::new(robot_id, MappingMethod::Sketch)
    }
}

/// A session of a method without a drawing (`odometry`, `icp`) for `robot_id`.
pub fn baseline_session(
    robot_id: &str,
    method: MappingMethod,
    seed: Option<u64>,
) -> CreateSessionRequest {
    CreateSessionRequest {
        seed,
        ..CreateSessionRequest::new(robot_id, method)
    }
}
