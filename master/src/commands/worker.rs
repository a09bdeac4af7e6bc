//! `parrt worker`.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt worker`.
#[derive(Debug, Args)]
pub struct WorkerArgs {}

/// Runs `parrt worker`.
pub fn run(_args: WorkerArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt worker` is not available in this build yet")
}
