//! What can go wrong in a distributed render, as one typed error ([`DistError`]) whose
//! [`DistError::is_bad_input`] tells a caller which failures are the user's input (exit 2 in
//! the CLI); the runtime itself decides no exit codes.

use crate::{checkpoint, rendezvous, spawn};
use std::time::Duration;
use thiserror::Error;

/// Errors of a distributed render.
#[derive(Debug, Error)]
pub enum DistError {
    /// The listen address could not be bound. (The cause is the source, printed after the
    /// message by `{:#}`; not repeated here.)
    #[error("cannot listen on {addr}")]
    Bind {
        /// The address asked for.
        addr: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Not enough workers arrived in time.
    #[error("{}", no_workers_message(*waited, *wanted, *ready, failed))]
    NoWorkers {
        /// How long we waited.
        waited: Duration,
        /// Workers needed to start.
        wanted: usize,
        /// Workers that were ready.
        ready: usize,
        /// Workers that connected and left before being ready, as `name: reason` (those that
        /// could not build the job say why here).
        failed: Vec<String>,
    },
    /// Every worker left mid-job and none came back in time.
    #[error(
        "all workers left and none returned within {} ({done}/{total} tiles done)",
        seconds(*waited)
    )]
    AllWorkersLost {
        /// How long we waited.
        waited: Duration,
        /// Tiles done.
        done: usize,
        /// Tiles in all.
        total: usize,
    },
    /// Cancelled (Ctrl-C); workers were told to shut down.
    #[error("interrupted; workers were told to shut down")]
    Interrupted,
    /// The accept loop ended unexpectedly.
    #[error("the listener stopped accepting connections")]
    AcceptFailed,
    /// Local workers could not be started.
    #[error(transparent)]
    Spawn(#[from] spawn::SpawnError),
    /// More local workers were asked for than one master starts.
    #[error("{asked} local workers asked for; one master starts at most {max}")]
    TooManyWorkers {
        /// Workers asked for.
        asked: usize,
        /// The most allowed ([`crate::options::MAX_SPAWNED_WORKERS`]).
        max: usize,
    },
    /// A tile's pixels would not fit one frame.
    #[error("tiles of {tile}x{tile} pixels do not fit the {max_frame}-byte frame limit")]
    TileTooLarge {
        /// The tile edge.
        tile: u32,
        /// The frame limit.
        max_frame: usize,
    },
    /// The checkpoint could not be used (another job's, exists without `--resume`, I/O).
    #[error(transparent)]
    Checkpoint(#[from] checkpoint::CheckpointError),
    /// The ranks of `parrt cluster` could not meet (a leftover or foreign rendezvous file, I/O).
    #[error(transparent)]
    Rendezvous(#[from] rendezvous::RendezvousError),
    /// The async runtime could not start.
    #[error("cannot start the async runtime: {0}")]
    Runtime(std::io::Error),
    /// The job message could not be encoded.
    #[error("cannot encode the job: {0}")]
    EncodeJob(parrt_protocol::ProtocolError),
    /// The job (its scene) is larger than a frame may be.
    #[error(
        "the job (scene and settings) is {bytes} bytes, more than the {max_frame}-byte frame limit"
    )]
    JobTooLarge {
        /// Bytes of the encoded job.
        bytes: usize,
        /// The frame limit.
        max_frame: usize,
    },
    /// A finished frame of a sequence could not be kept (its file not written), or the next
    /// frame not prepared.
    #[error("frame {frame}: {reason}")]
    Frame {
        /// The frame's number (from 0).
        frame: usize,
        /// What went wrong, with its causes.
        reason: String,
    },
}

impl DistError {
    /// Whether the user's input caused it (exit 2): a tile too large for a frame, a checkpoint
    /// of another job or one that exists without `--resume`.
    pub fn is_bad_input(&self) -> bool {
        match self {
            DistError::TileTooLarge { .. }
            | DistError::JobTooLarge { .. }
            | DistError::TooManyWorkers { .. } => true,
            DistError::Checkpoint(e) => e.is_bad_input(),
            DistError::Rendezvous(e) => e.is_bad_input(),
            _ => false,
        }
    }
}

/// Reasons shown in [`DistError::NoWorkers`] at most.
const SHOWN_FAILURES: usize = 3;
/// Characters of each reason shown (a peer chooses its name).
const SHOWN_REASON_CHARS: usize = 300;

fn no_workers_message(waited: Duration, wanted: usize, ready: usize, failed: &[String]) -> String {
    if failed.is_empty() {
        // "No worker" only when none came: with some there, say how many of how many.
        let (arrived, start) = match ready {
            0 => (
                format!(
                    "no worker arrived within {} (none of the {wanted} needed",
                    seconds(waited)
                ),
                "workers",
            ),
            n => (
                format!(
                    "only {n} of the {wanted} workers needed arrived within {} (the others never",
                    seconds(waited)
                ),
                "more",
            ),
        };
        return format!(
            "{arrived} connected and built the job); start {start} with \
             `parrt worker --connect ADDR` and the same token"
        );
    }
    let mut reasons = failed
        .iter()
        .take(SHOWN_FAILURES)
        .map(|r| match r.char_indices().nth(SHOWN_REASON_CHARS) {
            Some((cut, _)) => format!("{}…", &r[..cut]),
            None => r.clone(),
        })
        .collect::<Vec<_>>()
        .join("; ");
    if failed.len() > SHOWN_FAILURES {
        reasons += &format!("; and {} more", failed.len() - SHOWN_FAILURES);
    }
    format!(
        "{} worker{} connected but could not build the job within {} ({ready} of the \
         {wanted} needed ready): {reasons}",
        failed.len(),
        if failed.len() == 1 { "" } else { "s" },
        seconds(waited)
    )
}

/// Durations in messages: the one helper every crate shares (`parrt_protocol::seconds`).
pub use parrt_protocol::seconds::seconds;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_workers_says_who_came_and_why_they_failed() {
        let e = |failed: Vec<String>| DistError::NoWorkers {
            waited: Duration::from_secs(2),
            wanted: 1,
            ready: 0,
            failed,
        };
        assert!(e(vec![])
            .to_string()
            .starts_with("no worker arrived within 2 s"));
        assert_eq!(
            e(vec!["w1: cannot take the job: bad material".into()]).to_string(),
            "1 worker connected but could not build the job within 2 s (0 of the 1 needed \
             ready): w1: cannot take the job: bad material"
        );
        let many: Vec<String> = (0..5)
            .map(|i| format!("w{i}: {}", "x".repeat(400)))
            .collect();
        let m = e(many).to_string();
        assert!(
            m.starts_with("5 workers connected but could not build the job"),
            "{m}"
        );
        assert!(m.ends_with("; and 2 more"), "{m}");
        assert_eq!(seconds(Duration::from_nanos(120_002_006_428)), "120 s");
        // One worker of two wanted is not "no worker": the message says how many came.
        let some = DistError::NoWorkers {
            waited: Duration::from_nanos(120_002_006_428),
            wanted: 2,
            ready: 1,
            failed: vec![],
        }
        .to_string();
        assert_eq!(
            some,
            "only 1 of the 2 workers needed arrived within 120 s (the others never connected \
             and built the job); start more with `parrt worker --connect ADDR` and the same token"
        );
        assert_eq!(seconds(Duration::from_millis(2_460)), "2.5 s");
        assert!(
            m.len() < 4 * 320 + 200,
            "reasons are truncated: {}",
            m.len()
        );
    }
}
