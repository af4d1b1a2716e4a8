//! A typed async client of the HTTP API, for tests and fleet integration.
//!
//! Every method maps one endpoint; a 4xx/5xx answer becomes [`ClientError::Api`] with the
//! server's code and message.

use std::pin::Pin;

use axum::body::Bytes;
use futures::{Stream, StreamExt};
use reqwest::{Method, RequestBuilder, Response, StatusCode};
use serde::de::DeserializeOwned;
use thiserror::Error;

use crate::error::ErrorBody;
use crate::occupancy::OccupancyGridResponse;
use crate::registration::{
    RegistrationInfo, SketchInMapResponse, TransformRequest, TransformResponse,
};
use crate::types::{
    CreateSessionRequest, HealthResponse, PoseResponse, SessionEvent, SessionInfo, SessionList,
    SketchInfo, SketchList, SketchTrajectoryResponse, TrajectoryResponse,
};

/// What a client call can fail with.
#[derive(Debug, Error)]
pub enum ClientError {
    /// The server answered with an error status.
    #[error("HTTP {status}: {code}: {message}")]
    Api {
        /// The HTTP status.
        status: StatusCode,
        /// The error code from the body (`unknown` if the body was not our shape).
        code: String,
        /// The message from the body.
        message: String,
    },
    /// The request could not be sent or the answer not read.
    #[error("transport: {0}")]
    Transport(#[from] reqwest::Error),
    /// The answer did not parse as the expected type.
    #[error("unexpected response body: {0}")]
    Decode(String),
}

impl ClientError {
    /// The HTTP status, for [`ClientError::Api`].
    pub fn status(&self) -> Option<StatusCode> {
        match self {
            Self::Api { status, .. } => Some(*status),
            _ => None,
        }
    }

    /// The error code, for [`ClientError::Api`].
    pub fn code(&self) -> Option<&str> {
        match self {
            Self::Api { code, .. } => Some(code),
            _ => None,
        }
    }
}

/// A client of one sketchslam service.
#[derive(Debug, Clone)]
pub struct SketchslamClient {
    http: reqwest::Client,
    base: String,
    token: Option<String>,
}

impl SketchslamClient {
    /// A client of the service at `base_url`, e.g. `http://127.0.0.1:8080`.
    pub fn new(base_url: impl Into<String>) -> Self {
        let base = base_url.into().trim_end_matches('/').to_string();
        Self {
            http: reqwest::Client::new(),
            base,
            token: None,
        }
    }

    /// The same client sending `Authorization: Bearer <token>`.
    pub fn with_token(mut self, token: impl Into<String>) -> Self {
        self.token = Some(token.into());
        self
    }

    /// The base URL.
    pub fn base_url(&self) -> &str {
        &self.base
    }

    fn request(&self, method: Method, path: &str) -> RequestBuilder {
        let builder = self.http.request(method, format!("{}{}", self.base, path));
        match &self.token {
            Some(token) => builder.bearer_auth(token),
            None => builder,
        }
    }

    async fn send(builder: RequestBuilder) -> Result<Response, ClientError> {
        let response = builder.send().await?;
        let status = response.status();
        if status.is_client_error() || status.is_server_error() {
            let text = response.text().await.unwrap_or_default();
            let (code, message) = match serde_json::from_str::<ErrorBody>(&text) {
                Ok(body) => (body.error.code, body.error.message),
                Err(_) => ("unknown".to_string(), text),
            };
            return Err(ClientError::Api {
                status,
                code,
                message,
            });
        }
        Ok(response)
    }

    async fn json<T: DeserializeOwned>(builder: RequestBuilder) -> Result<T, ClientError> {
        let bytes = Self::send(builder).await?.bytes().await?;
        serde_json::from_slice(&bytes).map_err(|e| ClientError::Decode(e.to_string()))
    }

    async fn bytes(builder: RequestBuilder) -> Result<Vec<u8>, ClientError> {
        Ok(Self::send(builder).await?.bytes().await?.to_vec())
    }

    async fn text(builder: RequestBuilder) -> Result<String, ClientError> {
        Ok(Self::send(builder).await?.text().await?)
    }

    /// `GET /healthz`.
    pub async fn health(&self) -> Result<HealthResponse, ClientError> {
        Self::json(self.request(Method::GET, "/healthz")).await
    }

    /// `GET /metrics` (Prometheus text).
    pub async fn metrics(&self) -> Result<String, ClientError> {
        Self::text(self.request(Method::GET, "/metrics")).await
    }

    /// `GET /openapi.json`.
    pub async fn openapi(&self) -> Result<serde_json::Value, ClientError> {
        Self::json(self.request(Method::GET, "/openapi.json")).await
    }

    /// `POST /v1/sketches`: uploads a PNG or JPEG.
    pub async fn upload_sketch(
        &self,
        image: impl Into<Vec<u8>>,
        name: Option<&str>,
    ) -> Result<SketchInfo, ClientError> {
        self.upload_sketch_with_scale(image, name, None).await
    }

