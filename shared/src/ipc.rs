//! The iceoryx2 transport between a robot driver (the simulator, or a real robot's driver)
//! and the SLAM service: the ONE place where the services, ports and their settings are
//! built, so that both sides always open them with identical settings.
//!
//! Per robot `R` under prefix `P` there are three iceoryx2 services:
//! - `P/R/scan`: publish-subscribe of `[f32]` ranges with a [`ScanHeader`] user header; the
//!   publisher grows its slices by powers of two, so any beam count gets through;
//! - `P/R/odom`: publish-subscribe of [`Odometry`];
//! - `P/R/events`: an event service; publishers notify it after every sample (so the
//!   subscriber sleeps in a listener instead of spinning), and it carries the lock-step
//!   start-up handshake.
//!
//! The iceoryx2 `global.prefix` is derived from `P` as well (see [`IpcConfig`]): distinct
//! prefixes share nothing, not even `/dev/shm` segments (IPC-NOTES: a distinct root path
//! alone does not isolate).
//!
//! # Delivery modes
//!
//! iceoryx2's safe-overflow flag is a property of the *service*, and a subscriber opening a
//! service whose flag differs from its own fails (`IncompatibleOverflowBehavior`). Making the
//! mode a service setting would force the service side to know the mode of a publisher that
//! may not even run yet. So both modes use the **same service settings** (safe overflow off,
//! buffers of [`SCAN_BUFFER`] scans and [`ODOM_BUFFER`] odometry readings) and differ only
//! in the publisher's backpressure handler:
//! - [`Delivery::RealTime`]: a sample for a subscriber whose buffer is full is discarded at
//!   once (counted). The publisher never waits. Unlike safe overflow, the *newest* sample is
//!   the one lost; with a 32-scan buffer a slow subscriber lags at most 1.6 s at 20 Hz.
//! - [`Delivery::LockStep`]: the publisher waits while a subscriber's buffer is full. While it
//!   waits it checks every [`DEAD_CHECK_PERIOD`] whether a node died (a SIGKILLed subscriber
//!   never frees its buffer, IPC trap 2); if so, or when `backpressure_timeout` passes, the
//!   sample is discarded for that subscriber (counted) and dead nodes are cleaned up, so the
//!   next send does not wait again. Before the first sample the publisher waits for the
//!   subscriber to be connected ([`RobotPublisher::wait_for_subscribers`], IPC trap 1).
//!
//! The subscriber ([`RobotSubscriber`]) does not need to know the mode.
//!
//! # Threads
//!
//! iceoryx2 `ipc::Service` ports are neither `Send` nor `Sync` (IPC trap 4): a
//! [`RobotPublisher`] or [`RobotSubscriber`] is created, used and dropped on one thread.
//! Hand the owned [`SensorEvent`]s to other threads over channels.

use crate::messages::{Odometry, Scan, ScanHeader, SensorEvent};
use crate::names::{NameError, ServiceNames, Topic};
use iceoryx2::node::NodeState;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::event::PortFactory as EventService;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory as PubSubService;
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};
use thiserror::Error;

/// Scans a subscriber buffers before a lock-step publisher waits (real-time: discards).
pub const SCAN_BUFFER: usize = 32;
/// Odometry readings a subscriber buffers; larger than [`SCAN_BUFFER`] because odometry
/// comes 2-3 times as often as scans.
pub const ODOM_BUFFER: usize = 128;
/// Beams the publisher's scan slices hold before they grow (by powers of two).
pub const INITIAL_MAX_BEAMS: usize = 2048;
/// Publishers per topic (one driver plus one spare, e.g. a replacement starting up).
pub const MAX_PUBLISHERS: usize = 2;
/// Subscribers per topic.
pub const MAX_SUBSCRIBERS: usize = 8;
/// A waiting lock-step publisher starts looking for dead nodes after this long.
pub const DEAD_CHECK_PERIOD: Duration = Duration::from_millis(20);
/// The default backpressure timeout of [`Delivery::LockStep`]: a live subscriber that does
/// not take a sample for this long loses it. Generous, because a mapper may legitimately
/// spend hundreds of milliseconds on a scan; dead subscribers are detected much sooner.
pub const DEFAULT_BACKPRESSURE_TIMEOUT: Duration = Duration::from_secs(5);

