//! Request and response bodies of the HTTP API.
//!
//! Units follow the rest of sketchslam: map-frame lengths in meters, map-frame angles in
//! radians (`theta`), sketch positions in pixels from the image's top-left corner (`u`
//! right, `v` down), sketch headings in degrees counter-clockwise from the image's +u axis
//! (as in `scenario.toml`), stamps in seconds of the publisher's clock. The pose response
//! also carries the words of VDA 5050's `agvPosition` (`mapId`, `positionInitialized`,
//! `localizationScore`) so fleet managers can pass it through unchanged.

use serde::{Deserialize, Serialize};
use sketchslam_types::Pose2;
use sketchslam_types::sketch_trajectory_csv::{self, DrawingRow};
use sketchslam_types::trajectory_csv::{self, NumberFormat, StampedPose};
use utoipa::ToSchema;

use crate::error::ApiError;

/// A point on a sketch, pixels from the top-left corner.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PixelPoint {
    /// Column, pixels from the left edge.
    pub u: f64,
    /// Row, pixels from the top edge.
    pub v: f64,
}

/// One straight line extracted from a sketch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchLineInfo {
    /// The line's number in its sketch, from 0.
    pub index: usize,
    /// First endpoint.
    pub a: PixelPoint,
    /// Second endpoint.
    pub b: PixelPoint,
    /// Direction in degrees in [0, 180), counter-clockwise from +u as the drawing is seen.
    pub angle_deg: f64,
    /// Length in pixels.
    pub length_px: f64,
}

/// An uploaded sketch without its lines (list entries).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchSummary {
    /// Sketch id (UUID v4).
    pub id: String,
    /// The name given at upload, if any.
    pub name: Option<String>,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Number of extracted lines.
    pub line_count: usize,
    /// Upload time, milliseconds since the Unix epoch.
    pub created_unix_ms: u64,
    /// The scale declared at upload, meters per pixel (see [`SketchInfo`]).
    #[serde(default)]
    pub meters_per_pixel: Option<f64>,
}

/// An uploaded sketch with its extracted lines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchInfo {
    /// Sketch id (UUID v4).
    pub id: String,
    /// The name given at upload, if any.
    pub name: Option<String>,
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Upload time, milliseconds since the Unix epoch.
    pub created_unix_ms: u64,
    /// The scale declared at upload (`?meters_per_pixel=`), meters per pixel: the scale
    /// guess of every session on the drawing that gives none, and the scale of the
    /// drawing's frame in VDA 5050 positions (`mapId` = this drawing's id). Null when none
    /// was declared.
    #[serde(default)]
    pub meters_per_pixel: Option<f64>,
    /// The extracted lines.
    pub lines: Vec<SketchLineInfo>,
}

impl SketchInfo {
    /// The list entry of this sketch.
    pub fn summary(&self) -> SketchSummary {
        SketchSummary {
            id: self.id.clone(),
            name: self.name.clone(),
            width_px: self.width_px,
            height_px: self.height_px,
            line_count: self.lines.len(),
            created_unix_ms: self.created_unix_ms,
            meters_per_pixel: self.meters_per_pixel,
        }
    }
}

/// What an upload says of its drawing besides the image (`POST /v1/sketches?name=…&
/// meters_per_pixel=…`), checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SketchUpload {
    /// A name, at most 128 characters.
    pub name: Option<String>,
    /// The drawing's scale, meters per pixel, within [`METERS_PER_PIXEL_RANGE`].
    pub meters_per_pixel: Option<f64>,
}

/// `GET /v1/sketches`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchList {
    /// Every stored sketch, oldest first.
    pub sketches: Vec<SketchSummary>,
}

