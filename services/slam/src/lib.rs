//! The slam-service runtime: the part of the crate that does I/O.
//!
//! ```text
//! HTTP (http_server, axum) ──▶ Registry (sessions + sketches, implements api::Backend)
//!                             │ one Session per robot
//!                             ▼
//!   intake thread (iceoryx2 RobotSubscriber) ──bounded channel──▶ mapper thread (Mapper)
//! ```
//!
//! With `--mqtt-url`, the registry also hands each session it starts to a VDA 5050 bridge
//! (`vda5050`), which publishes the robot's position to an MQTT broker from the session's
//! events.
//!
//! iceoryx2 handles never leave their intake thread; the async side only sees the registry,
//! whose calls the router makes on tokio's blocking pool, and broadcast channels of events.
//! [`run`] serves until its `shutdown` future completes, then stops every session (storing
//! its map and trajectory under the data dir) before returning.

pub mod codec;
pub mod config;
pub mod http_server;
pub mod intake;
pub mod method;
pub mod metrics;
pub mod process_stats;
pub mod registration_codec;
pub mod registry;
pub mod session;
pub mod sketch_store;
pub mod storage;
pub mod vda5050;
pub mod warp_cache;

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;

use sketchslam_api::{RouterOptions, router};
use thiserror::Error;
use tokio::net::TcpListener;

pub use config::{RegistryConfig, ServiceConfig};
pub use http_server::HttpLimits;
pub use registry::Registry;

/// Why the service could not start or stopped with an error.
#[derive(Debug, Error)]
pub enum RuntimeError {
    /// A setting is unusable.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The data dir cannot be created or read.
    #[error("data dir {path}: {source}")]
    DataDir {
        /// The data dir.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The listen address cannot be bound.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The HTTP server failed.
    #[error("HTTP server: {0}")]
    Serve(std::io::Error),
    /// A blocking task failed.
    #[error("background task: {0}")]
    Task(String),
}

/// Runs the service until `shutdown` completes: binds `config.listen`, serves the HTTP API
/// over a [`Registry`] on `config.data_dir`, and on shutdown stops every session (so that
/// SSE streams end and maps are stored) before the server drains.
pub async fn run(
    config: ServiceConfig,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), RuntimeError> {
    let listener = TcpListener::bind(config.listen)
        .await
        .map_err(|source| RuntimeError::Bind {
            addr: config.listen,
            source,
        })?;
    serve(listener, config, shutdown).await
}

/// [`run`] on an already bound listener (tests bind port 0 and read the address first).
pub async fn serve(
    listener: TcpListener,
    config: ServiceConfig,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), RuntimeError> {
    // Checked before the data dir is touched: a bad setting changes nothing.
    let vda5050 = config
        .vda5050
        .clone()
        .map(|vda| vda5050::Vda5050::new(vda, config.mapper.grid.resolution_m))
        .transpose()
        .map_err(RuntimeError::Config)?;
    let registry_config = RegistryConfig::from(&config);
    let registry = tokio::task::spawn_blocking(move || Registry::open(registry_config))
        .await
        .map_err(|e| RuntimeError::Task(e.to_string()))??;
    let registry = Arc::new(registry);
    let vda5050 = vda5050.map(|vda| {
        let (observer, bridges) = vda.spawn();
        registry.observe_sessions(observer);
        bridges
    });
    let app = router(
        registry.clone(),
        RouterOptions {
            token: config.token.clone(),
            max_body_bytes: config.max_body_bytes,
            max_concurrent_uploads: config.max_concurrent_uploads,
            cors_origins: config.cors_origins.clone(),
        },
    );
    let addr = listener.local_addr().map_err(RuntimeError::Serve)?;
    tracing::info!(
        %addr,
        data_dir = %config.data_dir.display(),
        ipc_prefix = %config.ipc_prefix,
        max_sessions = config.max_sessions,
        auth = config.token.is_some(),
        max_connections = config.http.max_connections,
        header_read_timeout_s = config.http.header_read_timeout.as_secs_f64(),
        request_timeout_s = config.http.request_timeout.as_secs_f64(),
        "slam-service listening"
    );
    if let Some(silent) = config.idle_stop {
        // Checked every second (a quarter of the idle time when that is shorter).
        let period = (silent / 4).clamp(
            std::time::Duration::from_millis(100),
            std::time::Duration::from_secs(1),
        );
        every(period, &registry, move |r| {
            r.stop_silent_sessions(silent);
        });
    }
    if let Some(period) = config.checkpoint_period {
        every(period, &registry, |r| {
            r.checkpoint_sessions();
        });
    }
    let stopping = registry.clone();
    let graceful = async move {
        shutdown.await;
        tracing::info!("shutting down: stopping sessions");
        if let Err(e) = tokio::task::spawn_blocking(move || stopping.shutdown()).await {
            tracing::error!(error = %e, "stopping sessions failed");
        }
    };
    http_server::serve_http(listener, app, config.http, graceful).await;
    // Sessions started while the server drained are stopped too.
    tokio::task::spawn_blocking(move || registry.shutdown())
        .await
        .map_err(|e| RuntimeError::Task(e.to_string()))?;
    if let Some(bridges) = vda5050 {
        // Each bridge says OFFLINE for its stopped session, or gives up on a broker that
        // is away after a few seconds.
        if tokio::time::timeout(std::time::Duration::from_secs(10), bridges)
            .await
            .is_err()
        {
            tracing::warn!("VDA 5050 bridges still running at exit");
        }
    }
    tracing::info!("slam-service stopped");
    Ok(())
}

/// Runs `job` on the blocking pool every `period` (the first after one period, and never two
/// at once) for as long as the registry lives.
fn every(
    period: std::time::Duration,
    registry: &Arc<Registry>,
    job: impl Fn(&Registry) + Clone + Send + 'static,
) {
    let watched = Arc::downgrade(registry);
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(period);
        // A job that overran its period is not run again at once to catch up.
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        tick.tick().await; // the first tick is immediate
        loop {
            tick.tick().await;
            let Some(registry) = watched.upgrade() else {
                break;
            };
            let job = job.clone();
            if tokio::task::spawn_blocking(move || job(&registry))
                .await
                .is_err()
            {
                break;
            }
        }
    });
}
