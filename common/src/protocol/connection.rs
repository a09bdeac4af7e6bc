//! `Connection`: the only protocol type that touches I/O. It owns the stream and its read and
//! write buffers (through tokio-util's `Framed`). A peer closing between frames is a clean end
//! (`Ok(None)`); closing in the middle of a frame is an error.

use super::codec::{MessageCodec, ProtocolError, WireCounters};
use super::message::Message;
use futures::{SinkExt, StreamExt};
use std::sync::Arc;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::net::TcpStream;
use tokio_util::codec::Framed;

/// A framed message stream over a socket (or any byte stream, for tests).
#[derive(Debug)]
pub struct Connection<S = TcpStream> {
    framed: Framed<S, MessageCodec>,
}

impl<S: AsyncRead + AsyncWrite + Unpin> Connection<S> {
    /// Wraps `stream`, accepting frames of at most `max_frame` bytes.
    pub fn new(stream: S, max_frame: usize) -> Self {
        Connection {
            framed: Framed::new(stream, MessageCodec::new(max_frame)),
        }
    }

    /// The next message; `Ok(None)` when the peer closed cleanly between frames. Cancel-safe:
    /// a partly read frame stays in the buffer.
    pub async fn read(&mut self) -> Result<Option<Message>, ProtocolError> {
        self.framed.next().await.transpose()
    }

    /// Writes one message and flushes it.
    pub async fn write(&mut self, msg: &Message) -> Result<(), ProtocolError> {
        self.framed.send(msg).await
    }

    /// Writes several messages and flushes once (one system call where they fit).
    pub async fn write_all(&mut self, msgs: &[Message]) -> Result<(), ProtocolError> {
        for m in msgs {
            self.framed.feed(m).await?;
        }
        SinkExt::<&Message>::flush(&mut self.framed).await
    }

    /// Changes the largest frame accepted from now on.
    pub fn set_max_frame(&mut self, max_frame: usize) {
        self.framed.codec_mut().set_max_frame(max_frame);
    }

    /// Byte and frame counts of this connection.
    pub fn counters(&self) -> Arc<WireCounters> {
        self.framed.codec().counters()
    }

    /// The underlying stream.
    pub fn get_ref(&self) -> &S {
        self.framed.get_ref()
    }
}
