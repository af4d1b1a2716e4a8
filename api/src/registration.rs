//! Types of the map-on-drawing endpoints: the warp W that lays a `sketch` session's map on
//! its drawing (`GET /v1/sessions/{id}/registration`), the drawing's lines in map meters
//! (`GET /v1/sessions/{id}/sketch-in-map`), and batch transforms between a drawing pixel
//! and a map pose (`POST /v1/sessions/{id}/transform`) — how a user sends a robot to the
//! room they point at on their drawing.
//!
//! Frames: map `(x, y)` meters, heading counter-clockwise from +x; drawing image pixels
//! `(u, v)`, `v` down, heading counter-clockwise as seen on the drawing (the frame of
//! `SketchPoseInfo`). `registered` says whether the map's walls hold W at that place; where
//! they do not (a room not yet visited) the answer is W's extrapolation, the best guess.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::error::ApiError;

/// Points of one transform request at most (both directions together).
pub const MAX_TRANSFORM_POINTS: usize = 10_000;

/// W's parameters, so a client can apply it itself:
/// `W(p) = [[a, −b], [b, a]] p + t + Σ_k β_k(p) o_k` in the drawing frame `(u, −v)` pixels,
/// `β_k` the bilinear weights of the four control nodes around `p` (clamped to the grid's
/// cells outside it); node `k = row · columns + column` sits at
/// `grid_origin_m + (column, row) · grid_spacing_m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WarpInfo {
    /// `scale · cos(rotation)`, pixels per meter.
    pub a: f64,
    /// `scale · sin(rotation)`, pixels per meter.
    pub b: f64,
    /// Translation, drawing frame `(u, −v)`, pixels.
    pub t_px: [f64; 2],
    /// Map position of control node 0, meters.
    pub grid_origin_m: [f64; 2],
    /// Distance between control nodes, meters.
    pub grid_spacing_m: f64,
    /// Nodes along x.
    pub grid_columns: u32,
    /// Nodes along y.
    pub grid_rows: u32,
    /// Offset of each node, drawing frame pixels, row-major.
    pub offsets_px: Vec<[f64; 2]>,
    /// Wall points holding each node (0: nothing mapped near it).
    pub support: Vec<f64>,
}

/// `GET /v1/sessions/{id}/registration`: the map laid on the drawing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RegistrationInfo {
    /// The session.
    pub session_id: String,
    /// Keyframes whose walls W was fitted to.
    pub keyframes: u64,
    /// The map revision (loop corrections so far) at the fit.
    pub map_revision: u64,
    /// Wall points lying on a drawn line after W.
    pub inliers: u64,
    /// Their RMS distance from the line, drawing pixels.
    pub rms_px: f64,
    /// Steps of the robot's route (keyframe to keyframe) that W carries through a drawn
    /// wall, away from its doors and ends: a door the drawing leaves out, or W wrong there.
    #[serde(default)]
    pub walls_crossed: u64,
    /// W's overall scale, drawing pixels per map meter.
    pub scale_px_per_m: f64,
    /// W's overall rotation from the map to the drawing frame, radians.
    pub rotation_rad: f64,
    /// A map point counts as registered where at least this many wall points hold W.
    pub min_support: f64,
    /// The warp.
    pub warp: WarpInfo,
}

/// A drawn line carried into the map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchLineInMap {
    /// The line's index in the sketch (as in `GET /v1/sketches/{id}`).
    pub index: u32,
    /// The line as a polyline in map meters (W bends a straight stroke); empty where W
    /// cannot be inverted.
    pub points_m: Vec<[f64; 2]>,
    /// True when the map's walls hold W along at least half of it.
    pub registered: bool,
}

/// `GET /v1/sessions/{id}/sketch-in-map`: the drawing's lines in map meters, the rooms
/// not yet visited included, where the drawing says they are.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchInMapResponse {
    /// The session.
    pub session_id: String,
    /// Keyframes whose walls W was fitted to.
    pub keyframes: u64,
    /// The map revision at the fit.
    pub map_revision: u64,
    /// Every line of the drawing.
    pub lines: Vec<SketchLineInMap>,
}

/// A place on the drawing to carry into the map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct DrawingPointIn {
    /// Image column, pixels.
    pub u_px: f64,
    /// Image row, pixels (down).
    pub v_px: f64,
    /// A heading on the drawing, radians (optional).
    #[serde(default)]
    pub heading_rad: Option<f64>,
}

