//! Router tests: every endpoint and every bad input, against an in-memory fake backend,
//! driven with `tower::ServiceExt::oneshot` (no socket).

use std::sync::Arc;

use axum::Router;
use axum::body::{Body, Bytes};
use axum::http::{Method, Request, StatusCode, header};
use http_body_util::BodyExt;
use serde_json::{Value, json};
use sketchslam_api::*;
use tower::ServiceExt;

mod common;
use common::{Fake, PNG_MAGIC, fake_png, slow_fake_png};

struct Harness {
    fake: Arc<Fake>,
    app: Router,
}

fn harness(options: RouterOptions) -> Harness {
    let fake = Arc::new(Fake::default());
    let app = router(fake.clone(), options);
    Harness { fake, app }
}

fn default_harness() -> Harness {
    harness(RouterOptions {
        token: None,
        max_body_bytes: 4096,
        ..RouterOptions::default()
    })
}

struct Answer {
    status: StatusCode,
    content_type: String,
    body: Bytes,
}

impl Answer {
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }

    fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }

    /// Asserts our error shape with `status` and `code`; returns the message.
    fn error(&self, status: StatusCode, code: &str) -> String {
        assert_eq!(self.status, status, "body: {}", self.text());
        assert!(
            self.content_type.starts_with("application/json"),
            "{}",
            self.content_type
        );
        let v = self.json();
        assert_eq!(v["error"]["code"], code, "body: {v}");
        let message = v["error"]["message"].as_str().expect("message").to_string();
        assert!(!message.is_empty());
        message
    }
}

async fn send(app: &Router, req: Request<Body>) -> Answer {
    let response = app.clone().oneshot(req).await.unwrap();
    let status = response.status();
    let content_type = response
        .headers()
        .get(header::CONTENT_TYPE)
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    let body = response.into_body().collect().await.unwrap().to_bytes();
    Answer {
        status,
        content_type,
        body,
    }
}

async fn get(app: &Router, uri: &str) -> Answer {
    send(app, Request::get(uri).body(Body::empty()).unwrap()).await
}

async fn delete(app: &Router, uri: &str) -> Answer {
    send(app, Request::delete(uri).body(Body::empty()).unwrap()).await
}

async fn post(app: &Router, uri: &str, content_type: &str, body: impl Into<Body>) -> Answer {
    send(
        app,
        Request::post(uri)
            .header(header::CONTENT_TYPE, content_type)
            .body(body.into())
            .unwrap(),
    )
    .await
}

async fn post_json(app: &Router, uri: &str, body: &Value) -> Answer {
    post(app, uri, "application/json", body.to_string()).await
}

async fn upload(h: &Harness) -> String {
    let a = post(
        &h.app,
        "/v1/sketches?name=A",
        "image/png",
        fake_png(400, 400, 3),
    )
    .await;
    assert_eq!(a.status, StatusCode::CREATED, "{}", a.text());
    a.json()["id"].as_str().unwrap().to_string()
}

fn sketch_session(sketch_id: &str) -> Value {
    json!({"robot_id": "r1", "method": "sketch", "sketch_id": sketch_id,
           "start": {"u": 66.9, "v": 320.3, "heading_deg": 1.1}, "meters_per_pixel": 0.1})
}

async fn start_session(h: &Harness) -> String {
    let sketch = upload(h).await;
    let a = post_json(&h.app, "/v1/sessions", &sketch_session(&sketch)).await;
    assert_eq!(a.status, StatusCode::CREATED, "{}", a.text());
    a.json()["id"].as_str().unwrap().to_string()
}

#[tokio::test]
async fn healthz_answers_ok() {
    let h = default_harness();
    let a = get(&h.app, "/healthz").await;
    assert_eq!(a.status, StatusCode::OK);
    assert_eq!(a.json()["status"], "ok");
}

