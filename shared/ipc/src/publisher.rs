//! The robot side of the transport: a driver publishes its scans and odometry, in one of
//! the two delivery modes (real time or lock-step, see the crate docs).

use crate::config::IpcConfig;
use crate::error::{IpcError, setup_err};
use crate::services::*;
use iceoryx2::node::NodeState;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::*;
use sketchslam_types::names::{ServiceNames, Topic};
use sketchslam_types::{Odometry, ScanHeader, SensorEvent};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How a publisher behaves towards a subscriber that does not keep up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// Never wait: a sample for a subscriber with a full buffer is discarded and counted.
    RealTime,
    /// Wait while a subscriber's buffer is full; discard (and count) only when a node died
    /// or after `backpressure_timeout`.
    LockStep {
        /// The longest a send waits for one subscriber.
        backpressure_timeout: Duration,
    },
}

impl Delivery {
    /// Lock-step with [`DEFAULT_BACKPRESSURE_TIMEOUT`].
    pub fn lock_step() -> Self {
        Delivery::LockStep {
            backpressure_timeout: DEFAULT_BACKPRESSURE_TIMEOUT,
        }
    }
}

/// Counters shared with the backpressure handlers (which iceoryx2 requires to be `Send`).
#[derive(Debug, Default)]
struct SharedCounters {
    discarded: AtomicU64,
    needs_cleanup: AtomicBool,
}

/// What a [`RobotPublisher`] did so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PublisherStats {
    /// Scans sent (each counted once, however many subscribers got it).
    pub scans_sent: u64,
    /// Odometry readings sent.
    pub odometry_sent: u64,
    /// Deliveries to one subscriber given up (full buffer in real time; dead subscriber or
    /// backpressure timeout in lock-step).
    pub discarded: u64,
    /// Dead nodes whose resources this publisher removed.
    pub dead_nodes_cleaned: u64,
}

fn any_dead_node(config: &Config) -> bool {
    let mut dead = false;
    let listed = Node::<ipc::Service>::list(config, |state| {
        if matches!(state, NodeState::Dead(_)) {
            dead = true;
            CallbackProgression::Stop
        } else {
            CallbackProgression::Continue
        }
    });
    listed.is_ok() && dead
}

/// The backpressure handler of one publisher port for `delivery`.
fn backpressure_handler(
    delivery: Delivery,
    config: Config,
    counters: Arc<SharedCounters>,
) -> impl Fn(&BackpressureInfo) -> BackpressureAction + Send + 'static {
    // Elapsed milliseconds of the current wait at which we last looked for dead nodes.
    let last_check_ms = AtomicU64::new(0);
    move |info: &BackpressureInfo| {
        let give_up = |counters: &SharedCounters| {
            counters.discarded.fetch_add(1, Ordering::Relaxed);
            counters.needs_cleanup.store(true, Ordering::Relaxed);
            BackpressureAction::DiscardData
        };
        match delivery {
            Delivery::RealTime => give_up(&counters),
            Delivery::LockStep {
                backpressure_timeout,
            } => {
                if info.retries == 0 {
                    last_check_ms.store(0, Ordering::Relaxed);
                }
                if info.elapsed_time >= backpressure_timeout {
                    tracing::warn!(
                        timeout_ms = backpressure_timeout.as_millis() as u64,
                        "a subscriber did not take a sample in time; discarding it for that subscriber"
                    );
                    return give_up(&counters);
                }
                let elapsed_ms = info.elapsed_time.as_millis() as u64;
                let period_ms = DEAD_CHECK_PERIOD.as_millis() as u64;
                if elapsed_ms >= last_check_ms.load(Ordering::Relaxed) + period_ms {
                    last_check_ms.store(elapsed_ms, Ordering::Relaxed);
                    if any_dead_node(&config) {
                        tracing::warn!("a node died while the publisher waited; discarding");
                        return give_up(&counters);
                    }
                }
                BackpressureAction::Retry
            }
        }
    }
}

/// Publishes one robot's scans and odometry. Not `Send`: use it on one thread.
pub struct RobotPublisher {
    node: Node<ipc::Service>,
    services: RobotServices,
    scan: Publisher<ipc::Service, [f32], ScanHeader>,
    odom: Publisher<ipc::Service, Odometry, ()>,
    notifier: Notifier<ipc::Service>,
    delivery: Delivery,
    counters: Arc<SharedCounters>,
    stats: PublisherStats,
}

impl RobotPublisher {
    /// Opens (or creates) `robot_id`'s services under `config` and creates the publishers.
    pub fn new(config: &IpcConfig, robot_id: &str, delivery: Delivery) -> Result<Self, IpcError> {
        let names = config.names(robot_id)?;
        let node = config.create_node(&format!("{robot_id}-publisher"))?;
        let services = RobotServices::open(&node, names)?;
        let counters = Arc::new(SharedCounters::default());
        let ice = config.iceoryx_config()?;
        let scan = services
            .scan
            .publisher_builder()
            .initial_max_slice_len(INITIAL_MAX_BEAMS)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .max_loaned_samples(2)
            .set_backpressure_handler(backpressure_handler(
                delivery,
                ice.clone(),
                counters.clone(),
            ))
            .create()
            .map_err(|e| setup_err("create", "scan publisher", e))?;
        let odom = services
            .odom
            .publisher_builder()
            .max_loaned_samples(2)
            .set_backpressure_handler(backpressure_handler(delivery, ice, counters.clone()))
            .create()
            .map_err(|e| setup_err("create", "odometry publisher", e))?;
        let notifier = services
            .events
            .notifier_builder()
            .create()
            .map_err(|e| setup_err("create", "event notifier", e))?;
        Ok(Self {
            node,
            services,
            scan,
            odom,
            notifier,
            delivery,
            counters,
            stats: PublisherStats::default(),
        })
    }

