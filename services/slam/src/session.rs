//! One mapping session: a robot's intake thread feeding its own mapper thread.
//!
//! The mapper thread owns the processing order: it takes [`IntakeMsg`]s one by one, feeds
//! them to the [`Mapper`] (behind a mutex, so HTTP requests can copy the map or the
//! trajectory between two messages), updates the status, and broadcasts each new pose and
//! every status change to the session's event subscribers. A panic inside the engine marks
//! the session `failed` with the panic's message instead of taking the process down.
//!
//! After a loop closure moved the keyframes, the grid is rebuilt on the mapper thread too
//! ([`Mapper::refresh_map`]): when the intake has been idle for [`IDLE_REFRESH`], when an
//! HTTP request asked for the map (it waits for the rebuild, up to [`MAP_WAIT`]), and when
//! the intake hangs up. An HTTP request never rebuilds the map itself.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use sketchslam_api::{
    ApiError, EventLog, EventSubscription, PoseResponse, SessionEvent, SessionInfo, SessionState,
    SketchTrajectoryResponse, StopReason, TrajectoryResponse,
};
use sketchslam_ipc::IpcConfig;
use sketchslam_types::SensorEvent;

use super::codec::{no_drawing, occupancy_response, pose_response, trajectory_response};
use super::intake::{Intake, IntakeMsg};
use super::metrics::Histogram;
use super::registration_codec::{
    not_registered, pose_through_warp, registration_info, served_sketch_trajectory,
    sketch_in_map_response, transform_response,
};
use super::storage::{RegistrationFiles, SessionFiles, SessionMeta};
use super::warp_cache::{WarpCache, spawn_worker};
use sketchslam_api::{RegistrationInfo, SketchInMapResponse, TransformRequest, TransformResponse};
use sketchslam_engine::mapper::{Mapper, Method, trajectory_csv};
use sketchslam_engine::mapping::grid::OccupancyGrid;
use sketchslam_engine::registration::{
    DrawingRegistration, WarpProblem, render_drawing_on_map, render_map_on_drawing,
};
use sketchslam_engine::sketch::Sketch;
use sketchslam_engine::sketch::overlay::encode_png;

/// Events a session keeps for clients that reconnect, and the broadcast's lag bound: a
/// slower SSE client skips events.
const EVENT_CAPACITY: usize = 256;

/// While mapping, a `status` event (scan counts, score, loops) goes out at least this often
/// besides those sent on a change of state: the web page's health panel follows it.
pub const STATUS_PERIOD: Duration = Duration::from_secs(1);

/// The mapper thread rebuilds a stale map once the intake has been quiet this long.
pub const IDLE_REFRESH: Duration = Duration::from_millis(50);

/// The longest a map request waits for the mapper thread's rebuild; past it, the map as
/// last built is served.
pub const MAP_WAIT: Duration = Duration::from_secs(30);

/// Locks a mutex even if a panicking thread poisoned it (the data is still usable).
pub(crate) fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Milliseconds since the Unix epoch.
pub(crate) fn now_unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as u64)
        .unwrap_or(0)
}

/// What the HTTP side reads of a running session.
pub struct SessionShared {
    /// The status.
    pub info: Mutex<SessionInfo>,
    /// The latest pose.
    pub pose: Mutex<PoseResponse>,
    /// Odometry readings lost (the status counts scans only).
    pub odometry_lost: Mutex<u64>,
    /// The live feed.
    pub events: EventLog,
    /// Set by a map request that found the map stale; the mapper thread rebuilds it.
    map_wanted: AtomicBool,
    /// True while the mapper thread runs.
    mapping: AtomicBool,
    /// Notified (with the mapper's mutex) when the map was rebuilt or the thread ended.
    map_rebuilt: Condvar,
    /// The warp onto the drawing, read for each live pose.
    warp: Arc<WarpCache>,
    /// When the robot's last message was processed; `None` before its first.
    last_data: Mutex<Option<Instant>>,
}

impl SessionShared {
    fn publish_status(&self) {
        let info = lock(&self.info).clone();
        // No subscriber is not an error.
        self.events.publish(SessionEvent::Status(Box::new(info)));
    }
}