    /// `POST /v1/sketches` with the drawing's scale declared (`?meters_per_pixel=`).
    pub async fn upload_sketch_with_scale(
        &self,
        image: impl Into<Vec<u8>>,
        name: Option<&str>,
        meters_per_pixel: Option<f64>,
    ) -> Result<SketchInfo, ClientError> {
        let image: Vec<u8> = image.into();
        let content_type = if image.starts_with(&[0xFF, 0xD8]) {
            "image/jpeg"
        } else {
            "image/png"
        };
        let mut builder = self
            .request(Method::POST, "/v1/sketches")
            .header(reqwest::header::CONTENT_TYPE, content_type)
            .body(image);
        if let Some(name) = name {
            builder = builder.query(&[("name", name)]);
        }
        if let Some(mpp) = meters_per_pixel {
            builder = builder.query(&[("meters_per_pixel", mpp)]);
        }
        Self::json(builder).await
    }

    /// `GET /v1/sketches`.
    pub async fn list_sketches(&self) -> Result<SketchList, ClientError> {
        Self::json(self.request(Method::GET, "/v1/sketches")).await
    }

    /// `GET /v1/sketches/{id}`.
    pub async fn get_sketch(&self, id: &str) -> Result<SketchInfo, ClientError> {
        Self::json(self.request(Method::GET, &format!("/v1/sketches/{}", seg(id)))).await
    }

    /// `GET /v1/sketches/{id}/lines.png`.
    pub async fn sketch_overlay_png(&self, id: &str) -> Result<Vec<u8>, ClientError> {
        Self::bytes(self.request(Method::GET, &format!("/v1/sketches/{}/lines.png", seg(id)))).await
    }

    /// `DELETE /v1/sketches/{id}`.
    pub async fn delete_sketch(&self, id: &str) -> Result<(), ClientError> {
        Self::send(self.request(Method::DELETE, &format!("/v1/sketches/{}", seg(id)))).await?;
        Ok(())
    }

    /// `POST /v1/sessions`.
    pub async fn create_session(
        &self,
        request: &CreateSessionRequest,
    ) -> Result<SessionInfo, ClientError> {
        Self::json(self.request(Method::POST, "/v1/sessions").json(request)).await
    }

    /// `GET /v1/sessions`.
    pub async fn list_sessions(&self) -> Result<SessionList, ClientError> {
        Self::json(self.request(Method::GET, "/v1/sessions")).await
    }

    /// `GET /v1/sessions/{id}`.
    pub async fn get_session(&self, id: &str) -> Result<SessionInfo, ClientError> {
        Self::json(self.request(Method::GET, &format!("/v1/sessions/{}", seg(id)))).await
    }

