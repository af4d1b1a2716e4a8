//! The axum router: routes, handlers, bearer auth, body limit and request counting.
//!
//! Handlers are thin: parse and validate the request, call the [`Backend`] on tokio's
//! blocking pool, shape the answer. Every failure leaves as an [`ApiError`] JSON body.

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::sync::{Arc, Mutex};

use axum::body::Body;
use axum::extract::{MatchedPath, Request, State};
use axum::handler::Handler;
use axum::http::{HeaderMap, HeaderName, HeaderValue, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures::{Stream, StreamExt};
use serde::Deserialize;
use tokio_stream::wrappers::BroadcastStream;
use tower::limit::GlobalConcurrencyLimitLayer;
use tower_http::cors::{AllowOrigin, CorsLayer};
use utoipa::OpenApi;

use crate::backend::Backend;
use crate::error::{ApiError, ErrorBody};
use crate::event_log::{EventSubscription, NumberedEvent};
use crate::extract::{ApiBytes, ApiJson, ApiPath, ApiQuery};
use crate::map_image::{MAP_ORIGIN_X_HEADER, MAP_ORIGIN_Y_HEADER, MAP_RESOLUTION_HEADER};
use crate::occupancy::OccupancyGridResponse;
use crate::openapi::ApiDoc;
use crate::registration_routes::{
    session_registration, session_sketch_in_map, session_sketch_in_map_png, session_sketch_overlay,
    session_transform,
};
use crate::types::{
    CreateSessionRequest, HealthResponse, PoseResponse, SessionEvent, SessionInfo, SessionList,
    SketchInfo, SketchList, SketchUpload, check_meters_per_pixel,
};
use crate::web;

/// The default body limit: 16 MiB, far above any sketch photo worth uploading.
pub const DEFAULT_MAX_BODY_BYTES: usize = 16 * 1024 * 1024;

/// How the router is set up.
#[derive(Debug, Clone)]
pub struct RouterOptions {
    /// When set, every request except `GET /healthz` and the web page's files
    /// ([`web::is_public`]) needs `Authorization: Bearer <token>`.
    pub token: Option<String>,
    /// The largest request body accepted; larger ones get 413 before being read whole.
    pub max_body_bytes: usize,
    /// Drawing uploads (`POST /v1/sketches`) handled at once; more wait their turn, their
    /// bodies unread. Decoding a drawing at the pixel limit holds ~270 MB while it runs, so
    /// this bounds the service's peak memory, not only its CPU.
    pub max_concurrent_uploads: usize,
    /// Origins whose pages may call the API from a browser (CORS); `*` for any. Empty (the
    /// default): none but the service's own page.
    pub cors_origins: Vec<HeaderValue>,
}

impl Default for RouterOptions {
    fn default() -> Self {
        Self {
            token: None,
            max_body_bytes: DEFAULT_MAX_BODY_BYTES,
            max_concurrent_uploads: DEFAULT_MAX_CONCURRENT_UPLOADS,
            cors_origins: Vec::new(),
        }
    }
}

/// The CORS layer for `origins`: the API's methods, the headers a client sends (the token,
/// JSON, `Last-Event-ID`, `If-None-Match`) and those it may read (the map's tag and frame).
/// Preflight requests are answered here, before the token is checked: a browser sends
/// them without it.
fn cors_layer(origins: &[HeaderValue]) -> CorsLayer {
    use axum::http::Method;
    let allow_origin = if origins.iter().any(|o| o == "*") {
        AllowOrigin::any()
    } else {
        AllowOrigin::list(origins.iter().cloned())
    };
    CorsLayer::new()
        .allow_origin(allow_origin)
        .allow_methods([Method::GET, Method::POST, Method::DELETE])
        .allow_headers([
            header::AUTHORIZATION,
            header::CONTENT_TYPE,
            header::IF_NONE_MATCH,
            HeaderName::from_static("last-event-id"),
        ])
        .expose_headers([
            header::ETAG,
            MAP_RESOLUTION_HEADER,
            MAP_ORIGIN_X_HEADER,
            MAP_ORIGIN_Y_HEADER,
        ])
        .max_age(std::time::Duration::from_secs(600))
}

/// Default of [`RouterOptions::max_concurrent_uploads`].
pub const DEFAULT_MAX_CONCURRENT_UPLOADS: usize = 2;

/// Counts of answered HTTP requests by method, route template and status.
#[derive(Debug, Default)]
pub struct HttpMetrics {
    counts: Mutex<BTreeMap<(String, String, u16), u64>>,
}

impl HttpMetrics {
    fn record(&self, method: &str, route: &str, status: u16) {
        let mut counts = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        *counts
            .entry((method.to_string(), route.to_string(), status))
            .or_default() += 1;
    }

    /// `sketchslam_http_requests_total` in Prometheus text format.
    pub fn render(&self) -> String {
        let counts = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        let mut out = String::from(
            "# HELP sketchslam_http_requests_total HTTP requests answered, by method, route and status.\n\
             # TYPE sketchslam_http_requests_total counter\n",
        );
        for ((method, route, status), n) in counts.iter() {
            out.push_str(&format!(
                "sketchslam_http_requests_total{{method=\"{method}\",route=\"{}\",status=\"{status}\"}} {n}\n",
                escape_label(route)
            ));
        }
        out
    }
}

/// Escapes a Prometheus label value.
pub fn escape_label(value: &str) -> String {
    value
        .replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

#[derive(Clone)]
pub(crate) struct AppState {
    backend: Arc<dyn Backend>,
    http_metrics: Arc<HttpMetrics>,
}

/// The full HTTP API over `backend`.
pub fn router(backend: Arc<dyn Backend>, options: RouterOptions) -> Router {
    let state = AppState {
        backend,
        http_metrics: Arc::new(HttpMetrics::default()),
    };
    let limit = options.max_body_bytes;
    let token: Option<Arc<str>> = options.token.map(Arc::from);
    let app = Router::new()
        .route("/", get(web::index))
        .route("/js/{file}", get(web::module))
        .route("/app.css", get(web::app_css))
        .route("/healthz", get(healthz))
        .route("/metrics", get(metrics))
        .route("/openapi.json", get(openapi_json))
        .route(
            "/v1/sketches",
            get(list_sketches).post(create_sketch.layer(GlobalConcurrencyLimitLayer::new(
                options.max_concurrent_uploads.max(1),
            ))),
        )
        .route("/v1/sketches/{id}", get(get_sketch).delete(delete_sketch))
        .route("/v1/sketches/{id}/lines.png", get(sketch_overlay))
        .route("/v1/sessions", get(list_sessions).post(create_session))
        .route("/v1/sessions/{id}", get(get_session).delete(stop_session))
        .route("/v1/sessions/{id}/pose", get(session_pose))
        .route("/v1/sessions/{id}/trajectory", get(session_trajectory))
        .route("/v1/sessions/{id}/map", get(session_map_json))
        .route("/v1/sessions/{id}/map.png", get(session_map_png))
        .route("/v1/sessions/{id}/map.pgm", get(session_map_pgm))
        .route("/v1/sessions/{id}/map.yaml", get(session_map_yaml))
        .route("/v1/sessions/{id}/events", get(session_events))
        .route("/v1/sessions/{id}/registration", get(session_registration))
        .route(
            "/v1/sessions/{id}/sketch-overlay.png",
            get(session_sketch_overlay),
        )
        .route(
            "/v1/sessions/{id}/sketch-in-map",
            get(session_sketch_in_map),
        )
        .route(
            "/v1/sessions/{id}/sketch-in-map.png",
            get(session_sketch_in_map_png),
        )
        .route("/v1/sessions/{id}/transform", post(session_transform))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(axum::extract::DefaultBodyLimit::max(limit))
        .layer(middleware::from_fn(move |req: Request, next: Next| {
            content_length_guard(limit, req, next)
        }))
        .layer(middleware::from_fn(move |req: Request, next: Next| {
            bearer_auth(token.clone(), req, next)
        }))
        .layer(middleware::from_fn_with_state(
            state.clone(),
            count_requests,
        ))
        .with_state(state);
    if options.cors_origins.is_empty() {
        app
    } else {
        app.layer(cors_layer(&options.cors_origins))
    }
}

/// The `method` label of a request: one of HTTP's standard methods, or `other` for any
/// made-up one, so a client cannot add series to `/metrics` without bound (each series is
/// kept for the life of the process).
fn method_label(method: &axum::http::Method) -> &'static str {
    use axum::http::Method as M;
    match *method {
        M::GET => "GET",
        M::HEAD => "HEAD",
        M::POST => "POST",
        M::PUT => "PUT",
        M::DELETE => "DELETE",
        M::PATCH => "PATCH",
        M::OPTIONS => "OPTIONS",
        M::CONNECT => "CONNECT",
        M::TRACE => "TRACE",
        _ => "other",
    }
}

async fn count_requests(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let method = method_label(req.method());
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|p| p.as_str().to_string())
        .unwrap_or_else(|| "unmatched".to_string());
    let response = next.run(req).await;
    state
        .http_metrics
        .record(method, &route, response.status().as_u16());
    response
}