/// A running session.
pub struct Session {
    /// Session id.
    pub id: String,
    /// The robot.
    pub robot_id: String,
    shared: Arc<SessionShared>,
    mapper: Arc<Mutex<Mapper>>,
    threads: Mutex<Option<(Intake, JoinHandle<()>)>>,
    /// The warp worker and the flag that stops it.
    warp_worker: Mutex<Option<(Arc<AtomicBool>, JoinHandle<()>)>>,
    /// The answer of the one stop ([`Session::stop_with`]), once given.
    stopped: Mutex<Option<Result<SessionMeta, ApiError>>>,
    /// Scans processed and trajectory length at the last checkpoint
    /// ([`Session::checkpoint`]); `None` before it.
    checkpointed: Mutex<Option<(u64, usize)>>,
}

impl Session {
    /// Subscribes to the robot and starts the mapper thread. `info` is the initial status.
    pub fn start(
        info: SessionInfo,
        mapper: Mapper,
        ipc: IpcConfig,
        histogram: Arc<Histogram>,
    ) -> Result<Session, ApiError> {
        let id = info.id.clone();
        let robot_id = info.robot_id.clone();
        let initial_pose = pose_response(&id, &mapper.pose(), &mapper.health());
        let shared = Arc::new(SessionShared {
            info: Mutex::new(info),
            pose: Mutex::new(initial_pose),
            odometry_lost: Mutex::new(0),
            events: EventLog::new(EVENT_CAPACITY),
            map_wanted: AtomicBool::new(false),
            mapping: AtomicBool::new(true),
            map_rebuilt: Condvar::new(),
            warp: Arc::new(WarpCache::default()),
            last_data: Mutex::new(None),
        });
        let mapper = Arc::new(Mutex::new(mapper));
        let (intake, rx) = Intake::start(ipc, &robot_id).map_err(|e| {
            ApiError::Unavailable(format!("cannot subscribe to robot {robot_id:?}: {e}"))
        })?;
        // The warp worker fits what the mapper thread asks for (sketch sessions).
        let (warp_tx, warp_worker) = if lock(&mapper).drawing().is_some() {
            let (tx, problems) = std::sync::mpsc::channel();
            let stop = Arc::new(AtomicBool::new(false));
            let worker = spawn_worker(
                &robot_id,
                mapper.clone(),
                shared.warp.clone(),
                problems,
                stop.clone(),
            )
            .map_err(|e| ApiError::internal(format!("cannot spawn the warp worker: {e}")))?;
            (Some(tx), Some((stop, worker)))
        } else {
            (None, None)
        };
        let thread = {
            let shared = shared.clone();
            let mapper = mapper.clone();
            std::thread::Builder::new()
                .name(format!("mapper-{robot_id}"))
                .spawn(move || run_mapper(rx, mapper, shared, histogram, warp_tx))
                .map_err(|e| ApiError::internal(format!("cannot spawn the mapper thread: {e}")))?
        };
        tracing::info!(session = %id, robot = %robot_id, "session started");
        Ok(Session {
            id,
            robot_id,
            shared,
            mapper,
            threads: Mutex::new(Some((intake, thread))),
            warp_worker: Mutex::new(warp_worker),
            stopped: Mutex::new(None),
            checkpointed: Mutex::new(None),
        })
    }

    /// Stops the session once: the first caller finishes it (`Session::finish`) and hands
    /// its final status and files to `store`; every caller, concurrent or later, gets that
    /// one answer (the others wait for it). Two stops never save twice, so they never
    /// write the same files at once.
    pub fn stop_with(
        &self,
        reason: StopReason,
        store: impl FnOnce(&SessionMeta, &SessionFiles) -> Result<(), ApiError>,
    ) -> Result<SessionMeta, ApiError> {
        let mut slot = lock(&self.stopped);
        if let Some(answer) = slot.as_ref() {
            return answer.clone();
        }
        lock(&self.shared.info).stop_reason.get_or_insert(reason);
        let (meta, files) = self.finish();
        let answer = store(&meta, &files).map(|()| meta);
        *slot = Some(answer.clone());
        answer
    }

    /// How long since the robot's last message was processed; `None` before its first
    /// (a session waiting for a robot that has not started is not silent).
    pub fn silent_for(&self) -> Option<std::time::Duration> {
        lock(&self.shared.last_data).map(|at| at.elapsed())
    }

