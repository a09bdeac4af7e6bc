//! `parrt bench`: benchmarks and studies that print numbers (never assert timings). One module
//! per study.

pub mod accuracy;
pub mod cast;
pub mod cluster;
pub mod efficiency;
pub mod precision;
pub mod render;
pub mod simulate;

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
    /// The paper's efficiency tables: threads × tile sizes, per accelerator, mode and executor.
    Efficiency(efficiency::EfficiencyArgs),
    /// Predict master/worker efficiency for 1 to 1024 workers from measured tile costs.
    Simulate(simulate::SimulateArgs),
    /// Ray-casting throughput (eye + shadow rays, no shading), as Embree's nffcast measures it.
    Cast(cast::CastArgs),
    /// An emulated cluster: N real workers replaying a recorded render over an emulated LAN.
    Cluster(cluster::ClusterArgs),
    /// Speed against error: a reference render against a grid of configurations.
    Accuracy(accuracy::AccuracyArgs),
    /// Scenes moved by 1e0…1e8 and scaled by 1e-6…1e6 in f32, f64 and auto against the
    /// untransformed f64 render: pixels off, largest error, time.
    Precision(precision::PrecisionArgs),
}

/// Runs `parrt bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.which {
        BenchCommand::Render(a) => render::run(a),
        BenchCommand::Accuracy(a) => accuracy::run(a),
        BenchCommand::Cast(a) => cast::run(a),
        BenchCommand::Cluster(a) => cluster::run(a),
        BenchCommand::Efficiency(a) => efficiency::run(a),
        BenchCommand::Simulate(a) => simulate::run(a),
        BenchCommand::Precision(a) => precision::run(a),
    }
}
