//! `parrt master`.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt master`.
#[derive(Debug, Args)]
pub struct MasterArgs {}

/// Runs `parrt master`.
pub fn run(_args: MasterArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt master` is not available in this build yet")
}
