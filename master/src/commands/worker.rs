//! `parrt worker`: the worker library's own command line and entry point, so `parrt worker` and
//! `parrt-worker` are the same program. Only the exit-code mapping lives here.

use crate::exit::worker_error;
use std::process::ExitCode;

/// Arguments of `parrt worker` (defined by the worker library).
pub use parrt_worker::cli::WorkerArgs;

/// Runs `parrt worker`: usage errors (no token, bad flags) exit 2, others 1.
pub fn run(args: WorkerArgs) -> anyhow::Result<ExitCode> {
    parrt_worker::cli::run(args).map_err(worker_error)
}