#[tokio::test]
async fn sketch_lifecycle() {
    let h = default_harness();
    let a = post(
        &h.app,
        "/v1/sketches?name=A",
        "image/png",
        fake_png(400, 300, 3),
    )
    .await;
    assert_eq!(a.status, StatusCode::CREATED);
    let created = a.json();
    let id = created["id"].as_str().unwrap().to_string();
    assert_eq!(created["name"], "A");
    assert_eq!(created["width_px"], 400);
    assert_eq!(created["height_px"], 300);
    assert_eq!(created["lines"].as_array().unwrap().len(), 3);

    let list = get(&h.app, "/v1/sketches").await;
    assert_eq!(list.status, StatusCode::OK);
    assert_eq!(list.json()["sketches"][0]["id"], id.as_str());
    assert_eq!(list.json()["sketches"][0]["line_count"], 3);

    let one = get(&h.app, &format!("/v1/sketches/{id}")).await;
    assert_eq!(one.status, StatusCode::OK);
    assert_eq!(one.json(), created);

    let overlay = get(&h.app, &format!("/v1/sketches/{id}/lines.png")).await;
    assert_eq!(overlay.status, StatusCode::OK);
    assert_eq!(overlay.content_type, "image/png");
    assert!(overlay.body.starts_with(PNG_MAGIC));

    let gone = delete(&h.app, &format!("/v1/sketches/{id}")).await;
    assert_eq!(gone.status, StatusCode::NO_CONTENT);
    get(&h.app, &format!("/v1/sketches/{id}"))
        .await
        .error(StatusCode::NOT_FOUND, "sketch_not_found");
    delete(&h.app, &format!("/v1/sketches/{id}"))
        .await
        .error(StatusCode::NOT_FOUND, "sketch_not_found");
}

