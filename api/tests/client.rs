//! The typed client against the real router on a loopback socket (fake backend).

use std::sync::Arc;

use reqwest::StatusCode;
use sketchslam_api::*;

mod common;
use common::{Fake, fake_png};

async fn serve(token: Option<&str>) -> (Arc<Fake>, String) {
    let fake = Arc::new(Fake::default());
    let app = router(
        fake.clone(),
        RouterOptions {
            token: token.map(str::to_string),
            ..RouterOptions::default()
        },
    );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    tokio::spawn(async move { axum::serve(listener, app).await.unwrap() });
    (fake, format!("http://{addr}"))
}

#[tokio::test]
async fn client_covers_every_endpoint() {
    let (fake, base) = serve(Some("tok")).await;
    let anonymous = SketchslamClient::new(&base);
    assert_eq!(anonymous.health().await.unwrap().status, "ok");
    let e = anonymous.list_sketches().await.unwrap_err();
    assert_eq!(e.status(), Some(StatusCode::UNAUTHORIZED));
    assert_eq!(e.code(), Some("unauthorized"));

    let c = SketchslamClient::new(format!("{base}/")).with_token("tok");
    let sketch = c
        .upload_sketch(fake_png(400, 400, 2), Some("A B"))
        .await
        .unwrap();
    assert_eq!(sketch.name.as_deref(), Some("A B"));
    assert_eq!(c.list_sketches().await.unwrap().sketches.len(), 1);
    assert_eq!(c.get_sketch(&sketch.id).await.unwrap(), sketch);
    assert!(!c.sketch_overlay_png(&sketch.id).await.unwrap().is_empty());
    let e = c.upload_sketch(b"junk".to_vec(), None).await.unwrap_err();
    assert_eq!(e.code(), Some("invalid_image"));

    let request = CreateSessionRequest {
        sketch_id: Some(sketch.id.clone()),
        start: Some(SketchStart {
            u: 66.9,
            v: 320.3,
            heading_deg: 1.1,
        }),
        meters_per_pixel: Some(0.1),
        ..CreateSessionRequest::new("r1", MappingMethod::Sketch)
    };
    let session = c.create_session(&request).await.unwrap();
    assert_eq!(session.state, SessionState::WaitingForData);
    let e = c.create_session(&request).await.unwrap_err();
    assert_eq!(e.code(), Some("robot_busy"));
    assert_eq!(c.list_sessions().await.unwrap().sessions.len(), 1);
    assert_eq!(c.get_session(&session.id).await.unwrap().id, session.id);
    assert!(c.pose(&session.id).await.unwrap().position_initialized);
    assert_eq!(c.trajectory(&session.id).await.unwrap().points.len(), 2);
    assert!(
        c.trajectory_csv(&session.id)
            .await
            .unwrap()
            .starts_with("t,x,y,theta\n")
    );
    assert_eq!(c.map(&session.id).await.unwrap().data, vec![-1, 100]);
    assert!(
        c.map_png(&session.id)
            .await
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    assert!(c.map_pgm(&session.id).await.unwrap().starts_with(b"P5"));
    assert!(c.map_yaml(&session.id).await.unwrap().contains("map.pgm"));
    assert!(
        c.metrics()
            .await
            .unwrap()
            .contains("sketchslam_http_requests_total")
    );
    assert!(c.openapi().await.unwrap()["paths"]["/v1/sessions"].is_object());

    let mut events = c.events(&session.id).await.unwrap();
    match events.next_event().await.unwrap() {
        Some(SessionEvent::Status(s)) => assert_eq!(s.id, session.id),
        other => panic!("expected status first, got {other:?}"),
    }
    // Then the pose now, with the snapshot's id (no event before it: 0).
    let pose = fake.pose(&session.id).unwrap();
    assert_eq!(
        events.next_event().await.unwrap(),
        Some(SessionEvent::Pose(pose.clone()))
    );
    assert_eq!(events.last_event_id(), Some(0));
    fake.events.lock().unwrap()[&session.id].publish(SessionEvent::Pose(pose.clone()));
    assert_eq!(
        events.next_event().await.unwrap(),
        Some(SessionEvent::Pose(pose.clone()))
    );
    assert_eq!(events.last_event_id(), Some(1));
    // The connection is lost; two poses are published meanwhile; the client resumes
    // after the last id it read and gets exactly those two, not a fresh status.
    drop(events);
    for _ in 0..2 {
        fake.events.lock().unwrap()[&session.id].publish(SessionEvent::Pose(pose.clone()));
    }
    let mut events = c.events_after(&session.id, Some(1)).await.unwrap();
    for id in [2, 3] {
        assert_eq!(
            events.next_event().await.unwrap(),
            Some(SessionEvent::Pose(pose.clone()))
        );
        assert_eq!(events.last_event_id(), Some(id));
    }

    let stopped = c.stop_session(&session.id).await.unwrap();
    assert_eq!(stopped.state, SessionState::Stopped);
    assert!(matches!(
        events.next_event().await.unwrap(),
        Some(SessionEvent::Status(_))
    ));
    assert_eq!(events.next_event().await.unwrap(), None);

    c.delete_sketch(&sketch.id).await.unwrap();
    let e = c.get_sketch(&sketch.id).await.unwrap_err();
    assert_eq!(e.status(), Some(StatusCode::NOT_FOUND));
    // Ids are escaped as one path segment.
    let e = c.get_session("a/b c").await.unwrap_err();
    assert_eq!(e.code(), Some("session_not_found"));
}
