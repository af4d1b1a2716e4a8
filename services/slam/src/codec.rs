//! The runtime's codec: API bodies made from engine values and stored files.
//!
//! Between the engine (poses, grids, sketches, errors) and the HTTP API's types, on the
//! slam-service side: the registry and the sessions answer requests with these, so one
//! function says how each engine value looks on the wire.

use sketchslam_api::{
    ApiError, OccupancyGridResponse, PixelPoint, Pose2Info, PoseResponse, SketchInfo,
    SketchLineInfo, SketchPoseInfo, SketchPoseSource, SketchTrajectoryPointInfo,
    SketchTrajectoryResponse, TrajectoryPointInfo, TrajectoryResponse,
};
use sketchslam_engine::EngineError;
use sketchslam_engine::mapper::{DrawingPoint, Health, PoseEstimate, TrajectoryPoint};
use sketchslam_engine::mapping::grid::OccupancyGrid;
use sketchslam_types::trajectory_csv;

use super::storage::{SketchMeta, SketchShape};

/// The pose response of a mapper state.
pub fn pose_response(session_id: &str, pose: &PoseEstimate, health: &Health) -> PoseResponse {
    let initialized = health.initialized || health.scans_processed > 0;
    PoseResponse {
        session_id: session_id.to_string(),
        x: pose.map.x,
        y: pose.map.y,
        theta: pose.map.heading_rad,
        stamp: initialized.then_some(pose.stamp_ns as f64 * 1e-9),
        sketch: pose.sketch.map(|s| SketchPoseInfo {
            u: s.u_px,
            v: s.v_px,
            heading_deg: s.heading_rad.to_degrees(),
            meters_per_pixel: s.meters_per_pixel,
            source: Some(SketchPoseSource::Mcl),
        }),
        map_id: session_id.to_string(),
        position_initialized: initialized,
        localization_score: if health.localization_score.is_finite() {
            health.localization_score.clamp(0.0, 1.0)
        } else {
            0.0
        },
    }
}

/// The API's occupancy JSON of a grid.
pub fn occupancy_response(session_id: &str, grid: &OccupancyGrid) -> OccupancyGridResponse {
    let ros = grid.to_ros_occupancy();
    OccupancyGridResponse {
        session_id: session_id.to_string(),
        frame_id: "map".to_string(),
        width: ros.width as u32,
        height: ros.height as u32,
        resolution: ros.resolution_m,
        origin: Pose2Info {
            x: ros.origin.x,
            y: ros.origin.y,
            theta: ros.origin.heading_rad,
        },
        data: ros.data,
    }
}

/// The API's trajectory of mapper trajectory points.
pub fn trajectory_response(session_id: &str, points: &[TrajectoryPoint]) -> TrajectoryResponse {
    TrajectoryResponse {
        session_id: session_id.to_string(),
        points: points
            .iter()
            .map(|p| TrajectoryPointInfo {
                t: p.stamp_ns as f64 * 1e-9,
                x: p.pose.x,
                y: p.pose.y,
                theta: p.pose.heading_rad,
            })
            .collect(),
    }
}

/// The API's trajectory on the drawing of a `sketch` session's drawing points.
pub fn sketch_trajectory_response(
    session_id: &str,
    points: &[DrawingPoint],
) -> SketchTrajectoryResponse {
    SketchTrajectoryResponse {
        session_id: session_id.to_string(),
        points: points
            .iter()
            .map(|p| SketchTrajectoryPointInfo {
                t: p.stamp_ns as f64 * 1e-9,
                u: p.pose.u_px,
                v: p.pose.v_px,
                heading: p.pose.heading_rad,
                meters_per_pixel: p.pose.meters_per_pixel,
                source: p.source.as_str().to_string(),
            })
            .collect(),
    }
}

/// The error for `?frame=sketch` on a session that maps without a drawing.
pub fn no_drawing(session_id: &str, method: &str) -> ApiError {
    ApiError::invalid(
        "no_drawing",
        format!(
            "session {session_id} maps with method {method:?}, without a drawing: \
             only sketch sessions have a trajectory, a map or lines on a drawing"
        ),
    )
}

/// The API's description of a stored sketch: its metadata and extracted lines.
pub fn sketch_info(meta: &SketchMeta, shape: &SketchShape) -> SketchInfo {
    SketchInfo {
        id: meta.id.clone(),
        name: meta.name.clone(),
        width_px: shape.width_px,
        height_px: shape.height_px,
        created_unix_ms: meta.created_unix_ms,
        lines: shape
            .lines
            .iter()
            .map(|l| SketchLineInfo {
                index: l.index,
                a: PixelPoint { u: l.a.x, v: l.a.y },
                b: PixelPoint { u: l.b.x, v: l.b.y },
                angle_deg: l.angle_rad.to_degrees(),
                length_px: l.length_px(),
            })
            .collect(),
    }
}

/// The API error for a drawing the engine refused.
pub fn image_error(e: EngineError) -> ApiError {
    match e {
        EngineError::ImageTooLarge(m) => ApiError::too_large("image_too_large", m),
        EngineError::NoStrokes => ApiError::invalid(
            "no_lines",
            "no strokes found in the drawing: draw walls dark on light (or light on dark)",
        ),
        EngineError::NoLines => {
            ApiError::invalid("no_lines", "no straight lines found in the drawing")
        }
        EngineError::ImageDecode(m) => ApiError::invalid(
            "invalid_image",
            format!("the body is not a PNG or JPEG image that decodes: {m}"),
        ),
        other => ApiError::invalid("invalid_image", other.to_string()),
    }
}

/// The API's trajectory of a stored `trajectory.csv`; the values as stored (headings not
/// re-wrapped).
pub fn stored_trajectory_response(
    session_id: &str,
    csv: &str,
) -> Result<TrajectoryResponse, ApiError> {
    let rows = trajectory_csv::parse(csv)
        .map_err(|e| ApiError::internal(format!("trajectory.csv {e}")))?;
    Ok(TrajectoryResponse {
        session_id: session_id.to_string(),
        points: rows
            .iter()
            .map(TrajectoryPointInfo::from_stamped_pose)
            .collect(),
    })
}
