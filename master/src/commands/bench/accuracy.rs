//! `parrt bench accuracy`: speed against error (issue 6). Not yet built.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt bench accuracy`.
#[derive(Debug, Args)]
pub struct AccuracyArgs {}

/// Runs `parrt bench accuracy`.
pub fn run(_args: AccuracyArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt bench accuracy` is not available in this build yet")
}
