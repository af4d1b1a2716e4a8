//! The MQTT side of VDA 5050: one MQTT connection per running session (rumqttc), whose last
//! will is the robot's `connection: CONNECTIONBROKEN`. It publishes `connection: ONLINE` at
//! every (re)connection, the robot's `visualization` at most at the configured rate while
//! new poses arrive, and `connection: OFFLINE` when the session stops.
//!
//! ```text
//! Session events (broadcast) ──▶ session task ──try_publish──▶ rumqttc request queue
//!                                     ▲                              │
//!                       connected (watch) ◀── event-loop task ◀──────┘ (reconnects by itself)
//! ```
//!
//! Nothing here blocks the session: publishing only queues (a full queue drops a
//! visualization, never a pose of the map), and a broker that is away only delays MQTT.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, SystemTime};

use rumqttc::{
    AsyncClient, ConnectionError, Event, EventLoop, LastWill, MqttOptions, Outgoing, Packet, QoS,
};
use sketchslam_api::{EventSubscription, SessionInfo};
use tokio::sync::{broadcast, watch};

use super::Vda5050Config;
use super::messages::{Connection, ConnectionState, DrawingFrame, Header, Visualization};
use super::position_tracker::PositionTracker;

/// Requests queued toward the broker at most; more visualizations are dropped.
const QUEUE: usize = 64;
/// Wait between two connection attempts while the broker is away.
const RETRY: Duration = Duration::from_secs(1);
/// How long a stopping session waits for its OFFLINE and goodbye to leave.
const GOODBYE: Duration = Duration::from_secs(2);

/// Who the messages are from: the header fields every message of one robot shares.
#[derive(Debug)]
struct Sender {
    manufacturer: String,
    serial: String,
}

impl Sender {
    fn header(&self, header_id: u64) -> Header {
        Header {
            header_id,
            timestamp: super::messages::timestamp(SystemTime::now()),
            version: super::messages::PROTOCOL_VERSION,
            manufacturer: self.manufacturer.clone(),
            serial_number: self.serial.clone(),
        }
    }
}

/// The robot's `connection` topic and its `headerId` counter, shared by the session task
/// (OFFLINE) and the event loop (ONLINE at each connection, the last will before each
/// attempt).
///
/// Ids: before an attempt the will is written with the id after the next one; the
/// connection's ONLINE takes the next one, so the will (sent only if the connection then
/// breaks) or the OFFLINE follows it. A connection that was up and broke may have had its
/// will sent, so its id is used up before the next attempt.
#[derive(Debug)]
struct ConnectionTopic {
    topic: String,
    from: Arc<Sender>,
    next_id: AtomicU64,
    stopping: AtomicBool,
}

impl ConnectionTopic {
    /// A message with the next id.
    fn message(&self, state: ConnectionState) -> Vec<u8> {
        let id = self.next_id.fetch_add(1, Ordering::SeqCst);
        json(&Connection {
            header: self.from.header(id),
            connection_state: state,
        })
    }

    /// The last will for the next attempt: CONNECTIONBROKEN, stamped now.
    fn will(&self) -> LastWill {
        let id = self.next_id.load(Ordering::SeqCst) + 1;
        let payload = json(&Connection {
            header: self.from.header(id),
            connection_state: ConnectionState::ConnectionBroken,
        });
        LastWill::new(&self.topic, payload, QoS::AtLeastOnce, true)
    }

    fn send(&self, client: &AsyncClient, state: ConnectionState) {
        send(
            client,
            &self.topic,
            QoS::AtLeastOnce,
            true,
            self.message(state),
        );
    }
}

