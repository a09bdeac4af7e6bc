//! turmoil's simulated TCP plugged into the runtime's and the worker's network seams: the
//! master accepts from a [`SimListener`], workers dial through [`SimDial`]; everything above
//! the byte stream is the real code.

use std::io;
use std::net::SocketAddr;

/// The master's listener on a simulated host.
pub struct SimListener(pub turmoil::net::TcpListener);

impl parrt_runtime::net::Listener for SimListener {
    type Stream = turmoil::net::TcpStream;

    async fn accept(&mut self) -> io::Result<(Self::Stream, SocketAddr)> {
        self.0.accept().await
    }

    fn local_addr(&self) -> io::Result<SocketAddr> {
        self.0.local_addr()
    }
}

/// A worker's dialer on a simulated host (`addr` is `host:port`, resolved by the simulation).
#[derive(Clone, Copy, Debug, Default)]
pub struct SimDial;

impl parrt_worker::net::Dial for SimDial {
    type Stream = turmoil::net::TcpStream;

    async fn connect(&self, addr: &str) -> io::Result<Self::Stream> {
        turmoil::net::TcpStream::connect(addr.to_string()).await
    }
}
