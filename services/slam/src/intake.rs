//! The intake thread of a session: the one place a robot's iceoryx2 subscriber lives.
//!
//! iceoryx2 ports are not `Send` (docs/architecture.md, transport fact 4), so the
//! [`RobotSubscriber`] is created, used and dropped on this thread; what leaves it are owned
//! [`SensorEvent`]s and counters over a bounded std channel to the session's mapper thread.
//! The channel being bounded carries backpressure back to a lock-step publisher: a slow
//! mapper makes the intake wait, the subscriber's buffer fills, and the publisher waits too —
//! no scan is lost.
//!
//! A publisher may start before or after the session, stop, be killed and come back: the
//! subscriber outlives it, and sequence gaps are reported as lost samples.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use sketchslam_ipc::{IpcConfig, RobotSubscriber, SubscriberStats};
use sketchslam_types::SensorEvent;

/// How long one wait for data lasts before the stop flag is checked again.
const POLL: Duration = Duration::from_millis(50);
/// The longest the intake keeps draining after a stop was asked for (bounded for a
/// publisher that outpaces the mapper and would otherwise keep the drain going forever).
const FINAL_DRAIN: Duration = Duration::from_secs(10);
/// Capacity of the intake → mapper channel, messages.
pub const CHANNEL_CAPACITY: usize = 64;

/// What the intake hands to the mapper thread.
#[derive(Debug)]
pub enum IntakeMsg {
    /// The next message of the robot's stream, in stamp order.
    Event(SensorEvent),
    /// The subscriber's counters changed (losses, publisher restarts).
    Stats(SubscriberStats),
    /// Receiving failed; the intake keeps trying.
    Error(String),
}

/// A running intake thread.
pub struct Intake {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Intake {
    /// Starts the intake of `robot_id` and waits until its subscriber exists (so that a
    /// setup failure is reported to the client that started the session).
    pub fn start(ipc: IpcConfig, robot_id: &str) -> Result<(Intake, Receiver<IntakeMsg>), String> {
        let (tx, rx) = sync_channel(CHANNEL_CAPACITY);
        let (ready_tx, ready_rx) = sync_channel::<Result<(), String>>(1);
        let stop = Arc::new(AtomicBool::new(false));
        let thread_stop = stop.clone();
        let robot = robot_id.to_string();
        let thread = std::thread::Builder::new()
            .name(format!("intake-{robot_id}"))
            .spawn(move || run(ipc, robot, tx, thread_stop, ready_tx))
            .map_err(|e| format!("cannot spawn the intake thread: {e}"))?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok((
                Intake {
                    stop,
                    thread: Some(thread),
                },
                rx,
            )),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => {
                let _ = thread.join();
                Err("the intake thread ended during start-up".to_string())
            }
        }
    }

    /// Asks the thread to stop (it drains what has arrived, then ends).
    pub fn request_stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Stops the thread and waits for it.
    pub fn stop(mut self) {
        self.request_stop();
        if let Some(t) = self.thread.take()
            && t.join().is_err()
        {
            tracing::error!("the intake thread panicked");
        }
    }
}

impl Drop for Intake {
    fn drop(&mut self) {
        self.request_stop();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn run(
    ipc: IpcConfig,
    robot_id: String,
    tx: SyncSender<IntakeMsg>,
    stop: Arc<AtomicBool>,
    ready: SyncSender<Result<(), String>>,
) {
    let mut subscriber = match RobotSubscriber::new(&ipc, &robot_id) {
        Ok(s) => {
            let _ = ready.send(Ok(()));
            s
        }
        Err(e) => {
            let _ = ready.send(Err(format!("cannot subscribe to robot {robot_id:?}: {e}")));
            return;
        }
    };
    tracing::info!(robot = %robot_id, "intake subscribed");
    let mut last_stats = subscriber.stats();
    let mut last_error: Option<String> = None;
    let mut drain_deadline: Option<Instant> = None;
    loop {
        if drain_deadline.is_none() && stop.load(Ordering::SeqCst) {
            drain_deadline = Some(Instant::now() + FINAL_DRAIN);
        }
        let received = match drain_deadline {
            None => subscriber.receive_timeout(POLL),
            Some(deadline) if Instant::now() < deadline => subscriber.try_receive(),
            Some(_) => break,
        };
        match received {
            Ok(Some(event)) => {
                if tx.send(IntakeMsg::Event(event)).is_err() {
                    break;
                }
                last_error = None;
            }
            Ok(None) if drain_deadline.is_some() => break,
            Ok(None) => {}
            Err(e) => {
                let message = e.to_string();
                if last_error.as_deref() != Some(message.as_str()) {
                    tracing::warn!(robot = %robot_id, error = %message, "intake receive failed");
                    if tx.send(IntakeMsg::Error(message.clone())).is_err() {
                        break;
                    }
                    last_error = Some(message);
                }
                if drain_deadline.is_some() {
                    break;
                }
                std::thread::sleep(POLL);
            }
        }
        let stats = subscriber.stats();
        if (
            stats.scans_lost,
            stats.odometry_lost,
            stats.sequence_restarts,
        ) != (
            last_stats.scans_lost,
            last_stats.odometry_lost,
            last_stats.sequence_restarts,
        ) {
            for gap in subscriber.take_gaps() {
                tracing::info!(robot = %robot_id, ?gap, "gap in the robot's stream");
            }
            if tx.send(IntakeMsg::Stats(stats)).is_err() {
                break;
            }
        }
        last_stats = stats;
    }
    tracing::info!(robot = %robot_id, received = last_stats.scans_received, "intake stopped");
}