async fn bearer_auth(token: Option<Arc<str>>, req: Request, next: Next) -> Response {
    if let Some(token) = token
        && !web::is_public(req.uri().path())
        && !bearer_matches(req.headers(), &token)
    {
        return ApiError::Unauthorized.into_response();
    }
    next.run(req).await
}

/// Compares the presented bearer token without stopping at the first differing byte.
fn bearer_matches(headers: &HeaderMap, token: &str) -> bool {
    let Some(value) = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
    else {
        return false;
    };
    let Some(presented) = value
        .strip_prefix("Bearer ")
        .or_else(|| value.strip_prefix("bearer "))
    else {
        return false;
    };
    let (a, b) = (presented.trim().as_bytes(), token.as_bytes());
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

async fn content_length_guard(limit: usize, req: Request, next: Next) -> Response {
    let declared = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    if let Some(n) = declared
        && n > limit as u64
    {
        let mut response = ApiError::too_large(
            "payload_too_large",
            format!("the request body has {n} bytes; the limit is {limit}"),
        )
        .into_response();
        // The body is left unread, so the connection cannot carry another request: say so,
        // or a client may send its next request on it as the server closes it.
        response
            .headers_mut()
            .insert(header::CONNECTION, HeaderValue::from_static("close"));
        return response;
    }
    next.run(req).await
}

async fn not_found() -> ApiError {
    ApiError::NotFound {
        code: "not_found",
        message: "no such route".to_string(),
    }
}

async fn method_not_allowed() -> ApiError {
    ApiError::MethodNotAllowed
}

/// Runs a backend call on the blocking pool.
pub(crate) async fn call<T, F>(state: &AppState, f: F) -> Result<T, ApiError>
where
    T: Send + 'static,
    F: FnOnce(&dyn Backend) -> Result<T, ApiError> + Send + 'static,
{
    let backend = state.backend.clone();
    tokio::task::spawn_blocking(move || f(backend.as_ref()))
        .await
        .map_err(|e| ApiError::internal(format!("backend task failed: {e}")))?
}

pub(crate) fn with_content_type(content_type: &'static str, body: impl Into<Body>) -> Response {
    ([(header::CONTENT_TYPE, content_type)], body.into()).into_response()
}

/// Liveness probe; never needs a token.
#[utoipa::path(get, path = "/healthz", tag = "service",
    responses((status = 200, description = "The service is up", body = HealthResponse)))]
