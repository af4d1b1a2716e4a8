//! Errors of the HTTP API and their JSON shape.
//!
//! Every error leaves the service as `{"error": {"code": "...", "message": "..."}}` with a
//! 4xx or 5xx status. `code` is a stable, machine-readable word (`sketch_not_found`,
//! `robot_busy`, ...); `message` says in words what was wrong, naming the field or id.
//! Internal errors are logged with their detail and answered with a generic message.

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use thiserror::Error;
use utoipa::ToSchema;

/// The body of every error response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ErrorBody {
    /// What went wrong.
    pub error: ErrorDetail,
}

/// The code and message of an error response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ErrorDetail {
    /// A stable machine-readable code, e.g. `sketch_not_found`.
    #[schema(example = "sketch_not_found")]
    pub code: String,
    /// A human-readable explanation naming the field or id at fault.
    pub message: String,
}

/// Everything a request can fail with; each variant maps to one HTTP status.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum ApiError {
    /// 400: the request cannot be parsed (malformed JSON, empty body, bad query).
    #[error("{message}")]
    BadRequest {
        /// Machine-readable code.
        code: &'static str,
        /// Explanation.
        message: String,
    },
    /// 401: the bearer token is missing or wrong.
    #[error("missing or invalid bearer token")]
    Unauthorized,
    /// 404: no such sketch, session or route.
    #[error("{message}")]
    NotFound {
        /// Machine-readable code.
        code: &'static str,
        /// Explanation naming the id.
        message: String,
    },
    /// 405: the route exists but not with this method.
    #[error("method not allowed on this path")]
    MethodNotAllowed,
    /// 409: the request conflicts with the current state (robot already mapping, ...).
    #[error("{message}")]
    Conflict {
        /// Machine-readable code.
        code: &'static str,
        /// Explanation.
        message: String,
    },
    /// 413: the body (or the image in it) is too large.
    #[error("{message}")]
    TooLarge {
        /// Machine-readable code.
        code: &'static str,
        /// Explanation with the limit.
        message: String,
    },
    /// 422: the request parses but a value is not acceptable (named in the message).
    #[error("{message}")]
    Invalid {
        /// Machine-readable code.
        code: &'static str,
        /// Explanation naming the field.
        message: String,
    },
    /// 503: the service is shutting down or cannot take more work.
    #[error("{0}")]
    Unavailable(String),
    /// 500: a fault of the service; the detail is logged, never sent.
    #[error("internal error: {0}")]
    Internal(String),
}

impl ApiError {
    /// 400 with a code and message.
    pub fn bad_request(code: &'static str, message: impl Into<String>) -> Self {
        Self::BadRequest {
            code,
            message: message.into(),
        }
    }

    /// 422 with a code and message.
    pub fn invalid(code: &'static str, message: impl Into<String>) -> Self {
        Self::Invalid {
            code,
            message: message.into(),
        }
    }

    /// 409 with a code and message.
    pub fn conflict(code: &'static str, message: impl Into<String>) -> Self {
        Self::Conflict {
            code,
            message: message.into(),
        }
    }

    /// 413 with a code and message.
    pub fn too_large(code: &'static str, message: impl Into<String>) -> Self {
        Self::TooLarge {
            code,
            message: message.into(),
        }
    }

    /// 404 for an unknown sketch id.
    pub fn sketch_not_found(id: &str) -> Self {
        Self::NotFound {
            code: "sketch_not_found",
            message: format!("no sketch with id {id:?}"),
        }
    }

    /// 404 for an unknown session id.
    pub fn session_not_found(id: &str) -> Self {
        Self::NotFound {
            code: "session_not_found",
            message: format!("no session with id {id:?}"),
        }
    }

    /// 422 for a number that is NaN, infinite, or out of its range.
    pub fn invalid_number(field: &str, reason: &str) -> Self {
        Self::invalid("invalid_number", format!("{field}: {reason}"))
    }

    /// 500 carrying a detail that is logged but not sent.
    pub fn internal(detail: impl std::fmt::Display) -> Self {
        Self::Internal(detail.to_string())
    }

    /// The HTTP status of this error.
    pub fn status(&self) -> StatusCode {
        match self {
            Self::BadRequest { .. } => StatusCode::BAD_REQUEST,
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::NotFound { .. } => StatusCode::NOT_FOUND,
            Self::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
            Self::Conflict { .. } => StatusCode::CONFLICT,
            Self::TooLarge { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            Self::Invalid { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            Self::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            Self::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The machine-readable code of this error.
    pub fn code(&self) -> &'static str {
        match self {
            Self::BadRequest { code, .. }
            | Self::NotFound { code, .. }
            | Self::Conflict { code, .. }
            | Self::TooLarge { code, .. }
            | Self::Invalid { code, .. } => code,
            Self::Unauthorized => "unauthorized",
            Self::MethodNotAllowed => "method_not_allowed",
            Self::Unavailable(_) => "unavailable",
            Self::Internal(_) => "internal",
        }
    }

    /// The JSON body sent for this error (internal details withheld).
    pub fn body(&self) -> ErrorBody {
        let message = match self {
            Self::Internal(_) => "internal error; see the service log".to_string(),
            other => other.to_string(),
        };
        ErrorBody {
            error: ErrorDetail {
                code: self.code().to_string(),
                message,
            },
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if let Self::Internal(detail) = &self {
            tracing::error!(%detail, "internal error answering a request");
        }
        let status = self.status();
        let mut response = (status, axum::Json(self.body())).into_response();
        if status == StatusCode::UNAUTHORIZED {
            response.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                HeaderValue::from_static("Bearer realm=\"sketchslam\""),
            );
        }
        response
    }
}
