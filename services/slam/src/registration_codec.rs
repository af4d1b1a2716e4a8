//! The engine's [`DrawingRegistration`] in the API's terms and back: the warp's parameters
//! ([`RegistrationInfo`], also what a stopped session keeps as `registration.json`), the
//! drawing's lines in the map, and the answers to a transform batch.
//!
//! Sits between the session ([`super::session`], which fits the warp) and the HTTP types of
//! `sketchslam_api::registration`; pure conversions.

use super::codec::sketch_trajectory_response;
use sketchslam_api::{
    ApiError, DrawingPointOut, MapPointOut, PoseResponse, RegistrationInfo, SketchInMapResponse,
    SketchLineInMap, SketchPoseInfo, SketchPoseSource, SketchTrajectoryResponse, TransformRequest,
    TransformResponse, WarpInfo,
};
use sketchslam_engine::mapper::Mapper;
use sketchslam_engine::registration::drawing_registration::MIN_SUPPORT_POINTS;
use sketchslam_engine::registration::{
    ControlGrid, DrawingRegistration, Similarity, Warp, WarpFit,
};
use sketchslam_engine::sketch::{SketchLine, SketchPose};
use sketchslam_types::{Point2, Pose2};

/// 409 while a session has nothing mapped to lay on its drawing.
pub fn not_registered(session_id: &str) -> ApiError {
    ApiError::conflict(
        "not_registered",
        format!(
            "session {session_id} has not mapped enough walls yet to lay its map on the \
             drawing; ask again once the robot has moved"
        ),
    )
}

/// The pose on the drawing of `response`: `on`, read through the warp where `holds`
/// (source `warp` where mapped walls hold it, `warp_extrapolated` elsewhere; see
/// `Mapper::drawing_trajectory_through` for why W beats MCL even there), as
/// `Mapper::pose_on_drawing_through` gives it.
pub fn pose_through_warp(response: &mut PoseResponse, (on, holds): (SketchPose, bool)) {
    let source = if holds {
        SketchPoseSource::Warp
    } else {
        SketchPoseSource::WarpExtrapolated
    };
    if on.u_px.is_finite() && on.v_px.is_finite() {
        response.sketch = Some(SketchPoseInfo {
            u: on.u_px,
            v: on.v_px,
            heading_deg: on.heading_rad.to_degrees(),
            meters_per_pixel: on.meters_per_pixel,
            source: Some(source),
        });
    }
}

/// A `sketch` session's trajectory on the drawing as served: through `warp` when the map
/// is registered (`Mapper::drawing_trajectory_through`), MCL's until then.
pub fn served_sketch_trajectory(
    session_id: &str,
    mapper: &Mapper,
    warp: Option<&DrawingRegistration>,
) -> SketchTrajectoryResponse {
    match warp {
        Some(r) => sketch_trajectory_response(session_id, &mapper.drawing_trajectory_through(r)),
        None => sketch_trajectory_response(session_id, mapper.drawing_trajectory()),
    }
}

/// The registration as the API describes it.
pub fn registration_info(session_id: &str, r: &DrawingRegistration) -> RegistrationInfo {
    let w = r.warp();
    let s = &w.similarity;
    RegistrationInfo {
        session_id: session_id.to_string(),
        keyframes: r.keyframes as u64,
        map_revision: r.map_revision,
        inliers: r.fit.inliers as u64,
        rms_px: r.fit.rms_px,
        walls_crossed: r.fit.walls_crossed as u64,
        scale_px_per_m: s.scale_px_per_m(),
        rotation_rad: s.rotation_rad(),
        min_support: MIN_SUPPORT_POINTS,
        warp: WarpInfo {
            a: s.a,
            b: s.b,
            t_px: [s.t.x, s.t.y],
            grid_origin_m: [w.grid.origin.x, w.grid.origin.y],
            grid_spacing_m: w.grid.spacing_m,
            grid_columns: w.grid.columns as u32,
            grid_rows: w.grid.rows as u32,
            offsets_px: w.offsets.iter().map(|o| [o.x, o.y]).collect(),
            support: r.fit.support.clone(),
        },
    }
}

/// A stored [`RegistrationInfo`] as the engine's registration again; an error naming what
/// does not fit (a node count that is not columns × rows, a non-finite number).
pub fn registration_from_info(info: &RegistrationInfo) -> Result<DrawingRegistration, String> {
    let w = &info.warp;
    let nodes = w.grid_columns as usize * w.grid_rows as usize;
    if w.grid_columns < 2 || w.grid_rows < 2 {
        return Err(format!(
            "a {} × {} control grid: at least 2 × 2",
            w.grid_columns, w.grid_rows
        ));
    }
    if w.offsets_px.len() != nodes || w.support.len() != nodes {
        return Err(format!(
            "{} offsets and {} support values for {nodes} nodes",
            w.offsets_px.len(),
            w.support.len()
        ));
    }
    let numbers = [
        w.a,
        w.b,
        w.t_px[0],
        w.t_px[1],
        w.grid_origin_m[0],
        w.grid_origin_m[1],
    ];
    let finite = numbers.iter().all(|v| v.is_finite())
        && w.grid_spacing_m.is_finite()
        && w.grid_spacing_m > 0.0
        && w.offsets_px.iter().flatten().all(|v| v.is_finite());
    if !finite {
        return Err("a parameter of the warp is not a finite number".to_string());
    }
    let grid = ControlGrid {
        origin: Point2::new(w.grid_origin_m[0], w.grid_origin_m[1]),
        spacing_m: w.grid_spacing_m,
        columns: w.grid_columns as usize,
        rows: w.grid_rows as usize,
    };
    let warp = Warp {
        similarity: Similarity {
            a: w.a,
            b: w.b,
            t: Point2::new(w.t_px[0], w.t_px[1]),
        },
        grid,
        offsets: w
            .offsets_px
            .iter()
            .map(|[x, y]| Point2::new(*x, *y))
            .collect(),
    };
    Ok(DrawingRegistration {
        fit: WarpFit {
            warp,
            inliers: info.inliers as usize,
            rms_px: info.rms_px,
            support: w.support.clone(),
            walls_crossed: info.walls_crossed as usize,
        },
        keyframes: info.keyframes as usize,
        map_revision: info.map_revision,
        anchors: Vec::new(),
    })
}