pub(crate) async fn healthz() -> Json<HealthResponse> {
    Json(HealthResponse {
        status: "ok".to_string(),
    })
}

/// Prometheus metrics: per-session scans processed and lost, processing time, HTTP requests.
#[utoipa::path(get, path = "/metrics", tag = "service",
    responses((status = 200, description = "Prometheus text exposition format", body = String, content_type = "text/plain")))]
pub(crate) async fn metrics(State(state): State<AppState>) -> Result<Response, ApiError> {
    let http = state.http_metrics.render();
    let mut text = call(&state, |b| Ok(b.metrics_text())).await?;
    text.push_str(&http);
    Ok(with_content_type(
        "text/plain; version=0.0.4; charset=utf-8",
        text,
    ))
}

/// This API's OpenAPI 3.1 document.
#[utoipa::path(get, path = "/openapi.json", tag = "service",
    responses((status = 200, description = "The OpenAPI document", body = Object)))]
pub(crate) async fn openapi_json() -> Response {
    match ApiDoc::openapi().to_json() {
        Ok(json) => with_content_type("application/json", json),
        Err(e) => ApiError::internal(format!("openapi: {e}")).into_response(),
    }
}

/// `?name=&meters_per_pixel=` of a sketch upload.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct UploadQuery {
    /// A name for the sketch (at most 128 characters).
    name: Option<String>,
    /// The drawing's scale, when known (e.g. from a CAD plan or a dimension on the
    /// paper), meters per pixel, within 0.0001..10: the scale guess of every session on
    /// it that gives none, and the scale of its frame in VDA 5050 positions.
    meters_per_pixel: Option<f64>,
}

