//! The OpenAPI document against the wire (issue 17): schemathesis (PyPI, installed by
//! `scripts/install-test-deps`) fuzzes the real `slam-service`, token set, from its own
//! `/openapi.json`: examples, boundary values, random data and stateful sequences (upload,
//! start, read, stop), 50 examples per operation, a fixed seed.
//!
//! Every check runs but two, which test rules this API does not have:
//! `positive_data_acceptance` (a schema-valid request must succeed: a session needs a
//! sketch that exists and a start on its ink, an upload needs lines in the picture; these
//! are 404/422 by design) and `use_after_free` (a deleted resource must be gone: `DELETE
//! /v1/sessions/{id}` stops a session and keeps its map for download, as documented).
//! So: no 5xx, every status and content type documented, every body matching its schema,
//! every request without the token refused, invalid data refused.
//!
//! The event stream is left out: it does not end while its session runs, so every case
//! would wait out the fuzzer's timeout (10 s each, minutes in all). Its schema is checked
//! by `openapi_wire`'s tests and its wire format by `service_e2e` and the web page's test.

mod common;

use std::process::Command;

use anyhow::{Context, Result, ensure};
use common::{TempDir, dump_log, start_service};
use sketchslam_tests::processes::unique_prefix;

const TOKEN: &str = "contract-token";

fn python() -> String {
    std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_real_service_keeps_the_contract_of_its_openapi_document() -> Result<()> {
    let dir = TempDir::new("contract")?;
    let data = dir.0.join("data");
    let service = start_service(
        &data,
        &unique_prefix("contract"),
        &[],
        &[("SKETCHSLAM_TOKEN", TOKEN)],
    )
    .await?;
    let base = service.base.clone();
    let work = dir.0.clone();
    let out = tokio::task::spawn_blocking(move || {
        Command::new(python())
            .args(["-m", "schemathesis.cli", "run"])
            .arg(format!("{base}/openapi.json"))
            .args(["--url", &base])
            .args(["--checks", "all"])
            .args([
                "--exclude-checks",
                "positive_data_acceptance,use_after_free",
            ])
            .args(["--exclude-path", "/v1/sessions/{id}/events"])
            .args(["--max-examples", "50", "--seed", "1", "--workers", "1"])
            .args(["--header", &format!("Authorization: Bearer {TOKEN}")])
            .args(["--no-color"])
            .current_dir(&work)
            .output()
    })
    .await?
    .context("running schemathesis (scripts/install-test-deps installs it)")?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let summary: Vec<&str> = stdout
        .lines()
        .skip_while(|l| !l.contains("SUMMARY"))
        .collect();
    println!("{}", summary.join("\n"));
    if !out.status.success() {
        dump_log(&service.log, 40);
    }
    ensure!(
        out.status.success(),
        "schemathesis found the API breaking its document:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(())
}
