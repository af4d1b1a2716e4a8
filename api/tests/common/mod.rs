//! The in-memory fake backend shared by the router and client tests.
#![allow(dead_code, missing_docs)]

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use axum::body::Bytes;
use sketchslam_api::*;

pub const PNG_MAGIC: &[u8] = b"\x89PNG\r\n\x1a\n";

/// A fake "image": PNG magic, then `W H` and the number of lines as ASCII.
pub fn fake_png(width: u32, height: u32, lines: usize) -> Vec<u8> {
    let mut v = PNG_MAGIC.to_vec();
    v.extend_from_slice(format!("{width} {height} {lines}").as_bytes());
    v
}

#[derive(Default)]
pub struct Fake {
    pub sketches: Mutex<BTreeMap<String, SketchInfo>>,
    pub sessions: Mutex<BTreeMap<String, SessionInfo>>,
    pub events: Mutex<BTreeMap<String, std::sync::Arc<EventLog>>>,
    pub next: Mutex<u32>,
    /// Uploads being handled now, and the most at once so far.
    pub uploads_in_flight: AtomicUsize,
    pub max_uploads_in_flight: AtomicUsize,
}

/// A fake image whose upload takes `ms` milliseconds to handle.
pub fn slow_fake_png(width: u32, height: u32, lines: usize, ms: u64) -> Vec<u8> {
    let mut v = fake_png(width, height, lines);
    v.extend_from_slice(format!(" slow {ms}").as_bytes());
    v
}

impl Fake {
    fn next_id(&self) -> String {
        let mut n = self.next.lock().unwrap();
        *n += 1;
        format!("00000000-0000-4000-8000-{:012}", *n)
    }

    fn create_sketch_now(
        &self,
        upload: SketchUpload,
        image: Bytes,
    ) -> Result<SketchInfo, ApiError> {
        let Some(rest) = image.strip_prefix(PNG_MAGIC) else {
            return Err(ApiError::invalid(
                "invalid_image",
                "the body is not a PNG or JPEG image",
            ));
        };
        let text = String::from_utf8_lossy(rest);
        let (text, slow) = match text.split_once(" slow ") {
            Some((t, ms)) => (t.to_string(), ms.parse().unwrap_or(0)),
            None => (text.to_string(), 0),
        };
        std::thread::sleep(std::time::Duration::from_millis(slow));
        let nums: Vec<u64> = text.split(' ').filter_map(|s| s.parse().ok()).collect();
        let [w, h, lines] = nums[..] else {
            return Err(ApiError::invalid(
                "invalid_image",
                "the image does not decode",
            ));
        };
        if lines == 0 {
            return Err(ApiError::invalid(
                "no_lines",
                "no lines found in the drawing",
            ));
        }
        let info = SketchInfo {
            id: self.next_id(),
            name: upload.name,
            width_px: w as u32,
            height_px: h as u32,
            created_unix_ms: 1,
            meters_per_pixel: upload.meters_per_pixel,
            lines: (0..lines as usize)
                .map(|index| SketchLineInfo {
                    index,
                    a: PixelPoint { u: 0.0, v: 0.0 },
                    b: PixelPoint { u: 10.0, v: 0.0 },
                    angle_deg: 0.0,
                    length_px: 10.0,
                })
                .collect(),
        };
        self.sketches
            .lock()
            .unwrap()
            .insert(info.id.clone(), info.clone());
        Ok(info)
    }

    fn session(&self, id: &str) -> Result<SessionInfo, ApiError> {
        self.sessions
            .lock()
            .unwrap()
            .get(id)
            .cloned()
            .ok_or_else(|| ApiError::session_not_found(id))
    }
}

