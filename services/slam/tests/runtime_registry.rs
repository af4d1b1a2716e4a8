//! Runtime tests against a real [`Registry`] on a temporary data dir, fed by an in-process
//! iceoryx2 publisher on a unique prefix: sketch ingestion and start validation, a session's
//! life (waiting → mapping → stopped), a publisher that restarts with a gap, and a restart
//! of the registry on the same data dir (sketch and stopped session survive).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use axum::body::Bytes;
use sketchslam_api::{
    ApiError, Backend, CreateSessionRequest, MappingMethod, SessionState, SketchStart, SketchUpload,
};
use sketchslam_engine::sketch::Sketch;
use sketchslam_ipc::{Delivery, IpcConfig, RobotPublisher};
use sketchslam_slam::{Registry, RegistryConfig};
use sketchslam_types::{Odometry, ScanHeader};

/// A data dir removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Self {
        let p = std::env::temp_dir().join(format!("sketchslam-rt-{}", uuid::Uuid::new_v4()));
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn unique_prefix() -> String {
    format!("rt{}", &uuid::Uuid::new_v4().simple().to_string()[..12])
}

fn registry(dir: &Path, prefix: &str) -> Registry {
    registry_keeping(dir, prefix, 100)
}

fn registry_keeping(dir: &Path, prefix: &str, max_sketches: usize) -> Registry {
    Registry::open(RegistryConfig {
        data_dir: dir.to_path_buf(),
        ipc_prefix: prefix.to_string(),
        max_sessions: 4,
        max_sketches,
        mapper: Default::default(),
    })
    .unwrap()
}

fn sketch_a() -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../simulator/scenarios/paper-env1/sketch-a.png");
    std::fs::read(p).unwrap()
}

/// A `sketch` session for robot r1 on `sketch_id`, started at `(u, v)` px, heading 1.1°,
/// 0.1 m/px.
fn sketch_start(sketch_id: &str, u: f64, v: f64) -> CreateSessionRequest {
    CreateSessionRequest {
        sketch_id: Some(sketch_id.to_string()),
        start: Some(SketchStart {
            u,
            v,
            heading_deg: 1.1,
        }),
        meters_per_pixel: Some(0.1),
        ..CreateSessionRequest::new("r1", MappingMethod::Sketch)
    }
}

/// An upload named `name` with no scale.
fn named(name: &str) -> SketchUpload {
    SketchUpload {
        name: Some(name.into()),
        meters_per_pixel: None,
    }
}

fn code(e: ApiError) -> &'static str {
    e.code()
}

/// Range from `(x, y)` along `angle` to the walls of the box [-5, 15] × [-5, 5].
fn box_range(x: f64, y: f64, angle: f64) -> f32 {
    let (c, s) = (angle.cos(), angle.sin());
    let mut best = f64::INFINITY;
    for (wall, horizontal) in [(-5.0, false), (15.0, false), (-5.0, true), (5.0, true)] {
        let t = if horizontal {
            if s.abs() < 1e-12 {
                continue;
            } else {
                (wall - y) / s
            }
        } else if c.abs() < 1e-12 {
            continue;
        } else {
            (wall - x) / c
        };
        if t > 0.0 {
            best = best.min(t);
        }
    }
    best as f32
}

/// Publishes `n` odometry + scan pairs of a robot driving along +x from `x0`.
fn publish_run(publisher: &mut RobotPublisher, first_seq: u64, n: u64, x0: f64) {
    let beams = 271u32;
    let angle_min = -135f64.to_radians();
    let inc = 270f64.to_radians() / (beams - 1) as f64;
    for k in 0..n {
        let seq = first_seq + k;
        let stamp_ns = 1_000_000_000 + seq * 50_000_000;
        let x = x0 + k as f64 * 0.05;
        publisher
            .publish_odometry(&Odometry {
                sequence: seq,
                stamp_ns,
                x_m: x,
                y_m: 0.0,
                theta_rad: 0.0,
            })
            .unwrap();
        let ranges: Vec<f32> = (0..beams)
            .map(|i| box_range(x, 0.0, angle_min + i as f64 * inc))
            .collect();
        let header = ScanHeader {
            sequence: seq,
            stamp_ns,
            angle_min_rad: angle_min as f32,
            angle_increment_rad: inc as f32,
            range_min_m: 0.05,
            range_max_m: 30.0,
            beam_count: beams,
        };
        publisher.publish_scan(&header, &ranges).unwrap();
    }
}

