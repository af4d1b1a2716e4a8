//! Handlers of the map-on-drawing endpoints ([`crate::registration`]'s types): thin, as
//! the rest of [`crate::router`] — parse, validate, call the [`crate::Backend`] on the
//! blocking pool (the warp is fitted there), shape the answer.

use axum::Json;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::Response;

use crate::error::{ApiError, ErrorBody};
use crate::extract::{ApiJson, ApiPath};
use crate::map_image::TaggedPng;
use crate::registration::{
    RegistrationInfo, SketchInMapResponse, TransformRequest, TransformResponse,
};
use crate::router::{AppState, call, with_content_type};

/// The warp laying a `sketch` session's map on its drawing, fitted to the walls mapped so
/// far (refitted when the map has moved or grown).
#[utoipa::path(get, path = "/v1/sessions/{id}/registration", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "The warp and how well it fits", body = RegistrationInfo),
        (status = 404, description = "Unknown id", body = ErrorBody),
        (status = 409, description = "Nothing mapped to lay on the drawing yet", body = ErrorBody),
        (status = 422, description = "The session maps without a drawing", body = ErrorBody)))]
pub(crate) async fn session_registration(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<RegistrationInfo>, ApiError> {
    call(&state, move |b| b.registration(&id)).await.map(Json)
}

/// The map (red) and the route (blue) drawn over the drawing through the warp.
#[utoipa::path(get, path = "/v1/sessions/{id}/sketch-overlay.png", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "PNG, the drawing's size; with an ETag", body = Vec<u8>, content_type = "image/png"),
        (status = 304, description = "Unchanged since the ETag in If-None-Match"),
        (status = 404, description = "Unknown id", body = ErrorBody),
        (status = 409, description = "Nothing mapped to lay on the drawing yet", body = ErrorBody),
        (status = 422, description = "The session maps without a drawing", body = ErrorBody)))]
pub(crate) async fn session_sketch_overlay(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let png = call(&state, move |b| b.sketch_overlay_on_map_png(&id)).await?;
    Ok(TaggedPng::new(png).respond(&headers))
}

/// The drawing's lines in map meters through the warp's inverse: the rooms not yet
/// visited, where the drawing says they are.
#[utoipa::path(get, path = "/v1/sessions/{id}/sketch-in-map", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "The drawing's lines as map polylines", body = SketchInMapResponse),
        (status = 404, description = "Unknown id", body = ErrorBody),
        (status = 409, description = "Nothing mapped to lay on the drawing yet", body = ErrorBody),
        (status = 422, description = "The session maps without a drawing", body = ErrorBody)))]
pub(crate) async fn session_sketch_in_map(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Json<SketchInMapResponse>, ApiError> {
    call(&state, move |b| b.sketch_in_map(&id)).await.map(Json)
}

/// The map with the drawing's lines (blue) drawn over it through the warp's inverse.
#[utoipa::path(get, path = "/v1/sessions/{id}/sketch-in-map.png", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    responses(
        (status = 200, description = "PNG, north up", body = Vec<u8>, content_type = "image/png"),
        (status = 404, description = "Unknown id", body = ErrorBody),
        (status = 409, description = "Nothing mapped to lay on the drawing yet", body = ErrorBody),
        (status = 422, description = "The session maps without a drawing", body = ErrorBody)))]
pub(crate) async fn session_sketch_in_map_png(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
) -> Result<Response, ApiError> {
    let png = call(&state, move |b| b.sketch_in_map_png(&id)).await?;
    Ok(with_content_type("image/png", png))
}

/// Drawing pixels to map poses and map poses to drawing pixels, in one batch: how a robot
/// is sent to the room a user points at on their drawing.
#[utoipa::path(post, path = "/v1/sessions/{id}/transform", tag = "maps",
    params(("id" = String, Path, description = "Session id")),
    request_body = TransformRequest,
    responses(
        (status = 200, description = "The points, in the request's order", body = TransformResponse),
        (status = 400, description = "Malformed JSON", body = ErrorBody),
        (status = 404, description = "Unknown id", body = ErrorBody),
        (status = 409, description = "Nothing mapped to lay on the drawing yet", body = ErrorBody),
        (status = 413, description = "More than 10 000 points", body = ErrorBody),
        (status = 422, description = "An empty batch, a bad number (named), or no drawing", body = ErrorBody)))]
pub(crate) async fn session_transform(
    State(state): State<AppState>,
    ApiPath(id): ApiPath,
    ApiJson(request): ApiJson<TransformRequest>,
) -> Result<Json<TransformResponse>, ApiError> {
    request.validate()?;
    call(&state, move |b| b.transform(&id, request))
        .await
        .map(Json)
}
