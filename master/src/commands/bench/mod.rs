//! `parrt bench`: benchmarks and studies that print numbers (never assert timings). One module
//! per study.

pub mod accuracy;
pub mod render;

use clap::{Args, Subcommand};
use std::process::ExitCode;

/// Arguments of `parrt bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Which benchmark.
    #[command(subcommand)]
    pub which: BenchCommand,
}

/// The benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Time full renders (parse + build + trace) of scenes: median of K runs, Mrays/s.
    Render(render::BenchRenderArgs),
    /// Speed against error: a reference render against a grid of configurations.
    Accuracy(accuracy::AccuracyArgs),
}

/// Runs `parrt bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.which {
        BenchCommand::Render(a) => render::run(a),
        BenchCommand::Accuracy(a) => accuracy::run(a),
    }
}
