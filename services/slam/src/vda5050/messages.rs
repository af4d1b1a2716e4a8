//! The VDA 5050 2.1 messages the service publishes, as values: `visualization` (the
//! robot's position and velocity) and `connection` (ONLINE, OFFLINE, CONNECTIONBROKEN), with
//! their topics. Pure: the [`super::bridge`] adapter stamps and sends them.
//!
//! Field names and rules follow the VDA 5050 2.1 JSON schemas (`visualization.schema`,
//! `connection.schema`, VDA5050/VDA5050 on GitHub, MIT); the tests validate every message
//! against them. Not `state`: its required fields (order, battery, safety, errors) belong
//! to the vehicle's own controller.

use serde::Serialize;
use sketchslam_api::{PoseResponse, SessionInfo, SketchPoseInfo, SketchSummary};

/// The version string every header carries: the protocol this module follows.
pub const PROTOCOL_VERSION: &str = "2.1.0";

/// Where a robot's messages go: `{interface}/{major version}/{manufacturer}/{serial}/…`
/// (VDA 5050 §6.5, "Topic levels").
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicNames {
    /// The interface name, `uagv` by default.
    pub interface: String,
    /// The major version with its `v`, `v2` by default.
    pub major_version: String,
    /// The manufacturer, `sketchslam` by default.
    pub manufacturer: String,
}

impl Default for TopicNames {
    fn default() -> Self {
        Self {
            interface: "uagv".into(),
            major_version: "v2".into(),
            manufacturer: "sketchslam".into(),
        }
    }
}

impl TopicNames {
    /// The topic of `subtopic` (`visualization`, `connection`) for robot `serial`.
    pub fn topic(&self, serial: &str, subtopic: &str) -> String {
        format!(
            "{}/{}/{}/{serial}/{subtopic}",
            self.interface, self.major_version, self.manufacturer
        )
    }

    /// Why a name cannot be a topic level: empty, or holding `/`, `+`, `#` or a NUL
    /// (MQTT 3.1.1 §4.7), which would put the messages on another topic or none.
    pub fn check_level(what: &str, level: &str) -> Result<(), String> {
        if level.is_empty() {
            return Err(format!("{what} is empty"));
        }
        if let Some(c) = level.chars().find(|c| matches!(c, '/' | '+' | '#' | '\0')) {
            return Err(format!(
                "{what} {level:?} holds {c:?}, which MQTT topics reserve"
            ));
        }
        Ok(())
    }
}

/// The header every message starts with.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Header {
    /// Counts the messages sent on one topic, from 0.
    pub header_id: u64,
    /// ISO 8601, UTC, milliseconds: `2026-12-03T18:53:19.123Z`.
    pub timestamp: String,
    /// [`PROTOCOL_VERSION`].
    pub version: &'static str,
    /// The manufacturer level of the topic.
    pub manufacturer: String,
    /// The robot's id.
    pub serial_number: String,
}

/// `connectionState` of a `connection` message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum ConnectionState {
    /// The session runs and is connected.
    Online,
    /// The session stopped in an orderly way.
    Offline,
    /// The last will: the service's connection ended without a goodbye.
    #[serde(rename = "CONNECTIONBROKEN")]
    ConnectionBroken,
}

/// A `connection` message (retained).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Connection {
    /// The header.
    #[serde(flatten)]
    pub header: Header,
    /// The state.
    pub connection_state: ConnectionState,
}

/// `agvPosition` of a `visualization` message.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct AgvPosition {
    /// x in the frame of `map_id`, meters.
    pub x: f64,
    /// y in the frame of `map_id`, meters.
    pub y: f64,
    /// Heading in the frame of `map_id`, radians in [-π, π].
    pub theta: f64,
    /// The map the position is in: for a session on a drawing the drawing's id (its frame:
    /// [`DrawingFrame`]), otherwise the session id (the map `GET /v1/sessions/{id}/map`
    /// serves).
    pub map_id: String,
    /// False until the session has processed a scan.
    pub position_initialized: bool,
    /// The session's localization score, 0..1.
    pub localization_score: f64,
    /// How far the position may be off, meters ([`deviation_range_m`]).
    pub deviation_range: f64,
}

/// `velocity` of a `visualization` message: in the vehicle's frame (x ahead, y left).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Velocity {
    /// Forward speed, m/s.
    pub vx: f64,
    /// Leftward speed, m/s.
    pub vy: f64,
    /// Turn rate, rad/s counter-clockwise.
    pub omega: f64,
}

/// A `visualization` message.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Visualization {
    /// The header.
    #[serde(flatten)]
    pub header: Header,
    /// The position.
    pub agv_position: AgvPosition,
    /// The velocity.
    pub velocity: Velocity,
}

