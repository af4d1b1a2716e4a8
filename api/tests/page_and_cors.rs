//! The web page's files, the CORS option and the map's entity tag (issue 16), against the
//! in-memory fake backend, driven with `tower::ServiceExt::oneshot` (no socket). The page
//! itself is driven in a real browser by `tests/tests/web_page.rs`.

use std::sync::Arc;

use axum::Router;
use axum::body::{Body, Bytes};
use axum::http::{HeaderMap, HeaderValue, Method, Request, StatusCode, header};
use http_body_util::BodyExt;
use serde_json::json;
use sketchslam_api::*;
use tower::ServiceExt;

mod common;
use common::{Fake, fake_png};

const TOKEN: &str = "s3cret";
const DASHBOARD: &str = "https://dash.example.com";

fn app(cors_origins: &[&str]) -> Router {
    router(
        Arc::new(Fake::default()),
        RouterOptions {
            token: Some(TOKEN.to_string()),
            cors_origins: cors_origins
                .iter()
                .map(|o| HeaderValue::from_str(o).unwrap())
                .collect(),
            ..RouterOptions::default()
        },
    )
}

async fn send(app: &Router, req: Request<Body>) -> (StatusCode, HeaderMap, Bytes) {
    let response = app.clone().oneshot(req).await.unwrap();
    let (parts, body) = response.into_parts();
    (
        parts.status,
        parts.headers,
        body.collect().await.unwrap().to_bytes(),
    )
}

fn authed(method: Method, uri: &str) -> axum::http::request::Builder {
    Request::builder()
        .method(method)
        .uri(uri)
        .header(header::AUTHORIZATION, format!("Bearer {TOKEN}"))
}