#[tokio::test]
async fn sketch_upload_rejections_change_nothing() {
    let h = default_harness();
    post(
        &h.app,
        "/v1/sketches",
        "image/png",
        "definitely not an image",
    )
    .await
    .error(StatusCode::UNPROCESSABLE_ENTITY, "invalid_image");
    post(&h.app, "/v1/sketches", "image/png", fake_png(10, 10, 0))
        .await
        .error(StatusCode::UNPROCESSABLE_ENTITY, "no_lines");
    post(&h.app, "/v1/sketches", "image/png", Vec::new())
        .await
        .error(StatusCode::BAD_REQUEST, "empty_body");
    let long_name = format!("/v1/sketches?name={}", "x".repeat(200));
    post(&h.app, &long_name, "image/png", fake_png(10, 10, 1))
        .await
        .error(StatusCode::UNPROCESSABLE_ENTITY, "invalid_name");
    // Not UTF-8 once percent-decoded: refused, not stored as U+FFFD.
    post(
        &h.app,
        "/v1/sketches?name=caf%E9",
        "image/png",
        fake_png(10, 10, 1),
    )
    .await
    .error(StatusCode::BAD_REQUEST, "invalid_query");
    // Percent-encoded UTF-8 is kept as sent.
    let cafe = post(
        &h.app,
        "/v1/sketches?name=caf%C3%A9",
        "image/png",
        fake_png(400, 400, 3),
    )
    .await;
    assert_eq!(cafe.status, StatusCode::CREATED, "{}", cafe.text());
    assert_eq!(cafe.json()["name"], "café");
    assert_eq!(cafe.json()["meters_per_pixel"], Value::Null);
    // A declared scale is checked like a session's and kept.
    for bad in ["0", "-0.1", "1e308", "5e-324", "NaN", "inf"] {
        let m = post(
            &h.app,
            &format!("/v1/sketches?meters_per_pixel={bad}"),
            "image/png",
            fake_png(10, 10, 1),
        )
        .await;
        assert!(m.status.is_client_error(), "{bad}: {}", m.status);
        assert!(m.text().contains("meters_per_pixel"), "{bad}: {}", m.text());
    }
    let scaled = post(
        &h.app,
        "/v1/sketches?meters_per_pixel=0.05",
        "image/png",
        fake_png(400, 400, 3),
    )
    .await;
    assert_eq!(scaled.status, StatusCode::CREATED, "{}", scaled.text());
    assert_eq!(scaled.json()["meters_per_pixel"], 0.05);
    h.fake.sketches.lock().unwrap().clear();
    // Declared too large: refused from the header, before reading.
    let mut big = fake_png(10, 10, 1);
    big.resize(10_000, b' ');
    post(&h.app, "/v1/sketches", "image/png", big.clone())
        .await
        .error(StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large");
    // Streamed without a length: refused by the body limit while reading.
    let chunks: Vec<Result<Bytes, std::io::Error>> = big
        .chunks(1000)
        .map(|c| Ok(Bytes::copy_from_slice(c)))
        .collect();
    let streamed = Body::from_stream(futures::stream::iter(chunks));
    post(&h.app, "/v1/sketches", "image/png", streamed)
        .await
        .error(StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large");
    assert!(h.fake.sketches.lock().unwrap().is_empty());
    assert_eq!(
        get(&h.app, "/v1/sketches").await.json()["sketches"],
        json!([])
    );
}

#[tokio::test]
async fn unknown_sketch_ids_are_404_everywhere() {
    let h = default_harness();
    for uri in ["/v1/sketches/nope", "/v1/sketches/nope/lines.png"] {
        let m = get(&h.app, uri)
            .await
            .error(StatusCode::NOT_FOUND, "sketch_not_found");
        assert!(m.contains("nope"), "{m}");
    }
}

#[tokio::test]
async fn session_lifecycle_and_per_session_endpoints() {
    let h = default_harness();
    let id = start_session(&h).await;

    let info = get(&h.app, &format!("/v1/sessions/{id}")).await;
    assert_eq!(info.status, StatusCode::OK);
    assert_eq!(info.json()["state"], "waiting_for_data");
    assert_eq!(info.json()["robot_id"], "r1");
    assert_eq!(info.json()["method"], "sketch");

    let list = get(&h.app, "/v1/sessions").await.json();
    assert_eq!(list["sessions"].as_array().unwrap().len(), 1);

    let pose = get(&h.app, &format!("/v1/sessions/{id}/pose")).await.json();
    for key in [
        "x",
        "y",
        "theta",
        "stamp",
        "mapId",
        "positionInitialized",
        "localizationScore",
    ] {
        assert!(pose.get(key).is_some(), "pose lacks {key}: {pose}");
    }
    for key in ["u", "v", "heading_deg", "meters_per_pixel"] {
        assert!(
            pose["sketch"].get(key).is_some(),
            "pose.sketch lacks {key}: {pose}"
        );
    }

    let traj = get(&h.app, &format!("/v1/sessions/{id}/trajectory")).await;
    assert_eq!(traj.status, StatusCode::OK);
    assert_eq!(traj.json()["points"].as_array().unwrap().len(), 2);
    let csv = get(&h.app, &format!("/v1/sessions/{id}/trajectory?format=csv")).await;
    assert_eq!(csv.status, StatusCode::OK);
    assert!(csv.content_type.starts_with("text/csv"));
    let text = csv.text();
    assert_eq!(text.lines().next(), Some("t,x,y,theta"));
    assert_eq!(text.lines().count(), 3);
    get(&h.app, &format!("/v1/sessions/{id}/trajectory?format=xml"))
        .await
        .error(StatusCode::BAD_REQUEST, "invalid_query");
    // The same trajectory on the drawing, with each pose's source.
    let on_drawing = get(
        &h.app,
        &format!("/v1/sessions/{id}/trajectory?frame=sketch"),
    )
    .await;
    assert_eq!(on_drawing.status, StatusCode::OK, "{}", on_drawing.text());
    let points = on_drawing.json()["points"].as_array().unwrap().clone();
    assert_eq!(points.len(), 2);
    for key in ["t", "u", "v", "heading", "meters_per_pixel", "source"] {
        assert!(points[0].get(key).is_some(), "point lacks {key}");
    }
    assert_eq!(points[1]["source"], "odometry");
    let csv = get(
        &h.app,
        &format!("/v1/sessions/{id}/trajectory?frame=sketch&format=csv"),
    )
    .await;
    let text = csv.text();
    assert_eq!(text.lines().next(), Some("t,u,v,heading,meters_per_pixel"));
    assert_eq!(
        text.lines().nth(1),
        Some("0.000000000,66.900,320.300,0.020000,0.100000")
    );
    get(&h.app, &format!("/v1/sessions/{id}/trajectory?frame=world"))
        .await
        .error(StatusCode::BAD_REQUEST, "invalid_query");

    let png = get(&h.app, &format!("/v1/sessions/{id}/map.png")).await;
    assert_eq!(
        (png.status, png.content_type.as_str()),
        (StatusCode::OK, "image/png")
    );
    let pgm = get(&h.app, &format!("/v1/sessions/{id}/map.pgm")).await;
    assert_eq!(pgm.status, StatusCode::OK);
    assert!(pgm.body.starts_with(b"P5"));
    let yaml = get(&h.app, &format!("/v1/sessions/{id}/map.yaml")).await;
    assert_eq!(yaml.status, StatusCode::OK);
    assert!(yaml.text().contains("image: map.pgm"));
    let grid = get(&h.app, &format!("/v1/sessions/{id}/map")).await.json();
    assert_eq!(grid["header"]["frame_id"], "map");
    assert_eq!(grid["info"]["width"], 2);
    assert_eq!(grid["data"], json!([-1, 100]));
    assert_eq!(grid["info"]["origin"]["position"]["x"], -0.05);
    assert_eq!(grid["info"]["origin"]["orientation"]["w"], 1.0);

    let stopped = delete(&h.app, &format!("/v1/sessions/{id}")).await;
    assert_eq!(stopped.status, StatusCode::OK);
    assert_eq!(stopped.json()["state"], "stopped");
    // The map stays after the stop.
    assert_eq!(
        get(&h.app, &format!("/v1/sessions/{id}/map.png"))
            .await
            .status,
        StatusCode::OK
    );
}

#[tokio::test]
async fn unknown_session_ids_are_404_everywhere() {
    let h = default_harness();
    for suffix in [
        "",
        "/pose",
        "/trajectory",
        "/map",
        "/map.png",
        "/map.pgm",
        "/map.yaml",
        "/events",
    ] {
        get(&h.app, &format!("/v1/sessions/missing{suffix}"))
            .await
            .error(StatusCode::NOT_FOUND, "session_not_found");
    }
    delete(&h.app, "/v1/sessions/missing")
        .await
        .error(StatusCode::NOT_FOUND, "session_not_found");
}

#[tokio::test]
async fn session_request_rejections_name_the_problem_and_change_nothing() {
    let h = default_harness();
    let sketch = upload(&h).await;
    let base = sketch_session(&sketch);
    let with = |path: &[&str], value: Value| {
        let mut v = base.clone();
        let mut at = &mut v;
        for p in &path[..path.len() - 1] {
            at = &mut at[*p];
        }
        at[path[path.len() - 1]] = value;
        v
    };
    let cases: Vec<(Value, StatusCode, &str, &str)> = vec![
        (
            with(&["meters_per_pixel"], json!(-0.1)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_number",
            "meters_per_pixel",
        ),
        (
            with(&["meters_per_pixel"], json!(0.0)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_number",
            "meters_per_pixel",
        ),
        (
            with(&["meters_per_pixel"], json!("NaN")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_field",
            "meters_per_pixel",
        ),
        (
            with(&["start", "u"], json!("inf")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_field",
            "start.u",
        ),
        (
            with(&["start", "u"], json!(-1.0)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_number",
            "start.u",
        ),
        (
            with(&["start", "heading_deg"], json!(null)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_field",
            "start.heading_deg",
        ),
        (
            with(&["start", "u"], json!(5000.0)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_start",
            "start",
        ),
        (
            with(&["sketch_id"], json!("nope")),
            StatusCode::NOT_FOUND,
            "sketch_not_found",
            "nope",
        ),
        (
            with(&["robot_id"], json!("r/1")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_robot_id",
            "robot_id",
        ),
        (
            with(&["robot_id"], json!("")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_robot_id",
            "robot_id",
        ),
        (
            with(&["method"], json!("magic")),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_field",
            "method",
        ),
        (
            with(&["extra"], json!(1)),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_field",
            "extra",
        ),
        (
            json!({"robot_id": "r1", "method": "sketch"}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "missing_field",
            "sketch_id",
        ),
        (
            json!({"robot_id": "r1", "method": "sketch", "sketch_id": sketch}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "missing_field",
            "start",
        ),
        (
            json!({"robot_id": "r1", "method": "icp", "meters_per_pixel": 0.1}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unexpected_field",
            "sketch",
        ),
        (
            json!({"robot_id": "r1", "method": "graph", "sketch_id": sketch}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "unexpected_field",
            "sketch",
        ),
        (
            json!({"method": "icp"}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "invalid_field",
            "robot_id",
        ),
    ];
    for (body, status, code, needle) in cases {
        let m = post_json(&h.app, "/v1/sessions", &body)
            .await
            .error(status, code);
        assert!(
            m.contains(needle),
            "{body}: message {m:?} does not name {needle:?}"
        );
    }
    // Raw NaN/Infinity literals are not JSON: malformed.
    for raw in [
        r#"{"robot_id": "r1", "method": "icp""#,
        r#"{"robot_id": "r1", "method": "sketch", "meters_per_pixel": NaN}"#,
        r#"{"robot_id": "r1", "method": "sketch", "meters_per_pixel": Infinity}"#,
        r#"{"robot_id": "r1", "method": "icp"} trailing"#,
        "",
    ] {
        post(&h.app, "/v1/sessions", "application/json", raw)
            .await
            .error(StatusCode::BAD_REQUEST, "malformed_json");
    }
    // Too large JSON.
    let huge = format!(r#"{{"robot_id": "{}"}}"#, "r".repeat(5000));
    post(&h.app, "/v1/sessions", "application/json", huge)
        .await
        .error(StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large");
    assert!(h.fake.sessions.lock().unwrap().is_empty());
}

#[tokio::test]
async fn baseline_sessions_need_no_sketch_and_a_robot_maps_once() {
    let h = default_harness();
    // No Content-Type at all still parses.
    let req = Request::post("/v1/sessions")
        .body(Body::from(
            json!({"robot_id": "r2", "method": "icp"}).to_string(),
        ))
        .unwrap();
    let a = send(&h.app, req).await;
    assert_eq!(a.status, StatusCode::CREATED, "{}", a.text());
    let id = a.json()["id"].as_str().unwrap().to_string();
    post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r2", "method": "odometry"}),
    )
    .await
    .error(StatusCode::CONFLICT, "robot_busy");
    delete(&h.app, &format!("/v1/sessions/{id}")).await;
    let again = post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r2", "method": "odometry"}),
    )
    .await;
    assert_eq!(again.status, StatusCode::CREATED);
    // The loop-closing baseline without a drawing is a session like the others.
    let graph = post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r3", "method": "graph"}),
    )
    .await;
    assert_eq!(graph.status, StatusCode::CREATED, "{}", graph.text());
    assert_eq!(graph.json()["method"], "graph");
    let graph_id = graph.json()["id"].as_str().unwrap().to_string();
    get(
        &h.app,
        &format!("/v1/sessions/{graph_id}/trajectory?frame=sketch"),
    )
    .await
    .error(StatusCode::UNPROCESSABLE_ENTITY, "no_drawing");
}

/// Posts `graph` sessions with `key` set: to each of `bad` (a 422 `invalid_number` naming
/// its field), to `misspelt` (refused, not ignored: an option silently dropped changes the
/// map) and, with none made before, to `good` (created, and echoed as sent).
async fn a_session_option_is_checked(
    key: &str,
    bad: &[(serde_json::Value, &str)],
    misspelt: serde_json::Value,
    good: serde_json::Value,
) {
    let h = default_harness();
    let request = |value: &serde_json::Value| {
        let mut r = json!({"robot_id": "r1", "method": "graph"});
        r[key] = value.clone();
        r
    };
    for (value, field) in bad {
        let message = post_json(&h.app, "/v1/sessions", &request(value))
            .await
            .error(StatusCode::UNPROCESSABLE_ENTITY, "invalid_number");
        assert!(message.contains(field), "{message}");
    }
    let a = post_json(&h.app, "/v1/sessions", &request(&misspelt)).await;
    assert!(a.status.is_client_error(), "{}", a.text());
    assert!(h.fake.sessions.lock().unwrap().is_empty());
    let a = post_json(&h.app, "/v1/sessions", &request(&good)).await;
    assert_eq!(a.status, StatusCode::CREATED, "{}", a.text());
    assert_eq!(a.json()[key], good);
}

#[tokio::test]
async fn a_lidar_mount_is_kept_with_the_session_and_a_bad_one_is_named() {
    a_session_option_is_checked(
        "lidar_mount",
        &[
            (
                json!({"x_m": 11.0, "y_m": 0.0, "yaw_deg": 0.0}),
                "lidar_mount.x_m",
            ),
            (
                json!({"x_m": 0.0, "y_m": -10.5, "yaw_deg": 0.0}),
                "lidar_mount.y_m",
            ),
            (
                json!({"x_m": 0.3, "y_m": 0.0, "yaw_deg": 400.0}),
                "lidar_mount.yaw_deg",
            ),
        ],
        json!({"x": 0.3, "y_m": 0.0, "yaw_deg": 0.0}),
        json!({"x_m": 0.3, "y_m": -0.05, "yaw_deg": 5.0}),
    )
    .await;
}

#[tokio::test]
async fn an_odometry_model_is_kept_with_the_session_and_a_bad_one_is_named() {
    a_session_option_is_checked(
        "odometry_noise",
        &[
            (
                json!({"position_sd_per_m": -0.01}),
                "odometry_noise.position_sd_per_m",
            ),
            (
                json!({"heading_sd_per_rad": 11.0}),
                "odometry_noise.heading_sd_per_rad",
            ),
            (
                json!({"heading_sd_rad_per_m": 0.02, "position_sd_m_per_rad": 1e9}),
                "odometry_noise.position_sd_m_per_rad",
            ),
        ],
        // AMCL's names: its alphas weigh variances, ours standard deviations.
        json!({"alpha3": 0.2}),
        json!({"position_sd_per_m": 0.03, "heading_sd_per_rad": 0.05}),
    )
    .await;
}

#[tokio::test]
async fn the_observation_model_of_mcl_is_kept_with_the_session_and_a_bad_one_is_refused() {
    let h = default_harness();
    let a = post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r1", "method": "graph", "mcl_observation": "beam_model"}),
    )
    .await;
    assert!(a.status.is_client_error(), "{}", a.text());
    assert!(a.text().contains("mcl_observation"), "{}", a.text());
    assert!(h.fake.sessions.lock().unwrap().is_empty());
    let a = post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r1", "method": "graph", "mcl_observation": "ray_cast"}),
    )
    .await;
    assert_eq!(a.status, StatusCode::CREATED, "{}", a.text());
    assert_eq!(a.json()["mcl_observation"], "ray_cast");
}

#[tokio::test]
async fn the_drawing_localization_is_kept_with_the_session_and_a_bad_one_is_refused() {
    let h = default_harness();
    let a = post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r1", "method": "graph", "drawing_localization": "gps"}),
    )
    .await;
    assert!(a.status.is_client_error(), "{}", a.text());
    assert!(a.text().contains("drawing_localization"), "{}", a.text());
    assert!(h.fake.sessions.lock().unwrap().is_empty());
    let a = post_json(
        &h.app,
        "/v1/sessions",
        &json!({"robot_id": "r1", "method": "graph", "drawing_localization": "warp"}),
    )
    .await;
    assert_eq!(a.status, StatusCode::CREATED, "{}", a.text());
    assert_eq!(a.json()["drawing_localization"], "warp");
}

#[tokio::test]
async fn events_stream_status_then_poses_and_ends_on_stop() {
    let h = default_harness();
    let id = start_session(&h).await;
    let response = h
        .app
        .clone()
        .oneshot(
            Request::get(format!("/v1/sessions/{id}/events"))
                .body(Body::empty())
                .unwrap(),
        )
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::OK);
    assert!(
        response.headers()[header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .starts_with("text/event-stream")
    );
    let mut body = response.into_body();
    let pose = h.fake.pose(&id).unwrap();
    h.fake.events.lock().unwrap()[&id].publish(SessionEvent::Pose(pose));
    h.fake.stop_session(&id).unwrap();
    let mut text = String::new();
    while let Some(frame) = body.frame().await {
        if let Ok(data) = frame.unwrap().into_data() {
            text.push_str(&String::from_utf8_lossy(&data));
        }
    }
    let names: Vec<&str> = text
        .lines()
        .filter_map(|l| l.strip_prefix("event: "))
        .collect();
    // The snapshot (status, the pose now), the pose published, the stop.
    assert_eq!(names, ["status", "pose", "pose", "status"], "{text}");
    assert!(text.contains("\"positionInitialized\":true"));
    assert!(text.contains("\"state\":\"stopped\""));
}

#[tokio::test]
async fn a_reconnecting_client_resumes_after_its_last_event_id() {
    let h = default_harness();
    let id = start_session(&h).await;
    let pose = h.fake.pose(&id).unwrap();
    let log = h.fake.events.lock().unwrap()[&id].clone();
    for _ in 0..3 {
        log.publish(SessionEvent::Pose(pose.clone()));
    }
    drop(log);
    let events = |last: Option<&str>| {
        let mut req = Request::get(format!("/v1/sessions/{id}/events"));
        if let Some(last) = last {
            req = req.header("last-event-id", last);
        }
        h.app.clone().oneshot(req.body(Body::empty()).unwrap())
    };
    // Resumed after event 1: events 2 and 3, no snapshot first; a fresh client and one with
    // an id this session never gave start with the snapshot (status, the pose now).
    let resumed = events(Some("1")).await.unwrap();
    let fresh = events(None).await.unwrap();
    let unknown = events(Some("77")).await.unwrap();
    h.fake.stop_session(&id).unwrap();
    let read = |response: axum::response::Response| async move {
        let mut body = response.into_body();
        let mut text = String::new();
        while let Some(frame) = body.frame().await {
            if let Ok(data) = frame.unwrap().into_data() {
                text.push_str(&String::from_utf8_lossy(&data));
            }
        }
        let pick = |prefix: &str| -> Vec<String> {
            text.lines()
                .filter_map(|l| l.strip_prefix(prefix).map(str::to_string))
                .collect()
        };
        (pick("event: "), pick("id: "))
    };
    let (names, ids) = read(resumed).await;
    assert_eq!(names, ["pose", "pose", "status"]);
    assert_eq!(ids, ["2", "3", "4"]);
    for response in [fresh, unknown] {
        let (names, ids) = read(response).await;
        assert_eq!(names, ["status", "pose", "status"]);
        assert_eq!(ids, ["3", "3", "4"]);
    }
}

#[tokio::test]
async fn metrics_are_prometheus_text_with_http_counts() {
    let h = default_harness();
    get(&h.app, "/healthz").await;
    get(&h.app, "/v1/sessions/zzz").await;
    let a = get(&h.app, "/metrics").await;
    assert_eq!(a.status, StatusCode::OK);
    assert!(a.content_type.starts_with("text/plain"));
    let text = a.text();
    assert!(text.contains("sketchslam_scans_processed_total"), "{text}");
    assert!(
        text.contains(
            r#"sketchslam_http_requests_total{method="GET",route="/healthz",status="200"} 1"#
        ),
        "{text}"
    );
    assert!(
        text.contains(r#"route="/v1/sessions/{id}",status="404"} 1"#),
        "{text}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn uploads_beyond_the_limit_wait_their_turn() {
    // Decoding a drawing at the pixel limit holds ~270 MB: six uploads at once, at most
    // two handled together; all six answered.
    let h = harness(RouterOptions {
        max_body_bytes: 4096,
        max_concurrent_uploads: 2,
        ..RouterOptions::default()
    });
    let mut uploads = Vec::new();
    for _ in 0..6 {
        let app = h.app.clone();
        uploads.push(tokio::spawn(async move {
            post(
                &app,
                "/v1/sketches",
                "image/png",
                slow_fake_png(640, 480, 3, 150),
            )
            .await
        }));
    }
    for upload in uploads {
        assert_eq!(upload.await.unwrap().status, StatusCode::CREATED);
    }
    let most = h
        .fake
        .max_uploads_in_flight
        .load(std::sync::atomic::Ordering::SeqCst);
    assert_eq!(most, 2, "uploads handled at once");
}

#[tokio::test]
async fn made_up_methods_share_one_metrics_series() {
    // Before 2026-12-03 every made-up method string became a label value of its own, for
    // the life of the process: 300 requests, 301 series.
    let h = default_harness();
    for k in 0..50 {
        let method = Method::from_bytes(format!("BREW{k}").as_bytes()).unwrap();
        let req = Request::builder()
            .method(method)
            .uri("/healthz")
            .body(Body::empty())
            .unwrap();
        send(&h.app, req).await;
    }
    let text = get(&h.app, "/metrics").await.text();
    let series: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("sketchslam_http_requests_total{"))
        .collect();
    assert!(!text.contains("BREW"), "{text}");
    assert!(
        series
            .iter()
            .any(|l| l.contains(r#"method="other",route="/healthz""#) && l.ends_with(" 50")),
        "{series:?}"
    );
    assert!(series.len() <= 2, "{series:?}");
}

#[tokio::test]
async fn openapi_document_lists_every_route() {
    let h = default_harness();
    let a = get(&h.app, "/openapi.json").await;
    assert_eq!(a.status, StatusCode::OK);
    let doc = a.json();
    assert!(doc["openapi"].as_str().unwrap().starts_with("3."));
    let paths = doc["paths"].as_object().unwrap();
    for p in [
        "/healthz",
        "/metrics",
        "/openapi.json",
        "/v1/sketches",
        "/v1/sketches/{id}",
        "/v1/sketches/{id}/lines.png",
        "/v1/sessions",
        "/v1/sessions/{id}",
        "/v1/sessions/{id}/pose",
        "/v1/sessions/{id}/trajectory",
        "/v1/sessions/{id}/map",
        "/v1/sessions/{id}/map.png",
        "/v1/sessions/{id}/map.pgm",
        "/v1/sessions/{id}/map.yaml",
        "/v1/sessions/{id}/events",
        "/v1/sessions/{id}/registration",
        "/v1/sessions/{id}/sketch-overlay.png",
        "/v1/sessions/{id}/sketch-in-map",
        "/v1/sessions/{id}/sketch-in-map.png",
        "/v1/sessions/{id}/transform",
    ] {
        assert!(paths.contains_key(p), "openapi lacks {p}");
    }
    assert!(doc["components"]["schemas"]["CreateSessionRequest"].is_object());
    assert!(doc["components"]["schemas"]["TransformRequest"].is_object());
    assert!(paths["/v1/sessions/{id}/transform"]["post"].is_object());
}

#[tokio::test]
async fn unknown_routes_and_methods_answer_in_our_shape() {
    let h = default_harness();
    get(&h.app, "/v2/nothing")
        .await
        .error(StatusCode::NOT_FOUND, "not_found");
    send(
        &h.app,
        Request::builder()
            .method(Method::PUT)
            .uri("/v1/sketches")
            .body(Body::empty())
            .unwrap(),
    )
    .await
    .error(StatusCode::METHOD_NOT_ALLOWED, "method_not_allowed");
}

#[tokio::test]
async fn token_guards_everything_but_healthz() {
    let h = harness(RouterOptions {
        token: Some("s3cret".to_string()),
        max_body_bytes: 4096,
        ..RouterOptions::default()
    });
    assert_eq!(get(&h.app, "/healthz").await.status, StatusCode::OK);
    for uri in [
        "/v1/sketches",
        "/metrics",
        "/openapi.json",
        "/v1/sessions/x",
        "/nothing",
    ] {
        get(&h.app, uri)
            .await
            .error(StatusCode::UNAUTHORIZED, "unauthorized");
    }
    let wrong = Request::get("/v1/sketches")
        .header(header::AUTHORIZATION, "Bearer nope")
        .body(Body::empty())
        .unwrap();
    send(&h.app, wrong)
        .await
        .error(StatusCode::UNAUTHORIZED, "unauthorized");
    let upload_unauth = post(&h.app, "/v1/sketches", "image/png", fake_png(10, 10, 1)).await;
    upload_unauth.error(StatusCode::UNAUTHORIZED, "unauthorized");
    assert!(h.fake.sketches.lock().unwrap().is_empty());
    let right = Request::get("/v1/sketches")
        .header(header::AUTHORIZATION, "Bearer s3cret")
        .body(Body::empty())
        .unwrap();
    assert_eq!(send(&h.app, right).await.status, StatusCode::OK);
}

#[tokio::test]
async fn internal_errors_are_not_leaked() {
    let e = ApiError::internal("disk /secret/path failed");
    let body = e.body();
    assert_eq!(body.error.code, "internal");
    assert!(!body.error.message.contains("/secret"));
}

#[tokio::test]
async fn a_body_refused_unread_closes_its_connection() {
    // Answered from the Content-Length alone, the body still on the wire: the client must
    // not send another request on this connection.
    let h = default_harness();
    let req = Request::post("/v1/sketches")
        .header(header::CONTENT_TYPE, "image/png")
        .header(header::CONTENT_LENGTH, "1000000")
        .body(Body::empty())
        .unwrap();
    let response = h.app.clone().oneshot(req).await.unwrap();
    assert_eq!(response.status(), StatusCode::PAYLOAD_TOO_LARGE);
    assert_eq!(response.headers()[header::CONNECTION], "close");
}
