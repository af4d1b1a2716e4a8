//! The service behind the router: what the HTTP handlers ask of it.
//!
//! The API crate knows nothing of mappers, iceoryx2 or the data dir; the service runtime
//! implements [`Backend`] over its session registry, and tests implement it in memory.
//! Methods are synchronous and may block (decoding an image, stopping a mapper thread,
//! encoding a map): the router calls them on tokio's blocking pool. Every method returns
//! owned values and an [`ApiError`] that says what was wrong in the client's terms.

use axum::body::Bytes;

use crate::error::ApiError;
use crate::event_log::EventSubscription;
use crate::map_image::TaggedPng;
use crate::occupancy::OccupancyGridResponse;
use crate::registration::{
    RegistrationInfo, SketchInMapResponse, TransformRequest, TransformResponse,
};
use crate::types::{
    CreateSessionRequest, PoseResponse, SessionInfo, SketchInfo, SketchSummary,
    SketchTrajectoryResponse, SketchUpload, TrajectoryResponse,
};

/// The operations behind the HTTP API.
pub trait Backend: Send + Sync + 'static {
    /// Decodes and stores an uploaded sketch; refuses bodies that are no image
    /// (`invalid_image`), too large ones (`image_too_large`) and drawings without lines
    /// (`no_lines`). `upload` has been checked.
    fn create_sketch(&self, upload: SketchUpload, image: Bytes) -> Result<SketchInfo, ApiError>;
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
    /// The map as a PNG (black occupied, white free, grey unknown; north up) in its map
    /// frame (resolution and origin, as `map.yaml` gives them).
    fn map_png(&self, id: &str) -> Result<TaggedPng, ApiError>;
    /// The map as the PGM of a ROS map_server pair.
    fn map_pgm(&self, id: &str) -> Result<Vec<u8>, ApiError>;
    /// The map's ROS map_server YAML, naming `map.pgm` as its image.
    fn map_yaml(&self, id: &str) -> Result<String, ApiError>;
    /// The map as ROS OccupancyGrid JSON.
    fn map_occupancy(&self, id: &str) -> Result<OccupancyGridResponse, ApiError>;
    /// A live feed of the session's poses and status changes, resumed after `last_seen`
    /// (a client's `Last-Event-ID`) when the session still keeps what followed it
    /// ([`crate::EventLog::subscribe`]); the channel closes when the session stops (at
    /// once for a stopped session: [`EventSubscription::ended`]).
    fn subscribe_events(
        &self,
        id: &str,
        last_seen: Option<u64>,
    ) -> Result<EventSubscription, ApiError>;

    /// A `sketch` session's map laid on its drawing: the warp fitted to the walls mapped so
    /// far. `no_drawing` (422) for a session without a drawing, `not_registered` (409)
    /// while nothing is mapped to fit.
    fn registration(&self, id: &str) -> Result<RegistrationInfo, ApiError> {
        Err(no_registration(id))
    }
    /// The map and route drawn over the drawing through the warp, as a PNG.
    fn sketch_overlay_on_map_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        Err(no_registration(id))
    }
    /// The drawing's lines in map meters through the warp's inverse.
    fn sketch_in_map(&self, id: &str) -> Result<SketchInMapResponse, ApiError> {
        Err(no_registration(id))
    }
    /// The map with the drawing's lines drawn over it, as a PNG.
    fn sketch_in_map_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        Err(no_registration(id))
    }
    /// Drawing pixels to map poses and back, through the warp; `request` is validated.
    fn transform(
        &self,
        id: &str,
        request: TransformRequest,
    ) -> Result<TransformResponse, ApiError> {
        let _ = request;
        Err(no_registration(id))
    }

    /// The backend's part of `/metrics`, Prometheus text exposition format (`# HELP`,
    /// `# TYPE` and samples, newline-terminated).
    fn metrics_text(&self) -> String;
}

/// What a backend that lays no map on a drawing answers for session `id`.
fn no_registration(id: &str) -> ApiError {
    ApiError::NotFound {
        code: "no_registration",
        message: format!("this service does not lay session {id}'s map on a drawing"),
    }
}