/// A drawing as a VDA 5050 map, so that every robot mapping on one drawing reports in one
/// frame and a fleet manager shows them all on it: `mapId` is the drawing's id, the origin
/// its lower-left corner, x along its columns and y up its rows, in meters at the scale it
/// declared at upload (else at the session's scale guess). A point `(u, v)` (pixels from
/// the left and top edges) of a drawing `H` pixels high at `s` meters per pixel is at
///
/// `x = u·s,   y = (H − v)·s`,
///
/// where ROS's map_server puts the same pixel of an image with resolution `s` and origin
/// `(0, 0, 0)`; a heading on the drawing (counter-clockwise from +u as it is seen) is the
/// same angle from +x. Sessions on one drawing given different scales would disagree, which
/// is what declaring the scale at upload prevents.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawingFrame {
    /// The drawing's id.
    pub map_id: String,
    /// The drawing's height, pixels.
    pub height_px: f64,
    /// The frame's scale, meters per pixel.
    pub meters_per_pixel: f64,
}

impl DrawingFrame {
    /// The frame of the drawing `drawing` a session `info` maps on; `None` for a session
    /// without a drawing or without a usable scale.
    pub fn of(info: &SessionInfo, drawing: Option<&SketchSummary>) -> Option<Self> {
        let drawing = drawing.filter(|d| info.sketch_id.as_deref() == Some(d.id.as_str()))?;
        let scale = drawing.meters_per_pixel.or(info.meters_per_pixel_guess)?;
        (scale.is_finite() && scale > 0.0).then(|| Self {
            map_id: drawing.id.clone(),
            height_px: f64::from(drawing.height_px),
            meters_per_pixel: scale,
        })
    }

    /// The pose `on` the drawing in this frame: `(x, y, θ)` of the type doc. O(1).
    pub fn place(&self, on: &SketchPoseInfo) -> (f64, f64, f64) {
        let s = self.meters_per_pixel;
        (
            on.u * s,
            (self.height_px - on.v) * s,
            wrap_pi(on.heading_deg.to_radians()),
        )
    }
}

/// Builds `agvPosition` from a pose the session published: in the map frame, or, with a
/// `drawing` frame, at the pose on the drawing (`None` while the pose has none), the
/// deviation carried from map meters to the frame's by the drawing's local scale there.
/// `None` when a number is not finite (JSON has none, and a fleet manager must not read a
/// made-up one).
pub fn agv_position(
    pose: &PoseResponse,
    deviation_range_m: f64,
    drawing: Option<&DrawingFrame>,
) -> Option<AgvPosition> {
    let ((x, y, theta), map_id, deviation) = match drawing {
        None => (
            (pose.x, pose.y, wrap_pi(pose.theta)),
            pose.map_id.clone(),
            deviation_range_m,
        ),
        Some(frame) => {
            let on = pose.sketch.as_ref()?;
            // One map meter is 1 / s_local pixels, each s_frame meters of the frame.
            let deviation = deviation_range_m * frame.meters_per_pixel / on.meters_per_pixel;
            (frame.place(on), frame.map_id.clone(), deviation)
        }
    };
    let position = AgvPosition {
        x,
        y,
        theta,
        map_id,
        position_initialized: pose.position_initialized,
        localization_score: pose.localization_score.clamp(0.0, 1.0),
        deviation_range: deviation,
    };
    [
        position.x,
        position.y,
        position.theta,
        position.localization_score,
        position.deviation_range,
    ]
    .iter()
    .all(|v| v.is_finite())
    .then_some(position)
}

/// `a` wrapped into [-π, π].
pub fn wrap_pi(a: f64) -> f64 {
    let w = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if w < -std::f64::consts::PI {
        w + std::f64::consts::TAU
    } else {
        w
    }
}

/// How far the map position may be off, meters: the map's cell (the finest the position
/// means) plus the drift a scan-matched chain accumulates over the path since the last loop
/// closure, `resolution_m + drift_per_m · path_m`.
///
/// A bound from a physical rate, not a covariance: a scan-matched chain drifts by a small
/// fraction of the distance travelled (a few tenths of a percent to a few percent for 2D
/// LiDAR, by floor and sensor), and a closed loop pulls the pose back onto what was mapped.
pub fn deviation_range_m(resolution_m: f64, drift_per_m: f64, path_since_closure_m: f64) -> f64 {
    resolution_m + drift_per_m * path_since_closure_m.max(0.0)
}

