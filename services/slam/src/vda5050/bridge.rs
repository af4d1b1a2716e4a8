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
use std::time::{Duration, SystemTime};

use rumqttc::{AsyncClient, Event, EventLoop, LastWill, MqttOptions, Outgoing, Packet, QoS};
use sketchslam_api::{EventSubscription, PoseResponse, SessionEvent, SessionInfo};
use tokio::sync::{broadcast, watch};

use super::Vda5050Config;
use super::messages::{
    Connection, ConnectionState, Header, Velocity, Visualization, agv_position, deviation_range_m,
    velocity_between,
};

/// Requests queued toward the broker at most; more visualizations are dropped.
const QUEUE: usize = 64;
/// Wait between two connection attempts while the broker is away.
const RETRY: Duration = Duration::from_secs(1);
/// How long a stopping session waits for its OFFLINE and goodbye to leave.
const GOODBYE: Duration = Duration::from_secs(2);

/// The per-topic counters of one robot (`headerId` counts the messages sent on a topic).
#[derive(Debug, Default)]
struct HeaderIds {
    connection: u64,
    visualization: u64,
}

/// Serves one session until its events end (it stopped), then says OFFLINE.
pub async fn run_session(
    config: Arc<Vda5050Config>,
    resolution_m: f64,
    info: SessionInfo,
    events: EventSubscription,
) {
    let serial = info.robot_id.clone();
    let connection_topic = config.topics.topic(&serial, "connection");
    let visualization_topic = config.topics.topic(&serial, "visualization");
    let header = |id: u64| Header {
        header_id: id,
        timestamp: super::messages::timestamp(SystemTime::now()),
        version: super::messages::PROTOCOL_VERSION,
        manufacturer: config.topics.manufacturer.clone(),
        serial_number: serial.clone(),
    };
    let mut ids = HeaderIds::default();
    // The will carries the id after the first ONLINE: MQTT fixes it at connect time.
    let will = json(&Connection {
        header: header(1),
        connection_state: ConnectionState::ConnectionBroken,
    });
    let mut options = MqttOptions::new(
        format!("sketchslam-{}", info.id),
        config.broker.host.clone(),
        config.broker.port,
    );
    options
        .set_keep_alive(Duration::from_secs(5))
        .set_last_will(LastWill::new(
            &connection_topic,
            will,
            QoS::AtLeastOnce,
            true,
        ));
    if let Some((user, password)) = &config.broker.credentials {
        options.set_credentials(user.clone(), password.clone());
    }
    let (client, event_loop) = AsyncClient::new(options, QUEUE);
    let (connected_tx, mut connected) = watch::channel(Link::default());
    let loop_task = tokio::spawn(drive(event_loop, connected_tx, info.id.clone()));

    let mut latest: Option<PoseResponse> = None;
    let mut fresh = false;
    let mut previous: Option<(f64, (f64, f64, f64))> = None;
    let mut velocity = Velocity::default();
    let mut path_since_closure_m = 0.0;
    let mut closures = info.loop_closures;
    let mut tick = tokio::time::interval(config.period());
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut live = events.live;
    loop {
        tokio::select! {
            changed = connected.changed() => {
                if changed.is_err() {
                    break;
                }
                if !connected.borrow_and_update().up {
                    continue;
                }
                let online = json(&Connection {
                    header: header(ids.connection),
                    connection_state: ConnectionState::Online,
                });
                ids.connection += 1;
                send(&client, &connection_topic, QoS::AtLeastOnce, true, online);
            }
            event = live.recv() => match event {
                Ok(event) => match event.event {
                    SessionEvent::Pose(pose) => {
                        if let Some(t) = pose.stamp {
                            let now = (pose.x, pose.y, pose.theta);
                            if let Some((t0, before)) = previous {
                                if let Some(v) = velocity_between(before, now, t - t0) {
                                    velocity = v;
                                }
                                let step = (now.0 - before.0).hypot(now.1 - before.1);
                                if step.is_finite() {
                                    path_since_closure_m += step;
                                }
                            }
                            previous = Some((t, now));
                        }
                        latest = Some(pose);
                        fresh = true;
                    }
                    SessionEvent::Status(status) => {
                        if status.loop_closures > closures {
                            closures = status.loop_closures;
                            path_since_closure_m = 0.0;
                        }
                    }
                },
                Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => break,
            },
            _ = tick.tick() => {
                // Not queued while the broker is away: a fleet manager wants the position
                // now, not a burst of old ones at the reconnection.
                if !connected.borrow().up {
                    continue;
                }
                let Some(pose) = latest.as_ref().filter(|_| fresh) else { continue };
                let deviation =
                    deviation_range_m(resolution_m, config.drift_per_m, path_since_closure_m);
                let Some(position) = agv_position(pose, deviation) else { continue };
                let message = json(&Visualization {
                    header: header(ids.visualization),
                    agv_position: position,
                    velocity,
                });
                ids.visualization += 1;
                fresh = false;
                send(&client, &visualization_topic, QoS::AtMostOnce, false, message);
            }
        }
    }
    let offline = json(&Connection {
        header: header(ids.connection),
        connection_state: ConnectionState::Offline,
    });
    send(&client, &connection_topic, QoS::AtLeastOnce, true, offline);
    // An orderly DISCONNECT: the broker then drops the will.
    let _ = client.try_disconnect();
    let mut loop_task = loop_task;
    if tokio::time::timeout(GOODBYE, &mut loop_task).await.is_err() {
        tracing::warn!(session = %info.id, "MQTT broker away at stop: OFFLINE not delivered");
        loop_task.abort();
    }
}

/// The MQTT link as the event loop sees it.
#[derive(Debug, Clone, Copy, Default)]
struct Link {
    /// Connected now.
    up: bool,
}

/// Polls the MQTT event loop: reports each connection and loss into `link`, retries every
/// [`RETRY`] while the broker is away, ends after the goodbye leaves.
async fn drive(mut event_loop: EventLoop, link: watch::Sender<Link>, session: String) {
    let mut away_logged = false;
    loop {
        match event_loop.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                tracing::info!(%session, "MQTT connected");
                away_logged = false;
                link.send_replace(Link { up: true });
            }
            Ok(Event::Outgoing(Outgoing::Disconnect)) => break,
            Ok(_) => {}
            Err(e) => {
                link.send_if_modified(|l| std::mem::replace(&mut l.up, false));
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
