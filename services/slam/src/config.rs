//! The service's settings, as `run` takes them (the binary fills them from flags and
//! environment variables).

use std::net::SocketAddr;
use std::path::PathBuf;

use sketchslam_engine::mapper::MapperConfig;

use crate::http_server::HttpLimits;
use crate::vda5050::Vda5050Config;

/// Everything [`super::run`] needs.
#[derive(Debug, Clone)]
pub struct ServiceConfig {
    /// Where the HTTP API listens; loopback by default.
    pub listen: SocketAddr,
    /// Where sketches and stopped sessions are kept.
    pub data_dir: PathBuf,
    /// The iceoryx2 prefix shared with the robots' publishers.
    pub ipc_prefix: String,
    /// How many sessions may run at once.
    pub max_sessions: usize,
    /// How many sketches the data dir may hold; an upload beyond is refused (409).
    pub max_sketches: usize,
    /// When set, every request except `/healthz` and the web page's files needs `Authorization: Bearer <token>`.
    pub token: Option<String>,
    /// The largest accepted request body, bytes.
    pub max_body_bytes: usize,
    /// Settings of every session's mapper.
    pub mapper: MapperConfig,
    /// Connection cap and timeouts of the HTTP listener.
    pub http: HttpLimits,
    /// Drawing uploads decoded at once; more wait their turn.
    pub max_concurrent_uploads: usize,
    /// A session whose robot has sent nothing for this long stops and stores itself;
    /// `None`: never.
    pub idle_stop: Option<std::time::Duration>,
    /// Each running session that processed something since its last checkpoint is written
    /// to the data dir this often (every session is also written once at its start);
    /// `None`: only at its start.
    pub checkpoint_period: Option<std::time::Duration>,
    /// Origins whose browser pages may call the API (CORS); `*` for any; empty: none but
    /// the service's own page.
    pub cors_origins: Vec<axum::http::HeaderValue>,
    /// VDA 5050 over MQTT: each session's `visualization` and `connection` for its robot;
    /// `None`: off.
    pub vda5050: Option<Vda5050Config>,
}

impl Default for ServiceConfig {
    fn default() -> Self {
        Self {
            listen: SocketAddr::from(([127, 0, 0, 1], 8080)),
            data_dir: PathBuf::from("./data"),
            ipc_prefix: sketchslam_types::DEFAULT_PREFIX.to_string(),
            max_sessions: 16,
            max_sketches: 1000,
            token: None,
            max_body_bytes: sketchslam_api::DEFAULT_MAX_BODY_BYTES,
            mapper: MapperConfig::default(),
            http: HttpLimits::default(),
            max_concurrent_uploads: sketchslam_api::DEFAULT_MAX_CONCURRENT_UPLOADS,
            idle_stop: Some(std::time::Duration::from_secs(60)),
            checkpoint_period: Some(std::time::Duration::from_secs(30)),
            cors_origins: Vec::new(),
            vda5050: None,
        }
    }
}

/// The part of [`ServiceConfig`] the session registry uses.
#[derive(Debug, Clone)]
pub struct RegistryConfig {
    /// Where sketches and stopped sessions are kept.
    pub data_dir: PathBuf,
    /// The iceoryx2 prefix.
    pub ipc_prefix: String,
    /// How many sessions may run at once.
    pub max_sessions: usize,
    /// How many sketches the data dir may hold; an upload beyond is refused (409).
    pub max_sketches: usize,
    /// Settings of every session's mapper.
    pub mapper: MapperConfig,
}

impl From<&ServiceConfig> for RegistryConfig {
    fn from(c: &ServiceConfig) -> Self {
        Self {
            data_dir: c.data_dir.clone(),
            ipc_prefix: c.ipc_prefix.clone(),
            max_sessions: c.max_sessions,
            max_sketches: c.max_sketches,
            mapper: c.mapper.clone(),
        }
    }
}
