//! The README's API lines, run as written against the real `slam-service` (issue 17,
//! finding 9: they once set neither `$SKETCH` nor `$SESSION`, and one was single-quoted, a
//! 404 as written).
//!
//! The ```` ```sh ```` block under "### API" is cut from `README.md` and run by `bash` with
//! `set -euo pipefail`, in a temporary folder that links the repository's `simulator/`. Two
//! things differ from a reader's terminal, and nothing else: the `BASE=` line is replaced by
//! this test's port (the test fails unless it is there exactly once), and `cargo` is a shell
//! function that runs the simulator built for the tests, on this test's iceoryx2 prefix, and
//! refuses any other cargo command. Every `curl` in the block has `-f`, so an answer of 4xx
//! or 5xx stops the run.

mod common;

use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use anyhow::{Context, Result, bail, ensure};
use common::{SERVICE_LOG, in_temp_dir, start_service};
use sketchslam_api::SessionState;
use sketchslam_tests::processes::{binary, unique_prefix, workspace_root};

/// The README's first shell block after `heading`.
fn readme_block(readme: &str, heading: &str) -> Result<String> {
    let at = readme
        .find(heading)
        .with_context(|| format!("README.md has no {heading:?}"))?;
    let rest = &readme[at..];
    let start = rest
        .find("```sh\n")
        .context("no ```sh block after the heading")?
        + 6;
    let len = rest[start..].find("```").context("the block never ends")?;
    Ok(rest[start..start + len].to_string())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_readme_api_lines_run_as_written() -> Result<()> {
    in_temp_dir("readme", &[(SERVICE_LOG, 60)], |dir| async move {
        run(&dir).await
    })
    .await
}

async fn run(dir: &Path) -> Result<()> {
    let root = workspace_root();
    let readme = std::fs::read_to_string(root.join("README.md"))?;
    let block = readme_block(&readme, "### API (all under `/v1`")?;
    let base_lines: Vec<&str> = block
        .lines()
        .filter(|l| l.starts_with("BASE=http://127.0.0.1:8080"))
        .collect();
    ensure!(
        base_lines.len() == 1,
        "the block should set BASE once: {base_lines:?}"
    );

    let prefix = unique_prefix("readme");
    let service = start_service(&dir.join("data"), &prefix, &[], &[]).await?;
    let simulator = binary("sketchslam-simulator", "simulator")?;
    let script = format!(
        "set -euo pipefail\n\
         cargo() {{\n\
           [[ \"${{*:1:7}}\" == 'run --release -p sketchslam-simulator --bin simulator --' ]] \
             || {{ echo \"the README runs: cargo $*\" >&2; return 1; }}\n\
           shift 7\n\
           {simulator:?} \"$@\" --quiet\n\
         }}\n\
         {}",
        block.replacen(
            base_lines[0],
            &format!("BASE={}", service.client.base_url()),
            1
        )
    );
    let work = dir.join("work");
    std::fs::create_dir_all(&work)?;
    std::os::unix::fs::symlink(root.join("simulator"), work.join("simulator"))?;
    let mut bash = tokio::process::Command::new("bash");
    bash.arg("-c")
        .arg(&script)
        .current_dir(&work)
        .env("SKETCHSLAM_IPC_PREFIX", &prefix)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true);
    let out = tokio::time::timeout(Duration::from_secs(240), bash.output())
        .await
        .context("the README's lines ran for 4 minutes")??;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        bail!(
            "the README's lines failed ({}):\n{}\n--- stderr ---\n{}",
            out.status,
            stdout.chars().take(4000).collect::<String>(),
            String::from_utf8_lossy(&out.stderr)
        );
    }

    // What the lines fetched is what their comments say.
    let read = |name: &str| std::fs::read(work.join(name)).with_context(|| name.to_string());
    for png in ["lines.png", "map.png", "overlay.png", "in-map.png"] {
        ensure!(read(png)?.starts_with(b"\x89PNG"), "{png} is not a PNG");
    }
    ensure!(read("map.pgm")?.starts_with(b"P5"));
    ensure!(String::from_utf8(read("map.yaml")?)?.contains("image: map.pgm"));
    let map: serde_json::Value = serde_json::from_slice(&read("map.json")?)?;
    ensure!(map["header"]["frame_id"] == "map", "{}", map["header"]);
    let csv = String::from_utf8(read("trajectory.csv")?)?;
    ensure!(
        csv.lines().count() > 600,
        "{} trajectory lines",
        csv.lines().count()
    );
    let on_drawing: serde_json::Value = serde_json::from_slice(&read("on-drawing.json")?)?;
    ensure!(
        on_drawing["points"]
            .as_array()
            .is_some_and(|p| !p.is_empty())
    );
    let doc: serde_json::Value = serde_json::from_slice(&read("openapi.json")?)?;
    ensure!(doc["openapi"].is_string());
    ensure!(stdout.contains("event: pose"), "no event in the stream");
    ensure!(stdout.contains("\"registered\""), "no transform answer");
    // The last lines stopped the one session the block started, after its 600 scans.
    let sessions = service.client.list_sessions().await?.sessions;
    ensure!(
        sessions.len() == 1
            && sessions[0].state == SessionState::Stopped
            && sessions[0].scans_processed == 600,
        "{sessions:?}"
    );
    Ok(())
}
