//! `parrt bench`.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {}

/// Runs `parrt bench`.
pub fn run(_args: BenchArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt bench` is not available in this build yet")
}
