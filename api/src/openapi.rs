//! The OpenAPI document, generated from the handlers' `#[utoipa::path]` attributes and
//! the types' `ToSchema` derives (never written by hand). Served at `/openapi.json`.

use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi};

use crate::error::{ErrorBody, ErrorDetail};
use crate::occupancy::{
    MapMetaData, OccupancyGridResponse, RosHeader, RosPoint, RosPose, RosQuaternion, RosTime,
};
use crate::openapi_wire::WireFixes;
use crate::registration::{
    DrawingPointIn, DrawingPointOut, MapPointIn, MapPointOut, RegistrationInfo,
    SketchInMapResponse, SketchLineInMap, TransformRequest, TransformResponse, WarpInfo,
};
use crate::types::{
    CreateSessionRequest, DrawingLocalization, DrawingObservationModel, HealthResponse, LidarMount,
    MappingMethod, OdometryNoise, PixelPoint, PoseResponse, SessionEvent, SessionInfo, SessionList,
    SessionState, SketchInfo, SketchLineInfo, SketchList, SketchPoseInfo, SketchPoseSource,
    SketchStart, SketchSummary, SketchTrajectoryPointInfo, SketchTrajectoryResponse, StopReason,
    TrajectoryPointInfo, TrajectoryResponse,
};
use crate::{registration_routes, router};

/// The sketchslam HTTP API.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "sketchslam",
        description = "Metric maps from 2D LiDAR and odometry with a hand-drawn sketch as prior. \
                       Errors are `{\"error\": {\"code\", \"message\"}}`. When the service has a \
                       token, every request except /healthz and the web page's files (`/`, \
                       `/app.css`, `/js/*`) needs `Authorization: Bearer <token>`. A method a path \
                       does not list is answered 405 `method_not_allowed` with an `Allow` \
                       header. Before the API, the HTTP layer answers without a body: 414 for \
                       a request line it will not read, 431 for headers too large or too many \
                       (more than 100), 408 for a request not complete within the service's \
                       --request-timeout-s."
    ),
    paths(
        router::healthz,
        router::metrics,
        router::openapi_json,
        router::create_sketch,
        router::list_sketches,
        router::get_sketch,
        router::sketch_overlay,
        router::delete_sketch,
        router::create_session,
        router::list_sessions,
        router::get_session,
        router::stop_session,
        router::session_pose,
        router::session_trajectory,
        router::session_map_json,
        router::session_map_png,
        router::session_map_pgm,
        router::session_map_yaml,
        router::session_events,
        registration_routes::session_registration,
        registration_routes::session_sketch_overlay,
        registration_routes::session_sketch_in_map,
        registration_routes::session_sketch_in_map_png,
        registration_routes::session_transform,
    ),
    components(schemas(
        ErrorBody, ErrorDetail, CreateSessionRequest, HealthResponse, MappingMethod,
        OccupancyGridResponse, MapMetaData, RosHeader, RosTime, RosPose, RosPoint, RosQuaternion,
        PixelPoint, PoseResponse, SessionEvent, SessionInfo,
        SessionList, SessionState, StopReason, SketchInfo, SketchLineInfo, SketchList,
        SketchPoseInfo, SketchPoseSource, LidarMount, OdometryNoise, DrawingObservationModel, DrawingLocalization,
        SketchStart, SketchSummary, SketchTrajectoryPointInfo, SketchTrajectoryResponse,
        TrajectoryPointInfo, TrajectoryResponse, RegistrationInfo, WarpInfo, SketchInMapResponse,
        SketchLineInMap, TransformRequest, TransformResponse, DrawingPointIn, DrawingPointOut,
        MapPointIn, MapPointOut,
    )),
    modifiers(&BearerAuth, &WireFixes),
    security(("bearer" = [])),
    tags(
        (name = "sketches", description = "Hand-drawn maps"),
        (name = "sessions", description = "Mapping sessions, one robot each"),
        (name = "maps", description = "The maps sessions build"),
        (name = "service", description = "Health, metrics, this document"),
    )
)]
pub struct ApiDoc;

/// Declares the optional bearer token scheme.
struct BearerAuth;

impl Modify for BearerAuth {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let components = openapi.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            "bearer",
            SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
        );
    }
}
