//! Dialling the master: retry with exponential backoff (doubling, capped) until a connection is
//! made, the time budget is spent, or we are told to stop. Workers may start before the master.

use crate::error::WorkerError;
use crate::options::WorkerOptions;
use tokio::net::TcpStream;
use tokio::time::{sleep, Instant};
use tokio_util::sync::CancellationToken;
use tracing::debug;

/// Connects to `opts.connect`, retrying with backoff. `Ok(None)` when `stop` fired first.
pub async fn dial(
    opts: &WorkerOptions,
    stop: &CancellationToken,
) -> Result<Option<TcpStream>, WorkerError> {
    let start = Instant::now();
    let mut delay = opts.initial_backoff;
    let mut attempts = 0u32;
    loop {
        attempts += 1;
        let err = tokio::select! {
            _ = stop.cancelled() => return Ok(None),
            r = TcpStream::connect(&opts.connect) => match r {
                Ok(s) => {
                    let _ = s.set_nodelay(true);
                    return Ok(Some(s));
                }
                Err(e) => e,
            },
        };
        let elapsed = start.elapsed();
        if elapsed + delay > opts.dial_timeout {
            return Err(WorkerError::Dial {
                addr: opts.connect.clone(),
                attempts,
                elapsed,
                last: err,
            });
        }
        debug!(addr = %opts.connect, attempt = attempts, error = %err, ?delay, "dial failed, retrying");
        tokio::select! {
            _ = stop.cancelled() => return Ok(None),
            _ = sleep(delay) => {}
        }
        delay = (delay * 2).min(opts.max_backoff);
    }
}