/// The velocity in the vehicle's frame from two map poses `dt_s` apart: the displacement
/// turned into the frame of the mean heading, over the time (Δθ wrapped into [-π, π]).
/// `None` unless `dt_s` is positive and the result finite.
pub fn velocity_between(from: (f64, f64, f64), to: (f64, f64, f64), dt_s: f64) -> Option<Velocity> {
    if dt_s <= 0.0 || !dt_s.is_finite() {
        return None;
    }
    let d_theta = wrap_pi(to.2 - from.2);
    let mid = from.2 + 0.5 * d_theta;
    let (dx, dy) = (to.0 - from.0, to.1 - from.1);
    let (s, c) = mid.sin_cos();
    let v = Velocity {
        vx: (c * dx + s * dy) / dt_s,
        vy: (-s * dx + c * dy) / dt_s,
        omega: d_theta / dt_s,
    };
    [v.vx, v.vy, v.omega]
        .iter()
        .all(|x| x.is_finite())
        .then_some(v)
}

/// An ISO 8601 UTC timestamp with milliseconds, `YYYY-MM-DDTHH:mm:ss.sssZ`.
pub fn timestamp(at: std::time::SystemTime) -> String {
    humantime::format_rfc3339_millis(at).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn topics_follow_the_vda5050_levels() {
        assert_eq!(
            TopicNames::default().topic("robot-7", "visualization"),
            "uagv/v2/sketchslam/robot-7/visualization"
        );
        assert!(TopicNames::check_level("manufacturer", "acme").is_ok());
        for bad in ["", "a/b", "a+", "#"] {
            assert!(
                TopicNames::check_level("manufacturer", bad).is_err(),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn velocity_is_in_the_vehicle_frame() {
        // Facing +y (θ = π/2), 1 m along +y in 2 s: 0.5 m/s straight ahead.
        let v = velocity_between((0.0, 0.0, FRAC_PI_2), (0.0, 1.0, FRAC_PI_2), 2.0).unwrap();
        assert!(
            (v.vx - 0.5).abs() < 1e-12 && v.vy.abs() < 1e-12 && v.omega == 0.0,
            "{v:?}"
        );
        // Facing +x, 0.3 m to the left (+y) in 1 s: vy = +0.3.
        let v = velocity_between((1.0, 1.0, 0.0), (1.0, 1.3, 0.0), 1.0).unwrap();
        assert!(v.vx.abs() < 1e-12 && (v.vy - 0.3).abs() < 1e-12, "{v:?}");
        // A turn across ±π: from 179° to -179° is +2°, not -358°.
        let v = velocity_between(
            (0.0, 0.0, 179f64.to_radians()),
            (0.0, 0.0, -179f64.to_radians()),
            1.0,
        )
        .unwrap();
        assert!((v.omega - 2f64.to_radians()).abs() < 1e-12, "{v:?}");
        assert!(velocity_between((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.0).is_none());
        assert!(velocity_between((0.0, 0.0, 0.0), (f64::NAN, 0.0, 0.0), 1.0).is_none());
    }

    #[test]
    fn theta_is_wrapped_into_minus_pi_pi() {
        assert!((wrap_pi(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap_pi(-5.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!(wrap_pi(PI).abs() <= PI && wrap_pi(-PI).abs() <= PI);
        assert_eq!(wrap_pi(0.25), 0.25);
    }

    #[test]
    fn timestamps_are_iso8601_utc_with_milliseconds() {
        let t = std::time::UNIX_EPOCH + std::time::Duration::from_millis(1_764_788_000_123);
        assert_eq!(timestamp(t), "2025-12-03T18:53:20.123Z");
    }

    #[test]
    fn deviation_grows_with_the_path_since_the_last_closure() {
        assert_eq!(deviation_range_m(0.05, 0.02, 0.0), 0.05);
        assert!((deviation_range_m(0.05, 0.02, 10.0) - 0.25).abs() < 1e-12);
        assert_eq!(deviation_range_m(0.05, 0.02, -3.0), 0.05);
    }

    #[test]
    fn a_visualization_serializes_with_the_schema_names() {
        let pose = PoseResponse {
            session_id: "s".into(),
            x: 1.0,
            y: 2.0,
            theta: 4.0,
            stamp: Some(3.0),
            sketch: None,
            map_id: "s".into(),
            position_initialized: true,
            localization_score: 0.8,
        };
        let message = Visualization {
            header: Header {
                header_id: 3,
                timestamp: "2026-12-03T18:53:19.123Z".into(),
                version: PROTOCOL_VERSION,
                manufacturer: "sketchslam".into(),
                serial_number: "r1".into(),
            },
            agv_position: agv_position(&pose, 0.1, None).unwrap(),
            velocity: Velocity::default(),
        };
        let json = serde_json::to_value(&message).unwrap();
        assert_eq!(json["headerId"], 3);
        assert_eq!(json["serialNumber"], "r1");
        assert_eq!(json["agvPosition"]["mapId"], "s");
        assert_eq!(json["agvPosition"]["positionInitialized"], true);
        assert!((json["agvPosition"]["theta"].as_f64().unwrap() - (4.0 - 2.0 * PI)).abs() < 1e-12);
        assert_eq!(json["velocity"]["omega"], 0.0);
        let broken = Connection {
            header: message.header.clone(),
            connection_state: ConnectionState::ConnectionBroken,
        };
        assert_eq!(
            serde_json::to_value(&broken).unwrap()["connectionState"],
            "CONNECTIONBROKEN"
        );
        let nan = PoseResponse {
            x: f64::NAN,
            ..pose
        };
        assert!(agv_position(&nan, 0.1, None).is_none());
    }

    #[test]
    fn a_pose_on_a_drawing_is_placed_in_the_drawing_frame() {
        let frame = DrawingFrame {
            map_id: "d".into(),
            height_px: 400.0,
            meters_per_pixel: 0.05,
        };
        // Pixel (100, 300) of a 400 px high drawing at 5 cm a pixel: x = 5 m, y = 100 px
        // up from the bottom = 5 m; facing up the drawing (90° counter-clockwise from +u).
        let on = SketchPoseInfo {
            u: 100.0,
            v: 300.0,
            heading_deg: 90.0,
            meters_per_pixel: 0.1,
            source: None,
        };
        let pose = PoseResponse {
            session_id: "s".into(),
            x: -7.0,
            y: 3.0,
            theta: 0.0,
            stamp: Some(1.0),
            sketch: Some(on),
            map_id: "s".into(),
            position_initialized: true,
            localization_score: 0.9,
        };
        let p = agv_position(&pose, 0.2, Some(&frame)).unwrap();
        assert_eq!(p.map_id, "d");
        assert!(
            (p.x - 5.0).abs() < 1e-12 && (p.y - 5.0).abs() < 1e-12,
            "{p:?}"
        );
        assert!((p.theta - PI / 2.0).abs() < 1e-12);
        // 0.2 map meters are 2 px where the drawing is 0.1 m a pixel: 0.1 m of the frame.
        assert!((p.deviation_range - 0.1).abs() < 1e-12);
        // Without a pose on the drawing there is nothing to say in its frame.
        let off = PoseResponse {
            sketch: None,
            ..pose.clone()
        };
        assert!(agv_position(&off, 0.2, Some(&frame)).is_none());
        // The map frame as before.
        let map = agv_position(&pose, 0.2, None).unwrap();
        assert_eq!((map.map_id.as_str(), map.x, map.y), ("s", -7.0, 3.0));
    }

    #[test]
    fn the_frame_takes_the_declared_scale_before_the_session_guess() {
        let drawing = SketchSummary {
            id: "d".into(),
            name: None,
            width_px: 540,
            height_px: 390,
            line_count: 26,
            created_unix_ms: 1,
            meters_per_pixel: Some(0.1),
        };
        let info: SessionInfo = serde_json::from_value(serde_json::json!({
            "id": "s", "robot_id": "r1", "method": "sketch", "sketch_id": "d",
            "start": {"u": 1.0, "v": 2.0, "heading_deg": 0.0},
            "meters_per_pixel_guess": 0.12, "state": "mapping", "scans_processed": 0,
            "scans_lost": 0, "localization_score": 0.0, "recoveries": 0,
            "estimated_meters_per_pixel": 0.12, "last_error": null, "created_unix_ms": 1,
            "stopped_unix_ms": null, "stop_reason": null
        }))
        .unwrap();
        let frame = DrawingFrame::of(&info, Some(&drawing)).unwrap();
        assert_eq!(
            (
                frame.map_id.as_str(),
                frame.height_px,
                frame.meters_per_pixel
            ),
            ("d", 390.0, 0.1)
        );
        // Undeclared: the session's guess.
        let undeclared = SketchSummary {
            meters_per_pixel: None,
            ..drawing.clone()
        };
        assert_eq!(
            DrawingFrame::of(&info, Some(&undeclared)).map(|f| f.meters_per_pixel),
            Some(0.12)
        );
        // Another drawing, or none: no drawing frame.
        let other = SketchSummary {
            id: "e".into(),
            ..drawing
        };
        assert!(DrawingFrame::of(&info, Some(&other)).is_none());
        assert!(DrawingFrame::of(&info, None).is_none());
    }
}