/// A lock-step publisher for `robot` that waits for the session's subscriber, sends the
/// run `(first_seq, n, x0)` of [`publish_run`], and goes away once session `id` has
/// processed `total` scans: samples still queued when a publisher goes away may go with it
/// (its data segment is its own).
fn publish_until_processed(
    reg: &Registry,
    ipc: &IpcConfig,
    robot: &str,
    id: &str,
    (first_seq, n, x0): (u64, u64, f64),
    total: u64,
) {
    let mut publisher = RobotPublisher::new(ipc, robot, Delivery::lock_step()).unwrap();
    assert!(
        publisher
            .wait_for_subscribers(1, Duration::from_secs(10))
            .unwrap()
    );
    publish_run(&mut publisher, first_seq, n, x0);
    wait_for(&format!("{total} scans"), Duration::from_secs(20), || {
        reg.get_session(id).unwrap().scans_processed == total
    });
}

fn wait_for(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !f() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Compares grids without printing megabytes on failure.
fn assert_same_grid(
    a: &sketchslam_api::OccupancyGridResponse,
    b: &sketchslam_api::OccupancyGridResponse,
) {
    assert_eq!(a.header, b.header);
    let (a_info, b_info) = (&a.info, &b.info);
    assert_eq!((a_info.width, a_info.height), (b_info.width, b_info.height));
    let (ao, bo) = (a_info.origin, b_info.origin);
    // JSON keeps 15-17 significant digits, not always the last bit.
    for (x, y) in [
        (a_info.resolution, b_info.resolution),
        (ao.position.x, bo.position.x),
        (ao.position.y, bo.position.y),
        (ao.orientation.z, bo.orientation.z),
        (ao.orientation.w, bo.orientation.w),
    ] {
        assert!((x - y).abs() < 1e-9, "{x} != {y}");
    }
    let differing = a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count();
    assert_eq!(differing, 0, "{differing} cells differ");
}

#[test]
fn sketches_are_ingested_and_starts_validated() {
    let dir = TempDir::new();
    let reg = registry(&dir.0, &unique_prefix());
    let png = sketch_a();
    let info = reg
        .create_sketch(named("A"), Bytes::from(png.clone()))
        .unwrap();
    assert!(info.lines.len() >= 4, "{} lines", info.lines.len());
    assert!(
        reg.sketch_overlay_png(&info.id)
            .unwrap()
            .starts_with(b"\x89PNG")
    );

    assert_eq!(
        code(
            reg.create_sketch(SketchUpload::default(), Bytes::from_static(b"not an image"))
                .unwrap_err()
        ),
        "invalid_image"
    );
    // A blank white picture: decodes, but has no lines.
    let mut blank = Vec::new();
    image::RgbImage::from_pixel(64, 64, image::Rgb([255, 255, 255]))
        .write_to(
            &mut std::io::Cursor::new(&mut blank),
            image::ImageFormat::Png,
        )
        .unwrap();
    assert_eq!(
        code(
            reg.create_sketch(SketchUpload::default(), Bytes::from(blank))
                .unwrap_err()
        ),
        "no_lines"
    );
    assert_eq!(reg.list_sketches().unwrap().len(), 1);

    let request = |u: f64, v: f64| sketch_start(&info.id, u, v);
    let outside = reg
        .create_session(request(info.width_px as f64 + 3.0, 10.0))
        .unwrap_err();
    assert_eq!(code(outside.clone()), "invalid_start", "{outside}");
    assert!(outside.to_string().contains("start"));
    // A pixel on a stroke.
    let sketch = Sketch::from_image_bytes(&png).unwrap();
    let on_stroke = sketch.strokes.ones().next().unwrap();
    let (u, v) = (
        (on_stroke % sketch.width_px as usize) as f64 + 0.5,
        (on_stroke / sketch.width_px as usize) as f64 + 0.5,
    );
    assert_eq!(
        code(reg.create_session(request(u, v)).unwrap_err()),
        "invalid_start"
    );
    let mut unknown = request(66.9, 320.3);
    unknown.sketch_id = Some("nope".into());
    assert_eq!(
        code(reg.create_session(unknown).unwrap_err()),
        "sketch_not_found"
    );
    assert!(reg.list_sessions().unwrap().is_empty());

    // The scenario's marked start is accepted; the robot is then busy.
    let s = reg.create_session(request(66.9, 320.3)).unwrap();
    assert_eq!(s.state, SessionState::WaitingForData);
    assert_eq!(
        code(reg.create_session(request(66.9, 320.3)).unwrap_err()),
        "robot_busy"
    );
    reg.stop_session(&s.id).unwrap();
    reg.delete_sketch(&info.id).unwrap();
    assert_eq!(
        code(reg.get_sketch(&info.id).unwrap_err()),
        "sketch_not_found"
    );
    reg.shutdown();
}

#[test]
fn stored_sketches_open_without_decoding_their_images_and_are_capped() {
    let dir = TempDir::new();
    let prefix = unique_prefix();
    let reg = registry_keeping(&dir.0, &prefix, 2);
    let png = Bytes::from(sketch_a());
    let first = reg.create_sketch(named("A"), png.clone()).unwrap();
    let second = reg
        .create_sketch(SketchUpload::default(), png.clone())
        .unwrap();
    let over = reg
        .create_sketch(SketchUpload::default(), png.clone())
        .unwrap_err();
    assert_eq!(code(over.clone()), "too_many_sketches", "{over}");
    reg.delete_sketch(&second.id).unwrap();
    let second = reg
        .create_sketch(SketchUpload::default(), png.clone())
        .unwrap();
    let overlay = reg.sketch_overlay_png(&first.id).unwrap();
    reg.shutdown();
    drop(reg);

    // The images are no longer pictures: a start that decoded them would refuse them. A
    // third entry as versions before 2026-12-03 stored it (image and meta.json only) is
    // processed once at the start and gains the files the next start reads.
    for s in [&first, &second] {
        std::fs::write(dir.0.join("sketches").join(&s.id).join("image"), b"gone").unwrap();
    }
    let old = dir.0.join("sketches/old-style");
    std::fs::create_dir_all(&old).unwrap();
    std::fs::write(old.join("image"), &png).unwrap();
    std::fs::write(
        old.join("meta.json"),
        br#"{"id": "old-style", "name": "old", "created_unix_ms": 3}"#,
    )
    .unwrap();
    let reg = registry_keeping(&dir.0, &prefix, 3);
    assert_eq!(reg.get_sketch(&first.id).unwrap(), first);
    assert_eq!(reg.get_sketch(&second.id).unwrap().lines, first.lines);
    assert_eq!(reg.get_sketch("old-style").unwrap().lines, first.lines);
    assert!(old.join("sketch.json").exists() && old.join("strokes.bin").exists());
    // The mask is read back from strokes.bin: the same picture, the same refusals.
    assert_eq!(reg.sketch_overlay_png(&first.id).unwrap(), overlay);
    let sketch = Sketch::from_image_bytes(&png).unwrap();
    let on_stroke = sketch.strokes.ones().next().unwrap();
    let w = sketch.width_px as usize;
    let start = |u: f64, v: f64| sketch_start(&first.id, u, v);
    let (u, v) = ((on_stroke % w) as f64 + 0.5, (on_stroke / w) as f64 + 0.5);
    assert_eq!(
        code(reg.create_session(start(u, v)).unwrap_err()),
        "invalid_start"
    );
    let session = reg.create_session(start(66.9, 320.3)).unwrap();
    reg.stop_session(&session.id).unwrap();
    reg.shutdown();
}

#[test]
fn a_drawing_keeps_its_declared_scale_and_sessions_without_one_take_it() {
    let dir = TempDir::new();
    let prefix = unique_prefix();
    let reg = registry(&dir.0, &prefix);
    let png = Bytes::from(sketch_a());
    let scaled = SketchUpload {
        name: Some("A".into()),
        meters_per_pixel: Some(0.1),
    };
    let drawing = reg.create_sketch(scaled, png.clone()).unwrap();
    assert_eq!(drawing.meters_per_pixel, Some(0.1));
    let unscaled = reg.create_sketch(named("B"), png).unwrap();
    assert_eq!(unscaled.meters_per_pixel, None);

    // No scale in the request: the drawing's, or a 422 naming the field on one without.
    let without = |id: &str| CreateSessionRequest {
        meters_per_pixel: None,
        ..sketch_start(id, 66.9, 320.3)
    };
    let e = reg.create_session(without(&unscaled.id)).unwrap_err();
    assert_eq!(code(e.clone()), "missing_field", "{e}");
    assert!(e.to_string().contains("meters_per_pixel"), "{e}");
    let session = reg.create_session(without(&drawing.id)).unwrap();
    assert_eq!(session.meters_per_pixel_guess, Some(0.1));
    // A scale given wins over the drawing's.
    reg.stop_session(&session.id).unwrap();
    let own = reg
        .create_session(CreateSessionRequest {
            meters_per_pixel: Some(0.12),
            ..without(&drawing.id)
        })
        .unwrap();
    assert_eq!(own.meters_per_pixel_guess, Some(0.12));
    reg.shutdown();
    drop(reg);

    // Kept across a restart, in the list too.
    let reg = registry(&dir.0, &prefix);
    assert_eq!(
        reg.get_sketch(&drawing.id).unwrap().meters_per_pixel,
        Some(0.1)
    );
    let listed = reg.list_sketches().unwrap();
    let scale_of = |id: &str| listed.iter().find(|s| s.id == id).unwrap().meters_per_pixel;
    assert_eq!(
        (scale_of(&drawing.id), scale_of(&unscaled.id)),
        (Some(0.1), None)
    );
    reg.shutdown();
}

#[test]
fn a_robots_odometry_model_is_filled_in_kept_and_a_bad_one_refused() {
    let dir = TempDir::new();
    let prefix = unique_prefix();
    let reg = registry(&dir.0, &prefix);
    let graph = |robot: &str, noise| CreateSessionRequest {
        odometry_noise: Some(noise),
        ..CreateSessionRequest::new(robot, MappingMethod::Graph)
    };
    // Only the position's drift per meter given: the other three are the service's.
    let asked = sketchslam_api::OdometryNoise {
        position_sd_per_m: Some(0.03),
        ..Default::default()
    };
    let info = reg.create_session(graph("worn", asked)).unwrap();
    let filled = info.odometry_noise.expect("the model the session runs");
    assert_eq!(filled.position_sd_per_m, Some(0.03));
    assert!(
        filled.fields().iter().all(|(_, v)| v.is_some()),
        "{filled:?}"
    );
    // A negative factor is refused by name (the router refuses it first, with the range;
    // the engine too), and no session is made for it.
    let bad = sketchslam_api::OdometryNoise {
        heading_sd_per_rad: Some(-0.1),
        ..Default::default()
    };
    let e = reg.create_session(graph("bad", bad)).unwrap_err();
    assert_eq!(code(e.clone()), "invalid_parameter", "{e}");
    assert!(e.to_string().contains("odometry_noise"), "{e}");
    assert_eq!(reg.list_sessions().unwrap().len(), 1);
    // Kept with the stopped session across a restart.
    reg.stop_session(&info.id).unwrap();
    reg.shutdown();
    drop(reg);
    let reg = registry(&dir.0, &prefix);
    assert_eq!(
        reg.get_session(&info.id).unwrap().odometry_noise,
        Some(filled)
    );
    reg.shutdown();
}

#[test]
fn a_sketch_session_keeps_its_trajectory_on_the_drawing_across_a_restart() {
    let dir = TempDir::new();
    let prefix = unique_prefix();
    let reg = registry(&dir.0, &prefix);
    let sketch = reg
        .create_sketch(named("A"), Bytes::from(sketch_a()))
        .unwrap();
    let session = reg
        .create_session(CreateSessionRequest {
            robot_id: "drawn".into(),
            ..sketch_start(&sketch.id, 66.9, 320.3)
        })
        .unwrap();
    let baseline = reg
        .create_session(CreateSessionRequest::new("plain", MappingMethod::Graph))
        .unwrap();
    // The sketch session says which observation model its MCL weighs scans with (the
    // default, not asked for); a session without a drawing has none.
    assert_eq!(
        session.mcl_observation,
        Some(sketchslam_api::DrawingObservationModel::RayCast)
    );
    assert_eq!(baseline.mcl_observation, None);
    // Likewise which localization on the drawing holds its heading.
    assert_eq!(
        session.drawing_localization,
        Some(sketchslam_api::DrawingLocalization::Mcl)
    );
    assert_eq!(baseline.drawing_localization, None);
    let id = session.id.clone();
    let ipc = IpcConfig::new(&prefix).unwrap();
    publish_until_processed(&reg, &ipc, "drawn", &id, (0, 20, 0.0), 20);
    // Not asked for, the start stands; asked for and marked 12° off, the first scan's walls
    // turn it back onto the drawing's (near 0°).
    assert_eq!(
        reg.get_session(&id).unwrap().start_heading_from_walls_deg,
        None
    );
    let mut turned_start = sketch_start(&sketch.id, 66.9, 320.3);
    turned_start.robot_id = "turned".into();
    turned_start.start.as_mut().unwrap().heading_deg = 12.0;
    turned_start.start_heading_from_walls = Some(true);
    let turned = reg.create_session(turned_start).unwrap();
    assert_eq!(turned.start_heading_from_walls_deg, None);
    publish_until_processed(&reg, &ipc, "turned", &turned.id, (0, 2, 0.0), 2);
    let read = reg
        .get_session(&turned.id)
        .unwrap()
        .start_heading_from_walls_deg
        .expect("the walls give the start heading");
    assert!(read.abs() < 3.0, "start read at {read}°");
    reg.stop_session(&turned.id).unwrap();
    // One pose on the drawing per stamp of the map-frame trajectory: at the scans MCL's, or
    // the warp's once the session's worker has registered the map.
    let live = reg.sketch_trajectory(&id).unwrap();
    assert_eq!(live.points.len(), reg.trajectory(&id).unwrap().points.len());
    let at_scans = |p: &&sketchslam_api::SketchTrajectoryPointInfo| {
        ["mcl", "warp", "warp_extrapolated"].contains(&p.source.as_str())
    };
    assert!(live.points.iter().filter(at_scans).count() >= 20);
    assert!(
        live.points
            .iter()
            .all(|p| p.u.is_finite() && p.meters_per_pixel > 0.0)
    );
    // Without a drawing there is none, running or stopped.
    let plain = &baseline.id;
    assert_eq!(
        code(reg.sketch_trajectory(plain).unwrap_err()),
        "no_drawing"
    );
    reg.stop_session(plain).unwrap();
    assert_eq!(
        code(reg.sketch_trajectory(plain).unwrap_err()),
        "no_drawing"
    );

    reg.stop_session(&id).unwrap();
    // The same stamps; the poses through the final map's warp, fitted at the stop.
    let stopped = reg.sketch_trajectory(&id).unwrap();
    let stamps = |t: &sketchslam_api::SketchTrajectoryResponse| -> Vec<f64> {
        t.points.iter().map(|p| p.t).collect()
    };
    assert_eq!(stamps(&stopped), stamps(&live));
    reg.shutdown();
    drop(reg);
    // Stored with the session, served the same after a restart.
    let reg = registry(&dir.0, &prefix);
    assert_eq!(reg.sketch_trajectory(&id).unwrap(), stopped);
    assert!(
        dir.0
            .join(format!("sessions/{id}/sketch-trajectory.json"))
            .is_file()
    );
    reg.shutdown();
}

#[test]
fn a_session_maps_counts_gaps_and_survives_a_restart() {
    let dir = TempDir::new();
    let prefix = unique_prefix();
    let reg = registry(&dir.0, &prefix);
    let sketch = reg
        .create_sketch(named("A"), Bytes::from(sketch_a()))
        .unwrap();
    let session = reg
        .create_session(CreateSessionRequest::new("bot", MappingMethod::Icp))
        .unwrap();
    let id = session.id.clone();
    let mut events = reg.subscribe_events(&id, None).unwrap().live;
    assert!(!reg.pose(&id).unwrap().position_initialized);

    // The publisher starts after the session, sends 20 scans, and goes away.
    let ipc = IpcConfig::new(&prefix).unwrap();
    publish_until_processed(&reg, &ipc, "bot", &id, (0, 20, 0.0), 20);
    let info = reg.get_session(&id).unwrap();
    assert_eq!(info.state, SessionState::Mapping);
    assert_eq!(info.scans_lost, 0);
    // It comes back with a gap of 5 sequence numbers.
    publish_until_processed(&reg, &ipc, "bot", &id, (25, 10, 1.25), 30);
    wait_for("the gap", Duration::from_secs(5), || {
        reg.get_session(&id).unwrap().scans_lost == 5
    });
    let pose = reg.pose(&id).unwrap();
    assert!(pose.position_initialized);
    assert!((pose.x - 1.70).abs() < 0.2, "x = {}", pose.x);
    assert!(pose.sketch.is_none());
    // The live feed saw the status change and poses.
    let mut saw_pose = false;
    let mut saw_mapping = false;
    let mut ids = Vec::new();
    while let Ok(e) = events.try_recv() {
        ids.push(e.id);
        match e.event {
            sketchslam_api::SessionEvent::Pose(_) => saw_pose = true,
            sketchslam_api::SessionEvent::Status(s) => {
                saw_mapping |= s.state == SessionState::Mapping
            }
        }
    }
    assert!(saw_pose && saw_mapping);
    // Numbered 1, 2, ... in order; a client that saw the first resumes with all the others.
    assert_eq!(ids, (1..=ids.len() as u64).collect::<Vec<_>>());
    let resumed = reg.subscribe_events(&id, Some(1)).unwrap();
    assert!(resumed.resumed);
    assert_eq!(resumed.replay.len(), ids.len() - 1);
    let live_grid = reg.map_occupancy(&id).unwrap();
    assert!(live_grid.data.iter().any(|&v| v >= 65));
    let metrics = reg.metrics_text();
    assert!(
        metrics.contains(&format!(
            "sketchslam_scans_processed_total{{session=\"{id}\",robot=\"bot\",method=\"icp\"}} 30"
        )),
        "{metrics}"
    );
    assert!(
        metrics.contains("sketchslam_scan_processing_seconds_count 30"),
        "{metrics}"
    );
    // The session's heap: at least its grid, far below 50 MB after 30 scans.
    let heap: u64 = metrics
        .lines()
        .find_map(|l| {
            l.strip_prefix(&format!(
                "sketchslam_session_heap_bytes{{session=\"{id}\",robot=\"bot\",method=\"icp\"}} "
            ))
        })
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no heap gauge: {metrics}"));
    assert!(heap > 1000 && heap < 50 << 20, "{heap} bytes");

    let stopped = reg.stop_session(&id).unwrap();
    assert_eq!(stopped.state, SessionState::Stopped);
    // A stopped session's series go (the count by state keeps it); the process is measured.
    let metrics = reg.metrics_text();
    assert!(!metrics.contains(&format!("session=\"{id}\"")), "{metrics}");
    assert!(
        metrics.contains("sketchslam_sessions{state=\"stopped\"} 1"),
        "{metrics}"
    );
    assert!(metrics.contains("process_open_fds "), "{metrics}");
    assert!(stopped.stopped_unix_ms.is_some());
    // The robot may map again once its session stopped.
    let trajectory = reg.trajectory(&id).unwrap();
    let map_png = reg.map_png(&id).unwrap();
    let map_yaml = reg.map_yaml(&id).unwrap();
    let map_json = reg.map_occupancy(&id).unwrap();
    assert_same_grid(&map_json, &live_grid);
    assert!(map_yaml.contains("image: map.pgm"));
    assert!(trajectory.points.len() >= 30);
    assert!(dir.0.join(format!("sessions/{id}/trajectory.csv")).exists());
    reg.shutdown();
    drop(reg);

    // A new registry on the same data dir serves the same things.
    let reg = registry(&dir.0, &prefix);
    assert_eq!(reg.get_sketch(&sketch.id).unwrap(), sketch);
    let again = reg.get_session(&id).unwrap();
    assert_eq!(again, stopped);
    assert_eq!(reg.map_png(&id).unwrap(), map_png);
    assert_eq!(reg.map_yaml(&id).unwrap(), map_yaml);
    assert!(reg.map_pgm(&id).unwrap().starts_with(b"P5"));
    assert_same_grid(&reg.map_occupancy(&id).unwrap(), &map_json);
    let t2 = reg.trajectory(&id).unwrap();
    assert_eq!(t2.points.len(), trajectory.points.len());
    for (a, b) in t2.points.iter().zip(&trajectory.points) {
        assert!(
            (a.t - b.t).abs() < 1e-6
                && (a.x - b.x).abs() < 1e-5
                && (a.theta - b.theta).abs() < 1e-5
        );
    }
    assert_eq!(reg.pose(&id).unwrap().x, reg.pose(&id).unwrap().x);
    let mut rx = reg.subscribe_events(&id, None).unwrap().live;
    assert!(matches!(
        rx.try_recv(),
        Err(tokio::sync::broadcast::error::TryRecvError::Closed)
    ));
    reg.shutdown();
}

#[test]
fn fleets_run_side_by_side_within_the_limit() {
    let dir = TempDir::new();
    let reg = registry(&dir.0, &unique_prefix());
    let req = |robot: &str| CreateSessionRequest::new(robot, MappingMethod::Odometry);
    let ids: Vec<String> = (0..4)
        .map(|i| reg.create_session(req(&format!("r{i}"))).unwrap().id)
        .collect();
    assert_eq!(
        code(reg.create_session(req("r9")).unwrap_err()),
        "too_many_sessions"
    );
    reg.stop_session(&ids[0]).unwrap();
    reg.create_session(req("r9")).unwrap();
    assert_eq!(reg.list_sessions().unwrap().len(), 5);
    reg.shutdown();
    assert!(
        reg.list_sessions()
            .unwrap()
            .iter()
            .all(|s| s.state == SessionState::Stopped)
    );
    assert_eq!(
        code(reg.create_session(req("r10")).unwrap_err()),
        "unavailable"
    );
}