    /// The delivery mode this publisher was made with.
    pub fn delivery(&self) -> Delivery {
        self.delivery
    }

    /// The service names in use.
    pub fn names(&self) -> &ServiceNames {
        &self.services.names
    }

    /// Subscribers connected to both topics now.
    pub fn subscriber_count(&self) -> usize {
        self.services.subscriber_count()
    }

    /// Waits until at least `min_subscribers` subscribers exist on both topics and one of them
    /// has connected its ports to this publisher, so that no sample sent afterwards is lost
    /// to the start-up race (transport fact 1). Returns `false` on timeout.
    ///
    /// Handshake: the publisher notifies `PUBLISHER_UP` every 50 ms; a [`RobotSubscriber`](crate::RobotSubscriber)
    /// that sees it (while in `receive_timeout`) connects and answers `SUBSCRIBER_READY`.
    pub fn wait_for_subscribers(
        &mut self,
        min_subscribers: usize,
        timeout: Duration,
    ) -> Result<bool, IpcError> {
        let deadline = Instant::now() + timeout;
        while self.services.subscriber_count() < min_subscribers.max(1) {
            if Instant::now() >= deadline {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        self.connect()?;
        let listener = self
            .services
            .events
            .listener_builder()
            .create()
            .map_err(|e| setup_err("create", "event listener", e))?;
        loop {
            self.notify(EVENT_PUBLISHER_UP)?;
            let now = Instant::now();
            if now >= deadline {
                return Ok(false);
            }
            let mut ready = false;
            listener
                .timed_wait(
                    |activation| ready |= activation.id == EVENT_SUBSCRIBER_READY,
                    (deadline - now).min(Duration::from_millis(50)),
                )
                .map_err(|e| setup_err("wait on", "event listener", e))?;
            if ready {
                self.connect()?;
                return Ok(true);
            }
        }
    }

    fn connect(&self) -> Result<(), IpcError> {
        self.scan
            .update_connections()
            .map_err(|e| setup_err("connect", "scan publisher", e))?;
        self.odom
            .update_connections()
            .map_err(|e| setup_err("connect", "odometry publisher", e))
    }

    fn notify(&self, id: EventId) -> Result<(), IpcError> {
        self.notifier
            .notify_with_custom_event_id(id)
            .map(|_| ())
            .map_err(|e| IpcError::Send {
                topic: "events".into(),
                reason: format!("{e:?}"),
            })
    }

    /// After a send that gave up on a subscriber: remove dead nodes and drop their
    /// connections, so that the next send does not wait for them again.
    fn after_send(&mut self) -> Result<(), IpcError> {
        if self.counters.needs_cleanup.swap(false, Ordering::Relaxed) {
            let state = self.node.try_cleanup_dead_nodes();
            self.stats.dead_nodes_cleaned += state.cleanups;
            if state.cleanups > 0 {
                tracing::info!(cleaned = state.cleanups, "removed dead iceoryx2 nodes");
                self.connect()?;
            }
        }
        Ok(())
    }

    /// Publishes one scan: loans a slice of `ranges_m.len()` in shared memory, writes the
    /// ranges and the header in place, sends and notifies.
    pub fn publish_scan(&mut self, header: &ScanHeader, ranges_m: &[f32]) -> Result<(), IpcError> {
        if header.beam_count as usize != ranges_m.len() {
            return Err(IpcError::BeamCount {
                sequence: header.sequence,
                beam_count: header.beam_count,
                ranges: ranges_m.len(),
            });
        }
        let send_err = |e: &dyn std::fmt::Debug| IpcError::Send {
            topic: self.services.names.service_name(Topic::Scan),
            reason: format!("{e:?}"),
        };
        let mut sample = self
            .scan
            .loan_slice_uninit(ranges_m.len())
            .map_err(|e| send_err(&e))?;
        *sample.user_header_mut() = *header;
        let sample = sample.write_from_slice(ranges_m);
        sample.send().map_err(|e| send_err(&e))?;
        self.stats.scans_sent += 1;
        self.notify(EVENT_SCAN)?;
        self.after_send()
    }

    /// Publishes one odometry reading and notifies.
    pub fn publish_odometry(&mut self, odometry: &Odometry) -> Result<(), IpcError> {
        let sample = self.odom.loan_uninit().map_err(|e| IpcError::Send {
            topic: self.services.names.service_name(Topic::Odom),
            reason: format!("{e:?}"),
        })?;
        sample
            .write_payload(*odometry)
            .send()
            .map_err(|e| IpcError::Send {
                topic: self.services.names.service_name(Topic::Odom),
                reason: format!("{e:?}"),
            })?;
        self.stats.odometry_sent += 1;
        self.notify(EVENT_ODOM)?;
        self.after_send()
    }

    /// Publishes a scan or an odometry reading.
    pub fn publish(&mut self, event: &SensorEvent) -> Result<(), IpcError> {
        match event {
            SensorEvent::Scan(scan) => self.publish_scan(&scan.header, &scan.ranges_m),
            SensorEvent::Odometry(odometry) => self.publish_odometry(odometry),
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> PublisherStats {
        PublisherStats {
            discarded: self.counters.discarded.load(Ordering::Relaxed),
            ..self.stats
        }
    }
}
