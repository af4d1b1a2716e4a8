//! A `sketch` session's warp onto its drawing, kept fresh beside the mapper thread: the
//! last [`DrawingRegistration`], refitted by a worker thread of its own once the map has
//! grown by [`REFIT_KEYFRAMES`], and on demand by HTTP requests that find it stale (the map
//! grown or moved by a loop correction).
//!
//! Sits between the session's mapper (behind its mutex) and everything read through W:
//! the live pose on the drawing ([`super::session`]), the trajectory on the drawing, the
//! map-on-drawing endpoints. A fit copies the walls out under the mapper's lock
//! ([`Mapper::warp_problem`], O(keyframe points)) and solves without it, so the mapper
//! thread never waits for a fit.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use sketchslam_engine::mapper::Mapper;
use sketchslam_engine::registration::{DrawingRegistration, WarpProblem};

use super::session::lock;

/// The warp is fitted again once the map has this many keyframes more than at the last
/// fit (5 m of route at the default keyframe spacing), or has moved.
pub const REFIT_KEYFRAMES: usize = 10;

/// How often the worker looks whether the map has moved or grown.
pub const REFIT_POLL: Duration = Duration::from_millis(200);

/// The last fitted warp of a session.
#[derive(Debug, Default)]
pub struct WarpCache {
    slot: Mutex<Option<Arc<DrawingRegistration>>>,
}

impl WarpCache {
    /// The last fit, however old.
    pub fn current(&self) -> Option<Arc<DrawingRegistration>> {
        lock(&self.slot).clone()
    }

    /// The last fit while the map has neither moved nor grown by [`REFIT_KEYFRAMES`] since,
    /// else a new one; `None` while nothing can be fitted (or without a drawing).
    pub fn fresh(&self, mapper: &Mutex<Mapper>) -> Option<Arc<DrawingRegistration>> {
        self.refit_unless(mapper, |r, m| {
            r.map_revision == m.map_revision() && !has_grown(r, m)
        })
    }

    /// The worker's refit: a new fit once the map has grown by [`REFIT_KEYFRAMES`] since
    /// the last (or when there is none yet), not when it only moved — the live pose is read
    /// through W in the frame W was fitted in (`Mapper::pose_on_drawing_through`), so a loop
    /// correction leaves it right, and a refit per correction (one every few keyframes on
    /// a busy floor) would keep a core busy for nothing. HTTP requests that read W over the
    /// moved map ask [`WarpCache::fresh`].
    pub fn grown(&self, mapper: &Mutex<Mapper>) -> Option<Arc<DrawingRegistration>> {
        self.refit_unless(mapper, |r, m| !has_grown(r, m))
    }

    /// The last fit where `holds(fit, mapper)`, else a new one (the walls copied under the
    /// mapper's lock, the fit outside it).
    fn refit_unless(
        &self,
        mapper: &Mutex<Mapper>,
        holds: impl Fn(&DrawingRegistration, &Mapper) -> bool,
    ) -> Option<Arc<DrawingRegistration>> {
        let problem = {
            let m = lock(mapper);
            if let Some(r) = self.current().filter(|r| holds(r, &m)) {
                return Some(r);
            }
            m.warp_problem()?
        };
        self.store(timed_solve(&problem))
    }

    /// A new fit on the map as it is now, whatever the last one (the final map of a
    /// stopping session).
    pub fn refit(&self, mapper: &Mutex<Mapper>) -> Option<Arc<DrawingRegistration>> {
        let problem = lock(mapper).warp_problem()?;
        self.store(timed_solve(&problem))
    }

    fn store(&self, fitted: Option<DrawingRegistration>) -> Option<Arc<DrawingRegistration>> {
        let fitted = Arc::new(fitted?);
        *lock(&self.slot) = Some(fitted.clone());
        Some(fitted)
    }
}

/// True once the map has [`REFIT_KEYFRAMES`] keyframes more than `r` was fitted to.
fn has_grown(r: &DrawingRegistration, m: &Mapper) -> bool {
    m.keyframe_count() >= r.keyframes + REFIT_KEYFRAMES
}

/// [`WarpProblem::solve`], its time in the debug log.
fn timed_solve(problem: &WarpProblem) -> Option<DrawingRegistration> {
    let started = Instant::now();
    let fitted = problem.solve();
    tracing::debug!(
        fit_ms = started.elapsed().as_secs_f64() * 1e3,
        keyframes = problem.keyframes,
        walls = problem.walls.len(),
        inliers = fitted.as_ref().map_or(0, |r| r.fit.inliers),
        "warp fitted"
    );
    fitted
}

/// The worker that keeps `cache` fresh for `mapper` until `stop` is set; a thread named
/// `warp-ROBOT`.
pub fn spawn_worker(
    robot_id: &str,
    mapper: Arc<Mutex<Mapper>>,
    cache: Arc<WarpCache>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    std::thread::Builder::new()
        .name(format!("warp-{robot_id}"))
        .spawn(move || {
            while !stop.load(Ordering::Acquire) {
                cache.grown(&mapper);
                std::thread::sleep(REFIT_POLL);
            }
        })
}
