//! `mqtt-broker`: a real MQTT 3.1.1 broker (rumqttd) on a loopback port, for the tests of
//! the service's VDA 5050 side. A process of its own so a test can kill it and start it
//! again on the same port, as a broker that goes away and comes back. Retained messages
//! and last wills work as in Mosquitto; nothing is persisted across a restart.
//!
//! `mqtt-broker --port 18830` serves until killed.

use anyhow::Context;
use clap::Parser;

/// A loopback MQTT broker for tests.
#[derive(Debug, Parser)]
#[command(name = "mqtt-broker", about)]
struct Args {
    /// Loopback port to listen on.
    #[arg(long)]
    port: u16,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    // rumqttd's configuration is its TOML file format; only the v4 (MQTT 3.1.1) server.
    let config = format!(
        r#"
id = 0
[router]
id = 0
max_connections = 1000
max_outgoing_packet_count = 200
max_segment_size = 104857600
max_segment_count = 10

[v4.1]
name = "v4-1"
listen = "127.0.0.1:{port}"
next_connection_delay_ms = 1
    [v4.1.connections]
    connection_timeout_ms = 60000
    max_payload_size = 65536
    max_inflight_count = 100
    dynamic_filters = true
"#,
        port = args.port
    );
    let config: rumqttd::Config = toml::from_str(&config).context("broker configuration")?;
    let mut broker = rumqttd::Broker::new(config);
    eprintln!("mqtt-broker listening on 127.0.0.1:{}", args.port);
    broker.start().context("broker stopped")?;
    Ok(())
}