impl Backend for Fake {
    fn create_sketch(&self, upload: SketchUpload, image: Bytes) -> Result<SketchInfo, ApiError> {
        let now = self.uploads_in_flight.fetch_add(1, Ordering::SeqCst) + 1;
        self.max_uploads_in_flight.fetch_max(now, Ordering::SeqCst);
        let answer = self.create_sketch_now(upload, image);
        self.uploads_in_flight.fetch_sub(1, Ordering::SeqCst);
        answer
    }

    fn list_sketches(&self) -> Result<Vec<SketchSummary>, ApiError> {
        Ok(self
            .sketches
            .lock()
            .unwrap()
            .values()
            .map(SketchInfo::summary)
            .collect())
    }

    fn get_sketch(&self, id: &str) -> Result<SketchInfo, ApiError> {
        self.sketches
            .lock()
            .unwrap()
            .get(id)
            .cloned()
            .ok_or_else(|| ApiError::sketch_not_found(id))
    }

    fn sketch_overlay_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        self.get_sketch(id)?;
        Ok(PNG_MAGIC.to_vec())
    }

    fn delete_sketch(&self, id: &str) -> Result<(), ApiError> {
        self.sketches
            .lock()
            .unwrap()
            .remove(id)
            .map(|_| ())
            .ok_or_else(|| ApiError::sketch_not_found(id))
    }

    fn create_session(&self, mut r: CreateSessionRequest) -> Result<SessionInfo, ApiError> {
        if let Some(sketch_id) = &r.sketch_id {
            let sketch = self.get_sketch(sketch_id)?;
            r.meters_per_pixel = r.meters_per_pixel.or(sketch.meters_per_pixel);
            if r.meters_per_pixel.is_none() {
                return Err(ApiError::invalid(
                    "missing_field",
                    "meters_per_pixel: required for method \"sketch\" on a drawing that declared no scale",
                ));
            }
            let start = r.start.unwrap();
            if start.u >= sketch.width_px as f64 || start.v >= sketch.height_px as f64 {
                return Err(ApiError::invalid(
                    "invalid_start",
                    "start: outside the sketch",
                ));
            }
        }
        let mut sessions = self.sessions.lock().unwrap();
        if sessions
            .values()
            .any(|s| s.robot_id == r.robot_id && s.state != SessionState::Stopped)
        {
            return Err(ApiError::conflict("robot_busy", "robot already mapping"));
        }
        let info = SessionInfo {
            id: self.next_id(),
            robot_id: r.robot_id,
            method: r.method,
            sketch_id: r.sketch_id,
            start: r.start,
            meters_per_pixel_guess: r.meters_per_pixel,
            state: SessionState::WaitingForData,
            scans_processed: 0,
            scans_lost: 0,
            publisher_restarts: 0,
            localization_score: 0.0,
            recoveries: 0,
            loop_closures: 0,
            loop_closures_rejected: 0,
            estimated_meters_per_pixel: r.meters_per_pixel,
            last_error: None,
            created_unix_ms: 2,
            stopped_unix_ms: None,
            stop_reason: None,
            lidar_mount: r.lidar_mount,
            odometry_noise: r.odometry_noise,
            checkpoint_unix_ms: None,
            start_heading_from_walls_deg: None,
            mcl_observation: r.mcl_observation,
            drawing_localization: r.drawing_localization,
        };
        sessions.insert(info.id.clone(), info.clone());
        self.events
            .lock()
            .unwrap()
            .insert(info.id.clone(), std::sync::Arc::new(EventLog::new(16)));
        Ok(info)
    }

    fn list_sessions(&self) -> Result<Vec<SessionInfo>, ApiError> {
        Ok(self.sessions.lock().unwrap().values().cloned().collect())
    }

    fn get_session(&self, id: &str) -> Result<SessionInfo, ApiError> {
        self.session(id)
    }

    fn stop_session(&self, id: &str) -> Result<SessionInfo, ApiError> {
        let mut sessions = self.sessions.lock().unwrap();
        let s = sessions
            .get_mut(id)
            .ok_or_else(|| ApiError::session_not_found(id))?;
        s.state = SessionState::Stopped;
        s.stopped_unix_ms = Some(3);
        if let Some(log) = self.events.lock().unwrap().remove(id) {
            log.publish(SessionEvent::Status(Box::new(s.clone())));
        }
        Ok(s.clone())
    }

    fn pose(&self, id: &str) -> Result<PoseResponse, ApiError> {
        self.session(id)?;
        Ok(PoseResponse {
            session_id: id.to_string(),
            x: 1.0,
            y: 2.0,
            theta: 0.5,
            stamp: Some(1.5),
            sketch: Some(SketchPoseInfo {
                u: 66.9,
                v: 320.3,
                heading_deg: 1.1,
                meters_per_pixel: 0.1,
                source: Some(SketchPoseSource::Mcl),
            }),
            map_id: id.to_string(),
            position_initialized: true,
            localization_score: 0.9,
        })
    }

    fn trajectory(&self, id: &str) -> Result<TrajectoryResponse, ApiError> {
        self.session(id)?;
        Ok(TrajectoryResponse {
            session_id: id.to_string(),
            points: vec![
                TrajectoryPointInfo {
                    t: 0.0,
                    x: 0.0,
                    y: 0.0,
                    theta: 0.0,
                },
                TrajectoryPointInfo {
                    t: 0.05,
                    x: 0.04,
                    y: 0.0,
                    theta: 0.01,
                },
            ],
        })
    }

    fn sketch_trajectory(&self, id: &str) -> Result<SketchTrajectoryResponse, ApiError> {
        let info = self.session(id)?;
        if info.method != MappingMethod::Sketch {
            return Err(ApiError::invalid(
                "no_drawing",
                format!("session {id} maps without a drawing"),
            ));
        }
        let point = |t: f64, source: &str| SketchTrajectoryPointInfo {
            t,
            u: 66.9 + 10.0 * t,
            v: 320.3,
            heading: 0.02,
            meters_per_pixel: 0.1,
            source: source.into(),
        };
        Ok(SketchTrajectoryResponse {
            session_id: id.to_string(),
            points: vec![point(0.0, "mcl"), point(0.025, "odometry")],
        })
    }

    fn map_png(&self, id: &str) -> Result<TaggedPng, ApiError> {
        self.session(id)?;
        Ok(TaggedPng::in_frame(
            PNG_MAGIC.to_vec(),
            MapFrame {
                resolution_m: 0.05,
                origin_x_m: -1.5,
                origin_y_m: 2.25,
            },
        ))
    }

    fn map_pgm(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        self.session(id)?;
        Ok(b"P5\n2 1\n255\n\x00\xfe".to_vec())
    }

    fn map_yaml(&self, id: &str) -> Result<String, ApiError> {
        self.session(id)?;
        Ok("image: map.pgm\nresolution: 0.05\n".to_string())
    }

    fn map_occupancy(&self, id: &str) -> Result<OccupancyGridResponse, ApiError> {
        self.session(id)?;
        Ok(OccupancyGridResponse {
            header: RosHeader {
                stamp: RosTime::default(),
                frame_id: "map".to_string(),
            },
            info: MapMetaData {
                map_load_time: RosTime::default(),
                resolution: 0.05,
                width: 2,
                height: 1,
                origin: RosPose::planar(-0.05, 0.0, 0.0),
            },
            data: vec![-1, 100],
        })
    }

    fn subscribe_events(
        &self,
        id: &str,
        last_seen: Option<u64>,
    ) -> Result<EventSubscription, ApiError> {
        self.session(id)?;
        match self.events.lock().unwrap().get(id) {
            Some(log) => Ok(log.subscribe(last_seen)),
            None => Ok(EventSubscription::ended()),
        }
    }

    fn metrics_text(&self) -> String {
        "# TYPE sketchslam_scans_processed_total counter\nsketchslam_scans_processed_total{session=\"x\"} 0\n"
            .to_string()
    }
}