/// How a session builds its map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum MappingMethod {
    /// The hand-drawn-map method (needs `sketch_id`, `start`, and `meters_per_pixel` unless
    /// the drawing declared its scale at upload).
    Sketch,
    /// Baseline: frame-to-frame point-to-line ICP seeded by odometry, without the sketch
    /// (the paper's "conventional ICP-SLAM").
    Icp,
    /// Baseline: the sketch method's engine without the drawing (keyframe ICP, loop
    /// closure, pose graph), the class of LiDAR SLAM a user would otherwise run.
    Graph,
    /// Baseline: the map from dead reckoning alone.
    Odometry,
}

impl MappingMethod {
    /// The lowercase name used in JSON and metrics.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Sketch => "sketch",
            Self::Icp => "icp",
            Self::Graph => "graph",
            Self::Odometry => "odometry",
        }
    }
}

/// Where a person marked the robot's start on the sketch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SketchStart {
    /// Column, pixels from the left edge.
    #[schema(example = 66.9)]
    pub u: f64,
    /// Row, pixels from the top edge.
    #[schema(example = 320.3)]
    pub v: f64,
    /// Heading, degrees counter-clockwise from the image's +u axis.
    #[schema(example = 1.1)]
    pub heading_deg: f64,
}

/// Where the LiDAR sits on the robot: its pose in the robot frame (ROS `base_link` →
/// laser frame). A scanner off the centre seen as if at it bends the map when the robot
/// turns; with its mount every method maps with the scanner's true rays and reports the
/// robot's pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LidarMount {
    /// Forward of the robot's centre, meters.
    #[schema(example = 0.3)]
    pub x_m: f64,
    /// Left of the robot's centre, meters.
    #[schema(example = 0.0)]
    pub y_m: f64,
    /// The scanner's zero beam, degrees counter-clockwise from the robot's heading.
    #[schema(example = 5.0)]
    pub yaw_deg: f64,
}

impl LidarMount {
    /// The mount as the LiDAR's pose in the robot frame (yaw in radians).
    pub fn pose(&self) -> sketchslam_types::Pose2 {
        sketchslam_types::Pose2::new(self.x_m, self.y_m, self.yaw_deg.to_radians())
    }

    /// The mount of a LiDAR at `pose` in the robot frame.
    pub fn from_pose(pose: sketchslam_types::Pose2) -> LidarMount {
        LidarMount {
            x_m: pose.x,
            y_m: pose.y,
            yaw_deg: pose.heading_rad.to_degrees(),
        }
    }
}

/// How far the robot's wheel odometry can be off: the standard deviations its error grows
/// by per meter travelled and per radian turned, over a path of `D` meters and `Θ` radians
/// (the odometry motion model of Thrun, Burgard, Fox, *Probabilistic Robotics*, §5.4):
/// `σ_θ = α₁·Θ + α₂·D`, `σ_t = α₃·D + α₄·Θ`. The mapper reads it to tell when the odometry's
/// guess may lie outside the scan matcher's reach (a far guess is searched first) and how far
/// a match may move the pose from it. Standard deviations, not variances: ROS AMCL's
/// `odom_alpha1..4` weigh squares (`σ² = α₁·θ² + α₂·d²`), so take the square root of each.
/// A field left out keeps the service's default; a worn robot on carpet drifts a few
/// percent per meter (`position_sd_per_m` 0.03–0.05).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct OdometryNoise {
    /// α₁: heading error per radian turned, radians per radian (default 0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(example = 0.05)]
    pub heading_sd_per_rad: Option<f64>,
    /// α₂: heading error per meter travelled, radians per meter (default 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(example = 0.02)]
    pub heading_sd_rad_per_m: Option<f64>,
    /// α₃: position error per meter travelled, meters per meter (default 0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(example = 0.04)]
    pub position_sd_per_m: Option<f64>,
    /// α₄: position error per radian turned, meters per radian (default 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(example = 0.01)]
    pub position_sd_m_per_rad: Option<f64>,
}

/// An odometry noise factor is refused above this: a standard deviation of ten times the
/// path is no odometry at all.
pub const MAX_ODOMETRY_SD_FACTOR: f64 = 10.0;

