//! The network seam: how a worker opens a byte stream to its master. The real worker dials TCP
//! ([`TcpDial`]); a deterministic simulation (turmoil) or a test supplies its own [`Dial`], so the
//! same dial loop, handshake and message loop run over simulated or in-memory streams. Nothing
//! here frames, retries or authenticates: that stays in `dial` and `session`.

use std::collections::VecDeque;
use std::future::Future;
use std::io;
use std::sync::Mutex;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::net::TcpStream;

/// Opens connections to the master. One value serves a whole session (every dial attempt).
pub trait Dial: Send + Sync {
    /// The byte stream a connection gives.
    type Stream: AsyncRead + AsyncWrite + Unpin + Send + 'static;

    /// One attempt to connect to `addr` (`host:port`, as given to the worker). An error is
    /// retried with backoff by [`crate::dial::Dialer`] within the dial budget.
    fn connect(&self, addr: &str) -> impl Future<Output = io::Result<Self::Stream>> + Send;
}

/// Real TCP, with Nagle's algorithm off (small frames such as heartbeats go out at once).
#[derive(Clone, Copy, Debug, Default)]
pub struct TcpDial;

impl Dial for TcpDial {
    type Stream = TcpStream;

    async fn connect(&self, addr: &str) -> io::Result<TcpStream> {
        let s = TcpStream::connect(addr).await?;
        let _ = s.set_nodelay(true);
        Ok(s)
    }
}

/// Streams made in advance (e.g. one end of [`tokio::io::duplex`]), handed out one per
/// connection attempt in order; once they run out, attempts are refused. For tests that play
/// the master in the same process.
#[derive(Debug)]
pub struct Preconnected<S> {
    streams: Mutex<VecDeque<S>>,
}

impl<S> Preconnected<S> {
    /// Hands out `streams` in order.
    pub fn new(streams: impl IntoIterator<Item = S>) -> Self {
        Preconnected {
            streams: Mutex::new(streams.into_iter().collect()),
        }
    }
}

impl<S: AsyncRead + AsyncWrite + Unpin + Send + 'static> Dial for Preconnected<S> {
    type Stream = S;

    fn connect(&self, addr: &str) -> impl Future<Output = io::Result<S>> + Send {
        let next = self
            .streams
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .pop_front();
        let refused = io::Error::new(
            io::ErrorKind::ConnectionRefused,
            format!("no more prepared streams for {addr}"),
        );
        std::future::ready(next.ok_or(refused))
    }
}
