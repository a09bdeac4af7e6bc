//! Exit codes: 0 success, 2 bad input or usage, 1 any other failure, and 128 + the signal's
//! number for a render stopped by Ctrl-C (130) or SIGTERM (143), as a process the signal
//! killed would exit (an SMP render is killed by it; a distributed one stops its workers
//! first, then exits so). An error is bad input when its chain holds a
//! [`crate::cli_args::ArgError`] (the command line's own checks), a
//! [`parrt_runtime::DistError`] that says it is (a wrong checkpoint, a listen address that does
//! not resolve, ...) or an [`InputError`] (a command's wrapping of a library error it knows to
//! be the user's input); everything else exits 1. The libraries' errors travel unchanged up to
//! here: only this module maps them to codes.

use crate::cli_args::ArgError;
use std::fmt;

/// An error caused by the user's input (a malformed file, a bad flag value): exit status 2.
#[derive(Debug)]
pub struct InputError(pub anyhow::Error);

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#}", self.0)
    }
}

impl std::error::Error for InputError {}

/// Marks `e` as bad input.
pub fn input_error(e: impl Into<anyhow::Error>) -> anyhow::Error {
    anyhow::Error::new(InputError(e.into()))
}

/// The exit status for an error: 128 + the signal's number when a signal interrupted the
/// render, 2 when any cause in its chain is an [`InputError`], an [`ArgError`] or a
/// distributed render's error of bad input, else 1.
pub fn code_for(e: &anyhow::Error) -> u8 {
    let interrupted = e.chain().any(|c| {
        matches!(
            c.downcast_ref::<parrt_runtime::DistError>(),
            Some(parrt_runtime::DistError::Interrupted)
        )
    });
    if interrupted {
        let signal = parrt_runtime::stopped_by_signal().unwrap_or(libc::SIGINT);
        return u8::try_from(128 + signal).unwrap_or(130);
    }
    let bad_dist = e.chain().any(|c| {
        c.downcast_ref::<parrt_runtime::DistError>()
            .is_some_and(parrt_runtime::DistError::is_bad_input)
    });
    if bad_dist || ArgError::is_in(e) || e.chain().any(|c| c.is::<InputError>()) {
        2
    } else {
        1
    }
}

/// The exit status of a render that stopped itself on `signal` (a sequence stopping at a
/// frame boundary on Ctrl-C): 128 + the signal's number, as a process the signal killed.
pub fn stopped_by(signal: libc::c_int) -> std::process::ExitCode {
    std::process::ExitCode::from(u8::try_from(128 + signal).unwrap_or(130))
}

/// An error of the worker library (`parrt worker`, a worker rank of `parrt cluster`, the
/// master's token flags) for the command line: its `UsageError` (no token, bad flags) exits 2,
/// anything else 1.
pub fn worker_error(e: anyhow::Error) -> anyhow::Error {
    if e.chain().any(|c| c.is::<parrt_worker::cli::UsageError>()) {
        input_error(e)
    } else {
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_lines_errors_and_marked_input_exit_2_and_the_rest_1() {
        let arg = anyhow::Error::new(ArgError::Value("--tile 0".into())).context("starting");
        assert_eq!(code_for(&arg), 2);
        assert_eq!(code_for(&input_error(anyhow::anyhow!("bad file"))), 2);
        assert_eq!(code_for(&anyhow::anyhow!("disk full")), 1);
        let stopped = anyhow::Error::new(parrt_runtime::DistError::Interrupted).context("render");
        assert_eq!(
            code_for(&stopped),
            130,
            "Ctrl-C, as no signal was noted here"
        );
        let tile = parrt_runtime::DistError::TileTooLarge {
            tile: 4096,
            max_frame: 1 << 20,
        };
        let wrong = anyhow::Error::new(tile).context("distributed render failed");
        assert_eq!(code_for(&wrong), 2, "a distributed error of bad input");
        let lost = anyhow::Error::new(parrt_runtime::DistError::AcceptFailed);
        assert_eq!(code_for(&lost.context("render")), 1);
    }
}