impl OdometryNoise {
    /// Each given factor with its field's name (`odometry_noise.…`).
    pub fn fields(&self) -> [(&'static str, Option<f64>); 4] {
        [
            ("odometry_noise.heading_sd_per_rad", self.heading_sd_per_rad),
            (
                "odometry_noise.heading_sd_rad_per_m",
                self.heading_sd_rad_per_m,
            ),
            ("odometry_noise.position_sd_per_m", self.position_sd_per_m),
            (
                "odometry_noise.position_sd_m_per_rad",
                self.position_sd_m_per_rad,
            ),
        ]
    }

    /// Refuses a factor that is not finite or lies outside `0..=MAX_ODOMETRY_SD_FACTOR`,
    /// naming its field.
    pub fn validate(&self) -> Result<(), ApiError> {
        for (field, value) in self.fields() {
            let Some(value) = value else { continue };
            check_finite(field, value)?;
            if !(0.0..=MAX_ODOMETRY_SD_FACTOR).contains(&value) {
                return Err(ApiError::invalid_number(
                    field,
                    &format!(
                        "must lie between 0 and {MAX_ODOMETRY_SD_FACTOR} (a standard deviation per meter or radian of the path)"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A LiDAR mount is refused farther than this from the robot's centre, meters: a scanner
/// is on the robot.
pub const MAX_LIDAR_OFFSET_M: f64 = 10.0;

/// `POST /v1/sessions`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateSessionRequest {
    /// The robot whose `scan` and `odom` services feed the session.
    #[schema(example = "r1")]
    pub robot_id: String,
    /// The mapping method.
    pub method: MappingMethod,
    /// For `sketch`: the uploaded sketch to map with.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sketch_id: Option<String>,
    /// For `sketch`: the start pose marked on the sketch.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<SketchStart>,
    /// For `sketch`: a rough guess of the drawing's scale, meters per pixel (> 0).
    /// Optional when the drawing declared its scale at upload: that is the guess then.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(example = 0.1)]
    pub meters_per_pixel: Option<f64>,
    /// Seed of the session's random draws (MCL, RANSAC); the same seed and the same
    /// lock-step input reproduce a run exactly. Default: the service's seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Where the LiDAR sits on the robot; default: at the centre, facing forward.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar_mount: Option<LidarMount>,
    /// How far the robot's wheel odometry can be off; default: the service's model (worn
    /// wheels, 10 % of the path).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub odometry_noise: Option<OdometryNoise>,
    /// For `sketch`: how MCL on the drawing weighs a scan; default `ray_cast`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mcl_observation: Option<DrawingObservationModel>,
    /// For `sketch`: which localization on the drawing picks the drawn walls that hold the
    /// map's heading (the paper's eq. 5); default `mcl`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawing_localization: Option<DrawingLocalization>,
    /// For `sketch`: read the start heading from the first scan's walls against the
    /// drawing's wall directions (within 20° of the mark) and map from it when it differs
    /// from the marked one by more than a drawn wall's error (4°); default false, the mark
    /// stands. For a mark set by eye on a rectilinear floor; on the Intel Lab's drawings,
    /// whose walls are not square, it turned a right mark wrong (README).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_heading_from_walls: Option<bool>,
}

/// Which localization on the drawing picks the drawn walls in view that hold the robot's
/// heading (`sketch` sessions). The pose on the drawing the session serves is the warp's
/// either way, once the map's walls are fitted to the drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum DrawingLocalization {
    /// MCL's estimate, as the paper (the default).
    Mcl,
    /// The warp from the map onto the drawing, refitted every 5 m of route (MCL's estimate
    /// until the first fit): the walls are picked where the map says the robot is.
    Warp,
}

/// How MCL on the drawing weighs a scan against the drawn walls (`sketch` sessions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum DrawingObservationModel {
    /// The drawing's distance field at each beam's end: tolerant of returns short of a
    /// drawn wall (furniture, people), strict about returns seen through one (a fifth of
    /// the paper's cost).
    LikelihoodField,
    /// The paper's eq. (3): each beam's range against the range ray-traced on the drawing
    /// (the default).
    RayCast,
}

fn check_finite(field: &str, value: f64) -> Result<(), ApiError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ApiError::invalid_number(field, "must be a finite number"))
    }
}

/// A drawing's scale guess is refused outside this range, meters per pixel: 0.1 mm a pixel
/// is a microscope's, 10 m a pixel a city map's; a floor drawn on paper or a screen lies
/// between by orders of magnitude either way.
pub const METERS_PER_PIXEL_RANGE: (f64, f64) = (1e-4, 10.0);

/// Refuses a scale that is not finite or lies outside [`METERS_PER_PIXEL_RANGE`], naming
/// the field `meters_per_pixel` (of a session or of an upload).
pub fn check_meters_per_pixel(mpp: f64) -> Result<(), ApiError> {
    check_finite("meters_per_pixel", mpp)?;
    if mpp <= 0.0 {
        return Err(ApiError::invalid_number(
            "meters_per_pixel",
            "must be greater than 0",
        ));
    }
    let (lo, hi) = METERS_PER_PIXEL_RANGE;
    if !(lo..=hi).contains(&mpp) {
        return Err(ApiError::invalid_number(
            "meters_per_pixel",
            &format!("must lie between {lo} and {hi} (meters per pixel of the drawing)"),
        ));
    }
    Ok(())
}

/// A start heading is refused beyond ± this many degrees (one turn either way is how people
/// and tools write any heading).
pub const MAX_HEADING_DEG: f64 = 360.0;

impl CreateSessionRequest {
    /// A request for `robot_id` with `method` and every optional field left out (the
    /// service's defaults); set the others with struct update syntax.
    pub fn new(robot_id: &str, method: MappingMethod) -> Self {
        Self {
            robot_id: robot_id.into(),
            method,
            sketch_id: None,
            start: None,
            meters_per_pixel: None,
            seed: None,
            lidar_mount: None,
            odometry_noise: None,
            mcl_observation: None,
            drawing_localization: None,
            start_heading_from_walls: None,
        }
    }

    /// Checks everything that does not need the registry: the robot id, the fields the
    /// method needs, and that every number is finite and in range. The sketch's existence
    /// and whether the start lies on it are the backend's to check.
    pub fn validate(&self) -> Result<(), ApiError> {
        sketchslam_types::names::validate_segment("robot_id", &self.robot_id)
            .map_err(|e| ApiError::invalid("invalid_robot_id", e.to_string()))?;
        if let Some(noise) = self.odometry_noise {
            noise.validate()?;
        }
        if let Some(m) = self.lidar_mount {
            for (field, value) in [("lidar_mount.x_m", m.x_m), ("lidar_mount.y_m", m.y_m)] {
                check_finite(field, value)?;
                if value.abs() > MAX_LIDAR_OFFSET_M {
                    return Err(ApiError::invalid_number(
                        field,
                        &format!("must lie within ±{MAX_LIDAR_OFFSET_M} m of the robot's centre"),
                    ));
                }
            }
            check_finite("lidar_mount.yaw_deg", m.yaw_deg)?;
            if m.yaw_deg.abs() > MAX_HEADING_DEG {
                return Err(ApiError::invalid_number(
                    "lidar_mount.yaw_deg",
                    &format!("must lie within ±{MAX_HEADING_DEG}"),
                ));
            }
        }
        match self.method {
            MappingMethod::Sketch => {
                let sketch_id = self.sketch_id.as_deref().ok_or_else(|| {
                    ApiError::invalid("missing_field", "sketch_id: required for method \"sketch\"")
                })?;
                if sketch_id.is_empty() {
                    return Err(ApiError::invalid(
                        "missing_field",
                        "sketch_id: must not be empty",
                    ));
                }
                let start = self.start.ok_or_else(|| {
                    ApiError::invalid("missing_field", "start: required for method \"sketch\"")
                })?;
                check_finite("start.u", start.u)?;
                check_finite("start.v", start.v)?;
                check_finite("start.heading_deg", start.heading_deg)?;
                if start.heading_deg.abs() > MAX_HEADING_DEG {
                    return Err(ApiError::invalid_number(
                        "start.heading_deg",
                        &format!("must lie within ±{MAX_HEADING_DEG}"),
                    ));
                }
                if start.u < 0.0 {
                    return Err(ApiError::invalid_number("start.u", "must not be negative"));
                }
                if start.v < 0.0 {
                    return Err(ApiError::invalid_number("start.v", "must not be negative"));
                }
                // Absent, the drawing's declared scale stands in (checked by the service,
                // which knows the drawing).
                if let Some(mpp) = self.meters_per_pixel {
                    check_meters_per_pixel(mpp)?;
                }
            }
            MappingMethod::Icp | MappingMethod::Graph | MappingMethod::Odometry => {
                if self.sketch_id.is_some()
                    || self.start.is_some()
                    || self.meters_per_pixel.is_some()
                {
                    return Err(ApiError::invalid(
                        "unexpected_field",
                        format!(
                            "sketch_id, start and meters_per_pixel apply to method \"sketch\" only, not {:?}",
                            self.method.as_str()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The life of a session.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum SessionState {
    /// Subscribed, no scan received yet.
    WaitingForData,
    /// Scans are being processed.
    Mapping,
    /// Stopped by a client or by shutdown; the map and trajectory are kept.
    Stopped,
    /// The mapper failed; `last_error` says why.
    Failed,
    /// The service ended without stopping it (a crash, a kill, a power cut): the map,
    /// trajectory and status are those of its last checkpoint (`checkpoint_unix_ms`). It
    /// holds no robot: a new session for the same robot can start.
    Interrupted,
}

/// The status of a session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SessionInfo {
    /// Session id (UUID v4).
    pub id: String,
    /// The robot mapped.
    pub robot_id: String,
    /// The mapping method.
    pub method: MappingMethod,
    /// The sketch used (method `sketch`).
    pub sketch_id: Option<String>,
    /// The start marked on the sketch (method `sketch`).
    pub start: Option<SketchStart>,
    /// The scale guess given at the start (method `sketch`).
    pub meters_per_pixel_guess: Option<f64>,
    /// `sketch` sessions asked for `start_heading_from_walls`: the start heading the first
    /// scan's walls gave, degrees (the start's convention), which the map is built from
    /// instead of the marked one. Absent before the first scan, when the walls could not
    /// tell or agreed with the mark within 4° (the mark stands), and otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_heading_from_walls_deg: Option<f64>,
    /// Where the session is in its life.
    pub state: SessionState,
    /// Scans fused so far.
    pub scans_processed: u64,
    /// Scans the intake knows were lost: gaps in the publisher's sequence numbers.
    pub scans_lost: u64,
    /// Times the robot's publisher came back with its sequence restarted (a driver or
    /// simulator restart): a gap in the data that is not counted as lost scans.
    #[serde(default)]
    pub publisher_restarts: u64,
    /// Localization health in [0, 1] (VDA 5050 `localizationScore`).
    pub localization_score: f64,
    /// How often localization on the sketch recovered from a breakdown.
    pub recoveries: u64,
    /// Loops closed by the back end so far (`graph` and `sketch`): each one moved the
    /// trajectory and the map onto a second view of a place.
    #[serde(default)]
    pub loop_closures: u64,
    /// Loops the scan matcher found but the back end refused: they disagreed with the
    /// odometry chain or with the other loops (a look-alike room, a door in a row), or
    /// were taken out of the graph again.
    #[serde(default)]
    pub loop_closures_rejected: u64,
    /// The sketch's scale as currently estimated, meters per pixel.
    pub estimated_meters_per_pixel: Option<f64>,
    /// The last error of the mapper or intake, if any.
    pub last_error: Option<String>,
    /// Start time, milliseconds since the Unix epoch.
    pub created_unix_ms: u64,
    /// Stop time, milliseconds since the Unix epoch.
    pub stopped_unix_ms: Option<u64>,
    /// Why the session stopped (absent while it runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_reason: Option<StopReason>,
    /// Where the LiDAR sits on the robot, as the session was started with (absent: at the
    /// centre).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar_mount: Option<LidarMount>,
    /// The wheel odometry's error model the session maps with, every factor filled in
    /// (absent: the service's default, when the request gave none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub odometry_noise: Option<OdometryNoise>,
    /// `sketch` sessions: how MCL on the drawing weighs a scan (absent for the others).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mcl_observation: Option<DrawingObservationModel>,
    /// `sketch` sessions: which localization on the drawing holds the heading (absent for
    /// the others).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawing_localization: Option<DrawingLocalization>,
    /// When the running session was last written to disk (its checkpoint: what a crash
    /// would leave), milliseconds since the Unix epoch; absent before the first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoint_unix_ms: Option<u64>,
}

/// Why a session stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// A client stopped it (`DELETE /v1/sessions/{id}`).
    Requested,
    /// Its robot published nothing for the service's idle time (`--idle-stop-s`).
    RobotSilent,
    /// The service shut down.
    Shutdown,
}

/// `GET /v1/sessions`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SessionList {
    /// Every session, running and stopped, oldest first.
    pub sessions: Vec<SessionInfo>,
}

/// The robot's pose on the sketch, with the drawing's estimated scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchPoseInfo {
    /// Column, pixels.
    pub u: f64,
    /// Row, pixels.
    pub v: f64,
    /// Heading, degrees counter-clockwise from +u.
    pub heading_deg: f64,
    /// Estimated scale around the robot, meters per pixel.
    pub meters_per_pixel: f64,
    /// What gave it: `warp` (the map pose through the warp fitted to the map, where the
    /// mapped walls hold it), `warp_extrapolated` (the same where none does yet) or `mcl`
    /// (localization on the drawing, until the map is first registered); absent in
    /// sessions stored before the field existed.
    #[serde(default)]
    pub source: Option<SketchPoseSource>,
}

/// What gave a pose on the drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum SketchPoseSource {
    /// The map pose through the warp fitted to the map, where the mapped walls hold it.
    Warp,
    /// The same where no mapped wall holds the warp yet: its extrapolation.
    WarpExtrapolated,
    /// Localization on the drawing (MCL), at a scan.
    Mcl,
    /// MCL's last estimate carried forward by the odometry.
    Odometry,
}

/// `GET /v1/sessions/{id}/pose`: the latest pose estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PoseResponse {
    /// The session.
    pub session_id: String,
    /// Map-frame x, meters.
    pub x: f64,
    /// Map-frame y, meters.
    pub y: f64,
    /// Map-frame heading, radians.
    pub theta: f64,
    /// Stamp of the scan behind the estimate, seconds; null before the first scan.
    pub stamp: Option<f64>,
    /// The pose on the sketch (method `sketch` only).
    pub sketch: Option<SketchPoseInfo>,
    /// VDA 5050: the map the position refers to (the session id).
    #[serde(rename = "mapId")]
    pub map_id: String,
    /// VDA 5050: whether the position is initialized (a scan has been processed).
    #[serde(rename = "positionInitialized")]
    pub position_initialized: bool,
    /// VDA 5050: localization quality in [0, 1].
    #[serde(rename = "localizationScore")]
    pub localization_score: f64,
}

/// One pose of a `sketch` session's trajectory on the drawing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchTrajectoryPointInfo {
    /// Stamp, seconds.
    pub t: f64,
    /// Column on the drawing, pixels from the left edge.
    pub u: f64,
    /// Row on the drawing, pixels from the top edge.
    pub v: f64,
    /// Heading on the drawing, radians counter-clockwise from +u as the drawing is seen.
    pub heading: f64,
    /// The drawing's estimated scale there, meters per pixel.
    pub meters_per_pixel: f64,
    /// What gave the pose: `warp` (the map pose through the warp fitted to the map, where
    /// the mapped walls hold it), `warp_extrapolated` (the same where none does yet), `mcl`
    /// (localization on the drawing, at a scan, before the map is registered) or
    /// `odometry` (MCL's last estimate carried forward between scans).
    #[schema(example = "mcl")]
    pub source: String,
}

/// `GET /v1/sessions/{id}/trajectory?frame=sketch`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct SketchTrajectoryResponse {
    /// The session.
    pub session_id: String,
    /// One pose per stamp of the map-frame trajectory, in stamp order.
    pub points: Vec<SketchTrajectoryPointInfo>,
}

impl SketchTrajectoryResponse {
    /// The trajectory on the drawing as `sketch-trajectory.csv`: header
    /// `t,u,v,heading,meters_per_pixel` (seconds, pixels, radians, meters per pixel).
    pub fn to_csv(&self) -> String {
        let rows: Vec<DrawingRow> = self
            .points
            .iter()
            .map(|p| DrawingRow {
                t_s: p.t,
                u_px: p.u,
                v_px: p.v,
                heading_rad: p.heading,
                meters_per_pixel: p.meters_per_pixel,
            })
            .collect();
        sketch_trajectory_csv::write(&rows)
    }
}

/// One pose of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TrajectoryPointInfo {
    /// Stamp, seconds.
    pub t: f64,
    /// Map-frame x, meters.
    pub x: f64,
    /// Map-frame y, meters.
    pub y: f64,
    /// Map-frame heading, radians.
    pub theta: f64,
}

/// `GET /v1/sessions/{id}/trajectory`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TrajectoryResponse {
    /// The session.
    pub session_id: String,
    /// One pose per processed scan, in stamp order.
    pub points: Vec<TrajectoryPointInfo>,
}

