//! The VDA 5050 2.1 messages the service publishes, as values: `visualization` (the
//! robot's position and velocity) and `connection` (ONLINE, OFFLINE, CONNECTIONBROKEN), with
//! their topics. Pure: the [`super::bridge`] adapter stamps and sends them.
//!
//! Field names and rules follow the VDA 5050 2.1 JSON schemas (`visualization.schema`,
//! `connection.schema`, VDA5050/VDA5050 on GitHub, MIT); the tests validate every message
//! against them. Not `state`: its required fields (order, battery, safety, errors) belong
//! to the vehicle's own controller.

use serde::Serialize;
use sketchslam_api::PoseResponse;

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
    /// Map-frame x, meters.
    pub x: f64,
    /// Map-frame y, meters.
    pub y: f64,
    /// Map-frame heading, radians in [-π, π].
    pub theta: f64,
    /// The map the position is in: the session id (the map `GET /v1/sessions/{id}/map` serves).
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

/// Builds `agvPosition` from a pose the session published; `None` when the pose holds a
/// non-finite number (JSON has none, and a fleet manager must not read a made-up one).
pub fn agv_position(pose: &PoseResponse, deviation_range_m: f64) -> Option<AgvPosition> {
    let position = AgvPosition {
        x: pose.x,
        y: pose.y,
        theta: wrap_pi(pose.theta),
        map_id: pose.map_id.clone(),
        position_initialized: pose.position_initialized,
        localization_score: pose.localization_score.clamp(0.0, 1.0),
        deviation_range: deviation_range_m,
    };
    [
        position.x,
        position.y,
        position.theta,
        position.localization_score,
        deviation_range_m,
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
            agv_position: agv_position(&pose, 0.1).unwrap(),
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
        assert!(agv_position(&nan, 0.1).is_none());
    }
}