/// The drawing's `lines` in the map through `r`; a line is registered when W holds at
/// half of its samples or more.
pub fn sketch_in_map_response(
    session_id: &str,
    r: &DrawingRegistration,
    lines: &[SketchLine],
) -> SketchInMapResponse {
    let lines = lines
        .iter()
        .zip(r.lines_in_map(lines))
        .map(|(line, points)| {
            let held = points.iter().filter(|p| r.holds_at(**p)).count();
            SketchLineInMap {
                index: line.index as u32,
                registered: !points.is_empty() && 2 * held >= points.len(),
                points_m: points.iter().map(|p| [p.x, p.y]).collect(),
            }
        })
        .collect();
    SketchInMapResponse {
        session_id: session_id.to_string(),
        keyframes: r.keyframes as u64,
        map_revision: r.map_revision,
        lines,
    }
}

/// Every point of a validated `request` through `r`, in order.
pub fn transform_response(
    session_id: &str,
    r: &DrawingRegistration,
    request: &TransformRequest,
) -> TransformResponse {
    let to_map = request
        .to_map
        .iter()
        .map(|p| {
            let (pose, registered) =
                r.to_map(Point2::new(p.u_px, p.v_px), p.heading_rad.unwrap_or(0.0))?;
            Some(MapPointOut {
                x_m: pose.x,
                y_m: pose.y,
                heading_rad: p.heading_rad.map(|_| pose.heading_rad),
                registered,
            })
        })
        .collect();
    let to_drawing = request
        .to_drawing
        .iter()
        .map(|p| {
            let pose = Pose2::new(p.x_m, p.y_m, p.heading_rad.unwrap_or(0.0));
            let (on, registered) = r.to_drawing(&pose);
            DrawingPointOut {
                u_px: on.u_px,
                v_px: on.v_px,
                heading_rad: p.heading_rad.map(|_| on.heading_rad),
                meters_per_pixel: on.meters_per_pixel,
                registered,
            }
        })
        .collect();
    TransformResponse {
        session_id: session_id.to_string(),
        keyframes: r.keyframes as u64,
        map_revision: r.map_revision,
        to_map,
        to_drawing,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_api::{DrawingPointIn, MapPointIn};

    /// W = 10 px/m turned 0.1 rad on a 3 × 2 grid with two nodes moved, node 0 held.
    fn registration() -> DrawingRegistration {
        let grid = ControlGrid::covering(Point2::new(0.0, 0.0), Point2::new(8.0, 4.0), 4.0);
        let mut warp = Warp::rigid(Similarity::new(10.0, 0.1, Point2::new(50.0, -90.0)), grid);
        warp.offsets[1] = Point2::new(3.0, -2.0);
        warp.offsets[4] = Point2::new(-1.5, 4.0);
        let mut support = vec![0.0; grid.len()];
        support[0] = 50.0;
        DrawingRegistration {
            fit: WarpFit {
                warp,
                inliers: 50,
                rms_px: 0.7,
                support,
                walls_crossed: 3,
            },
            keyframes: 12,
            map_revision: 2,
            anchors: Vec::new(),
        }
    }

    #[test]
    fn the_stored_parameters_give_the_same_registration_back() {
        let r = registration();
        let info = registration_info("s", &r);
        let json = serde_json::to_string(&info).unwrap();
        let back: RegistrationInfo = serde_json::from_str(&json).unwrap();
        assert_eq!(registration_from_info(&back).unwrap(), r);
        let mut short = info.clone();
        short.warp.offsets_px.pop();
        assert!(
            registration_from_info(&short)
                .unwrap_err()
                .contains("5 offsets")
        );
    }

    #[test]
    fn a_pixel_goes_to_the_map_and_back_within_a_thousandth_of_a_pixel() {
        let r = registration();
        let pixels: Vec<DrawingPointIn> = [(60.0, 80.0), (95.0, 70.0), (130.0, 40.0)]
            .iter()
            .map(|&(u_px, v_px)| DrawingPointIn {
                u_px,
                v_px,
                heading_rad: Some(0.3),
            })
            .collect();
        let there = transform_response(
            "s",
            &r,
            &TransformRequest {
                to_map: pixels.clone(),
                to_drawing: vec![],
            },
        );
        let back_request = TransformRequest {
            to_map: vec![],
            to_drawing: there
                .to_map
                .iter()
                .map(|p| {
                    let p = p.expect("invertible");
                    MapPointIn {
                        x_m: p.x_m,
                        y_m: p.y_m,
                        heading_rad: p.heading_rad,
                    }
                })
                .collect(),
        };
        let back = transform_response("s", &r, &back_request);
        for (a, b) in pixels.iter().zip(&back.to_drawing) {
            assert!(
                (a.u_px - b.u_px).hypot(a.v_px - b.v_px) < 1e-3,
                "{a:?} {b:?}"
            );
            assert!((b.heading_rad.unwrap() - 0.3).abs() < 1e-6);
        }
        // Node 0 holds the first point (map ≈ (1, 1)), nothing holds the last.
        assert!(there.to_map[0].unwrap().registered);
        assert!(!there.to_map[2].unwrap().registered);
        assert_eq!((there.keyframes, there.map_revision), (12, 2));
    }
}
