//! `parrt-worker`: the same program as `parrt worker` (both call [`parrt_worker::cli::run`]).
use clap::Parser;
use std::process::ExitCode;

/// parrt render worker: connects to a master and renders the tiles it assigns.
#[derive(Debug, Parser)]
#[command(name = "parrt-worker", version = parrt_render::version_text!(), about)]
struct Cli {
    #[command(flatten)]
    args: parrt_worker::cli::WorkerArgs,
}

fn main() -> ExitCode {
    use std::io::Write;
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    // The instruction-set tier, once for the process: an unknown or unsupported PARRT_ISA is
    // bad input.
    if let Err(e) = parrt_render::isa::init() {
        // Not eprintln!: a closed stderr would turn exit 2 into a panic's 101.
        let _ = writeln!(std::io::stderr(), "parrt-worker: {e}");
        return ExitCode::from(2);
    }
    match parrt_worker::cli::run(cli.args) {
        Ok(code) => code,
        Err(e) => {
            // Not eprintln!: a closed stderr would turn the exit status into a panic's.
            let _ = writeln!(std::io::stderr(), "parrt-worker: {e:#}");
            let usage = e.chain().any(|c| c.is::<parrt_worker::cli::UsageError>());
            ExitCode::from(if usage { 2 } else { 1 })
        }
    }
}
