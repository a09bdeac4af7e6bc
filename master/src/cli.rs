//! Command-line definitions (clap) and dispatch to [`crate::commands`]. Usage errors exit 2.

use crate::commands;
use crate::exit;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// parrt: a parallel Whitted ray tracer for NFF scenes (SMP and distributed).
#[derive(Debug, Parser)]
#[command(
    name = "parrt",
    version = crate::version::text(),
    about = "A parallel Whitted ray tracer for NFF scenes, on one machine's cores or on workers \
             over TCP",
    long_about = None,
    propagate_version = true
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render an NFF file or a generated scene to an image (default: the built-in mount scene).
    Render(commands::render::RenderArgs),
    /// Print what an NFF file contains: counts, bounds, camera, parse time.
    Info(commands::info::InfoArgs),
    /// Write a generated SPD-style scene, or an NFF file, as NFF or as a POV-Ray scene.
    Scene(commands::scene::SceneArgs),
    /// Serve tile tasks to workers over TCP and assemble the image.
    Master(commands::master::MasterArgs),
    /// Connect to a master and render the tiles it assigns.
    Worker(commands::worker::WorkerArgs),
    /// One rank of a job started by srun, mpirun or mpiexec: rank 0 is the master, the others
    /// workers; they meet through a rendezvous file.
    Cluster(commands::cluster::ClusterArgs),
    /// Benchmarks and studies that print numbers (efficiency, accuracy, ...).
    Bench(commands::bench::BenchArgs),
    /// Draw a timeline written by --timeline as SVG or PNG (a row per thread or worker).
    PlotTimeline(commands::plot_timeline::PlotTimelineArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(commands::completions::CompletionsArgs),
    /// Print the manual page (roff), or write one page per command with --dir.
    Man(commands::man::ManArgs),
}

/// Parses the arguments, runs the command and returns the exit status. Errors are printed to
/// stderr as `parrt: <message>` with their causes.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version are not errors; clap knows which is which.
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    // The instruction-set tier, once for the process: an unknown or unsupported PARRT_ISA is
    // bad input.
    if let Err(e) = parrt_render::isa::init() {
        crate::errln!("parrt: {e}");
        return ExitCode::from(2);
    }
    // Library warnings (e.g. the NFF reader's) go to stderr; master and worker log more.
    if !matches!(
        cli.command,
        Command::Master(_) | Command::Worker(_) | Command::Cluster(_)
    ) {
        parrt_worker::cli::init_logging("warn");
    }
    let result = match cli.command {
        Command::Render(a) => commands::render::run(a),
        Command::Info(a) => commands::info::run(a),
        Command::Scene(a) => commands::scene::run(a),
        Command::Master(a) => commands::master::run(a),
        Command::Worker(a) => commands::worker::run(a),
        Command::Cluster(a) => commands::cluster::run(a),
        Command::Bench(a) => commands::bench::run(a),
        Command::PlotTimeline(a) => commands::plot_timeline::run(a),
        Command::Completions(a) => commands::completions::run(a),
        Command::Man(a) => commands::man::run(a),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            crate::errln!("parrt: {e:#}");
            ExitCode::from(exit::code_for(&e))
        }
    }
}