    /// `DELETE /v1/sessions/{id}`: stops the session.
    pub async fn stop_session(&self, id: &str) -> Result<SessionInfo, ClientError> {
        Self::json(self.request(Method::DELETE, &format!("/v1/sessions/{}", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/pose`.
    pub async fn pose(&self, id: &str) -> Result<PoseResponse, ClientError> {
        Self::json(self.request(Method::GET, &format!("/v1/sessions/{}/pose", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/trajectory`.
    pub async fn trajectory(&self, id: &str) -> Result<TrajectoryResponse, ClientError> {
        Self::json(self.request(Method::GET, &format!("/v1/sessions/{}/trajectory", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/trajectory?format=csv` (`trajectory.csv`).
    pub async fn trajectory_csv(&self, id: &str) -> Result<String, ClientError> {
        Self::text(
            self.request(Method::GET, &format!("/v1/sessions/{}/trajectory", seg(id)))
                .query(&[("format", "csv")]),
        )
        .await
    }

    /// `GET /v1/sessions/{id}/trajectory?frame=sketch` (a `sketch` session's trajectory on
    /// the drawing).
    pub async fn sketch_trajectory(
        &self,
        id: &str,
    ) -> Result<SketchTrajectoryResponse, ClientError> {
        Self::json(
            self.request(Method::GET, &format!("/v1/sessions/{}/trajectory", seg(id)))
                .query(&[("frame", "sketch")]),
        )
        .await
    }

    /// `GET /v1/sessions/{id}/map` (ROS OccupancyGrid JSON).
    pub async fn map(&self, id: &str) -> Result<OccupancyGridResponse, ClientError> {
        Self::json(self.request(Method::GET, &format!("/v1/sessions/{}/map", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/map.png`.
    pub async fn map_png(&self, id: &str) -> Result<Vec<u8>, ClientError> {
        Self::bytes(self.request(Method::GET, &format!("/v1/sessions/{}/map.png", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/map.pgm`.
    pub async fn map_pgm(&self, id: &str) -> Result<Vec<u8>, ClientError> {
        Self::bytes(self.request(Method::GET, &format!("/v1/sessions/{}/map.pgm", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/map.yaml`.
    pub async fn map_yaml(&self, id: &str) -> Result<String, ClientError> {
        Self::text(self.request(Method::GET, &format!("/v1/sessions/{}/map.yaml", seg(id)))).await
    }

    /// `GET /v1/sessions/{id}/registration`.
    pub async fn registration(&self, id: &str) -> Result<RegistrationInfo, ClientError> {
        let path = format!("/v1/sessions/{}/registration", seg(id));
        Self::json(self.request(Method::GET, &path)).await
    }

    /// `GET /v1/sessions/{id}/sketch-overlay.png`.
    pub async fn sketch_overlay_on_map_png(&self, id: &str) -> Result<Vec<u8>, ClientError> {
        let path = format!("/v1/sessions/{}/sketch-overlay.png", seg(id));
        Self::bytes(self.request(Method::GET, &path)).await
    }

    /// `GET /v1/sessions/{id}/sketch-in-map`.
    pub async fn sketch_in_map(&self, id: &str) -> Result<SketchInMapResponse, ClientError> {
        let path = format!("/v1/sessions/{}/sketch-in-map", seg(id));
        Self::json(self.request(Method::GET, &path)).await
    }

    /// `GET /v1/sessions/{id}/sketch-in-map.png`.
    pub async fn sketch_in_map_png(&self, id: &str) -> Result<Vec<u8>, ClientError> {
        let path = format!("/v1/sessions/{}/sketch-in-map.png", seg(id));
        Self::bytes(self.request(Method::GET, &path)).await
    }

    /// `POST /v1/sessions/{id}/transform`.
    pub async fn transform(
        &self,
        id: &str,
        request: &TransformRequest,
    ) -> Result<TransformResponse, ClientError> {
        let path = format!("/v1/sessions/{}/transform", seg(id));
        Self::json(self.request(Method::POST, &path).json(request)).await
    }

    /// `GET /v1/sessions/{id}/events`: the live feed of poses and status changes.
    pub async fn events(&self, id: &str) -> Result<EventStream, ClientError> {
        self.events_after(id, None).await
    }

    /// The live feed resumed after `last_event_id` (what [`EventStream::last_event_id`]
    /// said before the connection was lost): the events missed meanwhile first, when the
    /// session still keeps them, else a fresh `status` (`Last-Event-ID`).
    pub async fn events_after(
        &self,
        id: &str,
        last_event_id: Option<u64>,
    ) -> Result<EventStream, ClientError> {
        let mut request = self
            .request(Method::GET, &format!("/v1/sessions/{}/events", seg(id)))
            .header(reqwest::header::ACCEPT, "text/event-stream");
        if let Some(last) = last_event_id {
            request = request.header("last-event-id", last.to_string());
        }
        let response = Self::send(request).await?;
        Ok(EventStream {
            body: Box::pin(response.bytes_stream()),
            buffer: String::new(),
            last_event_id,
        })
    }
}

/// Percent-encodes an id for use as one path segment.
fn seg(id: &str) -> String {
    let mut out = String::with_capacity(id.len());
    for b in id.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

type ByteStream = Pin<Box<dyn Stream<Item = reqwest::Result<Bytes>> + Send>>;

/// Server-sent events of one session, parsed into [`SessionEvent`]s.
pub struct EventStream {
    body: ByteStream,
    buffer: String,
    last_event_id: Option<u64>,
}

impl std::fmt::Debug for EventStream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EventStream").finish_non_exhaustive()
    }
}

impl EventStream {
    /// The id of the last event read (to resume from with
    /// [`SketchslamClient::events_after`]).
    pub fn last_event_id(&self) -> Option<u64> {
        self.last_event_id
    }

    /// The next event; `None` once the server closed the stream (the session stopped).
    pub async fn next_event(&mut self) -> Result<Option<SessionEvent>, ClientError> {
        loop {
            while let Some(end) = self.buffer.find("\n\n") {
                let block: String = self.buffer.drain(..end + 2).collect();
                if let Some(id) = block
                    .lines()
                    .find_map(|l| l.strip_prefix("id:"))
                    .and_then(|v| v.trim().parse().ok())
                {
                    self.last_event_id = Some(id);
                }
                if let Some(event) = parse_sse_block(&block)? {
                    return Ok(Some(event));
                }
            }
            match self.body.next().await {
                Some(chunk) => {
                    let chunk = chunk?;
                    self.buffer
                        .push_str(&String::from_utf8_lossy(&chunk).replace("\r\n", "\n"));
                }
                None => return Ok(None),
            }
        }
    }
}

/// Parses one SSE block (`event:` and `data:` lines); comments and keep-alives give `None`.
fn parse_sse_block(block: &str) -> Result<Option<SessionEvent>, ClientError> {
    let mut name = None;
    let mut data = String::new();
    for line in block.lines() {
        if let Some(v) = line.strip_prefix("event:") {
            name = Some(v.trim().to_string());
        } else if let Some(v) = line.strip_prefix("data:") {
            if !data.is_empty() {
                data.push('\n');
            }
            data.push_str(v.strip_prefix(' ').unwrap_or(v));
        }
    }
    let decode = |e: serde_json::Error| ClientError::Decode(format!("SSE data: {e}"));
    match name.as_deref() {
        Some("pose") => Ok(Some(SessionEvent::Pose(
            serde_json::from_str(&data).map_err(decode)?,
        ))),
        Some("status") => Ok(Some(SessionEvent::Status(
            serde_json::from_str(&data).map_err(decode)?,
        ))),
        _ => Ok(None),
    }
}
