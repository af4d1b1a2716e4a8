//! The crate rules of docs/architecture.md, checked on the resolved dependency graph rather
//! than left to habit: the engine links no async runtime, transport, HTTP, logging or CLI
//! crate, and the HTTP API crate (and so its client) does not link iceoryx2.

use anyhow::{Context, Result, ensure};
use sketchslam_tests::processes::workspace_root;
use std::collections::BTreeSet;
use std::process::Command;

/// The names of every crate `package` links as a normal (non-dev, non-build) dependency,
/// transitively, as `cargo tree` resolves them from the lock file.
fn normal_dependencies(package: &str) -> Result<BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["tree", "--offline", "--locked", "-p", package])
        .args(["-e", "normal", "--prefix", "none", "--format", "{p}"])
        .current_dir(workspace_root())
        .output()
        .context("running cargo tree")?;
    ensure!(
        out.status.success(),
        "cargo tree -p {package} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let names: BTreeSet<String> = String::from_utf8(out.stdout)?
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect();
    ensure!(names.contains(package), "cargo tree did not list {package}");
    Ok(names)
}

#[test]
fn the_engine_links_no_runtime_transport_http_logging_or_cli_crate() -> Result<()> {
    let deps = normal_dependencies("sketchslam-engine")?;
    let forbidden = [
        "tokio",
        "axum",
        "hyper",
        "iceoryx2",
        "tracing",
        "tracing-subscriber",
        "clap",
        "reqwest",
    ];
    let found: Vec<&str> = forbidden
        .iter()
        .copied()
        .filter(|f| deps.contains(*f))
        .collect();
    ensure!(found.is_empty(), "the engine links {found:?}");
    // The one workspace crate it may use.
    let workspace: Vec<&String> = deps
        .iter()
        .filter(|d| d.starts_with("sketchslam-") && *d != "sketchslam-engine")
        .collect();
    ensure!(
        workspace == ["sketchslam-types"],
        "the engine depends on {workspace:?}"
    );
    Ok(())
}

#[test]
fn the_api_and_its_client_do_not_link_iceoryx2() -> Result<()> {
    let deps = normal_dependencies("sketchslam-api")?;
    ensure!(!deps.contains("iceoryx2"), "sketchslam-api links iceoryx2");
    ensure!(
        !deps.contains("sketchslam-engine"),
        "sketchslam-api links the engine"
    );
    // The check can fail: the transport crate does link iceoryx2.
    ensure!(normal_dependencies("sketchslam-ipc")?.contains("iceoryx2"));
    Ok(())
}
