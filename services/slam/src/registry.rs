//! The session registry: sketches and sessions, running and stopped; implements the API's
//! [`Backend`].
//!
//! Locks are held only to look entries up or swap them; decoding sketches, starting and
//! stopping sessions and rendering maps happen outside them. The drawings themselves are
//! the [`SketchStore`]'s.

use std::collections::{BTreeMap, HashSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use axum::body::Bytes;
use sketchslam_api::{
    ApiError, Backend, CreateSessionRequest, EventSubscription, MapFrame, MappingMethod,
    OccupancyGridResponse, PoseResponse, RegistrationInfo, SessionInfo, SessionState,
    SketchInMapResponse, SketchInfo, SketchSummary, SketchTrajectoryResponse, SketchUpload,
    StopReason, TaggedPng, TrajectoryResponse, TransformRequest, TransformResponse,
};
use sketchslam_ipc::IpcConfig;

use super::RuntimeError;
use super::codec::{no_drawing, occupancy_response, stored_occupancy, stored_trajectory_response};
use super::config::RegistryConfig;
use super::method::{
    api_drawing_localization, api_observation, api_odometry_noise, engine_heading_view,
    engine_method, engine_observation, engine_odometry_noise,
};
use super::metrics::{Histogram, RunningSession, render_metrics};
use super::process_stats::ProcessStats;
use super::registration_codec::{not_registered, registration_from_info, transform_response};
use super::session::{Session, lock, now_unix_ms};
use super::sketch_store::SketchStore;
use super::storage::{SessionMeta, Storage};
use super::vda5050::StartedSession;
use sketchslam_engine::EngineError;
use sketchslam_engine::mapper::{Mapper, SketchPrior};
use sketchslam_engine::sketch::SketchPose;
use tokio::sync::mpsc;

enum Entry {
    Live(Arc<Session>),
    Stopped(Box<SessionMeta>),
}

impl Entry {
    fn info(&self) -> SessionInfo {
        match self {
            Entry::Live(s) => s.info(),
            Entry::Stopped(m) => m.info.clone(),
        }
    }
}

#[derive(Default)]
struct Sessions {
    entries: BTreeMap<String, Entry>,
    /// Robots whose session is being started (not yet in `entries`).
    starting: HashSet<String>,
}

/// Sketches and sessions of one service.
pub struct Registry {
    config: RegistryConfig,
    ipc: IpcConfig,
    storage: Storage,
    histogram: Arc<Histogram>,
    sketches: SketchStore,
    sessions: Mutex<Sessions>,
    closing: AtomicBool,
    /// Told of every session started (the VDA 5050 bridges); dropped at shutdown.
    observer: Mutex<Option<mpsc::UnboundedSender<StartedSession>>>,
}

impl Registry {
    /// Opens the data dir and loads what a previous run stored.
    pub fn open(config: RegistryConfig) -> Result<Registry, RuntimeError> {
        let ipc = IpcConfig::new(&config.ipc_prefix)
            .map_err(|e| RuntimeError::Config(format!("ipc prefix: {e}")))?;
        let (storage, leftovers) =
            Storage::open(&config.data_dir).map_err(|e| RuntimeError::DataDir {
                path: config.data_dir.clone(),
                source: e,
            })?;
        let data_dir_err = |e| RuntimeError::DataDir {
            path: config.data_dir.clone(),
            source: e,
        };
        let sketches = SketchStore::open(&storage, config.max_sketches).map_err(data_dir_err)?;
        let mut sessions = Sessions::default();
        for mut meta in storage.load_sessions().map_err(data_dir_err)? {
            if matches!(
                meta.info.state,
                SessionState::WaitingForData | SessionState::Mapping
            ) {
                // A checkpoint of a session that was running when the service died.
                tracing::warn!(
                    session = %meta.info.id,
                    robot = %meta.info.robot_id,
                    scans = meta.info.scans_processed,
                    checkpoint_unix_ms = meta.info.checkpoint_unix_ms,
                    "a session was running when the service ended: listed as interrupted, \
                     with its last checkpoint"
                );
                meta.info.state = SessionState::Interrupted;
            }
            sessions
                .entries
                .insert(meta.info.id.clone(), Entry::Stopped(Box::new(meta)));
        }
        tracing::info!(
            data_dir = %config.data_dir.display(),
            sketches = sketches.len(),
            sessions = sessions.entries.len(),
            temp_files_removed = leftovers.temp_files_removed.len(),
            incomplete_moved_aside = leftovers.incomplete_moved.len(),
            "registry opened"
        );
        Ok(Registry {
            config,
            ipc,
            storage,
            histogram: Arc::new(Histogram::default()),
            sketches,
            sessions: Mutex::new(sessions),
            closing: AtomicBool::new(false),
            observer: Mutex::new(None),
        })
    }

    fn live(&self, id: &str) -> Result<Result<Arc<Session>, Box<SessionMeta>>, ApiError> {
        match lock(&self.sessions).entries.get(id) {
            Some(Entry::Live(s)) => Ok(Ok(s.clone())),
            Some(Entry::Stopped(m)) => Ok(Err(m.clone())),
            None => Err(ApiError::session_not_found(id)),
        }
    }

    fn stored_file(&self, id: &str, name: &str) -> Result<Vec<u8>, ApiError> {
        self.storage
            .read_session_file(id, name)
            .map_err(|e| ApiError::internal(format!("reading {name} of session {id}: {e}")))
    }

    /// A stopped session's registration file: `no_drawing` for a session without a drawing,
    /// `not_registered` when it stopped before anything could be registered.
    fn stored_registration_file(
        &self,
        id: &str,
        meta: &SessionMeta,
        name: &str,
    ) -> Result<Vec<u8>, ApiError> {
        if meta.info.method != MappingMethod::Sketch {
            return Err(no_drawing(id, meta.info.method.as_str()));
        }
        match self.storage.read_session_file(id, name) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(not_registered(id)),
            other => other
                .map_err(|e| ApiError::internal(format!("reading {name} of session {id}: {e}"))),
        }
    }

    /// Stops a session for `reason` and stores it; a stopped one answers its final status.
    fn stop_because(&self, id: &str, reason: StopReason) -> Result<SessionInfo, ApiError> {
        let session = match self.live(id)? {
            Ok(session) => session,
            Err(meta) => return Ok(meta.info),
        };
        let meta = session.stop_with(reason, |meta, files| {
            self.storage
                .save_session(meta, files)
                .map_err(|e| ApiError::internal(format!("storing session {id}: {e}")))
        })?;
        let info = meta.info.clone();
        lock(&self.sessions)
            .entries
            .insert(id.to_string(), Entry::Stopped(Box::new(meta)));
        Ok(info)
    }

    /// Stops (and stores) every running session whose robot has sent nothing for
    /// `silent` since its last message; returns their ids. A session still waiting for its
    /// robot's first message is left running.
    pub fn stop_silent_sessions(&self, silent: std::time::Duration) -> Vec<String> {
        let quiet: Vec<String> = self
            .running()
            .into_iter()
            .filter(|s| s.silent_for().is_some_and(|d| d >= silent))
            .map(|s| s.id.clone())
            .collect();
        quiet
            .into_iter()
            .filter(|id| match self.stop_because(id, StopReason::RobotSilent) {
                Ok(_) => {
                    tracing::info!(session = %id, silent_s = silent.as_secs_f64(), "robot silent: session stopped and stored");
                    true
                }
                Err(e) => {
                    tracing::error!(session = %id, error = %e, "stopping a silent session failed");
                    false
                }
            })
            .collect()
    }

    /// Writes a checkpoint of every running session that processed something since its
    /// last one ([`Session::checkpoint`]); returns how many were written. A failed write is
    /// logged and retried at the next call.
    pub fn checkpoint_sessions(&self) -> usize {
        self.running().iter().filter(|s| self.checkpoint(s)).count()
    }

    /// The running sessions, copied out of the registry's lock.
    fn running(&self) -> Vec<Arc<Session>> {
        lock(&self.sessions)
            .entries
            .values()
            .filter_map(|e| match e {
                Entry::Live(s) => Some(s.clone()),
                Entry::Stopped(_) => None,
            })
            .collect()
    }

    /// One session's checkpoint; false when none was written.
    fn checkpoint(&self, session: &Session) -> bool {
        let started = std::time::Instant::now();
        let written = session.checkpoint(|meta, files| {
            self.storage.save_session(meta, files).map_err(|e| {
                ApiError::internal(format!("checkpoint of session {}: {e}", session.id))
            })
        });
        match written {
            Ok(written) => {
                if written {
                    tracing::debug!(
                        session = %session.id,
                        elapsed_ms = started.elapsed().as_secs_f64() * 1e3,
                        "checkpoint written"
                    );
                }
                written
            }
            Err(e) => {
                tracing::error!(session = %session.id, error = %e, "checkpoint failed");
                false
            }
        }
    }

    /// Sends every session started from now on, with its events from its start, to
    /// `observer` (until [`Registry::shutdown`]).
    pub fn observe_sessions(&self, observer: mpsc::UnboundedSender<StartedSession>) {
        *lock(&self.observer) = Some(observer);
    }

    /// Stops every running session (storing its map) and refuses new ones; the observer
    /// is dropped once they are stopped, so it learns that no session will follow.
    pub fn shutdown(&self) {
        self.closing.store(true, Ordering::SeqCst);
        let ids: Vec<String> = self.running().iter().map(|s| s.id.clone()).collect();
        std::thread::scope(|scope| {
            for id in &ids {
                scope.spawn(move || {
                    if let Err(e) = self.stop_because(id, StopReason::Shutdown) {
                        tracing::error!(session = %id, error = %e, "stopping at shutdown failed");
                    }
                });
            }
        });
        lock(&self.observer).take();
        tracing::info!(stopped = ids.len(), "registry shut down");
    }

    fn start_session(&self, request: &CreateSessionRequest, id: &str) -> Result<Session, ApiError> {
        let method = engine_method(request.method);
        let prior = match request.method {
            MappingMethod::Sketch => {
                let sketch_id = request.sketch_id.as_deref().unwrap_or_default();
                let sketch = self.sketches.sketch(sketch_id)?;
                let start = request
                    .start
                    .ok_or_else(|| ApiError::invalid("missing_field", "start: required"))?;
                if !sketch.contains(start.u, start.v) {
                    return Err(ApiError::invalid(
                        "invalid_start",
                        format!(
                            "start: ({}, {}) lies outside the sketch ({} × {} px)",
                            start.u, start.v, sketch.width_px, sketch.height_px
                        ),
                    ));
                }
                if sketch.is_stroke(start.u, start.v) {
                    return Err(ApiError::invalid(
                        "invalid_start",
                        format!(
                            "start: ({}, {}) lies on a drawn wall; mark the start in free space",
                            start.u, start.v
                        ),
                    ));
                }
                Some(SketchPrior {
                    sketch,
                    start: SketchPose {
                        u_px: start.u,
                        v_px: start.v,
                        heading_rad: start.heading_deg.to_radians(),
                        meters_per_pixel: request.meters_per_pixel.unwrap_or_default(),
                    },
                })
            }
            MappingMethod::Icp | MappingMethod::Graph | MappingMethod::Odometry => None,
        };
        let mut mapper_config = self.config.mapper.clone();
        if let Some(seed) = request.seed {
            mapper_config.seed = seed;
        }
        if let Some(m) = request.lidar_mount {
            mapper_config.lidar_mount = m.pose();
        }
        // The model the session runs: the request's factors over the service's default.
        let odometry_noise = request.odometry_noise.map(|asked| {
            let filled =
                engine_odometry_noise(&asked, mapper_config.odometry_noise.unwrap_or_default());
            mapper_config.odometry_noise = Some(filled);
            api_odometry_noise(&filled)
        });
        if let Some(model) = request.mcl_observation {
            mapper_config.mcl.observation = engine_observation(model);
        }
        if let Some(from_walls) = request.start_heading_from_walls {
            mapper_config.sketch_start_from_walls = from_walls;
        }
        if let Some(localization) = request.drawing_localization {
            mapper_config.sketch_heading_view = engine_heading_view(localization);
        }
        // What the session runs, asked for or the service's default (sketch sessions only).
        let sketch = request.method == MappingMethod::Sketch;
        let mcl_observation = sketch.then(|| api_observation(mapper_config.mcl.observation));
        let drawing_localization =
            sketch.then(|| api_drawing_localization(mapper_config.sketch_heading_view));
        let mapper = Mapper::new(method, prior, mapper_config).map_err(|e| match e {
            EngineError::InvalidParameter { name, reason } => {
                ApiError::invalid("invalid_parameter", format!("{name}: {reason}"))
            }
            other => ApiError::internal(other),
        })?;
        let info = SessionInfo {
            id: id.to_string(),
            robot_id: request.robot_id.clone(),
            method: request.method,
            sketch_id: request.sketch_id.clone(),
            start: request.start,
            meters_per_pixel_guess: request.meters_per_pixel,
            state: SessionState::WaitingForData,
            scans_processed: 0,
            scans_lost: 0,
            publisher_restarts: 0,
            localization_score: 0.0,
            recoveries: 0,
            loop_closures: 0,
            loop_closures_rejected: 0,
            estimated_meters_per_pixel: request.meters_per_pixel,
            last_error: None,
            created_unix_ms: now_unix_ms(),
            stopped_unix_ms: None,
            stop_reason: None,
            lidar_mount: request.lidar_mount,
            odometry_noise,
            mcl_observation,
            drawing_localization,
            checkpoint_unix_ms: None,
            start_heading_from_walls_deg: None,
        };
        Session::start(info, mapper, self.ipc.clone(), self.histogram.clone())
    }
}