/// Serves one session until its events end (it stopped), then says OFFLINE. Positions are
/// in the `drawing`'s frame when the session maps on one, else in the session's map.
pub async fn run_session(
    config: Arc<Vda5050Config>,
    resolution_m: f64,
    info: SessionInfo,
    drawing: Option<DrawingFrame>,
    events: EventSubscription,
) {
    let from = Arc::new(Sender {
        manufacturer: config.topics.manufacturer.clone(),
        serial: info.robot_id.clone(),
    });
    let visualization_topic = config.topics.topic(&info.robot_id, "visualization");
    let connection = Arc::new(ConnectionTopic {
        topic: config.topics.topic(&info.robot_id, "connection"),
        from: from.clone(),
        next_id: AtomicU64::new(0),
        stopping: AtomicBool::new(false),
    });
    let mut options = MqttOptions::new(
        format!("sketchslam-{}", info.id),
        config.broker.host.clone(),
        config.broker.port,
    );
    options
        .set_keep_alive(Duration::from_secs(5))
        .set_last_will(connection.will());
    if let Some((user, password)) = &config.broker.credentials {
        options.set_credentials(user.clone(), password.clone());
    }
    let (client, event_loop) = AsyncClient::new(options, QUEUE);
    let (link_tx, link) = watch::channel(false);
    let mut loop_task = tokio::spawn(drive(
        event_loop,
        client.clone(),
        connection.clone(),
        link_tx,
        info.id.clone(),
    ));

    let mut visualization_id = 0u64;
    let mut tracker = PositionTracker::new(info.loop_closures);
    for kept in &events.replay {
        tracker.on_event(&kept.event);
    }
    let mut tick = tokio::time::interval(config.period());
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut live = events.live;
    loop {
        tokio::select! {
            event = live.recv() => match event {
                Ok(event) => tracker.on_event(&event.event),
                Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => break,
            },
            _ = tick.tick() => {
                // Not queued while the broker is away: a fleet manager wants the position
                // now, not a burst of old ones at the reconnection.
                if !*link.borrow() {
                    continue;
                }
                let Some((position, velocity)) =
                    tracker.take_fresh(resolution_m, config.drift_per_m, drawing.as_ref())
                else {
                    continue;
                };
                let message = json(&Visualization {
                    header: from.header(visualization_id),
                    agv_position: position,
                    velocity,
                });
                visualization_id += 1;
                send(&client, &visualization_topic, QoS::AtMostOnce, false, message);
            }
        }
    }
    // OFFLINE, then an orderly DISCONNECT (the broker then drops the will). Should the
    // link break before they leave, the event loop says them at the next connection.
    connection.stopping.store(true, Ordering::SeqCst);
    connection.send(&client, ConnectionState::Offline);
    let _ = client.try_disconnect();
    if tokio::time::timeout(GOODBYE, &mut loop_task).await.is_err() {
        tracing::warn!(session = %info.id, "MQTT broker away at stop: OFFLINE not delivered");
        loop_task.abort();
    }
}

/// Polls the MQTT event loop: at each connection says ONLINE (OFFLINE and goodbye once the
/// session is stopping) and reports in `link` whether it is connected; when a connection fails, writes a
/// fresh will and retries every [`RETRY`]; ends after the goodbye leaves.
async fn drive(
    mut event_loop: EventLoop,
    client: AsyncClient,
    connection: Arc<ConnectionTopic>,
    link: watch::Sender<bool>,
    session: String,
) {
    let mut away_logged = false;
    loop {
        match event_loop.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                tracing::info!(%session, "MQTT connected");
                away_logged = false;
                if connection.stopping.load(Ordering::SeqCst) {
                    connection.send(&client, ConnectionState::Offline);
                    let _ = client.try_disconnect();
                } else {
                    // Queued before any visualization of this connection.
                    connection.send(&client, ConnectionState::Online);
                }
                link.send_replace(true);
            }
            Ok(Event::Outgoing(Outgoing::Disconnect)) => break,
            Ok(_) => {}
            // The client is gone: nothing will ever be sent again.
            Err(ConnectionError::RequestsDone) => break,
            Err(e) => {
                let was_up = link.send_if_modified(|up| std::mem::replace(up, false));
                if was_up {
                    // The broker may have sent the will: its id is taken.
                    connection.next_id.fetch_add(1, Ordering::SeqCst);
                }
                event_loop.mqtt_options.set_last_will(connection.will());
                if !away_logged {
                    tracing::warn!(%session, error = %e, "MQTT broker unreachable; retrying");
                    away_logged = true;
                }
                tokio::time::sleep(RETRY).await;
            }
        }
    }
}

fn send(client: &AsyncClient, topic: &str, qos: QoS, retain: bool, payload: Vec<u8>) {
    if let Err(e) = client.try_publish(topic, qos, retain, payload) {
        tracing::debug!(%topic, error = %e, "MQTT queue full: message dropped");
    }
}

fn json<T: serde::Serialize>(message: &T) -> Vec<u8> {
    // These types hold strings and finite numbers only: serializing cannot fail.
    serde_json::to_vec(message).unwrap_or_default()
}
