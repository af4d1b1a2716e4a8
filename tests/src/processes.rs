//! Launching the real binaries from tests, benchmarks and `evaluate`.
//!
//! - [`binary`] finds (and builds once, with the caller's own profile and target dir) a
//!   workspace binary, so `cargo test --workspace` alone works on a fresh clone;
//! - [`ChildGuard`] kills and reaps a child when dropped, so a failing test leaves nothing
//!   behind;
//! - [`unique_prefix`] gives every run its own iceoryx2 prefix, so parallel runs never see
//!   each other; [`free_port`] a loopback port for the HTTP API.

use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Mutex, OnceLock};

/// The folder holding this profile's binaries: the running executable's folder, or its
/// parent when it runs from `deps/` (test harnesses).
pub fn bin_dir() -> Result<PathBuf> {
    let exe = std::env::current_exe().context("locating the running executable")?;
    let mut dir = exe
        .parent()
        .context("executable without a folder")?
        .to_path_buf();
    if dir.file_name().is_some_and(|n| n == "deps") {
        dir.pop();
    }
    Ok(dir)
}

/// The path of workspace binary `bin` of package `package`, with every workspace binary
/// built first (once per process) with the same profile and target dir as the running
/// executable.
///
/// The build covers the whole workspace (`cargo build --workspace --bins`), not just
/// `package`: Cargo unifies dependency features over the packages it builds, so building
/// one package alone selects other features than `cargo test --workspace` did and
/// recompiles much of the dependency tree (minutes on a fresh clone). Over the whole
/// workspace the features match, and after `cargo test --workspace` the build is a no-op.
pub fn binary(package: &str, bin: &str) -> Result<PathBuf> {
    static BUILT: OnceLock<Mutex<Option<PathBuf>>> = OnceLock::new();
    let built = BUILT.get_or_init(|| Mutex::new(None));
    let mut built = built.lock().unwrap_or_else(|e| e.into_inner());
    let dir = match built.as_ref() {
        Some(dir) => dir.clone(),
        None => {
            let dir = build_workspace_bins()?;
            *built = Some(dir.clone());
            dir
        }
    };
    let path = dir.join(bin);
    if !path.exists() {
        bail!(
            "{} not found: build the workspace's binaries (cargo build --release --workspace \
             --bins) and run from the target folder, or put `{bin}` (package {package}) \
             beside this executable",
            path.display()
        );
    }
    Ok(path)
}

/// Builds every workspace binary with the running executable's profile and target dir;
/// returns the folder holding them. An executable that does not run from a Cargo target
/// folder (copied or installed elsewhere) builds nothing: the binaries must lie beside it.
fn build_workspace_bins() -> Result<PathBuf> {
    let dir = bin_dir()?;
    if !dir.join(".fingerprint").is_dir() {
        return Ok(dir);
    }
    let profile = dir
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("debug")
        .to_string();
    let target_dir = dir.parent().context("profile folder without a parent")?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args(["build", "--quiet", "--workspace", "--bins"])
        .env("CARGO_TARGET_DIR", target_dir);
    match profile.as_str() {
        "debug" => {}
        "release" => {
            cmd.arg("--release");
        }
        other => {
            cmd.args(["--profile", other]);
        }
    }
    cmd.current_dir(workspace_root());
    let status = cmd
        .status()
        .context("running cargo build --workspace --bins")?;
    if !status.success() {
        bail!("cargo build --workspace --bins failed");
    }
    Ok(dir)
}

/// The workspace root (this crate's parent folder).
pub fn workspace_root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap_or(Path::new("."))
}

/// A bundled scenario folder, e.g. `paper-env1`.
pub fn bundled_scenario(name: &str) -> PathBuf {
    workspace_root()
        .join("simulator")
        .join("scenarios")
        .join(name)
}

/// A child process killed and reaped when the guard is dropped.
#[derive(Debug)]
pub struct ChildGuard {
    name: String,
    child: Option<Child>,
}

impl ChildGuard {
    /// Spawns `cmd`, naming it `name` in errors.
    pub fn spawn(name: &str, cmd: &mut Command) -> Result<ChildGuard> {
        let child = cmd.spawn().with_context(|| format!("starting {name}"))?;
        Ok(ChildGuard {
            name: name.to_string(),
            child: Some(child),
        })
    }

    /// The child's process id.
    pub fn id(&self) -> u32 {
        self.child.as_ref().map_or(0, Child::id)
    }

    /// The child, for waiting on it.
    pub fn child_mut(&mut self) -> &mut Child {
        self.child.as_mut().expect("child present until drop")
    }

    /// Sends SIGKILL now (a crash, for tests) and reaps the child.
    pub fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }

    /// Sends SIGTERM (a clean stop) and waits up to `timeout` before killing.
    pub fn terminate(&mut self, timeout: std::time::Duration) -> Option<std::process::ExitStatus> {
        let mut c = self.child.take()?;
        // The kill(1) command, so that this crate needs no unsafe libc call.
        let _ = Command::new("kill")
            .args(["-TERM", &c.id().to_string()])
            .status();
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = c.try_wait() {
                return Some(status);
            }
            if std::time::Instant::now() >= deadline {
                let _ = c.kill();
                return c.wait().ok();
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }

    /// Waits for the child to exit by itself, up to `timeout`; kills it after.
    pub fn wait_timeout(
        &mut self,
        timeout: std::time::Duration,
    ) -> Result<std::process::ExitStatus> {
        let deadline = std::time::Instant::now() + timeout;
        let c = self.child_mut();
        loop {
            if let Some(status) = c.try_wait()? {
                return Ok(status);
            }
            if std::time::Instant::now() >= deadline {
                let _ = c.kill();
                let _ = c.wait();
                bail!("{} did not finish within {:?}", self.name, timeout);
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        self.kill();
    }
}

/// An iceoryx2 prefix no other run of this machine uses: process id, a counter and a tag.
pub fn unique_prefix(tag: &str) -> String {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    let tag: String = tag
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .take(16)
        .collect();
    format!("ss{}x{n}x{nanos:x}{tag}", std::process::id())
}

/// A loopback TCP port free at the time of the call.
pub fn free_port() -> Result<u16> {
    let listener = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(listener.local_addr()?.port())
}