/// Event id notified after a scan was published.
const EVENT_SCAN: EventId = EventId::new(1);
/// Event id notified after an odometry reading was published.
const EVENT_ODOM: EventId = EventId::new(2);
/// Event id a lock-step publisher notifies while it waits for subscribers to connect.
const EVENT_PUBLISHER_UP: EventId = EventId::new(3);
/// Event id a subscriber notifies once its ports are connected to the publishers.
const EVENT_SUBSCRIBER_READY: EventId = EventId::new(4);

/// Everything that can fail in the transport.
#[derive(Debug, Error)]
pub enum IpcError {
    /// The prefix or robot id cannot be part of a service name.
    #[error(transparent)]
    Name(#[from] NameError),
    /// iceoryx2 could not create or open something (node, service, port).
    #[error("iceoryx2: cannot {action} {what}: {reason}")]
    Setup {
        /// "create", "open", ...
        action: &'static str,
        /// The node, service or port concerned.
        what: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// A sample could not be loaned or sent.
    #[error("iceoryx2: cannot send on {topic}: {reason}")]
    Send {
        /// The service name.
        topic: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// A sample could not be received.
    #[error("iceoryx2: cannot receive on {topic}: {reason}")]
    Receive {
        /// The service name.
        topic: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// A scan's header disagrees with its ranges.
    #[error("scan {sequence}: header says {beam_count} beams but {ranges} ranges were given")]
    BeamCount {
        /// The scan's sequence number.
        sequence: u64,
        /// `header.beam_count`.
        beam_count: u32,
        /// The number of ranges.
        ranges: usize,
    },
}

fn setup_err(action: &'static str, what: impl Into<String>, e: impl std::fmt::Debug) -> IpcError {
    IpcError::Setup {
        action,
        what: what.into(),
        reason: format!("{e:?}"),
    }
}

/// How a run's processes find each other: the prefix of the service names and of every
/// iceoryx2 resource. Processes with different prefixes are fully isolated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IpcConfig {
    /// The prefix, e.g. `sketchslam` (1-64 of `[A-Za-z0-9_-]`).
    pub prefix: String,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            prefix: crate::names::DEFAULT_PREFIX.to_string(),
        }
    }
}

impl IpcConfig {
    /// A configuration for `prefix`, validated.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        crate::names::validate_segment("prefix", prefix)?;
        Ok(Self {
            prefix: prefix.to_string(),
        })
    }

    /// The service names of `robot_id`.
    pub fn names(&self, robot_id: &str) -> Result<ServiceNames, IpcError> {
        Ok(ServiceNames::new(&self.prefix, robot_id)?)
    }

    /// The iceoryx2 configuration: iceoryx2's built-in defaults (not a config file found
    /// in the working directory, so that two processes started from different directories
    /// still agree) with `global.prefix = "<prefix>_"`.
    pub fn iceoryx_config(&self) -> Result<Config, IpcError> {
        crate::names::validate_segment("prefix", &self.prefix)?;
        let mut config = Config::default();
        config.global.prefix = FileName::new(format!("{}_", self.prefix).as_bytes())
            .map_err(|e| setup_err("use", format!("prefix {:?}", self.prefix), e))?;
        Ok(config)
    }

    /// A node under this configuration: `SignalHandlingMode::Disabled` (the owning process
    /// handles signals itself, e.g. with tokio; IPC trap 3), and the resources of dead nodes
    /// (a killed earlier run) are cleaned before it is returned.
    pub fn create_node(&self, node_name: &str) -> Result<Node<ipc::Service>, IpcError> {
        let config = self.iceoryx_config()?;
        let name = NodeName::new(node_name).map_err(|e| setup_err("name", node_name, e))?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| setup_err("create", format!("node {node_name}"), e))?;
        let cleanup = node.try_cleanup_dead_nodes();
        if cleanup.cleanups > 0 || cleanup.failed_cleanups > 0 {
            tracing::info!(
                cleaned = cleanup.cleanups,
                failed = cleanup.failed_cleanups,
                "cleaned up dead iceoryx2 nodes"
            );
        }
        Ok(node)
    }
}

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

/// The three services of one robot, opened or created with the shared settings.
struct RobotServices {
    names: ServiceNames,
    scan: PubSubService<ipc::Service, [f32], ScanHeader>,
    odom: PubSubService<ipc::Service, Odometry, ()>,
    events: EventService<ipc::Service>,
}