/// Uploads a sketch (PNG or JPEG body) and extracts its lines.
#[utoipa::path(post, path = "/v1/sketches", tag = "sketches", params(UploadQuery),
    request_body(content = Vec<u8>, content_type = "image/png", description = "A PNG or JPEG image"),
    responses(
        (status = 201, description = "Stored", body = SketchInfo),
        (status = 400, description = "Empty body", body = ErrorBody),
        (status = 409, description = "As many sketches as the service keeps are stored (`too_many_sketches`): delete one first", body = ErrorBody),
        (status = 413, description = "Body or image too large", body = ErrorBody),
        (status = 422, description = "Not an image, no lines in it, a bad name or a scale out of range", body = ErrorBody)))]
pub(crate) async fn create_sketch(
    State(state): State<AppState>,
    ApiQuery(query): ApiQuery<UploadQuery>,
    ApiBytes(body): ApiBytes,
) -> Result<(StatusCode, Json<SketchInfo>), ApiError> {
    if body.is_empty() {
        return Err(ApiError::bad_request(
            "empty_body",
            "the request body is empty; send the sketch as a PNG or JPEG image",
        ));
    }
    let name = match query.name {
        Some(name) if name.chars().count() > 128 || name.chars().any(char::is_control) => {
            return Err(ApiError::invalid(
                "invalid_name",
                "name: at most 128 characters, no control characters",
            ));
        }
        Some(name) if name.trim().is_empty() => None,
        other => other,
    };
    if let Some(mpp) = query.meters_per_pixel {
        check_meters_per_pixel(mpp)?;
    }
    let upload = SketchUpload {
        name,
        meters_per_pixel: query.meters_per_pixel,
    };
    let info = call(&state, move |b| b.create_sketch(upload, body)).await?;
    Ok((StatusCode::CREATED, Json(info)))
}

/// Lists stored sketches.
#[utoipa::path(get, path = "/v1/sketches", tag = "sketches",
    responses((status = 200, description = "Every sketch", body = SketchList)))]
pub(crate) async fn list_sketches(
    State(state): State<AppState>,
) -> Result<Json<SketchList>, ApiError> {
    let sketches = call(&state, |b| b.list_sketches()).await?;
    Ok(Json(SketchList { sketches }))
}

/// One sketch with its extracted lines.
#[utoipa::path(get, path = "/v1/sketches/{id}", tag = "sketches",
    params(("id" = String, Path, description = "Sketch id")),
    responses(
        (status = 200, description = "The sketch", body = SketchInfo),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn get_sketch(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<SketchInfo>, ApiError> {
    call(&state, move |b| b.get_sketch(&id)).await.map(Json)
}

/// The sketch with its extracted lines drawn over it.
#[utoipa::path(get, path = "/v1/sketches/{id}/lines.png", tag = "sketches",
    params(("id" = String, Path, description = "Sketch id")),
    responses(
        (status = 200, description = "PNG overlay", body = Vec<u8>, content_type = "image/png"),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn sketch_overlay(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Response, ApiError> {
    let png = call(&state, move |b| b.sketch_overlay_png(&id)).await?;
    Ok(with_content_type("image/png", png))
}

/// Deletes a stored sketch.
#[utoipa::path(delete, path = "/v1/sketches/{id}", tag = "sketches",
    params(("id" = String, Path, description = "Sketch id")),
    responses(
        (status = 204, description = "Deleted"),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn delete_sketch(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<StatusCode, ApiError> {
    call(&state, move |b| b.delete_sketch(&id)).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// Starts a mapping session for a robot.
#[utoipa::path(post, path = "/v1/sessions", tag = "sessions",
    request_body = CreateSessionRequest,
    responses(
        (status = 201, description = "Started", body = SessionInfo),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 404, description = "Unknown sketch", body = ErrorBody),
        (status = 409, description = "Robot already mapping, or too many sessions", body = ErrorBody),
        (status = 422, description = "Invalid field (named in the message)", body = ErrorBody)))]
pub(crate) async fn create_session(
    State(state): State<AppState>,
    ApiJson(request): ApiJson<CreateSessionRequest>,
) -> Result<(StatusCode, Json<SessionInfo>), ApiError> {
    request.validate()?;
    let info = call(&state, move |b| b.create_session(request)).await?;
    Ok((StatusCode::CREATED, Json(info)))
}

/// Lists sessions, running and stopped.
#[utoipa::path(get, path = "/v1/sessions", tag = "sessions",
    responses((status = 200, description = "Every session", body = SessionList)))]
pub(crate) async fn list_sessions(
    State(state): State<AppState>,
) -> Result<Json<SessionList>, ApiError> {
    let sessions = call(&state, |b| b.list_sessions()).await?;
    Ok(Json(SessionList { sessions }))
}

/// A session's status.
#[utoipa::path(get, path = "/v1/sessions/{id}", tag = "sessions",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "Status", body = SessionInfo),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn get_session(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<SessionInfo>, ApiError> {
    call(&state, move |b| b.get_session(&id)).await.map(Json)
}

/// Stops a session; its map and trajectory stay available.
#[utoipa::path(delete, path = "/v1/sessions/{id}", tag = "sessions",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "Stopped", body = SessionInfo),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn stop_session(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<SessionInfo>, ApiError> {
    call(&state, move |b| b.stop_session(&id)).await.map(Json)
}

