//! `parrt scene`.

use clap::Args;
use std::process::ExitCode;

/// Arguments of `parrt scene`.
#[derive(Debug, Args)]
pub struct SceneArgs {}

/// Runs `parrt scene`.
pub fn run(_args: SceneArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`parrt scene` is not available in this build yet")
}