impl RobotServices {
    fn open(node: &Node<ipc::Service>, names: ServiceNames) -> Result<Self, IpcError> {
        let scan_name = names.service_name(Topic::Scan);
        let odom_name = names.service_name(Topic::Odom);
        let events_name = format!("{}/{}/events", names.prefix, names.robot_id);
        let service_name =
            |n: &str| ServiceName::new(n).map_err(|e| setup_err("name", format!("service {n}"), e));
        let scan = node
            .service_builder(&service_name(&scan_name)?)
            .publish_subscribe::<[f32]>()
            .user_header::<ScanHeader>()
            .enable_safe_overflow(false)
            .subscriber_max_buffer_size(SCAN_BUFFER)
            .history_size(0)
            .max_publishers(MAX_PUBLISHERS)
            .max_subscribers(MAX_SUBSCRIBERS)
            .open_or_create()
            .map_err(|e| setup_err("open", format!("service {scan_name}"), e))?;
        let odom = node
            .service_builder(&service_name(&odom_name)?)
            .publish_subscribe::<Odometry>()
            .enable_safe_overflow(false)
            .subscriber_max_buffer_size(ODOM_BUFFER)
            .history_size(0)
            .max_publishers(MAX_PUBLISHERS)
            .max_subscribers(MAX_SUBSCRIBERS)
            .open_or_create()
            .map_err(|e| setup_err("open", format!("service {odom_name}"), e))?;
        let events = node
            .service_builder(&service_name(&events_name)?)
            .event()
            .open_or_create()
            .map_err(|e| setup_err("open", format!("service {events_name}"), e))?;
        Ok(Self {
            names,
            scan,
            odom,
            events,
        })
    }

    fn subscriber_count(&self) -> usize {
        self.scan
            .dynamic_config()
            .number_of_subscribers()
            .min(self.odom.dynamic_config().number_of_subscribers())
    }

    fn publisher_count(&self) -> usize {
        self.scan
            .dynamic_config()
            .number_of_publishers()
            .min(self.odom.dynamic_config().number_of_publishers())
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
    /// to the start-up race (IPC trap 1). Returns `false` on timeout.
    ///
    /// Handshake: the publisher notifies `PUBLISHER_UP` every 50 ms; a [`RobotSubscriber`]
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

/// FNV-1a (64 bit) over the little-endian bit patterns of `ranges_m`: a cheap fingerprint
/// to check that a scan crossed the transport bit for bit (NaN and infinities included).
pub fn ranges_checksum(ranges_m: &[f32]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for r in ranges_m {
        for byte in r.to_bits().to_le_bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    hash
}

/// A jump in a topic's sequence numbers seen by a subscriber.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gap {
    /// The topic with the jump.
    pub topic: Topic,
    /// The sequence number that was expected next.
    pub expected: u64,
    /// The sequence number that arrived. Less than `expected` means the publisher restarted.
    pub received: u64,
}

impl Gap {
    /// Samples lost in this gap (0 for a publisher restart).
    pub fn lost(&self) -> u64 {
        self.received.saturating_sub(self.expected)
    }
}

/// What a [`RobotSubscriber`] received so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SubscriberStats {
    /// Scans received.
    pub scans_received: u64,
    /// Odometry readings received.
    pub odometry_received: u64,
    /// Scans missing according to sequence numbers.
    pub scans_lost: u64,
    /// Odometry readings missing according to sequence numbers.
    pub odometry_lost: u64,
    /// Sequence numbers that went backwards (a publisher restarted).
    pub sequence_restarts: u64,
    /// Events delivered out of stamp order (only possible after losses).
    pub out_of_order: u64,
}

#[derive(Debug)]
struct Held<T> {
    item: T,
    stamp_ns: u64,
    /// Proven that nothing of the other topic with a smaller stamp is still in flight.
    safe: bool,
}

/// Merges a robot's two topics into one stream in stamp order (odometry before a scan with
/// the same stamp), without knowing the publisher's timing. Pure: no iceoryx2 inside.
///
/// The publisher sends both topics through one thread in stamp order, and each topic is a
/// FIFO. So after draining one topic's queue completely, every sample of the *other* topic
/// held before that drain is known to have no predecessor still in flight:
/// - held odometry becomes safe after a later scan drain (and whenever its stamp is at or
///   below the newest scan received);
/// - held scans become safe after a later odometry drain (and whenever their stamp is below
///   the newest odometry received).
///
/// The head of the merged stream is released only when it is safe. A receiver alternates
/// odometry drain, scan drain, odometry drain, so everything received is released by the
/// end of one pull.
#[derive(Debug, Default)]
pub struct StampMerge {
    odometry: VecDeque<Held<Odometry>>,
    scans: VecDeque<Held<Scan>>,
    newest_scan_ns: Option<u64>,
    newest_odometry_ns: Option<u64>,
    last_released_ns: Option<u64>,
    out_of_order: u64,
}

impl StampMerge {
    /// An empty merge.
    pub fn new() -> Self {
        Self::default()
    }

