//! The iceoryx2 transport between a robot driver (the simulator, or a real robot's driver)
//! and the SLAM service: the ONE place where the services, ports and their settings are
//! built, so that both sides always open them with identical settings.
//!
//! Per robot `R` under prefix `P` there are three iceoryx2 services:
//! - `P/R/scan`: publish-subscribe of `[f32]` ranges with a
//!   [`ScanHeader`](sketchslam_types::ScanHeader) user header; the publisher grows its slices
//!   by powers of two, so any beam count gets through;
//! - `P/R/odom`: publish-subscribe of [`Odometry`](sketchslam_types::Odometry);
//! - `P/R/events`: an event service; publishers notify it after every sample (so the
//!   subscriber sleeps in a listener instead of spinning), and it carries the lock-step
//!   start-up handshake.
//!
//! The iceoryx2 `global.prefix` is derived from `P` as well (see [`IpcConfig`]): distinct
//! prefixes share nothing, not even `/dev/shm` segments (a distinct root path
//! alone does not isolate; see `docs/architecture.md`).
//!
//! "Transport fact N" below and in the files cites the numbered list of what the code relies
//! on about iceoryx2, in `docs/architecture.md` ("Transport").
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
//!   never frees its buffer, transport fact 2); if so, or when `backpressure_timeout` passes, the
//!   sample is discarded for that subscriber (counted) and dead nodes are cleaned up, so the
//!   next send does not wait again. Before the first sample the publisher waits for the
//!   subscriber to be connected ([`RobotPublisher::wait_for_subscribers`], transport
//!   fact 1).
//!
//! The subscriber ([`RobotSubscriber`]) does not need to know the mode.
//!
//! # Threads
//!
//! iceoryx2 `ipc::Service` ports are neither `Send` nor `Sync` (transport fact 4): a
//! [`RobotPublisher`] or [`RobotSubscriber`] is created, used and dropped on one thread.
//! Hand the owned [`SensorEvent`](sketchslam_types::SensorEvent)s to other threads over
//! channels.

mod checksum;
mod config;
mod error;
mod merge;
mod publisher;
mod services;
mod subscriber;

pub use checksum::ranges_checksum;
pub use config::IpcConfig;
pub use error::IpcError;
pub use merge::StampMerge;
pub use publisher::{Delivery, PublisherStats, RobotPublisher};
pub use services::{
    DEAD_CHECK_PERIOD, DEFAULT_BACKPRESSURE_TIMEOUT, INITIAL_MAX_BEAMS, MAX_PUBLISHERS,
    MAX_SUBSCRIBERS, ODOM_BUFFER, SCAN_BUFFER,
};
pub use subscriber::{Gap, RobotSubscriber, SubscriberStats};