/// The latest pose: map frame, on the sketch, and VDA 5050's agvPosition words.
#[utoipa::path(get, path = "/v1/sessions/{id}/pose", tag = "sessions",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "Pose", body = PoseResponse),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_pose(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<PoseResponse>, ApiError> {
    call(&state, move |b| b.pose(&id)).await.map(Json)
}

/// `?format=` and `?frame=` of the trajectory.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
pub(crate) struct TrajectoryQuery {
    /// `json` (default) or `csv` (`trajectory.csv`, header `t,x,y,theta`; on the drawing
    /// `sketch-trajectory.csv`, header `t,u,v,heading,meters_per_pixel`).
    format: Option<String>,
    /// `map` (default: meters, the map frame) or `sketch` (the pose on the drawing, `sketch`
    /// sessions only).
    frame: Option<String>,
}

/// The trajectory, as JSON or as CSV, in the map frame or on the drawing.
#[utoipa::path(get, path = "/v1/sessions/{id}/trajectory", tag = "sessions",
    params(("id" = String, Path, description = "Session id"), TrajectoryQuery),
    responses(
        (status = 200, description = "Trajectory (JSON, or CSV with ?format=csv); with ?frame=sketch a SketchTrajectoryResponse", body = crate::types::TrajectoryResponse),
        (status = 400, description = "Unknown format or frame", body = ErrorBody),
        (status = 422, description = "frame=sketch on a session without a drawing", body = ErrorBody),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_trajectory(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
    ApiQuery(query): ApiQuery<TrajectoryQuery>,
) -> Result<Response, ApiError> {
    let csv = match query.format.as_deref() {
        None | Some("json") => false,
        Some("csv") => true,
        Some(other) => {
            return Err(ApiError::bad_request(
                "invalid_query",
                format!("format: {other:?} is not one of \"json\", \"csv\""),
            ));
        }
    };
    let on_drawing = match query.frame.as_deref() {
        None | Some("map") => false,
        Some("sketch") => true,
        Some(other) => {
            return Err(ApiError::bad_request(
                "invalid_query",
                format!("frame: {other:?} is not one of \"map\", \"sketch\""),
            ));
        }
    };
    if on_drawing {
        let trajectory = call(&state, move |b| b.sketch_trajectory(&id)).await?;
        return Ok(if csv {
            (
                [
                    (header::CONTENT_TYPE, "text/csv; charset=utf-8"),
                    (
                        header::CONTENT_DISPOSITION,
                        "attachment; filename=\"sketch-trajectory.csv\"",
                    ),
                ],
                trajectory.to_csv(),
            )
                .into_response()
        } else {
            Json(trajectory).into_response()
        });
    }
    let trajectory = call(&state, move |b| b.trajectory(&id)).await?;
    if csv {
        Ok((
            [
                (header::CONTENT_TYPE, "text/csv; charset=utf-8"),
                (
                    header::CONTENT_DISPOSITION,
                    "attachment; filename=\"trajectory.csv\"",
                ),
            ],
            trajectory.to_csv(),
        )
            .into_response())
    } else {
        Ok(Json(trajectory).into_response())
    }
}

/// The map as ROS OccupancyGrid JSON.
#[utoipa::path(get, path = "/v1/sessions/{id}/map", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "Occupancy grid", body = OccupancyGridResponse),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_map_json(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<OccupancyGridResponse>, ApiError> {
    call(&state, move |b| b.map_occupancy(&id)).await.map(Json)
}