    /// Holds a received odometry reading.
    pub fn push_odometry(&mut self, odometry: Odometry) {
        self.newest_odometry_ns = Some(
            self.newest_odometry_ns
                .map_or(odometry.stamp_ns, |n| n.max(odometry.stamp_ns)),
        );
        self.odometry.push_back(Held {
            stamp_ns: odometry.stamp_ns,
            item: odometry,
            safe: false,
        });
    }

    /// Holds a received scan.
    pub fn push_scan(&mut self, scan: Scan) {
        let stamp_ns = scan.header.stamp_ns;
        self.newest_scan_ns = Some(self.newest_scan_ns.map_or(stamp_ns, |n| n.max(stamp_ns)));
        self.scans.push_back(Held {
            item: scan,
            stamp_ns,
            safe: false,
        });
    }

    /// The odometry queue was drained empty: every scan held now is safe.
    pub fn odometry_drained(&mut self) {
        self.scans.iter_mut().for_each(|h| h.safe = true);
    }

    /// The scan queue was drained empty: every odometry reading held now is safe.
    pub fn scans_drained(&mut self) {
        self.odometry.iter_mut().for_each(|h| h.safe = true);
    }

    /// Events held, released or not.
    pub fn len(&self) -> usize {
        self.odometry.len() + self.scans.len()
    }

    /// True when nothing is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Events released out of stamp order so far (possible only when samples were lost).
    pub fn out_of_order(&self) -> u64 {
        self.out_of_order
    }

    /// The next event in stamp order, if it is known that nothing earlier is in flight.
    pub fn pop(&mut self) -> Option<SensorEvent> {
        let odom_first = match (self.odometry.front(), self.scans.front()) {
            (None, None) => return None,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (Some(o), Some(s)) => o.stamp_ns <= s.stamp_ns,
        };
        let event = if odom_first {
            let head = self.odometry.front()?;
            let safe = head.safe || self.newest_scan_ns.is_some_and(|n| head.stamp_ns <= n);
            if !safe {
                return None;
            }
            SensorEvent::Odometry(self.odometry.pop_front()?.item)
        } else {
            let head = self.scans.front()?;
            let safe = head.safe || self.newest_odometry_ns.is_some_and(|n| head.stamp_ns < n);
            if !safe {
                return None;
            }
            SensorEvent::Scan(self.scans.pop_front()?.item)
        };
        let stamp = event.stamp_ns();
        if self.last_released_ns.is_some_and(|last| stamp < last) {
            self.out_of_order += 1;
        }
        self.last_released_ns = Some(self.last_released_ns.map_or(stamp, |l| l.max(stamp)));
        Some(event)
    }
}

/// Receives one robot's scans and odometry as owned [`SensorEvent`]s in stamp order.
/// Not `Send`: use it on one thread.
pub struct RobotSubscriber {
    _node: Node<ipc::Service>,
    services: RobotServices,
    scan: Subscriber<ipc::Service, [f32], ScanHeader>,
    odom: Subscriber<ipc::Service, Odometry, ()>,
    listener: Listener<ipc::Service>,
    notifier: Notifier<ipc::Service>,
    merge: StampMerge,
    next_scan_sequence: Option<u64>,
    next_odometry_sequence: Option<u64>,
    gaps: Vec<Gap>,
    stats: SubscriberStats,
    ready_requested: bool,
}

impl RobotSubscriber {
    /// Opens (or creates) `robot_id`'s services under `config` and creates the subscribers.
    /// A publisher need not exist yet.
    pub fn new(config: &IpcConfig, robot_id: &str) -> Result<Self, IpcError> {
        let names = config.names(robot_id)?;
        let node = config.create_node(&format!("{robot_id}-subscriber"))?;
        let services = RobotServices::open(&node, names)?;
        let scan = services
            .scan
            .subscriber_builder()
            .buffer_size(SCAN_BUFFER)
            .create()
            .map_err(|e| setup_err("create", "scan subscriber", e))?;
        let odom = services
            .odom
            .subscriber_builder()
            .buffer_size(ODOM_BUFFER)
            .create()
            .map_err(|e| setup_err("create", "odometry subscriber", e))?;
        let listener = services
            .events
            .listener_builder()
            .create()
            .map_err(|e| setup_err("create", "event listener", e))?;
        let notifier = services
            .events
            .notifier_builder()
            .create()
            .map_err(|e| setup_err("create", "event notifier", e))?;
        let subscriber = Self {
            _node: node,
            services,
            scan,
            odom,
            listener,
            notifier,
            merge: StampMerge::new(),
            next_scan_sequence: None,
            next_odometry_sequence: None,
            gaps: Vec::new(),
            stats: SubscriberStats::default(),
            // A publisher already waiting in its handshake notified before we listened.
            ready_requested: true,
        };
        Ok(subscriber)
    }