impl TrajectoryResponse {
    /// The trajectory as `trajectory.csv` ([`sketchslam_types::trajectory_csv`], fixed
    /// decimals), the values as they are (headings not re-wrapped).
    pub fn to_csv(&self) -> String {
        let rows: Vec<StampedPose> = self.points.iter().map(|p| p.stamped_pose()).collect();
        trajectory_csv::write(&rows, NumberFormat::Fixed)
    }
}

impl TrajectoryPointInfo {
    /// The point as a CSV row, values unchanged.
    pub fn stamped_pose(&self) -> StampedPose {
        StampedPose {
            t_s: self.t,
            pose: Pose2 {
                x: self.x,
                y: self.y,
                heading_rad: self.theta,
            },
        }
    }

    /// A CSV row as a point, values unchanged.
    pub fn from_stamped_pose(row: &StampedPose) -> TrajectoryPointInfo {
        TrajectoryPointInfo {
            t: row.t_s,
            x: row.pose.x,
            y: row.pose.y,
            theta: row.pose.heading_rad,
        }
    }
}

/// `GET /healthz`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct HealthResponse {
    /// `ok`.
    pub status: String,
}

/// What `GET /v1/sessions/{id}/events` streams (server-sent events named `pose` and
/// `status`, the data being the JSON of the matching response type).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", content = "data", rename_all = "snake_case")]
pub enum SessionEvent {
    /// A new pose estimate.
    Pose(PoseResponse),
    /// A change of the session's status (state, error, ...); boxed, as it is the larger by
    /// far and most events are poses.
    Status(Box<SessionInfo>),
}

impl SessionEvent {
    /// The SSE event name: `pose` or `status`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Pose(_) => "pose",
            Self::Status(_) => "status",
        }
    }
}
