//! `slam-service`: the sketchslam mapping service. A thin `main` over
//! [`sketchslam_slam::run`]: flags (each also read from an environment variable),
//! structured logs, a tokio runtime, and a clean shutdown on Ctrl-C or SIGTERM.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use sketchslam_slam::vda5050::{BrokerAddress, TopicNames, Vda5050Config};
use sketchslam_slam::{HttpLimits, ServiceConfig, run};

/// Builds metric maps from robots' LiDAR and odometry, with hand-drawn sketches as prior.
#[derive(Debug, Parser)]
#[command(name = "slam-service", version, about)]
struct Args {
    /// Address of the HTTP API (loopback by default).
    #[arg(long, env = "SKETCHSLAM_LISTEN", default_value = "127.0.0.1:8080")]
    listen: SocketAddr,
    /// Where sketches and stopped sessions are stored.
    #[arg(long, env = "SKETCHSLAM_DATA_DIR", default_value = "./data")]
    data_dir: PathBuf,
    /// iceoryx2 prefix shared with the robots' publishers (isolates parallel runs).
    #[arg(long, env = "SKETCHSLAM_IPC_PREFIX", default_value = sketchslam_types::DEFAULT_PREFIX)]
    ipc_prefix: String,
    /// How many sessions may run at once.
    #[arg(long, env = "SKETCHSLAM_MAX_SESSIONS", default_value_t = 16)]
    max_sessions: usize,
    /// How many drawings may be stored; an upload beyond is refused (409
    /// `too_many_sketches`). A stored drawing costs its files on disk and, in memory, its
    /// lines only (its stroke mask is read while a session uses it).
    #[arg(long, env = "SKETCHSLAM_MAX_SKETCHES", default_value_t = 1000)]
    max_sketches: usize,
    /// Largest accepted request body, bytes.
    #[arg(long, env = "SKETCHSLAM_MAX_BODY_BYTES", default_value_t = sketchslam_api::DEFAULT_MAX_BODY_BYTES)]
    max_body_bytes: usize,
    /// Bearer token required on every request except /healthz and the web page's files (prefer the variable).
    #[arg(long, env = "SKETCHSLAM_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Drawing uploads decoded at once (each holds up to ~270 MB while it runs); more wait.
    #[arg(long, env = "SKETCHSLAM_MAX_CONCURRENT_UPLOADS", default_value_t = sketchslam_api::DEFAULT_MAX_CONCURRENT_UPLOADS)]
    max_concurrent_uploads: usize,
    /// Seconds a session's robot may send nothing before the session stops and stores
    /// itself (its status says `robot_silent`); 0: never.
    #[arg(long, env = "SKETCHSLAM_IDLE_STOP_S", default_value_t = 60.0)]
    idle_stop_s: f64,
    /// Seconds between checkpoints of each running session (its map, trajectory and
    /// status written to the data dir, so that a crash leaves it `interrupted`, not lost);
    /// 0: only the one at its start.
    #[arg(long, env = "SKETCHSLAM_CHECKPOINT_S", default_value_t = 30.0)]
    checkpoint_s: f64,
    /// HTTP connections served at once; more wait until one closes.
    #[arg(long, env = "SKETCHSLAM_MAX_CONNECTIONS", default_value_t = HttpLimits::default().max_connections)]
    max_connections: usize,
    /// Seconds a client has to send a request's headers (and the longest pause inside a
    /// body); an idle keep-alive connection is closed after it too.
    #[arg(long, env = "SKETCHSLAM_HEADER_TIMEOUT_S", default_value_t = HttpLimits::default().header_read_timeout.as_secs_f64())]
    header_timeout_s: f64,
    /// Seconds a request may take, body included, before it is answered 408 (an event
    /// stream, once started, is not bounded).
    #[arg(long, env = "SKETCHSLAM_REQUEST_TIMEOUT_S", default_value_t = HttpLimits::default().request_timeout.as_secs_f64())]
    request_timeout_s: f64,
    /// An origin (`https://dash.example.com`) whose browser pages may call the API (CORS);
    /// repeat or separate with commas for several, `*` for any. Off by default: only the
    /// service's own page at `/` can.
    #[arg(
        long = "cors-origin",
        env = "SKETCHSLAM_CORS_ORIGIN",
        value_delimiter = ','
    )]
    cors_origins: Vec<String>,
    /// MQTT broker for VDA 5050 (`mqtt://[user:password@]host[:port]`): each session then
    /// publishes its robot's `visualization` and `connection` there. Off by default.
    #[arg(long, env = "SKETCHSLAM_MQTT_URL")]
    mqtt_url: Option<String>,
    /// VDA 5050 topic level 1, the interface name.
    #[arg(long, env = "SKETCHSLAM_VDA5050_INTERFACE", default_value = "uagv")]
    vda5050_interface: String,
    /// VDA 5050 topic level 2, the major version.
    #[arg(long, env = "SKETCHSLAM_VDA5050_VERSION", default_value = "v2")]
    vda5050_version: String,
    /// VDA 5050 topic level 3 and header field, the manufacturer (level 4, the serial
    /// number, is the session's robot id).
    #[arg(
        long,
        env = "SKETCHSLAM_VDA5050_MANUFACTURER",
        default_value = "sketchslam"
    )]
    vda5050_manufacturer: String,
    /// VDA 5050 `visualization` messages per second per robot at most (0 < rate <= 10).
    #[arg(long, env = "SKETCHSLAM_VDA5050_RATE_HZ", default_value_t = 5.0)]
    vda5050_rate_hz: f64,
    /// Log as JSON lines instead of text.
    #[arg(long, env = "SKETCHSLAM_LOG_JSON")]
    log_json: bool,
}

