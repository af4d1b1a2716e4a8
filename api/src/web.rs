//! The web page, served by the service itself: `/` (the page), `/app.css` and the page's
//! ES modules under `/js/` (hand-written, no dependency), all compiled into the binary with
//! `include_str!`, so the page needs no CDN, no network and no build step.
//!
//! The page is a client of the public API like any other: it holds no secret and needs no
//! token to load ([`is_public`]); its API calls carry the bearer token the user types in.
//! A `Content-Security-Policy` keeps it to its own origin.

use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};

use crate::error::ApiError;
use crate::extract::ApiPath;

const INDEX_HTML: &str = include_str!("../web/index.html");
const APP_CSS: &str = include_str!("../web/app.css");

/// The page's modules, by file name under `/js/`.
const MODULES: [(&str, &str); 5] = [
    ("app.js", include_str!("../web/js/app.js")),
    ("api.js", include_str!("../web/js/api.js")),
    ("events.js", include_str!("../web/js/events.js")),
    ("live_view.js", include_str!("../web/js/live_view.js")),
    ("picture_view.js", include_str!("../web/js/picture_view.js")),
];

/// Scripts and styles only from this origin; pictures also from the blob URLs the page
/// makes of the PNGs it fetches with the token.
const CSP: &str = "default-src 'self'; img-src 'self' blob: data:; script-src 'self'; \
                   style-src 'self'; connect-src 'self'; object-src 'none'; \
                   base-uri 'none'; frame-ancestors 'none'";

/// Whether `path` is served without a token: the liveness probe and the page's files.
pub fn is_public(path: &str) -> bool {
    matches!(path, "/healthz" | "/" | "/app.css") || path.starts_with("/js/")
}

fn asset(content_type: &'static str, body: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(content_type)),
            (header::CACHE_CONTROL, HeaderValue::from_static("no-cache")),
            (
                header::CONTENT_SECURITY_POLICY,
                HeaderValue::from_static(CSP),
            ),
            (
                header::X_CONTENT_TYPE_OPTIONS,
                HeaderValue::from_static("nosniff"),
            ),
        ],
        body,
    )
        .into_response()
}

/// `GET /`: the page.
pub(crate) async fn index() -> Response {
    asset("text/html; charset=utf-8", INDEX_HTML)
}

/// `GET /js/{file}`: one of the page's modules.
pub(crate) async fn module(ApiPath(file): ApiPath) -> Result<Response, ApiError> {
    MODULES
        .iter()
        .find(|(name, _)| *name == file)
        .map(|(_, body)| asset("text/javascript; charset=utf-8", body))
        .ok_or_else(|| ApiError::NotFound {
            code: "not_found",
            message: "the page has no such module".to_string(),
        })
}

/// `GET /app.css`: the page's style sheet.
pub(crate) async fn app_css() -> Response {
    asset("text/css; charset=utf-8", APP_CSS)
}
