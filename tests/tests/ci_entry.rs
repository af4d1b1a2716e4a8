//! `.ci/run` runs exactly the README's test command: the second line of the README's first
//! shell block, run from the checkout's root. If either changes without the other, this
//! fails (a CI that ran something else would pass while the README's command broke).

use anyhow::{Context, Result, ensure};
use sketchslam_tests::processes::workspace_root;

#[test]
fn ci_runs_the_readme_test_command() -> Result<()> {
    let root = workspace_root();
    let readme = std::fs::read_to_string(root.join("README.md"))?;
    let block = readme
        .split_once("```sh\n")
        .and_then(|(_, rest)| rest.split_once("```"))
        .map(|(block, _)| block)
        .context("README.md has no ```sh block")?;
    let commands: Vec<&str> = block.lines().filter(|l| !l.trim().is_empty()).collect();
    ensure!(
        commands.len() == 2,
        "the README's first block: {commands:?}"
    );
    let ci = std::fs::read_to_string(root.join(".ci/run"))?;
    let steps: Vec<&str> = ci
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .collect();
    ensure!(
        steps
            == [
                "set -euo pipefail",
                "cd \"$(dirname \"$0\")/..\"",
                commands[1]
            ],
        ".ci/run does {steps:?}, the README's test command is {:?}",
        commands[1]
    );
    Ok(())
}