    /// The service names in use.
    pub fn names(&self) -> &ServiceNames {
        &self.services.names
    }

    /// Publishers present on both topics now.
    pub fn publisher_count(&self) -> usize {
        self.services.publisher_count()
    }

    /// The counters so far.
    pub fn stats(&self) -> SubscriberStats {
        SubscriberStats {
            out_of_order: self.merge.out_of_order(),
            ..self.stats
        }
    }

    /// Sequence jumps seen since the last call.
    pub fn take_gaps(&mut self) -> Vec<Gap> {
        std::mem::take(&mut self.gaps)
    }

    fn track(&mut self, topic: Topic, sequence: u64) {
        let next = match topic {
            Topic::Scan => &mut self.next_scan_sequence,
            Topic::Odom => &mut self.next_odometry_sequence,
        };
        if let Some(expected) = *next
            && sequence != expected
        {
            let gap = Gap {
                topic,
                expected,
                received: sequence,
            };
            if sequence < expected {
                self.stats.sequence_restarts += 1;
            } else {
                match topic {
                    Topic::Scan => self.stats.scans_lost += gap.lost(),
                    Topic::Odom => self.stats.odometry_lost += gap.lost(),
                }
            }
            tracing::warn!(?gap, "sequence jump");
            self.gaps.push(gap);
        }
        *next = Some(sequence + 1);
    }

    fn drain_odometry(&mut self) -> Result<usize, IpcError> {
        let mut n = 0;
        loop {
            let sample = self.odom.receive().map_err(|e| IpcError::Receive {
                topic: self.services.names.service_name(Topic::Odom),
                reason: format!("{e:?}"),
            })?;
            let Some(sample) = sample else { break };
            let odometry = *sample.payload();
            drop(sample);
            self.stats.odometry_received += 1;
            self.track(Topic::Odom, odometry.sequence);
            self.merge.push_odometry(odometry);
            n += 1;
        }
        self.merge.odometry_drained();
        Ok(n)
    }

    fn drain_scans(&mut self) -> Result<usize, IpcError> {
        let mut n = 0;
        loop {
            let sample = self.scan.receive().map_err(|e| IpcError::Receive {
                topic: self.services.names.service_name(Topic::Scan),
                reason: format!("{e:?}"),
            })?;
            let Some(sample) = sample else { break };
            let mut header = *sample.user_header();
            let ranges_m = sample.payload().to_vec();
            drop(sample);
            // The slice length is authoritative; a header disagreeing with it is corrected
            // rather than trusted.
            header.beam_count = ranges_m.len() as u32;
            self.stats.scans_received += 1;
            self.track(Topic::Scan, header.sequence);
            self.merge.push_scan(Scan { header, ranges_m });
            n += 1;
        }
        self.merge.scans_drained();
        Ok(n)
    }

    /// Drains both queues (odometry, scans, odometry) into the merge.
    fn pull(&mut self) -> Result<(), IpcError> {
        if self.ready_requested && self.services.publisher_count() > 0 {
            self.scan
                .update_connections()
                .map_err(|e| setup_err("connect", "scan subscriber", e))?;
            self.odom
                .update_connections()
                .map_err(|e| setup_err("connect", "odometry subscriber", e))?;
            self.notifier
                .notify_with_custom_event_id(EVENT_SUBSCRIBER_READY)
                .map_err(|e| IpcError::Send {
                    topic: "events".into(),
                    reason: format!("{e:?}"),
                })?;
            self.ready_requested = false;
        }
        self.drain_odometry()?;
        self.drain_scans()?;
        self.drain_odometry()?;
        Ok(())
    }