    /// The current status.
    pub fn info(&self) -> SessionInfo {
        lock(&self.shared.info).clone()
    }

    /// Heap held by the mapper's growing parts ([`Mapper::heap_bytes`]); O(scans) under
    /// the mapper's lock.
    pub fn heap_bytes(&self) -> usize {
        lock(&self.mapper).heap_bytes()
    }

    /// Odometry readings lost so far.
    pub fn odometry_lost(&self) -> u64 {
        *lock(&self.shared.odometry_lost)
    }

    /// The latest pose.
    pub fn pose(&self) -> PoseResponse {
        lock(&self.shared.pose).clone()
    }

    /// A receiver of the live feed.
    pub fn subscribe(&self, last_seen: Option<u64>) -> EventSubscription {
        self.shared.events.subscribe(last_seen)
    }

    /// The sensor stamp of the last pose, ns (0 before the first): the map's time.
    pub fn last_stamp_ns(&self) -> u64 {
        lock(&self.mapper)
            .trajectory()
            .last()
            .map_or(0, |p| p.stamp_ns)
    }

    /// The trajectory so far.
    pub fn trajectory(&self) -> TrajectoryResponse {
        let points = lock(&self.mapper).trajectory().to_vec();
        trajectory_response(&self.id, &points)
    }

    /// The trajectory on the drawing so far (`sketch` sessions; an error for the others).
    pub fn sketch_trajectory(&self) -> Result<SketchTrajectoryResponse, ApiError> {
        let warp = self.shared.warp.current();
        let m = lock(&self.mapper);
        if m.method() != Method::Sketch {
            return Err(no_drawing(&self.id, m.method().as_str()));
        }
        Ok(served_sketch_trajectory(&self.id, &m, warp.as_deref()))
    }

    /// A copy of the map so far (rendering happens outside the mapper's lock). After a
    /// loop closure it waits for the mapper thread to rebuild the map (up to [`MAP_WAIT`]).
    pub fn grid(&self) -> OccupancyGrid {
        let m = lock(&self.mapper);
        if m.map_is_current() || !self.shared.mapping.load(Ordering::Acquire) {
            return m.grid_as_built().clone();
        }
        self.shared.map_wanted.store(true, Ordering::Release);
        let (m, _) = self
            .shared
            .map_rebuilt
            .wait_timeout_while(m, MAP_WAIT, |m| {
                !m.map_is_current() && self.shared.mapping.load(Ordering::Acquire)
            })
            .unwrap_or_else(|e| e.into_inner());
        m.grid_as_built().clone()
    }

    /// The map laid on the drawing ([`WarpCache::fresh`]), with the drawing.
    fn registered(&self) -> Result<(Arc<DrawingRegistration>, Arc<Sketch>), ApiError> {
        let sketch = {
            let m = lock(&self.mapper);
            match m.drawing() {
                Some(drawing) => drawing.sketch.clone(),
                None => return Err(no_drawing(&self.id, m.method().as_str())),
            }
        };
        let fitted = self
            .shared
            .warp
            .fresh(&self.mapper)
            .ok_or_else(|| not_registered(&self.id))?;
        Ok((fitted, sketch))
    }

    /// `GET /registration`.
    pub fn registration(&self) -> Result<RegistrationInfo, ApiError> {
        let (r, _) = self.registered()?;
        Ok(registration_info(&self.id, &r))
    }

    /// `GET /sketch-in-map`.
    pub fn sketch_in_map(&self) -> Result<SketchInMapResponse, ApiError> {
        let (r, sketch) = self.registered()?;
        Ok(sketch_in_map_response(&self.id, &r, &sketch.lines))
    }

    /// `POST /transform` (`request` validated).
    pub fn transform(&self, request: &TransformRequest) -> Result<TransformResponse, ApiError> {
        let (r, _) = self.registered()?;
        Ok(transform_response(&self.id, &r, request))
    }

    /// `GET /sketch-overlay.png`: the map and the route over the drawing.
    pub fn sketch_overlay_png(&self) -> Result<Vec<u8>, ApiError> {
        let (r, sketch) = self.registered()?;
        Ok(self.overlay_png(&r, &sketch, &self.grid()))
    }

