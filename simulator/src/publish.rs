//! Publishing a time-ordered stream of [`SensorEvent`]s over iceoryx2 with a
//! [`RobotPublisher`]: paced by the simulated clock (real time, or a multiple of it), or in
//! lock-step with the subscriber (wait for it to connect, then as fast as it consumes; no
//! sample lost, so a run is deterministic).
//!
//! Generic over any event iterator: the simulator passes [`crate::Simulation`]'s events,
//! tests pass synthetic ones. The [`RobotPublisher`] is not `Send`, so this runs on the
//! thread that created it.

use sketchslam_ipc::{Delivery, IpcError, RobotPublisher};
use sketchslam_types::SensorEvent;
use std::io::Write;
use std::time::{Duration, Instant};
use thiserror::Error;

/// How fast events go out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pace {
    /// Event with stamp `t` goes out `(t - t_first) / rate` after the first one.
    /// `rate = 1.0` is real time, `2.0` twice as fast.
    RealTime {
        /// Speed-up factor over the simulated clock, > 0.
        rate: f64,
    },
    /// Wait for subscribers before the first event, then send as fast as they consume.
    LockStep {
        /// Subscribers (on both topics) to wait for.
        min_subscribers: usize,
        /// How long to wait for them before giving up.
        connect_timeout: Duration,
    },
}

impl Pace {
    /// The iceoryx2 delivery mode this pace needs.
    pub fn delivery(&self, backpressure_timeout: Duration) -> Delivery {
        match self {
            Pace::RealTime { .. } => Delivery::RealTime,
            Pace::LockStep { .. } => Delivery::LockStep {
                backpressure_timeout,
            },
        }
    }
}

/// Options of [`publish_events`].
#[derive(Debug, Clone, PartialEq)]
pub struct PublishOptions {
    /// Pacing.
    pub pace: Pace,
    /// Stop after this many scans (the odometry before the last scan is sent too).
    pub max_scans: Option<u64>,
    /// Total scans expected, for the progress line.
    pub expected_scans: Option<u64>,
    /// Print a progress line on stderr about twice a second.
    pub progress: bool,
}

/// What a run of [`publish_events`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PublishSummary {
    /// Scans sent.
    pub scans_sent: u64,
    /// Odometry readings sent.
    pub odometry_sent: u64,
    /// Deliveries given up (dead or too slow subscriber; see `shared::ipc::Delivery`).
    pub discarded: u64,
    /// Dead iceoryx2 nodes removed on the way.
    pub dead_nodes_cleaned: u64,
    /// Wall time from the first event (after the lock-step handshake) to the last.
    pub wall_time: Duration,
    /// Simulated time from the first event's stamp to the last one's, seconds.
    pub sim_time_s: f64,
}

/// Why publishing stopped early.
#[derive(Debug, Error)]
pub enum PublishError {
    /// The transport failed.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// No subscriber connected in lock-step mode.
    #[error("no subscriber connected within {0:?} (lock-step waits for one before sending)")]
    NoSubscriber(Duration),
    /// The real-time rate factor is not a positive finite number.
    #[error("rate must be a positive finite factor, got {0}")]
    BadRate(f64),
    /// The events are not in stamp order.
    #[error("event stamps go backwards: {previous_ns} ns then {stamp_ns} ns")]
    Unordered {
        /// Stamp of the previous event.
        previous_ns: u64,
        /// Stamp of the offending event.
        stamp_ns: u64,
    },
}

