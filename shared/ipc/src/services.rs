//! The settings every process opens a robot's three iceoryx2 services with (buffers, port
//! counts, event ids), and the one function that opens them, so both sides always agree.

use crate::error::{IpcError, setup_err};
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::event::PortFactory as EventService;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory as PubSubService;
use sketchslam_types::names::{ServiceNames, Topic};
use sketchslam_types::{Odometry, ScanHeader};
use std::time::Duration;

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
/// The default backpressure timeout of [`Delivery::LockStep`](crate::Delivery::LockStep): a live subscriber that does
/// not take a sample for this long loses it. Generous, because a mapper may legitimately
/// spend hundreds of milliseconds on a scan; dead subscribers are detected much sooner.
pub const DEFAULT_BACKPRESSURE_TIMEOUT: Duration = Duration::from_secs(5);

/// Event id notified after a scan was published.
pub(crate) const EVENT_SCAN: EventId = EventId::new(1);
/// Event id notified after an odometry reading was published.
pub(crate) const EVENT_ODOM: EventId = EventId::new(2);
/// Event id a lock-step publisher notifies while it waits for subscribers to connect.
pub(crate) const EVENT_PUBLISHER_UP: EventId = EventId::new(3);
/// Event id a subscriber notifies once its ports are connected to the publishers.
pub(crate) const EVENT_SUBSCRIBER_READY: EventId = EventId::new(4);

/// The three services of one robot, opened or created with the shared settings.
pub(crate) struct RobotServices {
    pub(crate) names: ServiceNames,
    pub(crate) scan: PubSubService<ipc::Service, [f32], ScanHeader>,
    pub(crate) odom: PubSubService<ipc::Service, Odometry, ()>,
    pub(crate) events: EventService<ipc::Service>,
}

impl RobotServices {
    pub(crate) fn open(node: &Node<ipc::Service>, names: ServiceNames) -> Result<Self, IpcError> {
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

    pub(crate) fn subscriber_count(&self) -> usize {
        self.scan
            .dynamic_config()
            .number_of_subscribers()
            .min(self.odom.dynamic_config().number_of_subscribers())
    }

    pub(crate) fn publisher_count(&self) -> usize {
        self.scan
            .dynamic_config()
            .number_of_publishers()
            .min(self.odom.dynamic_config().number_of_publishers())
    }
}