    /// `GET /sketch-in-map.png`: the drawing's lines over the map.
    pub fn sketch_in_map_png(&self) -> Result<Vec<u8>, ApiError> {
        let (r, sketch) = self.registered()?;
        Ok(in_map_png(&r, &sketch, &self.grid()))
    }

    /// The map `grid` and the route over the drawing through `r`.
    fn overlay_png(
        &self,
        r: &DrawingRegistration,
        sketch: &Sketch,
        grid: &OccupancyGrid,
    ) -> Vec<u8> {
        let route: Vec<_> = lock(&self.mapper)
            .trajectory()
            .iter()
            .map(|t| t.pose)
            .collect();
        encode_png(&render_map_on_drawing(
            sketch,
            r.warp(),
            &grid.occupied_points(),
            &route,
        ))
    }

    /// What a session keeps of its registration through `r`, rendered over `grid`.
    fn registration_files(
        &self,
        r: &DrawingRegistration,
        sketch: &Sketch,
        grid: &OccupancyGrid,
    ) -> Option<RegistrationFiles> {
        Some(RegistrationFiles {
            registration_json: serde_json::to_vec(&registration_info(&self.id, r)).ok()?,
            sketch_overlay_png: self.overlay_png(r, sketch, grid),
            sketch_in_map_json: serde_json::to_vec(&sketch_in_map_response(
                &self.id,
                r,
                &sketch.lines,
            ))
            .ok()?,
            sketch_in_map_png: in_map_png(r, sketch, grid),
        })
    }

    /// The pose and the files of the session as it is now, its pose and route carried onto
    /// the drawing through `warp` (when there is one): what a stop stores, and what a
    /// checkpoint does. The map is the one last built (a checkpoint does not wait for the
    /// rebuild after a loop closure; a stop's mapper thread rebuilt it before it ended).
    /// The map-on-drawing pictures are rendered only `with_registration` (a stop): they
    /// cost seconds on a large floor.
    fn snapshot(
        &self,
        warp: Option<Arc<DrawingRegistration>>,
        with_registration: bool,
    ) -> (PoseResponse, SessionFiles) {
        let (grid, points, pose, on_drawing, sketch) = {
            let m = lock(&self.mapper);
            let estimate = m.pose();
            let mut pose = pose_response(&self.id, &estimate, &m.health());
            if let Some(r) = &warp {
                pose_through_warp(&mut pose, m.pose_on_drawing_through(r));
            }
            let on_drawing = (m.method() == Method::Sketch)
                .then(|| served_sketch_trajectory(&self.id, &m, warp.as_deref()));
            let sketch = m.drawing().map(|d| d.sketch.clone());
            let grid = m.grid_as_built().clone();
            (grid, m.trajectory().to_vec(), pose, on_drawing, sketch)
        };
        let stamp_ns = points.last().map_or(0, |p| p.stamp_ns);
        let map_json = serde_json::to_vec(&occupancy_response(&grid, stamp_ns))
            .unwrap_or_else(|_| b"{}".to_vec());
        let registration = match (&warp, &sketch) {
            (Some(r), Some(sketch)) if with_registration => {
                self.registration_files(r, sketch, &grid)
            }
            _ => None,
        };
        let files = SessionFiles {
            map_pgm: grid.to_pgm(),
            map_yaml: grid.to_yaml("map.pgm"),
            map_png: grid.to_png(),
            map_json,
            trajectory_csv: trajectory_csv(&points),
            sketch_trajectory_json: on_drawing.and_then(|t| serde_json::to_vec(&t).ok()),
            registration,
        };
        (pose, files)
    }

