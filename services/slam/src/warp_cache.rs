//! A `sketch` session's warp onto its drawing, kept fresh beside the mapper thread: the
//! last [`DrawingRegistration`], fitted by a worker thread of its own whenever the mapper
//! asks (every [`REFIT_KEYFRAMES`] keyframes, `Mapper::warp_request`), and on demand by
//! HTTP requests that find it stale (the map grown or moved by a loop correction).
//!
//! Sits between the session's mapper (behind its mutex) and everything read through W:
//! the live pose on the drawing ([`super::session`]), the trajectory on the drawing, the
//! map-on-drawing endpoints, and the mapper's own front end. The mapper thread copies the
//! walls out when the mapper asks ([`Mapper::warp_request`], O(keyframe points)) and sends
//! them here; the worker solves without the lock and hands the fit back
//! ([`Mapper::deliver_warp`]). The mapper reads each fit from a keyframe count fixed when it
//! asked (`sketchslam_engine::mapper::REFIT_KEYFRAMES` keyframes later), so the map is the
//! same however long the fit takes; the mapper thread waits for a fit only when it is due
//! and not done ([`WarpCache::wait_for_delivery`]): in a lock-step replay that costs time,
//! in real time it happens when a fit takes longer than the robot takes to drive 5 m.
//! HTTP refits update the cache only, never the mapper.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use sketchslam_engine::mapper::Mapper;
use sketchslam_engine::registration::{DrawingRegistration, WarpProblem};

use super::session::lock;

/// The mapper asks for a fit once its map has this many keyframes more than at the last
/// request (5 m of route at the default keyframe spacing); HTTP requests refit once the
/// map has grown by as much, or has moved.
pub use sketchslam_engine::mapper::REFIT_KEYFRAMES;

/// How often the worker looks whether it is to stop.
pub const REFIT_POLL: Duration = Duration::from_millis(200);

/// How long the mapper thread waits for a fit it is due to read before it goes on without
/// (the fit failed in the worker, or the worker is gone): the map then depends on timing.
pub const DELIVERY_WAIT: Duration = Duration::from_secs(60);

/// The last fitted warp of a session.
#[derive(Debug, Default)]
pub struct WarpCache {
    slot: Mutex<Option<Arc<DrawingRegistration>>>,
    /// Notified (with the mapper's mutex) when the worker hands the mapper a fit.
    delivered: Condvar,
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

    /// The mapper thread, before it maps the next message: while the mapper waits for a
    /// fit it asked for ([`Mapper::awaits_warp`]), waits for the worker to deliver it, up to
    /// [`DELIVERY_WAIT`]; then goes on without it (logged). Returns the mapper's guard.
    pub fn wait_for_delivery<'a>(&self, mut m: MutexGuard<'a, Mapper>) -> MutexGuard<'a, Mapper> {
        let started = Instant::now();
        while m.awaits_warp() {
            let left = DELIVERY_WAIT.saturating_sub(started.elapsed());
            if left.is_zero() {
                tracing::warn!("no warp fit within {DELIVERY_WAIT:?}: mapping on without it");
                m.deliver_warp(None);
                break;
            }
            m = self
                .delivered
                .wait_timeout(m, left)
                .map(|(g, _)| g)
                .unwrap_or_else(|e| e.into_inner().0);
        }
        m
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

/// The worker that fits what the mapper thread sends (`problems`, the mapper's
/// [`Mapper::warp_request`]s), stores each fit in `cache` and hands it to `mapper`, until
/// `stop` is set or the mapper thread hangs up; a thread named `warp-ROBOT`.
pub fn spawn_worker(
    robot_id: &str,
    mapper: Arc<Mutex<Mapper>>,
    cache: Arc<WarpCache>,
    problems: Receiver<WarpProblem>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<JoinHandle<()>> {
    std::thread::Builder::new()
        .name(format!("warp-{robot_id}"))
        .spawn(move || {
            while !stop.load(Ordering::Acquire) {
                let problem = match problems.recv_timeout(REFIT_POLL) {
                    Ok(problem) => problem,
                    Err(RecvTimeoutError::Timeout) => continue,
                    Err(RecvTimeoutError::Disconnected) => break,
                };
                let fitted = cache.store(timed_solve(&problem));
                lock(&mapper).deliver_warp(fitted);
                cache.delivered.notify_all();
            }
        })
}
