//! The service side of the transport: one robot's scans and odometry received as owned
//! events in stamp order, with the gaps and restarts its sequence numbers show.

use crate::config::IpcConfig;
use crate::error::{IpcError, setup_err};
use crate::merge::StampMerge;
use crate::services::*;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use sketchslam_types::names::{ServiceNames, Topic};
use sketchslam_types::{Odometry, Scan, ScanHeader, SensorEvent};
use std::time::{Duration, Instant};

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