    /// The next event if one is available now, without waiting.
    pub fn try_receive(&mut self) -> Result<Option<SensorEvent>, IpcError> {
        if let Some(event) = self.merge.pop() {
            return Ok(Some(event));
        }
        self.listen(None)?;
        self.pull()?;
        Ok(self.merge.pop())
    }

    /// Consumes pending notifications; waits up to `timeout` for one if given.
    fn listen(&mut self, timeout: Option<Duration>) -> Result<u64, IpcError> {
        let mut publisher_up = false;
        let callback = |a: iceoryx2::port::EventActivation| {
            publisher_up |= a.id == EVENT_PUBLISHER_UP;
        };
        let n = match timeout {
            Some(t) => self.listener.timed_wait(callback, t),
            None => self.listener.try_wait(callback),
        }
        .map_err(|e| setup_err("wait on", "event listener", e))?;
        self.ready_requested |= publisher_up;
        Ok(n)
    }

    /// The next event in stamp order, waiting up to `timeout` (sleeping in the event
    /// listener, not spinning). `Ok(None)` when nothing arrived in time.
    pub fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<SensorEvent>, IpcError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(event) = self.try_receive()? {
                return Ok(Some(event));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            self.listen(Some(deadline - now))?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn odom(seq: u64, t: u64) -> Odometry {
        Odometry {
            sequence: seq,
            stamp_ns: t,
            ..Default::default()
        }
    }

    fn scan(seq: u64, t: u64) -> Scan {
        Scan {
            header: ScanHeader {
                sequence: seq,
                stamp_ns: t,
                ..Default::default()
            },
            ranges_m: vec![],
        }
    }

    fn drain(m: &mut StampMerge) -> Vec<(char, u64)> {
        std::iter::from_fn(|| m.pop())
            .map(|e| match e {
                SensorEvent::Odometry(o) => ('o', o.stamp_ns),
                SensorEvent::Scan(s) => ('s', s.header.stamp_ns),
            })
            .collect()
    }

    #[test]
    fn merge_orders_by_stamp_with_odometry_first_on_ties() {
        let mut m = StampMerge::new();
        // Pull: odometry drain, scan drain, odometry drain.
        m.push_odometry(odom(0, 0));
        m.push_odometry(odom(1, 20));
        m.push_odometry(odom(2, 40));
        m.odometry_drained();
        m.push_scan(scan(0, 0));
        m.push_scan(scan(1, 50));
        m.scans_drained();
        m.push_odometry(odom(3, 60));
        m.odometry_drained();
        assert_eq!(
            drain(&mut m),
            vec![('o', 0), ('s', 0), ('o', 20), ('o', 40), ('s', 50)]
        );
        // Odometry at 60 waits: a scan at 55 may still be in flight until the next scan drain.
        assert_eq!(m.len(), 1);
        m.scans_drained();
        assert_eq!(drain(&mut m), vec![('o', 60)]);
        assert_eq!(m.out_of_order(), 0);
    }

    #[test]
    fn merge_holds_odometry_until_no_earlier_scan_can_arrive() {
        let mut m = StampMerge::new();
        m.push_scan(scan(0, 10));
        m.odometry_drained(); // scan 10 safe
        // Odometry at 30 arrived, but a scan at 25 may still be in flight.
        m.push_odometry(odom(0, 30));
        assert_eq!(drain(&mut m), vec![('s', 10)]);
        assert_eq!(m.len(), 1);
        // The scan at 25 was sent before the odometry at 30.
        m.push_scan(scan(1, 25));
        m.scans_drained();
        m.odometry_drained();
        assert_eq!(drain(&mut m), vec![('s', 25), ('o', 30)]);
        assert!(m.is_empty());
    }

    #[test]
    fn merge_holds_a_scan_until_its_odometry_is_drained() {
        let mut m = StampMerge::new();
        m.push_scan(scan(0, 100));
        m.scans_drained();
        // No odometry drain yet: odometry at <= 100 might be queued.
        assert_eq!(m.pop(), None);
        m.push_odometry(odom(0, 90));
        m.push_odometry(odom(1, 100));
        m.odometry_drained();
        assert_eq!(drain(&mut m), vec![('o', 90), ('o', 100), ('s', 100)]);
    }

    #[test]
    fn prefix_goes_into_the_iceoryx_config() {
        let c = IpcConfig::new("run-42").unwrap();
        let ice = c.iceoryx_config().unwrap();
        assert_eq!(ice.global.prefix.to_string(), "run-42_");
        assert!(IpcConfig::new("a/b").is_err());
    }
}