/// Completes on Ctrl-C or SIGTERM.
async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(e) = tokio::signal::ctrl_c().await {
            tracing::error!(error = %e, "cannot listen for Ctrl-C");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(e) => {
                tracing::error!(error = %e, "cannot listen for SIGTERM");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => tracing::info!("Ctrl-C received"),
        _ = terminate => tracing::info!("SIGTERM received"),
    }
}

/// A `--cors-origin` value: `*`, or `scheme://host[:port]` as a browser sends it in
/// `Origin` (no path, no trailing slash: a browser never sends one, so it would never match).
fn cors_origin(origin: &str) -> anyhow::Result<axum::http::HeaderValue> {
    let ok = origin == "*"
        || origin.split_once("://").is_some_and(|(scheme, rest)| {
            matches!(scheme, "http" | "https") && !rest.is_empty() && !rest.contains('/')
        });
    anyhow::ensure!(
        ok,
        "--cors-origin: {origin:?} is not an origin like https://dash.example.com or *"
    );
    axum::http::HeaderValue::from_str(origin)
        .with_context(|| format!("--cors-origin: {origin:?} is not a valid header value"))
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()));
    if args.log_json {
        builder.json().init();
    } else {
        builder.init();
    }
    let seconds = |name: &str, s: f64| {
        std::time::Duration::try_from_secs_f64(s)
            .ok()
            .filter(|d| !d.is_zero())
            .with_context(|| format!("--{name}: {s} is not a positive number of seconds"))
    };
    let http = HttpLimits {
        max_connections: args.max_connections.max(1),
        header_read_timeout: seconds("header-timeout-s", args.header_timeout_s)?,
        request_timeout: seconds("request-timeout-s", args.request_timeout_s)?,
        ..HttpLimits::default()
    };
    let cors_origins = args
        .cors_origins
        .iter()
        .map(|o| o.trim())
        .filter(|o| !o.is_empty())
        .map(cors_origin)
        .collect::<anyhow::Result<Vec<_>>>()?;
    let vda5050 = match args.mqtt_url.as_deref().filter(|u| !u.is_empty()) {
        None => None,
        // Checked (rate, topic levels) where the service starts.
        Some(url) => Some(Vda5050Config {
            broker: BrokerAddress::parse(url).map_err(|e| anyhow::anyhow!("--mqtt-url: {e}"))?,
            topics: TopicNames {
                interface: args.vda5050_interface,
                major_version: args.vda5050_version,
                manufacturer: args.vda5050_manufacturer,
            },
            rate_hz: args.vda5050_rate_hz,
            drift_per_m: Vda5050Config::DEFAULT_DRIFT_PER_M,
        }),
    };
    let config = ServiceConfig {
        listen: args.listen,
        data_dir: args.data_dir,
        ipc_prefix: args.ipc_prefix,
        max_sessions: args.max_sessions,
        max_sketches: args.max_sketches,
        token: args.token.filter(|t| !t.is_empty()),
        max_body_bytes: args.max_body_bytes,
        http,
        max_concurrent_uploads: args.max_concurrent_uploads.max(1),
        checkpoint_period: if args.checkpoint_s == 0.0 {
            None
        } else {
            Some(seconds("checkpoint-s", args.checkpoint_s)?)
        },
        idle_stop: if args.idle_stop_s == 0.0 {
            None
        } else {
            Some(seconds("idle-stop-s", args.idle_stop_s)?)
        },
        cors_origins,
        vda5050,
        ..ServiceConfig::default()
    };
    let runtime = tokio::runtime::Runtime::new().context("starting the tokio runtime")?;
    runtime
        .block_on(run(config, shutdown_signal()))
        .context("slam-service failed")
}