impl Backend for Registry {
    fn create_sketch(&self, upload: SketchUpload, image: Bytes) -> Result<SketchInfo, ApiError> {
        self.sketches.create(upload, &image)
    }

    fn list_sketches(&self) -> Result<Vec<SketchSummary>, ApiError> {
        Ok(self.sketches.list())
    }

    fn get_sketch(&self, id: &str) -> Result<SketchInfo, ApiError> {
        self.sketches.info(id)
    }

    fn sketch_overlay_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        self.sketches.overlay_png(id)
    }

    fn delete_sketch(&self, id: &str) -> Result<(), ApiError> {
        self.sketches.delete(id)
    }

    fn create_session(&self, mut request: CreateSessionRequest) -> Result<SessionInfo, ApiError> {
        if self.closing.load(Ordering::SeqCst) {
            return Err(ApiError::Unavailable("the service is shutting down".into()));
        }
        // Cheap checks first, so a bad request never touches the robot's services.
        let mut drawing = None;
        if request.method == MappingMethod::Sketch {
            let info = self
                .sketches
                .info(request.sketch_id.as_deref().unwrap_or_default())?;
            let drawing = drawing.insert(info.summary());
            // No scale given: the one the drawing declared at upload.
            request.meters_per_pixel = request.meters_per_pixel.or(drawing.meters_per_pixel);
            if request.meters_per_pixel.is_none() {
                return Err(ApiError::invalid(
                    "missing_field",
                    format!(
                        "meters_per_pixel: required for method \"sketch\" on drawing {} (it declared no scale at upload)",
                        drawing.id
                    ),
                ));
            }
        }
        {
            let mut sessions = lock(&self.sessions);
            let busy = sessions.starting.contains(&request.robot_id)
                || sessions.entries.values().any(|e| match e {
                    Entry::Live(s) => s.robot_id == request.robot_id,
                    Entry::Stopped(_) => false,
                });
            if busy {
                return Err(ApiError::conflict(
                    "robot_busy",
                    format!(
                        "robot {:?} is already in a running session; stop it first",
                        request.robot_id
                    ),
                ));
            }
            let running = sessions
                .entries
                .values()
                .filter(|e| matches!(e, Entry::Live(_)))
                .count()
                + sessions.starting.len();
            if running >= self.config.max_sessions {
                return Err(ApiError::conflict(
                    "too_many_sessions",
                    format!(
                        "{running} sessions are running, the limit is {}",
                        self.config.max_sessions
                    ),
                ));
            }
            sessions.starting.insert(request.robot_id.clone());
        }
        let id = uuid::Uuid::new_v4().to_string();
        let started = self.start_session(&request, &id);
        let mut sessions = lock(&self.sessions);
        sessions.starting.remove(&request.robot_id);
        let session = Arc::new(started?);
        let info = session.info();
        if let Some(observer) = lock(&self.observer).as_ref() {
            // From its first event (kept since the start), not from now.
            let _ = observer.send((info.clone(), drawing, session.subscribe(Some(0))));
        }
        sessions.entries.insert(id, Entry::Live(session.clone()));
        drop(sessions);
        // On disk from its start, so that a crash leaves a record of it (`interrupted`).
        self.checkpoint(&session);
        Ok(info)
    }

    fn list_sessions(&self) -> Result<Vec<SessionInfo>, ApiError> {
        let mut list: Vec<SessionInfo> = lock(&self.sessions)
            .entries
            .values()
            .map(Entry::info)
            .collect();
        list.sort_by(|a, b| (a.created_unix_ms, &a.id).cmp(&(b.created_unix_ms, &b.id)));
        Ok(list)
    }

    fn get_session(&self, id: &str) -> Result<SessionInfo, ApiError> {
        lock(&self.sessions)
            .entries
            .get(id)
            .map(Entry::info)
            .ok_or_else(|| ApiError::session_not_found(id))
    }

    fn stop_session(&self, id: &str) -> Result<SessionInfo, ApiError> {
        self.stop_because(id, StopReason::Requested)
    }

    fn pose(&self, id: &str) -> Result<PoseResponse, ApiError> {
        Ok(match self.live(id)? {
            Ok(s) => s.pose(),
            Err(meta) => meta.pose,
        })
    }

    fn trajectory(&self, id: &str) -> Result<TrajectoryResponse, ApiError> {
        match self.live(id)? {
            Ok(s) => Ok(s.trajectory()),
            Err(_) => {
                let csv = self.stored_file(id, "trajectory.csv")?;
                stored_trajectory_response(id, &String::from_utf8_lossy(&csv))
            }
        }
    }

    fn sketch_trajectory(&self, id: &str) -> Result<SketchTrajectoryResponse, ApiError> {
        match self.live(id)? {
            Ok(s) => s.sketch_trajectory(),
            Err(meta) => {
                if meta.info.method != MappingMethod::Sketch {
                    return Err(no_drawing(id, meta.info.method.as_str()));
                }
                let json = self.stored_file(id, "sketch-trajectory.json")?;
                serde_json::from_slice(&json).map_err(|e| {
                    ApiError::internal(format!("sketch-trajectory.json of session {id}: {e}"))
                })
            }
        }
    }

    fn map_png(&self, id: &str) -> Result<TaggedPng, ApiError> {
        match self.live(id)? {
            Ok(s) => {
                let grid = s.grid();
                let origin = grid.origin();
                Ok(TaggedPng::in_frame(
                    grid.to_png(),
                    MapFrame {
                        resolution_m: grid.resolution_m(),
                        origin_x_m: origin.x,
                        origin_y_m: origin.y,
                    },
                ))
            }
            Err(_) => {
                let png = self.stored_file(id, "map.png")?;
                let yaml = self.stored_file(id, "map.yaml")?;
                match MapFrame::from_ros_yaml(&String::from_utf8_lossy(&yaml)) {
                    Some(frame) => Ok(TaggedPng::in_frame(png, frame)),
                    None => Err(ApiError::internal(format!(
                        "map.yaml of session {id} names no resolution and origin"
                    ))),
                }
            }
        }
    }

    fn map_pgm(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        match self.live(id)? {
            Ok(s) => Ok(s.grid().to_pgm()),
            Err(_) => self.stored_file(id, "map.pgm"),
        }
    }

    fn map_yaml(&self, id: &str) -> Result<String, ApiError> {
        match self.live(id)? {
            Ok(s) => Ok(s.grid().to_yaml("map.pgm")),
            Err(_) => Ok(String::from_utf8_lossy(&self.stored_file(id, "map.yaml")?).into_owned()),
        }
    }

    fn map_occupancy(&self, id: &str) -> Result<OccupancyGridResponse, ApiError> {
        match self.live(id)? {
            Ok(s) => {
                let grid = s.grid();
                Ok(occupancy_response(&grid, s.last_stamp_ns()))
            }
            Err(_) => stored_occupancy(&self.stored_file(id, "map.json")?)
                .map_err(|e| ApiError::internal(format!("map.json of session {id}: {e}"))),
        }
    }

    fn registration(&self, id: &str) -> Result<RegistrationInfo, ApiError> {
        match self.live(id)? {
            Ok(s) => s.registration(),
            Err(meta) => {
                let json = self.stored_registration_file(id, &meta, "registration.json")?;
                serde_json::from_slice(&json).map_err(|e| {
                    ApiError::internal(format!("registration.json of session {id}: {e}"))
                })
            }
        }
    }

    fn sketch_overlay_on_map_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        match self.live(id)? {
            Ok(s) => s.sketch_overlay_png(),
            Err(meta) => self.stored_registration_file(id, &meta, "sketch-overlay.png"),
        }
    }

    fn sketch_in_map(&self, id: &str) -> Result<SketchInMapResponse, ApiError> {
        match self.live(id)? {
            Ok(s) => s.sketch_in_map(),
            Err(meta) => {
                let json = self.stored_registration_file(id, &meta, "sketch-in-map.json")?;
                serde_json::from_slice(&json).map_err(|e| {
                    ApiError::internal(format!("sketch-in-map.json of session {id}: {e}"))
                })
            }
        }
    }

    fn sketch_in_map_png(&self, id: &str) -> Result<Vec<u8>, ApiError> {
        match self.live(id)? {
            Ok(s) => s.sketch_in_map_png(),
            Err(meta) => self.stored_registration_file(id, &meta, "sketch-in-map.png"),
        }
    }

    fn transform(
        &self,
        id: &str,
        request: TransformRequest,
    ) -> Result<TransformResponse, ApiError> {
        match self.live(id)? {
            Ok(s) => s.transform(&request),
            Err(_) => {
                let info = self.registration(id)?;
                let r = registration_from_info(&info).map_err(|e| {
                    ApiError::internal(format!("registration.json of session {id}: {e}"))
                })?;
                Ok(transform_response(id, &r, &request))
            }
        }
    }

    fn subscribe_events(
        &self,
        id: &str,
        last_seen: Option<u64>,
    ) -> Result<EventSubscription, ApiError> {
        Ok(match self.live(id)? {
            Ok(s) => s.subscribe(last_seen),
            // A closed channel: the stream ends after the initial status.
            Err(_) => EventSubscription::ended(),
        })
    }

    fn metrics_text(&self) -> String {
        let mut live = Vec::new();
        let mut states = Vec::new();
        for entry in lock(&self.sessions).entries.values() {
            match entry {
                Entry::Live(s) => live.push(s.clone()),
                Entry::Stopped(m) => states.push(m.info.state),
            }
        }
        // Outside the registry's lock: each waits for its mapper between two messages.
        let running: Vec<RunningSession> = live
            .iter()
            .map(|s| RunningSession {
                info: s.info(),
                odometry_lost: s.odometry_lost(),
                heap_bytes: s.heap_bytes() as u64,
            })
            .collect();
        states.extend(running.iter().map(|r| r.info.state));
        let sketches = self.sketches.len();
        render_metrics(
            &running,
            &states,
            sketches,
            &self.histogram,
            &ProcessStats::read(),
        )
    }
}
