//! The runtime's codec: API bodies made from engine values and stored files.
//!
//! Between the engine (poses, grids, sketches, errors) and the HTTP API's types, on the
//! slam-service side: the registry and the sessions answer requests with these, so one
//! function says how each engine value looks on the wire.

use sketchslam_api::{
    ApiError, MapMetaData, OccupancyGridResponse, PixelPoint, PoseResponse, RosHeader, RosPose,
    RosTime, SketchInfo, SketchLineInfo, SketchPoseInfo, SketchPoseSource,
    SketchTrajectoryPointInfo, SketchTrajectoryResponse, TrajectoryPointInfo, TrajectoryResponse,
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
pub fn occupancy_response(grid: &OccupancyGrid, stamp_ns: u64) -> OccupancyGridResponse {
    let ros = grid.to_ros_occupancy();
    let stamp = RosTime::from_ns(stamp_ns);
    OccupancyGridResponse {
        header: RosHeader {
            stamp,
            frame_id: "map".to_string(),
        },
        info: MapMetaData {
            map_load_time: stamp,
            resolution: ros.resolution_m,
            width: ros.width as u32,
            height: ros.height as u32,
            origin: RosPose::planar(ros.origin.x, ros.origin.y, ros.origin.heading_rad),
        },
        data: ros.data,
    }
}

/// `map.json` as versions before 2026-12-04 stored it: flat, the origin as `(x, y, θ)`.
#[derive(serde::Deserialize)]
struct FlatOccupancy {
    frame_id: String,
    width: u32,
    height: u32,
    resolution: f64,
    origin: FlatOrigin,
    data: Vec<i8>,
}

#[derive(serde::Deserialize)]
struct FlatOrigin {
    x: f64,
    y: f64,
    theta: f64,
}

/// A stored `map.json`, in today's shape or in the flat one of older versions (stamped
/// 0: they kept no stamp).
pub fn stored_occupancy(json: &[u8]) -> Result<OccupancyGridResponse, serde_json::Error> {
    serde_json::from_slice(json).or_else(|e| {
        let Ok(flat) = serde_json::from_slice::<FlatOccupancy>(json) else {
            return Err(e);
        };
        Ok(OccupancyGridResponse {
            header: RosHeader {
                stamp: RosTime::default(),
                frame_id: flat.frame_id,
            },
            info: MapMetaData {
                map_load_time: RosTime::default(),
                resolution: flat.resolution,
                width: flat.width,
                height: flat.height,
                origin: RosPose::planar(flat.origin.x, flat.origin.y, flat.origin.theta),
            },
            data: flat.data,
        })
    })
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
        meters_per_pixel: meta.meters_per_pixel,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_stored_in_the_flat_shape_is_served_in_the_ros_one() {
        let flat = br#"{"session_id": "s", "frame_id": "map", "width": 2, "height": 1,
            "resolution": 0.05, "origin": {"x": -1.0, "y": 2.0, "theta": 3.141592653589793},
            "data": [-1, 100]}"#;
        let grid = stored_occupancy(flat).unwrap();
        assert_eq!(grid.header.frame_id, "map");
        assert_eq!((grid.info.width, grid.info.height), (2, 1));
        assert_eq!(grid.info.origin.position.x, -1.0);
        // A half turn: (0, 0, 1, 0).
        assert!((grid.info.origin.orientation.z - 1.0).abs() < 1e-12);
        assert_eq!(grid.data, vec![-1, 100]);
        // Today's shape reads back as itself; anything else is an error.
        let json = serde_json::to_vec(&grid).unwrap();
        assert_eq!(stored_occupancy(&json).unwrap(), grid);
        assert!(stored_occupancy(b"{}").is_err());
    }
}
