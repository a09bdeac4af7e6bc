//! Dialling the master: retry with exponential backoff (doubling, capped) until a connection is
//! made, the time budget is spent, or we are told to stop. Workers may start before the master.
//! A handshake cut short (the master's connection table full, the master restarting) is retried
//! with backoff (the budget counted afresh when the master closed it: it is up, only busy); a
//! refusal never is. What a connection is (TCP, or a simulated or
//! in-memory stream) comes from a [`Dial`]; this file only decides when to try again.

use crate::error::WorkerError;
use crate::net::{Dial, TcpDial};
use crate::options::WorkerOptions;
use std::time::Duration;
use tokio::net::TcpStream;
use tokio::time::{sleep, Instant};
use tokio_util::sync::CancellationToken;
use tracing::{debug, warn};

/// Handshakes cut short that a worker retries quietly (logged at DEBUG) before it warns.
pub const QUIET_RETRIES: u32 = 3;

/// Connects to `opts.connect`, retrying with backoff. `Ok(None)` when `stop` fired first.
pub async fn dial(
    opts: &WorkerOptions,
    stop: &CancellationToken,
) -> Result<Option<TcpStream>, WorkerError> {
    Dialer::new(opts).connect(stop).await
}

/// One dial budget shared by every attempt of a session: failed connections and handshakes
/// cut short (a full connection table, a master restarting) both wait the next backoff delay
/// and count against [`WorkerOptions::dial_timeout`].
#[derive(Debug)]
pub struct Dialer<'a, D = TcpDial> {
    opts: &'a WorkerOptions,
    dial: &'a D,
    start: Instant,
    delay: Duration,
    attempts: u32,
}

impl<'a> Dialer<'a, TcpDial> {
    /// A fresh budget for TCP, starting now.
    pub fn new(opts: &'a WorkerOptions) -> Self {
        Dialer::with(opts, &TcpDial)
    }
}

impl<'a, D: Dial> Dialer<'a, D> {
    /// A fresh budget, starting now, connecting through `dial`.
    pub fn with(opts: &'a WorkerOptions, dial: &'a D) -> Self {
        Dialer {
            opts,
            dial,
            start: Instant::now(),
            delay: opts.initial_backoff,
            attempts: 0,
        }
    }

    /// Attempts made so far.
    pub fn attempts(&self) -> u32 {
        self.attempts
    }

    /// Connects, retrying with backoff. `Ok(None)` when `stop` fired first.
    pub async fn connect(
        &mut self,
        stop: &CancellationToken,
    ) -> Result<Option<D::Stream>, WorkerError> {
        loop {
            self.attempts += 1;
            let err = tokio::select! {
                biased;
                _ = stop.cancelled() => return Ok(None),
                r = self.dial.connect(&self.opts.connect) => match r {
                    Ok(s) => return Ok(Some(s)),
                    Err(e) => e,
                },
            };
            let elapsed = self.start.elapsed();
            if elapsed + self.delay > self.opts.dial_timeout {
                return Err(WorkerError::Dial {
                    addr: self.opts.connect.clone(),
                    attempts: self.attempts,
                    elapsed,
                    last: err,
                });
            }
            debug!(
                addr = %self.opts.connect, attempt = self.attempts, error = %err,
                delay = ?self.delay, "dial failed, retrying"
            );
            if !self.sleep(stop).await {
                return Ok(None);
            }
        }
    }

    /// After a handshake cut short by `why`: waits the next backoff delay and returns
    /// `Ok(true)` to try again, `Ok(false)` when `stop` fired, or `why` itself when the budget
    /// is spent.
    pub async fn retry_after(
        &mut self,
        why: WorkerError,
        stop: &CancellationToken,
    ) -> Result<bool, WorkerError> {
        // A master that closed our handshake is up, only busy (its handshake budget full,
        // perhaps of squatters it is evicting): keep dialling it with backoff, the budget
        // counted afresh. One that timed out or never answered still spends the budget.
        if closed_by_master(&why) {
            self.start = Instant::now();
        }
        if self.start.elapsed() + self.delay > self.opts.dial_timeout {
            return Err(why);
        }
        // The first few are routine when many workers arrive at once (the master's handshake
        // budget turns the latest away for a moment); only a run of them is worth a warning.
        if self.attempts <= QUIET_RETRIES {
            debug!(
                addr = %self.opts.connect, attempt = self.attempts, error = %why,
                delay = ?self.delay, "handshake cut short, retrying"
            );
        } else {
            warn!(
                addr = %self.opts.connect, attempt = self.attempts, error = %why,
                delay = ?self.delay, "handshake cut short, retrying"
            );
        }
        Ok(self.sleep(stop).await)
    }

    /// Sleeps the current delay and doubles it (capped); false when `stop` fired.
    async fn sleep(&mut self, stop: &CancellationToken) -> bool {
        tokio::select! {
            biased;
            _ = stop.cancelled() => return false,
            _ = sleep(self.delay) => {}
        }
        self.delay = (self.delay * 2).min(self.opts.max_backoff);
        true
    }
}

/// Whether the master ended the handshake itself (closed or reset the connection).
fn closed_by_master(why: &WorkerError) -> bool {
    match why {
        WorkerError::ClosedInHandshake => true,
        WorkerError::Protocol(parrt_protocol::ProtocolError::Io(e)) => matches!(
            e.kind(),
            std::io::ErrorKind::ConnectionReset | std::io::ErrorKind::ConnectionAborted
        ),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_protocol::Token;

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
