//! The service behind the router: what the HTTP handlers ask of it.
//!
//! The API crate knows nothing of mappers, iceoryx2 or the data dir; the service runtime
//! implements [`Backend`] over its session registry, and tests implement it in memory.
//! Methods are synchronous and may block (decoding an image, stopping a mapper thread,
//! encoding a map): the router calls them on tokio's blocking pool. Every method returns
//! owned values and an [`ApiError`] that says what was wrong in the client's terms.

use axum::body::Bytes;
use tokio::sync::broadcast;

use crate::error::ApiError;
use crate::types::{
    CreateSessionRequest, OccupancyGridResponse, PoseResponse, SessionEvent, SessionInfo,
    SketchInfo, SketchSummary, SketchTrajectoryResponse, TrajectoryResponse,
};

/// The operations behind the HTTP API.
pub trait Backend: Send + Sync + 'static {
    /// Decodes and stores an uploaded sketch; refuses bodies that are no image
    /// (`invalid_image`), too large ones (`image_too_large`) and drawings without lines
    /// (`no_lines`).
    fn create_sketch(&self, name: Option<String>, image: Bytes) -> Result<SketchInfo, ApiError>;
    /// Every stored sketch, oldest first.
    fn list_sketches(&self) -> Result<Vec<SketchSummary>, ApiError>;
    /// One sketch with its lines.
    fn get_sketch(&self, id: &str) -> Result<SketchInfo, ApiError>;
    /// A PNG of the sketch with its extracted lines drawn over it.
    fn sketch_overlay_png(&self, id: &str) -> Result<Vec<u8>, ApiError>;
    /// Removes a stored sketch (sessions already using it keep their copy).
    fn delete_sketch(&self, id: &str) -> Result<(), ApiError>;

    /// Starts a session; `request` has passed [`CreateSessionRequest::validate`]. Refuses an
    /// unknown sketch (`sketch_not_found`, 404), a start outside it (`invalid_start`), a
    /// robot already mapping (`robot_busy`, 409), too many sessions (`too_many_sessions`).
    fn create_session(&self, request: CreateSessionRequest) -> Result<SessionInfo, ApiError>;
    /// Every session, running and stopped, oldest first.
    fn list_sessions(&self) -> Result<Vec<SessionInfo>, ApiError>;
    /// One session's status.
    fn get_session(&self, id: &str) -> Result<SessionInfo, ApiError>;
    /// Stops a session (idempotent); its map and trajectory are kept and stored.
    fn stop_session(&self, id: &str) -> Result<SessionInfo, ApiError>;

    /// The latest pose estimate.
    fn pose(&self, id: &str) -> Result<PoseResponse, ApiError>;
    /// The trajectory so far (or final, once stopped).
    fn trajectory(&self, id: &str) -> Result<TrajectoryResponse, ApiError>;
    /// A `sketch` session's trajectory on the drawing (the pose on the drawing at every
    /// stamp of [`Backend::trajectory`]); an error for a session without a drawing.
    fn sketch_trajectory(&self, id: &str) -> Result<SketchTrajectoryResponse, ApiError>;
    /// The map as a PNG (black occupied, white free, grey unknown; north up).
    fn map_png(&self, id: &str) -> Result<Vec<u8>, ApiError>;
    /// The map as the PGM of a ROS map_server pair.
    fn map_pgm(&self, id: &str) -> Result<Vec<u8>, ApiError>;
    /// The map's ROS map_server YAML, naming `map.pgm` as its image.
    fn map_yaml(&self, id: &str) -> Result<String, ApiError>;
    /// The map as ROS OccupancyGrid JSON.
    fn map_occupancy(&self, id: &str) -> Result<OccupancyGridResponse, ApiError>;
    /// A live feed of the session's poses and status changes; the channel closes when the
    /// session stops (at once for a stopped session).
    fn subscribe_events(&self, id: &str) -> Result<broadcast::Receiver<SessionEvent>, ApiError>;

    /// The backend's part of `/metrics`, Prometheus text exposition format (`# HELP`,
    /// `# TYPE` and samples, newline-terminated).
    fn metrics_text(&self) -> String;
}