/// Publishes `events` (in stamp order) through `publisher` as `options` say.
pub fn publish_events<I>(
    publisher: &mut RobotPublisher,
    events: I,
    options: &PublishOptions,
) -> Result<PublishSummary, PublishError>
where
    I: IntoIterator<Item = SensorEvent>,
{
    let rate = match options.pace {
        Pace::RealTime { rate } if !(rate.is_finite() && rate > 0.0) => {
            return Err(PublishError::BadRate(rate));
        }
        Pace::RealTime { rate } => Some(rate),
        Pace::LockStep {
            min_subscribers,
            connect_timeout,
        } => {
            tracing::info!(min_subscribers, "waiting for subscribers (lock-step)");
            if !publisher.wait_for_subscribers(min_subscribers, connect_timeout)? {
                return Err(PublishError::NoSubscriber(connect_timeout));
            }
            tracing::info!("subscriber connected; publishing");
            None
        }
    };

    let start_stats = publisher.stats();
    let mut progress = Progress::new(options.progress, options.expected_scans);
    let mut first: Option<(u64, Instant)> = None;
    let mut last_stamp_ns: Option<u64> = None;
    let mut wall_start = Instant::now();
    let mut scans_sent = 0u64;
    let done = |scans_sent: u64| options.max_scans.is_some_and(|max| scans_sent >= max);
    for event in events.into_iter().take_while(|_| !done(0)) {
        let stamp_ns = event.stamp_ns();
        if let Some(previous_ns) = last_stamp_ns
            && stamp_ns < previous_ns
        {
            return Err(PublishError::Unordered {
                previous_ns,
                stamp_ns,
            });
        }
        last_stamp_ns = Some(stamp_ns);
        let (t0_ns, w0) = *first.get_or_insert_with(|| {
            wall_start = Instant::now();
            (stamp_ns, wall_start)
        });
        if let Some(rate) = rate {
            let due = w0 + Duration::from_secs_f64((stamp_ns - t0_ns) as f64 * 1e-9 / rate);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
        publisher.publish(&event)?;
        progress.tick(&publisher.stats(), stamp_ns.saturating_sub(t0_ns));
        if matches!(event, SensorEvent::Scan(_)) {
            scans_sent += 1;
            // Stop before pulling another event, so callers that record what the
            // iterator yields (the truth) see exactly what was sent.
            if done(scans_sent) {
                break;
            }
        }
    }
    let stats = publisher.stats();
    progress.finish(&stats);
    Ok(PublishSummary {
        scans_sent: stats.scans_sent - start_stats.scans_sent,
        odometry_sent: stats.odometry_sent - start_stats.odometry_sent,
        discarded: stats.discarded - start_stats.discarded,
        dead_nodes_cleaned: stats.dead_nodes_cleaned - start_stats.dead_nodes_cleaned,
        wall_time: first.map_or(Duration::ZERO, |_| wall_start.elapsed()),
        sim_time_s: match (first, last_stamp_ns) {
            (Some((t0, _)), Some(t1)) => (t1 - t0) as f64 * 1e-9,
            _ => 0.0,
        },
    })
}

/// The stderr progress line.
struct Progress {
    enabled: bool,
    expected_scans: Option<u64>,
    last_print: Instant,
    printed: bool,
}

impl Progress {
    fn new(enabled: bool, expected_scans: Option<u64>) -> Self {
        Self {
            enabled,
            expected_scans,
            last_print: Instant::now(),
            printed: false,
        }
    }

    fn line(&self, stats: &sketchslam_ipc::PublisherStats, sim_ns: Option<u64>) -> String {
        let scans = match self.expected_scans {
            Some(total) => format!("{}/{total}", stats.scans_sent),
            None => stats.scans_sent.to_string(),
        };
        let sim = sim_ns.map_or(String::new(), |ns| {
            format!("  sim {:.1} s", ns as f64 * 1e-9)
        });
        format!(
            "published scans {scans}  odometry {}  discarded {}{sim}",
            stats.odometry_sent, stats.discarded
        )
    }

    fn tick(&mut self, stats: &sketchslam_ipc::PublisherStats, sim_ns: u64) {
        if self.enabled && self.last_print.elapsed() >= Duration::from_millis(500) {
            self.last_print = Instant::now();
            self.printed = true;
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r{}   ", self.line(stats, Some(sim_ns)));
            let _ = err.flush();
        }
    }

    fn finish(&mut self, stats: &sketchslam_ipc::PublisherStats) {
        if self.enabled {
            let lead = if self.printed { "\r" } else { "" };
            eprintln!("{lead}{}   ", self.line(stats, None));
        }
    }
}