    /// Writes the running session to disk through `store` (a checkpoint: what a crash
    /// leaves of it) unless nothing was processed since the last one or it has stopped;
    /// returns whether it wrote. Serialized with [`Session::stop_with`], so a checkpoint
    /// never lands after the final save. The pose goes onto the drawing through the warp
    /// last fitted (a checkpoint fits none), and the map-on-drawing files are left to the
    /// stop: an interrupted session answers them `not_registered`.
    pub fn checkpoint(
        &self,
        store: impl FnOnce(&SessionMeta, &SessionFiles) -> Result<(), ApiError>,
    ) -> Result<bool, ApiError> {
        let slot = lock(&self.stopped);
        if slot.is_some() || !self.shared.mapping.load(Ordering::Acquire) {
            return Ok(false);
        }
        // Odometry alone moves the trajectory too: both counts say whether anything changed.
        let progress = (
            lock(&self.shared.info).scans_processed,
            lock(&self.mapper).trajectory().len(),
        );
        let mut last = lock(&self.checkpointed);
        if *last == Some(progress) {
            return Ok(false);
        }
        let (pose, files) = self.snapshot(self.shared.warp.current(), false);
        let mut info = lock(&self.shared.info).clone();
        info.checkpoint_unix_ms = Some(now_unix_ms());
        store(
            &SessionMeta {
                info: info.clone(),
                pose,
            },
            &files,
        )?;
        lock(&self.shared.info).checkpoint_unix_ms = info.checkpoint_unix_ms;
        *last = Some(progress);
        drop(slot);
        Ok(true)
    }

    /// Stops the intake (it drains what arrived), lets the mapper process everything
    /// received, and returns the final status, pose and files ([`Session::stop_with`] calls
    /// it once).
    fn finish(&self) -> (SessionMeta, SessionFiles) {
        if let Some((intake, thread)) = lock(&self.threads).take() {
            intake.stop();
            if thread.join().is_err() {
                tracing::error!(session = %self.id, "the mapper thread panicked");
            }
        }
        self.stop_warp_worker();
        // The final map's warp, whatever the worker fitted last. The mapper thread rebuilt
        // the map when the intake hung up.
        let warp = self.shared.warp.refit(&self.mapper);
        let (pose, files) = self.snapshot(warp, true);
        *lock(&self.shared.pose) = pose.clone();
        let info = {
            let mut info = lock(&self.shared.info);
            if info.state != SessionState::Failed {
                info.state = SessionState::Stopped;
            }
            info.stopped_unix_ms.get_or_insert_with(now_unix_ms);
            info.clone()
        };
        self.shared.publish_status();
        tracing::info!(
            session = %self.id,
            scans = info.scans_processed,
            lost = info.scans_lost,
            "session stopped"
        );
        (SessionMeta { info, pose }, files)
    }
}

impl Session {
    /// Stops the warp worker and waits for it (it ends within a poll and a fit).
    fn stop_warp_worker(&self) {
        if let Some((stop, worker)) = lock(&self.warp_worker).take() {
            stop.store(true, Ordering::Release);
            if worker.join().is_err() {
                tracing::error!(session = %self.id, "the warp worker panicked");
            }
        }
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        if let Some((intake, thread)) = lock(&self.threads).take() {
            intake.stop();
            let _ = thread.join();
        }
        self.stop_warp_worker();
    }
}

/// The drawing's lines over the map `grid` through `r`.
fn in_map_png(r: &DrawingRegistration, sketch: &Sketch, grid: &OccupancyGrid) -> Vec<u8> {
    encode_png(&render_drawing_on_map(grid, &r.lines_in_map(&sketch.lines)))
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string())
}

/// Marks the mapper thread ended (whichever way it ends) and wakes map requests; under the
/// mapper's lock, so a request checking the flag cannot miss the wake-up.
struct MappingEnded {
    mapper: Arc<Mutex<Mapper>>,
    shared: Arc<SessionShared>,
}

impl Drop for MappingEnded {
    fn drop(&mut self) {
        let _m = lock(&self.mapper);
        self.shared.mapping.store(false, Ordering::Release);
        self.shared.map_rebuilt.notify_all();
    }
}