#[tokio::test]
async fn the_page_and_every_module_it_imports_load_without_a_token() {
    let app = app(&[]);
    let (status, headers, body) = send(&app, Request::get("/").body(Body::empty()).unwrap()).await;
    assert_eq!(status, StatusCode::OK);
    assert!(
        headers[header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .starts_with("text/html")
    );
    assert!(
        headers[header::CONTENT_SECURITY_POLICY]
            .to_str()
            .unwrap()
            .contains("default-src 'self'")
    );
    let html = String::from_utf8(body.to_vec()).unwrap();
    assert!(html.contains(r#"<script type="module" src="/js/app.js">"#));
    // Follow the imports from app.js: every module the page needs is served.
    let mut queue = vec!["app.js".to_string()];
    let mut seen = Vec::new();
    while let Some(file) = queue.pop() {
        if seen.contains(&file) {
            continue;
        }
        let (status, headers, body) = send(
            &app,
            Request::get(format!("/js/{file}"))
                .body(Body::empty())
                .unwrap(),
        )
        .await;
        assert_eq!(status, StatusCode::OK, "/js/{file}");
        assert!(
            headers[header::CONTENT_TYPE]
                .to_str()
                .unwrap()
                .starts_with("text/javascript")
        );
        let js = String::from_utf8(body.to_vec()).unwrap();
        for line in js.lines().filter(|l| l.starts_with("import ")) {
            let name = line
                .split("from './")
                .nth(1)
                .and_then(|r| r.split('\'').next());
            queue.push(name.expect("a relative import").to_string());
        }
        seen.push(file);
    }
    assert!(seen.len() >= 5, "{seen:?}");
    let (status, _, _) = send(&app, Request::get("/app.css").body(Body::empty()).unwrap()).await;
    assert_eq!(status, StatusCode::OK);
    let (status, _, body) = send(
        &app,
        Request::get("/js/secret.js").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(String::from_utf8_lossy(&body).contains("not_found"));
    // The API behind it still needs the token.
    let (status, _, _) = send(
        &app,
        Request::get("/v1/sketches").body(Body::empty()).unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
}

/// `GET uri` with the token, from the dashboard's page.
fn authed_from_dashboard(uri: &str) -> Request<Body> {
    authed(Method::GET, uri)
        .header(header::ORIGIN, DASHBOARD)
        .body(Body::empty())
        .unwrap()
}

fn preflight(origin: &str) -> Request<Body> {
    Request::builder()
        .method(Method::OPTIONS)
        .uri("/v1/sessions")
        .header(header::ORIGIN, origin)
        .header(header::ACCESS_CONTROL_REQUEST_METHOD, "POST")
        .header(
            header::ACCESS_CONTROL_REQUEST_HEADERS,
            "authorization,content-type",
        )
        .body(Body::empty())
        .unwrap()
}

#[tokio::test]
async fn cors_is_off_by_default() {
    let app = app(&[]);
    let (_, headers, _) = send(&app, preflight(DASHBOARD)).await;
    assert!(headers.get(header::ACCESS_CONTROL_ALLOW_ORIGIN).is_none());
    let (status, headers, _) = send(&app, authed_from_dashboard("/v1/sketches")).await;
    assert_eq!(status, StatusCode::OK);
    assert!(headers.get(header::ACCESS_CONTROL_ALLOW_ORIGIN).is_none());
}

#[tokio::test]
async fn a_listed_origin_passes_preflight_without_the_token_and_reads_the_map_headers() {
    let app = app(&[DASHBOARD]);
    // A browser's preflight carries no token; it must not be refused for that.
    let (status, headers, _) = send(&app, preflight(DASHBOARD)).await;
    assert!(status.is_success(), "{status}");
    assert_eq!(headers[header::ACCESS_CONTROL_ALLOW_ORIGIN], DASHBOARD);
    let allowed = headers[header::ACCESS_CONTROL_ALLOW_HEADERS]
        .to_str()
        .unwrap()
        .to_lowercase();
    assert!(
        allowed.contains("authorization") && allowed.contains("content-type"),
        "{allowed}"
    );
    // Another origin gets no grant.
    let (_, headers, _) = send(&app, preflight("https://evil.example.com")).await;
    assert!(headers.get(header::ACCESS_CONTROL_ALLOW_ORIGIN).is_none());
    // The real request: granted, and the map's tag and frame are readable by the page.
    let (status, headers, _) = send(&app, authed_from_dashboard("/v1/sketches")).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(headers[header::ACCESS_CONTROL_ALLOW_ORIGIN], DASHBOARD);
    let exposed = headers[header::ACCESS_CONTROL_EXPOSE_HEADERS]
        .to_str()
        .unwrap()
        .to_lowercase();
    for h in [
        "etag",
        "x-map-resolution-m",
        "x-map-origin-x-m",
        "x-map-origin-y-m",
    ] {
        assert!(exposed.contains(h), "{exposed} lacks {h}");
    }
    // Still no way in without the token.
    let (status, _, _) = send(
        &app,
        Request::get("/v1/sketches")
            .header(header::ORIGIN, DASHBOARD)
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn an_unchanged_map_is_answered_304_with_its_tag_and_frame() {
    let app = app(&[]);
    let (status, _, body) = send(
        &app,
        authed(Method::POST, "/v1/sketches?name=A")
            .header(header::CONTENT_TYPE, "image/png")
            .body(Body::from(fake_png(400, 400, 3)))
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::CREATED);
    let sketch: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let request = json!({"robot_id": "r1", "method": "sketch", "sketch_id": sketch["id"],
        "start": {"u": 66.9, "v": 320.3, "heading_deg": 1.1}, "meters_per_pixel": 0.1});
    let (status, _, body) = send(
        &app,
        authed(Method::POST, "/v1/sessions")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(request.to_string()))
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::CREATED);
    let session: serde_json::Value = serde_json::from_slice(&body).unwrap();
    let uri = format!("/v1/sessions/{}/map.png", session["id"].as_str().unwrap());

    let (status, headers, png) =
        send(&app, authed(Method::GET, &uri).body(Body::empty()).unwrap()).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(headers[header::CONTENT_TYPE], "image/png");
    assert!(!png.is_empty());
    // The fake's frame, in Rust's round-trip form.
    assert_eq!(headers["x-map-resolution-m"], "0.05");
    assert_eq!(headers["x-map-origin-x-m"], "-1.5");
    assert_eq!(headers["x-map-origin-y-m"], "2.25");
    let etag = headers[header::ETAG].clone();
    assert!(etag.to_str().unwrap().starts_with('"'));

    let (status, headers, body) = send(
        &app,
        authed(Method::GET, &uri)
            .header(header::IF_NONE_MATCH, etag.clone())
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::NOT_MODIFIED);
    assert!(body.is_empty());
    assert_eq!(headers[header::ETAG], etag);
    // A stale tag gets the picture.
    let (status, _, body) = send(
        &app,
        authed(Method::GET, &uri)
            .header(header::IF_NONE_MATCH, "\"0000000000000000\"")
            .body(Body::empty())
            .unwrap(),
    )
    .await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(body, png);
}
