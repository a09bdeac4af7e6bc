//! `Connection`: the only protocol type that touches I/O. It owns the stream and its read and
//! write buffers (through tokio-util's `Framed`). A peer closing between frames is a clean end
//! (`Ok(None)`); closing in the middle of a frame is an error. [`Connection::alive_until`] says
//! until when a peer counts as alive: bytes arriving are life, but a frame must still arrive at
//! a floor rate.

use super::codec::{Encoded, MessageCodec, ProtocolError, WireCounters};
use super::limits::frame_allowance;
use super::message::Message;
use futures::{SinkExt, StreamExt};
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::net::TcpStream;
use tokio::time::Instant;
use tokio_util::codec::Framed;

/// How many bytes of messages fed together ([`Connection::write_all`]) are gathered before they
/// go to the stream: one whole chunk of the encrypted channel. tokio-util's default (8 KiB)
/// cut a batch of tile results into a write, a chunk sealed and a system call every ~9 KB.
pub const WRITE_BATCH: usize = super::channel::MAX_CHUNK;

/// A framed message stream over a socket (or any byte stream, for tests).
#[derive(Debug)]
pub struct Connection<S = TcpStream> {
    framed: Framed<S, MessageCodec>,
}

impl<S: AsyncRead + AsyncWrite + Unpin> Connection<S> {
    /// Wraps `stream`, accepting frames of at most `max_frame` bytes.
    pub fn new(stream: S, max_frame: usize) -> Self {
        let mut framed = Framed::new(stream, MessageCodec::new(max_frame));
        framed.set_backpressure_boundary(WRITE_BATCH);
        Connection { framed }
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

    /// Writes a message encoded once for many peers, and flushes it.
    pub async fn write_encoded(&mut self, msg: &Encoded) -> Result<(), ProtocolError> {
        self.framed.send(msg).await
    }

    /// Writes several messages and flushes once: they reach the stream gathered into writes of
    /// at least [`WRITE_BATCH`] bytes (the last may be shorter).
    pub async fn write_all(&mut self, msgs: &[Message]) -> Result<(), ProtocolError> {
        for m in msgs {
            self.framed.feed(m).await?;
        }
        SinkExt::<&Message>::flush(&mut self.framed).await
    }

    /// Changes the largest frame accepted and sent from now on.
    pub fn set_max_frame(&mut self, max_frame: usize) {
        self.framed.codec_mut().set_max_frame(max_frame);
    }

    /// Changes the largest frame accepted from now on (frames sent keep their limit).
    pub fn set_max_receive(&mut self, max_frame: usize) {
        self.framed.codec_mut().set_max_receive(max_frame);
    }

    /// The frame being read, if one has begun: when its length prefix arrived, and its length.
    pub fn pending_frame(&self) -> Option<(Instant, usize)> {
        self.framed.codec().pending_frame()
    }

    /// The instant after which a peer that must never be silent for `timeout` counts as gone:
    /// `timeout` after bytes last arrived, but no later than `timeout` plus the frame's
    /// allowance at [`super::limits::MIN_FRAME_RATE`] after a frame being read began. Bytes
    /// are seen only while [`Connection::read`] is being polled.
    pub fn alive_until(&self, timeout: Duration) -> Instant {
        let codec = self.framed.codec();
        let idle = codec.last_bytes() + timeout;
        match codec.pending_frame() {
            Some((began, len)) => idle.min(began + timeout + frame_allowance(len)),
            None => idle,
        }
    }

    /// Byte and frame counts of this connection.
    pub fn counters(&self) -> Arc<WireCounters> {
        self.framed.codec().counters()
    }

    /// The underlying stream.
    pub fn get_ref(&self) -> &S {
        self.framed.get_ref()
    }

    /// The underlying stream, mutably (for tests that write raw bytes).
    pub fn get_mut(&mut self) -> &mut S {
        self.framed.get_mut()
    }

    /// The underlying stream, giving up the connection (bytes read but not yet decoded are
    /// lost; for tests that go on in raw bytes).
    pub fn into_inner(self) -> S {
        self.framed.into_inner()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io;
    use std::pin::Pin;
    use std::task::{Context, Poll};

    /// A sink that keeps what is written and counts the writes that reach it.
    #[derive(Default)]
    struct CountedSink {
        writes: usize,
        bytes: Vec<u8>,
    }

    impl AsyncWrite for CountedSink {
        fn poll_write(
            self: Pin<&mut Self>,
            _: &mut Context<'_>,
            buf: &[u8],
        ) -> Poll<io::Result<usize>> {
            let me = self.get_mut();
            me.writes += 1;
            me.bytes.extend_from_slice(buf);
            Poll::Ready(Ok(buf.len()))
        }

        fn poll_flush(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<io::Result<()>> {
            Poll::Ready(Ok(()))
        }

        fn poll_shutdown(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<io::Result<()>> {
            Poll::Ready(Ok(()))
        }
    }

    /// A batch of 40 messages of ~3 KB (a batch of tiles' results, 120 KB) reaches the stream
    /// in writes of a whole channel chunk, not tokio-util's 8 KiB default (which made 14), and
    /// the bytes are those of the messages written one by one.
    #[tokio::test]
    async fn a_batch_of_messages_goes_out_in_writes_of_a_chunk() {
        let msgs: Vec<Message> = (0..40)
            .map(|i| Message::Error {
                reason: format!("{i:>3000}"),
            })
            .collect();
        // A connection needs a reader too: one that is at its end at once.
        let sink = || tokio::io::join(tokio::io::empty(), CountedSink::default());
        let mut batched = Connection::new(sink(), 1 << 20);
        batched.write_all(&msgs).await.unwrap();
        let mut one_by_one = Connection::new(sink(), 1 << 20);
        for m in &msgs {
            one_by_one.write(m).await.unwrap();
        }
        let (batched, one_by_one) = (batched.get_ref().writer(), one_by_one.get_ref().writer());
        let total = one_by_one.bytes.len();
        assert!(total > 120_000, "{total} bytes");
        assert_eq!(batched.bytes, one_by_one.bytes);
        assert_eq!(batched.writes, 2, "{total} bytes in 2 writes");
    }
}