/// The mapper thread: processes every message until the intake hangs up.
fn run_mapper(
    rx: Receiver<IntakeMsg>,
    mapper: Arc<Mutex<Mapper>>,
    shared: Arc<SessionShared>,
    histogram: Arc<Histogram>,
    warp_tx: Option<Sender<WarpProblem>>,
) {
    let session_id = lock(&shared.info).id.clone();
    let _ended = MappingEnded {
        mapper: mapper.clone(),
        shared: shared.clone(),
    };
    // Rebuilds a stale map (mapping-side work, between messages) and wakes map requests.
    let refresh = || {
        let mut m = lock(&mapper);
        m.refresh_map(); // a no-op on a current map
        shared.map_wanted.store(false, Ordering::Release);
        shared.map_rebuilt.notify_all();
        drop(m);
    };
    let mut last_status = Instant::now();
    // Scans processed since the last status event: sent once the robot pauses, so the last
    // counts of a burst are not left waiting for the next scan.
    let mut status_stale = false;
    loop {
        let msg = match rx.recv_timeout(IDLE_REFRESH) {
            Ok(msg) => msg,
            Err(RecvTimeoutError::Timeout) => {
                refresh();
                if status_stale {
                    shared.publish_status();
                    last_status = Instant::now();
                    status_stale = false;
                }
                continue;
            }
            Err(RecvTimeoutError::Disconnected) => {
                refresh();
                break;
            }
        };
        if shared.map_wanted.load(Ordering::Acquire) {
            refresh();
        }
        match msg {
            IntakeMsg::Event(event) => {
                *lock(&shared.last_data) = Some(Instant::now());
                let is_scan = matches!(event, SensorEvent::Scan(_));
                let started = Instant::now();
                let warp = shared.warp.current();
                let outcome = catch_unwind(AssertUnwindSafe(|| {
                    // A fit the mapper is due to read is waited for: the map does not
                    // depend on how long fits take (`warp_cache`).
                    let mut m = shared.warp.wait_for_delivery(lock(&mapper));
                    m.on_event(&event);
                    if let Some(tx) = &warp_tx
                        && let Some(problem) = m.warp_request()
                        && tx.send(problem).is_err()
                    {
                        // The worker is gone: answer for it, so the mapper never waits.
                        m.deliver_warp(None);
                    }
                    let on_drawing = warp.as_ref().map(|r| m.pose_on_drawing_through(r));
                    // The map frame's axes are the drawing's: the start's map heading is
                    // its heading on the drawing.
                    let start_from_walls = m
                        .start_turn_rad()
                        .map(|_| m.start_pose().heading_rad.to_degrees());
                    (m.health(), m.pose(), on_drawing, start_from_walls)
                }));
                let (health, pose, on_drawing, start_from_walls) = match outcome {
                    Ok(v) => v,
                    Err(payload) => {
                        let message = format!("the mapper failed: {}", panic_message(&*payload));
                        tracing::error!(session = %session_id, %message);
                        {
                            let mut info = lock(&shared.info);
                            info.state = SessionState::Failed;
                            info.last_error = Some(message);
                        }
                        shared.publish_status();
                        return;
                    }
                };
                if is_scan {
                    histogram.observe(started.elapsed());
                }
                let mut response = pose_response(&session_id, &pose, &health);
                if let Some(on) = on_drawing {
                    pose_through_warp(&mut response, on);
                }
                *lock(&shared.pose) = response.clone();
                let state_changed = {
                    let mut info = lock(&shared.info);
                    info.scans_processed = health.scans_processed;
                    info.recoveries = health.recoveries as u64;
                    info.loop_closures = u64::from(health.loop_closures);
                    info.loop_closures_rejected = u64::from(health.loop_closures_rejected);
                    info.localization_score = response.localization_score;
                    info.estimated_meters_per_pixel = health.meters_per_pixel;
                    info.start_heading_from_walls_deg = start_from_walls;
                    let changed = info.state == SessionState::WaitingForData;
                    if changed {
                        info.state = SessionState::Mapping;
                    }
                    changed
                };
                // A status at least every STATUS_PERIOD while mapping, so a watcher of the
                // event stream sees the counters move without polling.
                if state_changed || last_status.elapsed() >= STATUS_PERIOD {
                    shared.publish_status();
                    last_status = Instant::now();
                    status_stale = false;
                } else {
                    status_stale = true;
                }
                if is_scan {
                    shared.events.publish(SessionEvent::Pose(response));
                }
            }
            IntakeMsg::Stats(stats) => {
                {
                    let mut info = lock(&shared.info);
                    info.scans_lost = stats.scans_lost;
                    info.publisher_restarts = stats.sequence_restarts;
                }
                *lock(&shared.odometry_lost) = stats.odometry_lost;
                shared.publish_status();
            }
            IntakeMsg::Error(message) => {
                lock(&shared.info).last_error = Some(message);
                shared.publish_status();
            }
        }
    }
}
