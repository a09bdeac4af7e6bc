//! `parrt render`.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt render`.
#[derive(Debug, Args)]
pub struct RenderArgs {}

/// Runs `parrt render`.
pub fn run(_args: RenderArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt render` is not available in this build yet")
}