/// The map as a PNG, with an `ETag` (send it back in `If-None-Match` to get `304` while the
/// map is unchanged) and the map frame in `X-Map-Resolution-M`, `X-Map-Origin-X-M` and
/// `X-Map-Origin-Y-M` (pixel column `c`, row `r` from the top, of an `h`-row picture is at
/// `x = origin_x + (c + ½)·res`, `y = origin_y + (h − r − ½)·res`).
#[utoipa::path(get, path = "/v1/sessions/{id}/map.png", tag = "maps",
    params(("id" = String, Path, description = "Session id"),
        ("If-None-Match" = Option<String>, Header, description = "The ETag of the map the client holds")),
    responses(
        (status = 200, description = "PNG", body = Vec<u8>, content_type = "image/png",
            headers(("ETag" = String, description = "Tag of this picture"),
                ("X-Map-Resolution-M" = f64, description = "Meters per pixel"),
                ("X-Map-Origin-X-M" = f64, description = "Map x of the bottom-left corner, m"),
                ("X-Map-Origin-Y-M" = f64, description = "Map y of the bottom-left corner, m"))),
        (status = 304, description = "Unchanged since the ETag in If-None-Match"),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_map_png(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let png = call(&state, move |b| b.map_png(&id)).await?;
    Ok(png.respond(&headers))
}

/// The map's PGM (ROS map_server).
#[utoipa::path(get, path = "/v1/sessions/{id}/map.pgm", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "PGM (P5)", body = Vec<u8>, content_type = "image/x-portable-graymap"),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_map_pgm(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Response, ApiError> {
    let pgm = call(&state, move |b| b.map_pgm(&id)).await?;
    Ok(with_content_type("image/x-portable-graymap", pgm))
}

/// The map's YAML (ROS map_server), naming `map.pgm`.
#[utoipa::path(get, path = "/v1/sessions/{id}/map.yaml", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "YAML", body = String, content_type = "application/yaml"),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_map_yaml(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Response, ApiError> {
    let yaml = call(&state, move |b| b.map_yaml(&id)).await?;
    Ok(with_content_type("application/yaml", yaml))
}

/// Server-sent events: `status` and the pose now (once a scan has given one) first, then
/// each new `pose` and `status` change; the stream ends when the session stops. Every event
/// carries an `id:`; a client that reconnects with `Last-Event-ID` gets the events it missed
/// (of the last few hundred the session keeps) and then the live feed, without the snapshot
/// first; an id the session no longer keeps starts over with the snapshot.
#[utoipa::path(get, path = "/v1/sessions/{id}/events", tag = "sessions",
    params(
        ("id" = String, Path, description = "Session id"),
        ("Last-Event-ID" = Option<String>, Header, description = "Resume after this event id (a number as sent in `id:`; anything else starts the stream over)")),
    responses(
        (status = 200, description = "text/event-stream of `pose` and `status` events, each with an `id:`", body = SessionEvent, content_type = "text/event-stream"),
        (status = 404, description = "Unknown id", body = ErrorBody)))]
pub(crate) async fn session_events(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
    headers: HeaderMap,
) -> Result<Sse<impl Stream<Item = Result<Event, Infallible>>>, ApiError> {
    // An unreadable id is no id: the stream starts over.
    let last_seen = headers
        .get("last-event-id")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    let (status, pose, sub) = call(&state, move |b| {
        // Subscribe first so that nothing between the snapshot and the feed is missed.
        let sub = b.subscribe_events(&id, last_seen)?;
        // The pose now, once a scan has given one: a robot standing still publishes none.
        let pose = b.pose(&id).ok().filter(|p| p.stamp.is_some());
        Ok((b.get_session(&id)?, pose, sub))
    })
    .await?;
    let EventSubscription {
        replay,
        resumed,
        last_id,
        live,
    } = sub;
    let first: Vec<NumberedEvent> = if resumed {
        replay
    } else {
        // The snapshot (the status, then the pose now) takes the id of the last event
        // before it: resuming from it continues with what followed.
        std::iter::once(SessionEvent::Status(Box::new(status)))
            .chain(pose.map(SessionEvent::Pose))
            .map(|event| NumberedEvent { id: last_id, event })
            .collect()
    };
    let live = BroadcastStream::new(live)
        .filter_map(|item| async move { item.ok() })
        .filter(move |e| futures::future::ready(e.id > last_id));
    let events = futures::stream::iter(first)
        .chain(live)
        .map(|e| Ok(to_sse(&e.event).id(e.id.to_string())));
    Ok(Sse::new(events).keep_alive(KeepAlive::default()))
}

fn to_sse(event: &SessionEvent) -> Event {
    let data = match event {
        SessionEvent::Pose(p) => serde_json::to_string(p),
        SessionEvent::Status(s) => serde_json::to_string(s),
    }
    .unwrap_or_else(|_| "{}".to_string());
    Event::default().event(event.name()).data(data)
}
