//! The real `slam-service` for tests, benchmarks and `evaluate`: started on a loopback
//! port over a data dir and an iceoryx2 prefix, and awaited until `/healthz` answers.
//!
//! The one place that launches the service (the multi-process tests, `bench-http`,
//! `bench-fleet` and the real-process mode of `evaluate` all go through
//! [`ServiceProcess::start`]). What callers vary is in [`ServiceOptions`]: the data dir,
//! the prefix, the port, the log file, extra arguments and environment variables. The
//! service never inherits the `SKETCHSLAM_*` settings of the caller's environment that its
//! arguments do not override (token, body limit, session limit, JSON logs): a run sees only
//! what its options say. The child is a [`ChildGuard`], killed on drop.

use crate::processes::{ChildGuard, binary, free_port};
use anyhow::{Result, bail};
use sketchslam_api::SketchslamClient;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How long the service may take to answer `/healthz` after start.
pub const SERVICE_START_TIMEOUT: Duration = Duration::from_secs(60);

/// The service's settings read from the environment that no argument of
/// [`ServiceProcess::start`] overrides; removed unless [`ServiceOptions::env`] sets them.
const INHERITED_SETTINGS: [&str; 4] = [
    "SKETCHSLAM_TOKEN",
    "SKETCHSLAM_MAX_BODY_BYTES",
    "SKETCHSLAM_MAX_SESSIONS",
    "SKETCHSLAM_LOG_JSON",
];

/// How to start a service.
#[derive(Debug, Clone)]
pub struct ServiceOptions {
    /// `--data-dir`.
    pub data_dir: PathBuf,
    /// `--ipc-prefix`.
    pub prefix: String,
    /// The loopback port; None: a free one.
    pub port: Option<u16>,
    /// Where the service's stderr goes.
    pub log: PathBuf,
    /// Append to `log` (a restarted service on the same data dir) instead of truncating it.
    pub append_log: bool,
    /// More arguments, e.g. `--max-sessions 64`.
    pub extra_args: Vec<String>,
    /// Environment variables set for the service (after the inherited settings are
    /// removed), e.g. `RUST_LOG` or `SKETCHSLAM_TOKEN`.
    pub env: Vec<(String, String)>,
}

impl ServiceOptions {
    /// A service over `data_dir` and `prefix` on a free port, logging to `log`
    /// (truncated), with no extra argument or variable.
    pub fn new(
        data_dir: impl Into<PathBuf>,
        prefix: impl Into<String>,
        log: impl Into<PathBuf>,
    ) -> Self {
        ServiceOptions {
            data_dir: data_dir.into(),
            prefix: prefix.into(),
            port: None,
            log: log.into(),
            append_log: false,
            extra_args: Vec::new(),
            env: Vec::new(),
        }
    }

    /// Appends to the log instead of truncating it.
    pub fn append_log(mut self) -> Self {
        self.append_log = true;
        self
    }

    /// Adds arguments.
    pub fn args<S: AsRef<str>>(mut self, args: impl IntoIterator<Item = S>) -> Self {
        self.extra_args
            .extend(args.into_iter().map(|a| a.as_ref().to_string()));
        self
    }

    /// Sets an environment variable of the service.
    pub fn env(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.env.push((key.into(), value.into()));
        self
    }
}

/// A running `slam-service` and a client of its API.
#[derive(Debug)]
pub struct ServiceProcess {
    /// The process.
    pub guard: ChildGuard,
    /// A client of its API (without a token).
    pub client: SketchslamClient,
    /// `http://127.0.0.1:PORT`.
    pub base: String,
    /// Where its stderr goes.
    pub log: PathBuf,
}

impl ServiceProcess {
    /// Starts `slam-service` with `options` and waits until `/healthz` answers (at most
    /// [`SERVICE_START_TIMEOUT`]); fails if the service exits first.
    pub async fn start(options: &ServiceOptions) -> Result<ServiceProcess> {
        let exe = binary("sketchslam-slam", "slam-service")?;
        let port = match options.port {
            Some(p) => p,
            None => free_port()?,
        };
        let log = std::fs::File::options()
            .create(true)
            .write(true)
            .append(options.append_log)
            .truncate(!options.append_log)
            .open(&options.log)?;
        let mut cmd = Command::new(exe);
        cmd.args(["--listen", &format!("127.0.0.1:{port}")])
            .arg("--data-dir")
            .arg(&options.data_dir)
            .args(["--ipc-prefix", &options.prefix])
            .args(&options.extra_args)
            .stdout(Stdio::null())
            .stderr(log);
        for key in INHERITED_SETTINGS {
            cmd.env_remove(key);
        }
        for (k, v) in &options.env {
            cmd.env(k, v);
        }
        let mut guard = ChildGuard::spawn("slam-service", &mut cmd)?;
        let base = format!("http://127.0.0.1:{port}");
        let client = SketchslamClient::new(base.clone());
        let deadline = Instant::now() + SERVICE_START_TIMEOUT;
        // /healthz needs no token even when the service has one.
        while client.health().await.is_err() {
            if let Some(status) = guard.child_mut().try_wait()? {
                bail!(
                    "slam-service exited at start: {status} (see {})",
                    options.log.display()
                );
            }
            if Instant::now() > deadline {
                bail!(
                    "slam-service did not answer /healthz within {SERVICE_START_TIMEOUT:?} \
                     (see {})",
                    options.log.display()
                );
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        Ok(ServiceProcess {
            guard,
            client,
            base,
            log: options.log.clone(),
        })
    }
}

/// Prints the last `lines` lines of a service log to stderr (on failure).
pub fn dump_log(log: &Path, lines: usize) {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let tail: Vec<&str> = text.lines().rev().take(lines).collect();
    for line in tail.iter().rev() {
        eprintln!("slam-service| {line}");
    }
}
