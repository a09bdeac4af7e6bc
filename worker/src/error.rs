//! The worker's error type. Every failure a worker can meet, with the master's reason when the
//! master gave one.

use parrt_protocol::seconds::seconds;
use parrt_protocol::ProtocolError;
use std::time::Duration;
use thiserror::Error;

/// Why a worker stopped with a failure.
#[derive(Debug, Error)]
pub enum WorkerError {
    /// No connection could be made within the dial budget.
    #[error(
        "cannot connect to master at {addr} after {attempts} attempts over {}: {last}",
        seconds(*elapsed)
    )]
    Dial {
        /// The address dialled.
        addr: String,
        /// Attempts made.
        attempts: u32,
        /// Time spent.
        elapsed: Duration,
        /// The last connection error.
        last: std::io::Error,
    },
    /// The master refused us (wrong token, wrong version, ...).
    #[error("master refused the connection: {0}")]
    Refused(String),
    /// The master broke the protocol or the connection failed.
    #[error("protocol error: {0}")]
    Protocol(#[from] ProtocolError),
    /// The master sent something out of place.
    #[error("unexpected {got} from master while {during}")]
    Unexpected {
        /// Message kind received.
        got: &'static str,
        /// What we were doing.
        during: &'static str,
    },
    /// The master fell silent for too long.
    #[error("no message from master for {}", seconds(*.0))]
    MasterSilent(Duration),
    /// The peer we dialled did not prove it knows the token: it is not our master (a wrong
    /// address, a squatted port) or its token differs. We sent it no MAC.
    #[error(
        "the peer at {0} did not prove it knows the token (not a parrt master, or a different \
         token); nothing was sent to it"
    )]
    MasterUnproven(String),
    /// The master took nothing we wrote for too long (stopped, or not reading).
    #[error("the master took nothing we sent for {}; giving up", seconds(*.0))]
    MasterNotReading(Duration),
    /// The master closed the connection during the handshake.
    #[error("master closed the connection during the handshake")]
    ClosedInHandshake,
    /// The encrypted channel could not be set up (bytes that are not a parrt master's).
    #[error("encrypted channel: {0}")]
    Channel(parrt_protocol::ChannelError),
    /// The task building the rayon pool failed (panicked).
    #[error("cannot start the render threads: {0}")]
    PoolTask(String),
    /// The rayon pool could not be built.
    #[error("cannot start {threads} render threads: {source}")]
    Pool {
        /// Threads asked for.
        threads: usize,
        /// The cause.
        source: rayon::ThreadPoolBuildError,
    },
}

impl WorkerError {
    /// Whether this ends a handshake in a way worth retrying: cut or timed out (a full
    /// connection table, a master restarting), never refused or unproven.
    pub fn is_cut_handshake(&self) -> bool {
        matches!(
            self,
            WorkerError::ClosedInHandshake
                | WorkerError::MasterSilent(_)
                | WorkerError::MasterNotReading(_)
                | WorkerError::Protocol(ProtocolError::Io(_) | ProtocolError::Truncated(_))
        )
    }
}