/// A map place to carry onto the drawing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct MapPointIn {
    /// Meters.
    pub x_m: f64,
    /// Meters.
    pub y_m: f64,
    /// A map heading, radians (optional).
    #[serde(default)]
    pub heading_rad: Option<f64>,
}

/// `POST /v1/sessions/{id}/transform`: points either way, in one batch.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TransformRequest {
    /// Drawing pixels to map poses.
    #[serde(default)]
    pub to_map: Vec<DrawingPointIn>,
    /// Map poses to drawing pixels.
    #[serde(default)]
    pub to_drawing: Vec<MapPointIn>,
}

impl TransformRequest {
    /// Refuses an empty batch, one of more than [`MAX_TRANSFORM_POINTS`], and non-finite or
    /// out-of-range numbers (naming the field and index).
    pub fn validate(&self) -> Result<(), ApiError> {
        let n = self.to_map.len() + self.to_drawing.len();
        if n == 0 {
            return Err(ApiError::invalid(
                "empty_transform",
                "give points in to_map (drawing pixels) or to_drawing (map meters)",
            ));
        }
        if n > MAX_TRANSFORM_POINTS {
            return Err(ApiError::too_large(
                "too_many_points",
                format!("{n} points; at most {MAX_TRANSFORM_POINTS} per request"),
            ));
        }
        const LIMIT: f64 = 1e7;
        let check = |field: String, v: f64| {
            if v.is_finite() && v.abs() <= LIMIT {
                Ok(())
            } else {
                Err(ApiError::invalid_number(
                    &field,
                    "must be a finite number of magnitude at most 1e7",
                ))
            }
        };
        for (i, p) in self.to_map.iter().enumerate() {
            check(format!("to_map[{i}].u_px"), p.u_px)?;
            check(format!("to_map[{i}].v_px"), p.v_px)?;
            if let Some(h) = p.heading_rad {
                check(format!("to_map[{i}].heading_rad"), h)?;
            }
        }
        for (i, p) in self.to_drawing.iter().enumerate() {
            check(format!("to_drawing[{i}].x_m"), p.x_m)?;
            check(format!("to_drawing[{i}].y_m"), p.y_m)?;
            if let Some(h) = p.heading_rad {
                check(format!("to_drawing[{i}].heading_rad"), h)?;
            }
        }
        Ok(())
    }
}

/// A drawing point in the map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct MapPointOut {
    /// Meters.
    pub x_m: f64,
    /// Meters.
    pub y_m: f64,
    /// The heading in the map, radians, when one was given.
    pub heading_rad: Option<f64>,
    /// True where the map's walls hold W.
    pub registered: bool,
}

/// A map point on the drawing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct DrawingPointOut {
    /// Image column, pixels.
    pub u_px: f64,
    /// Image row, pixels.
    pub v_px: f64,
    /// The heading on the drawing, radians, when one was given.
    pub heading_rad: Option<f64>,
    /// The drawing's local scale there, meters per pixel.
    pub meters_per_pixel: f64,
    /// True where the map's walls hold W.
    pub registered: bool,
}

/// The answer to a [`TransformRequest`], in its order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TransformResponse {
    /// The session.
    pub session_id: String,
    /// Keyframes whose walls W was fitted to.
    pub keyframes: u64,
    /// The map revision at the fit.
    pub map_revision: u64,
    /// One per `to_map` point; `null` where W cannot be inverted (a point W folds).
    pub to_map: Vec<Option<MapPointOut>>,
    /// One per `to_drawing` point.
    pub to_drawing: Vec<DrawingPointOut>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_transform_batch_is_checked_before_anything_is_computed() {
        assert_eq!(
            TransformRequest::default().validate().unwrap_err().code(),
            "empty_transform"
        );
        let far = TransformRequest {
            to_drawing: vec![MapPointIn {
                x_m: 1e9,
                y_m: 0.0,
                heading_rad: None,
            }],
            ..Default::default()
        };
        let e = far.validate().unwrap_err();
        assert!(e.to_string().contains("to_drawing[0].x_m"), "{e}");
        let many = TransformRequest {
            to_map: vec![
                DrawingPointIn {
                    u_px: 1.0,
                    v_px: 2.0,
                    heading_rad: None
                };
                MAX_TRANSFORM_POINTS + 1
            ],
            ..Default::default()
        };
        assert_eq!(many.validate().unwrap_err().code(), "too_many_points");
        let json = r#"{"to_map": [{"u_px": 3, "v_px": 4}], "frame": "x"}"#;
        assert!(serde_json::from_str::<TransformRequest>(json).is_err());
    }
}
