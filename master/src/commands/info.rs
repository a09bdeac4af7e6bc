//! `parrt info`.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt info`.
#[derive(Debug, Args)]
pub struct InfoArgs {}

/// Runs `parrt info`.
pub fn run(_args: InfoArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt info` is not available in this build yet")
}
