//! The network seam: the master accepts peers from a [`Listener`] and speaks to each over its
//! [`Listener::Stream`]. [`TcpListener`] is tokio's TCP; the deterministic simulation plugs in
//! simulated TCP (turmoil) here, so the same accept loop, handshake and relay run on both.
//! Nothing else in the runtime names a socket type.

use std::future::Future;
use std::io;
use std::net::SocketAddr;
use tokio::io::{AsyncRead, AsyncWrite};

/// Where peers come from.
pub trait Listener: Send + 'static {
    /// One peer's byte stream.
    type Stream: AsyncRead + AsyncWrite + Unpin + Send + 'static;

    /// The next peer and its address.
    fn accept(&mut self) -> impl Future<Output = io::Result<(Self::Stream, SocketAddr)>> + Send;

    /// The address bound (the port chosen when asked for `:0`).
    fn local_addr(&self) -> io::Result<SocketAddr>;
}

/// tokio's TCP listener; accepted sockets have Nagle's algorithm off (small frames are
/// latency-bound).
#[derive(Debug)]
pub struct TcpListener(pub tokio::net::TcpListener);

impl TcpListener {
    /// Binds `addr` (`host:port`).
    pub async fn bind(addr: &str) -> io::Result<TcpListener> {
        tokio::net::TcpListener::bind(addr).await.map(TcpListener)
    }
}

impl Listener for TcpListener {
    type Stream = tokio::net::TcpStream;

    async fn accept(&mut self) -> io::Result<(Self::Stream, SocketAddr)> {
        let (s, a) = self.0.accept().await?;
        let _ = s.set_nodelay(true);
        Ok((s, a))
    }

    fn local_addr(&self) -> io::Result<SocketAddr> {
        self.0.local_addr()
    }
}
