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

#[cfg(test)]
mod tests {
    use super::*;
    use parrt::protocol::Token;
    use std::time::Duration;

    /// A loopback port with nothing listening (bound, then released).
    fn dead_port() -> String {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let a = l.local_addr().unwrap();
        drop(l);
        a.to_string()
    }

    #[tokio::test(start_paused = true)]
    async fn gives_up_after_the_budget_with_growing_delays() {
        let mut o = WorkerOptions::new(dead_port(), Token::new("t").unwrap());
        o.dial_timeout = Duration::from_secs(10);
        let t0 = Instant::now();
        match dial(&o, &CancellationToken::new()).await {
            Err(WorkerError::Dial { attempts, .. }) => {
                // 50+100+200+400+800+1600+2000+2000+2000 ms fit in 10 s: 10 attempts.
                assert_eq!(attempts, 10);
            }
            other => panic!("expected a dial error, got {other:?}"),
        }
        assert!(t0.elapsed() <= Duration::from_secs(10));
    }

    #[tokio::test(start_paused = true)]
    async fn stop_ends_dialling_quietly() {
        let o = WorkerOptions::new(dead_port(), Token::new("t").unwrap());
        let stop = CancellationToken::new();
        stop.cancel();
        assert!(dial(&o, &stop).await.unwrap().is_none());
    }
}
