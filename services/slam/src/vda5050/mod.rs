//! VDA 5050 over MQTT: each running session reports its robot's position to a fleet
//! manager as VDA 5050 2.1 `visualization` and `connection` messages (off unless the
//! service is given `--mqtt-url`).
//!
//! [`messages`] builds the messages and [`position_tracker`] follows a session's events
//! (both pure); [`bridge`] runs one MQTT connection per session; [`Vda5050`] takes the sessions the registry starts and gives each its bridge.

pub mod bridge;
pub mod messages;
pub mod position_tracker;

use std::sync::Arc;
use std::time::Duration;

use sketchslam_api::{EventSubscription, SessionInfo, SketchSummary};
use tokio::sync::mpsc;
use tokio::task::{JoinHandle, JoinSet};

pub use messages::TopicNames;

/// The fastest `visualization` rate: VDA 5050 leaves it to the integrator; 10 Hz is what
/// fleet managers expect of a vehicle at most.
pub const MAX_RATE_HZ: f64 = 10.0;

/// Where the broker is: `mqtt://[user[:password]@]host[:port]` (port 1883 by default).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrokerAddress {
    /// Host name or address.
    pub host: String,
    /// TCP port.
    pub port: u16,
    /// User name and password, when the URL has them.
    pub credentials: Option<(String, String)>,
}

impl BrokerAddress {
    /// Reads `mqtt://…` or `tcp://…`; other schemes (TLS among them) are refused by name.
    pub fn parse(text: &str) -> Result<Self, String> {
        let url = url::Url::parse(text).map_err(|e| format!("MQTT URL {text:?}: {e}"))?;
        if !matches!(url.scheme(), "mqtt" | "tcp") {
            return Err(format!(
                "MQTT URL {text:?}: scheme {:?} is not supported (mqtt:// or tcp://; no TLS yet)",
                url.scheme()
            ));
        }
        let host = url
            .host_str()
            .filter(|h| !h.is_empty())
            .ok_or_else(|| format!("MQTT URL {text:?} names no host"))?;
        let host = host
            .trim_start_matches('[')
            .trim_end_matches(']')
            .to_string();
        let credentials = (!url.username().is_empty()).then(|| {
            let decode = |s: &str| {
                percent_encoding::percent_decode_str(s)
                    .decode_utf8_lossy()
                    .into_owned()
            };
            (decode(url.username()), decode(url.password().unwrap_or("")))
        });
        Ok(Self {
            host,
            port: url.port().unwrap_or(1883),
            credentials,
        })
    }
}

/// Everything the VDA 5050 side needs.
#[derive(Debug, Clone)]
pub struct Vda5050Config {
    /// The broker.
    pub broker: BrokerAddress,
    /// The topic levels before the robot's id.
    pub topics: TopicNames,
    /// `visualization` messages per second at most, in (0, [`MAX_RATE_HZ`]].
    pub rate_hz: f64,
    /// Drift of the position per meter travelled since the last loop closure, for
    /// `deviationRange` ([`messages::deviation_range_m`]).
    pub drift_per_m: f64,
}

impl Vda5050Config {
    /// The default drift per meter: 2 %, generous for a scan-matched 2D LiDAR chain.
    pub const DEFAULT_DRIFT_PER_M: f64 = 0.02;

    /// Checks the rate and the topic levels.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.rate_hz > 0.0 && self.rate_hz <= MAX_RATE_HZ) {
            return Err(format!(
                "VDA 5050 visualization rate {} Hz: must be in (0, {MAX_RATE_HZ}]",
                self.rate_hz
            ));
        }
        TopicNames::check_level("VDA 5050 interface", &self.topics.interface)?;
        TopicNames::check_level("VDA 5050 major version", &self.topics.major_version)?;
        TopicNames::check_level("VDA 5050 manufacturer", &self.topics.manufacturer)?;
        Ok(())
    }

    /// The time between two `visualization` messages.
    pub fn period(&self) -> Duration {
        Duration::from_secs_f64(1.0 / self.rate_hz)
    }
}

/// A session the registry just started, with its drawing (if it maps on one) and its
/// events from the start.
pub type StartedSession = (SessionInfo, Option<SketchSummary>, EventSubscription);

/// Gives each started session its MQTT bridge.
pub struct Vda5050 {
    config: Arc<Vda5050Config>,
    resolution_m: f64,
}

impl Vda5050 {
    /// A bridge factory for `config` (checked), for maps of `resolution_m` cells (the floor
    /// of `deviationRange`).
    pub fn new(config: Vda5050Config, resolution_m: f64) -> Result<Self, String> {
        config.validate()?;
        Ok(Self {
            config: Arc::new(config),
            resolution_m,
        })
    }

    /// Spawns, on the current tokio runtime, the task that bridges every session sent on
    /// the returned channel. Once the channel closes, the task ends when the last bridge
    /// has said OFFLINE (its sessions stopped) or given up on an absent broker.
    pub fn spawn(self) -> (mpsc::UnboundedSender<StartedSession>, JoinHandle<()>) {
        tracing::info!(
            broker = %format!("{}:{}", self.config.broker.host, self.config.broker.port),
            rate_hz = self.config.rate_hz,
            "VDA 5050 over MQTT on"
        );
        let (tx, mut rx) = mpsc::unbounded_channel::<StartedSession>();
        let task = tokio::spawn(async move {
            let mut bridges = JoinSet::new();
            loop {
                tokio::select! {
                    started = rx.recv() => match started {
                        Some((info, drawing, events)) => {
                            let frame = messages::DrawingFrame::of(&info, drawing.as_ref());
                            bridges.spawn(bridge::run_session(
                                self.config.clone(),
                                self.resolution_m,
                                info,
                                frame,
                                events,
                            ));
                        }
                        None => break,
                    },
                    // Reaps finished bridges so the set does not grow with every session.
                    Some(_) = bridges.join_next(), if !bridges.is_empty() => {}
                }
            }
            while bridges.join_next().await.is_some() {}
        });
        (tx, task)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn broker_urls_are_read_or_refused_by_name() {
        let b = BrokerAddress::parse("mqtt://127.0.0.1:18830").unwrap();
        assert_eq!(
            (b.host.as_str(), b.port, b.credentials),
            ("127.0.0.1", 18830, None)
        );
        let b = BrokerAddress::parse("tcp://broker.local").unwrap();
        assert_eq!(b.port, 1883);
        let b = BrokerAddress::parse("mqtt://fleet:p%40ss@[::1]:1884").unwrap();
        assert_eq!(b.host, "::1");
        assert_eq!(b.credentials, Some(("fleet".into(), "p@ss".into())));
        let e = BrokerAddress::parse("mqtts://broker:8883").unwrap_err();
        assert!(e.contains("mqtts"), "{e}");
        assert!(BrokerAddress::parse("broker:1883").is_err());
        assert!(BrokerAddress::parse("not a url").is_err());
    }

    #[test]
    fn the_rate_must_be_positive_and_at_most_10_hz() {
        let config = |rate_hz| Vda5050Config {
            broker: BrokerAddress::parse("mqtt://localhost").unwrap(),
            topics: TopicNames::default(),
            rate_hz,
            drift_per_m: Vda5050Config::DEFAULT_DRIFT_PER_M,
        };
        assert!(config(10.0).validate().is_ok());
        assert_eq!(config(4.0).period(), Duration::from_millis(250));
        for bad in [0.0, -1.0, 10.5, f64::NAN] {
            assert!(config(bad).validate().is_err(), "{bad}");
        }
    }
}
