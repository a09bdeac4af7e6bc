//! The encrypted channel every worker connection runs inside: a Noise handshake
//! (`Noise_NNpsk0_25519_ChaChaPoly_BLAKE2s`, through the `snow` crate, its cipher on ring's
//! assembly) keyed by a pre-shared key derived one way from the token ([`LinkKey`]), then a
//! byte stream ([`SecureStream`]) whose every chunk is encrypted and authenticated. The message protocol ([`super::Connection`],
//! its frames and their limits) runs unchanged on top of it, over TCP or any other byte stream.
//!
//! ## On the wire
//! ```text
//! worker → master   [u32 len] 0x00 version(varint) ‖ Noise message 1 (psk, e)       48 bytes
//! master → worker   [u32 len] 0xFF ‖ Noise message 2 (e, ee)                           48 bytes
//!              or   [u32 len] postcard(Message::Refused{reason})   (in clear; then close)
//! then both ways    [u16 len] ciphertext of up to 65 519 plaintext bytes + 16-byte tag
//! ```
//! The two handshake frames are shaped like the message frames of protocol versions 1 and 2
//! (a Hello starts with variant 0 and the version): a master of any version reads the
//! version of a worker of any other and refuses it with a reason each can decode. The version
//! and a label are the Noise prologue, so a relay that alters them breaks the handshake.
//!
//! ## What it proves
//! Message 1 is encrypted under the PSK: a master tells a wrong token from the first message
//! and refuses it (in clear: it has no key to encrypt with). Message 2 is keyed by both
//! ephemeral keys and the PSK: a worker that reads it knows the master holds the token. Every
//! later chunk carries a Poly1305 tag and an implicit counter: a chunk altered, dropped,
//! replayed or reordered fails to decrypt, and that ends the connection
//! ([`ChannelError::Tampered`]). The ephemeral keys give forward secrecy: a token learned
//! later does not open traffic recorded before.

use super::auth::Token;
use super::codec::{decode_payload, encode_payload, ProtocolError, LENGTH_PREFIX};
use super::limits::HANDSHAKE_MAX_FRAME;
use super::message::Message;
use super::PROTOCOL_VERSION;
use bytes::{Buf, BytesMut};
use std::fmt;
use std::io;
use std::pin::Pin;
use std::task::{ready, Context, Poll};
use thiserror::Error;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt, ReadBuf};

/// The Noise protocol name: no static keys (NN), the PSK mixed in before the first message
/// (psk0), X25519, ChaCha20-Poly1305, BLAKE2s.
pub const NOISE_PARAMS: &str = "Noise_NNpsk0_25519_ChaChaPoly_BLAKE2s";

/// The largest Noise message (the Noise specification's limit).
pub const MAX_NOISE_MESSAGE: usize = 65_535;

/// Bytes of the authentication tag on every encrypted chunk.
pub const TAG_LEN: usize = 16;

/// The most plaintext bytes in one encrypted chunk; larger writes are split, and reads join
/// them (the message frames on top keep their own limits on the total).
pub const MAX_CHUNK: usize = MAX_NOISE_MESSAGE - TAG_LEN;

/// Bytes of an encrypted chunk's length prefix.
const CHUNK_PREFIX: usize = 2;

/// The HKDF `info` label of the link key: the token's other uses (the live view's credential)
/// derive with labels of their own, so no derived value stands for another.
const PSK_LABEL: &[u8] = b"parrt worker link psk v1";

/// The start of the Noise prologue (the greeting's header bytes follow it).
const PROLOGUE_LABEL: &[u8] = b"parrt worker link";

/// First byte of the master's second handshake frame (a Refused message starts with its
/// variant index, 4).
const NOISE_REPLY: u8 = 0xFF;

/// Errors setting up or using the channel.
#[derive(Debug, Error)]
pub enum ChannelError {
    /// The socket failed.
    #[error("i/o error: {0}")]
    Io(#[from] io::Error),
    /// The peer closed the connection before the handshake ended.
    #[error("the peer closed the connection during the handshake")]
    Closed,
    /// A handshake frame longer than [`HANDSHAKE_MAX_FRAME`].
    #[error("frame larger than the limit of {max} bytes ({len} announced)")]
    FrameTooLarge {
        /// Bytes announced.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// The first frame is not a parrt greeting (variant 0 and a version).
    #[error("not a parrt greeting")]
    NotParrt,
    /// The peer speaks another protocol version.
    #[error("protocol version {0}")]
    OtherVersion(u32),
    /// The peer's handshake message does not decrypt: it holds another token (or the bytes
    /// were altered on the way).
    #[error("the encrypted handshake failed: the peer holds another token, or a relay altered it")]
    WrongKey,
    /// The master refused us in clear during the handshake.
    #[error("{0}")]
    Refused(String),
    /// Anything else the Noise library reported.
    #[error("noise: {0}")]
    Noise(snow::Error),
    /// An encrypted chunk failed authentication: altered, replayed, reordered or forged.
    #[error("an encrypted chunk failed authentication (altered on the way, or not from the peer)")]
    Tampered,
}

impl From<ChannelError> for io::Error {
    fn from(e: ChannelError) -> io::Error {
        match e {
            ChannelError::Io(e) => e,
            ChannelError::Closed => io::Error::new(io::ErrorKind::UnexpectedEof, e),
            other => io::Error::new(io::ErrorKind::InvalidData, other),
        }
    }
}

/// The pre-shared key of the worker link: HKDF-SHA256 of the token with its own label. One
/// way: it does not give back the token, nor any other value derived from it. `Debug` hides it.
#[derive(Clone, PartialEq, Eq)]
pub struct LinkKey([u8; 32]);

impl fmt::Debug for LinkKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("LinkKey(<hidden>)")
    }
}

impl LinkKey {
    /// The link key of `token`.
    pub fn from_token(token: &Token) -> Self {
        let mut key = [0u8; 32];
        hkdf::Hkdf::<sha2::Sha256>::new(None, token.as_bytes())
            .expand(PSK_LABEL, &mut key)
            .expect("32 bytes is a valid HKDF-SHA256 output length");
        LinkKey(key)
    }
}

/// A fixed ephemeral key for a handshake, derived from a seed: only the deterministic
/// simulation uses one (so a run replays byte for byte); everyone else passes `None` and gets
/// fresh keys from the operating system.
pub fn seeded_ephemeral(seed: u64) -> [u8; 32] {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    h.update(b"parrt simulated ephemeral key");
    h.update(seed.to_le_bytes());
    h.finalize().into()
}

/// The greeting's clear header: variant 0 (Hello's) and our version as a postcard varint.
fn greeting_header() -> Vec<u8> {
    let mut h = vec![0u8];
    let mut v = PROTOCOL_VERSION;
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            h.push(b);
            return h;
        }
        h.push(b | 0x80);
    }
}

fn prologue(header: &[u8]) -> Vec<u8> {
    [PROLOGUE_LABEL, header].concat()
}

fn builder<'a>(
    key: &'a LinkKey,
    prologue: &'a [u8],
    ephemeral: Option<&'a [u8; 32]>,
) -> Result<snow::Builder<'a>, ChannelError> {
    let params = NOISE_PARAMS
        .parse()
        .map_err(|e: snow::Error| ChannelError::Noise(e))?;
    let mut b = snow::Builder::new(params)
        .psk(0, &key.0)
        .and_then(|b| b.prologue(prologue))
        .map_err(ChannelError::Noise)?;
    if let Some(e) = ephemeral {
        b = b.fixed_ephemeral_key_for_testing_only(e);
    }
    Ok(b)
}

/// Reads one handshake frame (4-byte length, at most [`HANDSHAKE_MAX_FRAME`] bytes), never a
/// byte beyond it.
async fn read_frame<S: AsyncRead + Unpin>(s: &mut S) -> Result<Vec<u8>, ChannelError> {
    let mut len = [0u8; LENGTH_PREFIX];
    read_exact(s, &mut len).await?;
    let len = u32::from_be_bytes(len) as usize;
    if len > HANDSHAKE_MAX_FRAME {
        return Err(ChannelError::FrameTooLarge {
            len,
            max: HANDSHAKE_MAX_FRAME,
        });
    }
    let mut payload = vec![0u8; len];
    read_exact(s, &mut payload).await?;
    Ok(payload)
}

async fn read_exact<S: AsyncRead + Unpin>(s: &mut S, buf: &mut [u8]) -> Result<(), ChannelError> {
    match s.read_exact(buf).await {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Err(ChannelError::Closed),
        Err(e) => Err(e.into()),
    }
}

async fn write_frame<S: AsyncWrite + Unpin>(s: &mut S, parts: &[&[u8]]) -> io::Result<()> {
    let len: usize = parts.iter().map(|p| p.len()).sum();
    let mut f = Vec::with_capacity(LENGTH_PREFIX + len);
    f.extend_from_slice(&(len as u32).to_be_bytes());
    for p in parts {
        f.extend_from_slice(p);
    }
    s.write_all(&f).await?;
    s.flush().await
}

/// The worker's side: sends the greeting and checks the master's answer. `Ok` once the master
/// has proved it holds the token; [`ChannelError::WrongKey`] when it has not (a wrong address,
/// a squatted port, another token), [`ChannelError::Refused`] with the master's reason.
pub async fn connect<S: AsyncRead + AsyncWrite + Unpin>(
    mut stream: S,
    key: &LinkKey,
    ephemeral: Option<[u8; 32]>,
) -> Result<SecureStream<S>, ChannelError> {
    let header = greeting_header();
    let prologue = prologue(&header);
    let mut hs = builder(key, &prologue, ephemeral.as_ref())?
        .build_initiator()
        .map_err(ChannelError::Noise)?;
    let mut msg = [0u8; 128];
    let n = hs
        .write_message(&[], &mut msg)
        .map_err(ChannelError::Noise)?;
    write_frame(&mut stream, &[&header, &msg[..n]]).await?;
    let reply = read_frame(&mut stream).await?;
    match reply.split_first() {
        Some((&NOISE_REPLY, noise)) => {
            let mut payload = [0u8; 128];
            hs.read_message(noise, &mut payload)
                .map_err(|_| ChannelError::WrongKey)?;
        }
        _ => {
            return Err(match decode_payload(&reply) {
                Ok(Message::Refused { reason }) => ChannelError::Refused(reason),
                _ => ChannelError::NotParrt,
            })
        }
    }
    let t = hs.into_transport_mode().map_err(ChannelError::Noise)?;
    Ok(SecureStream::new(stream, t))
}

/// The master's side: reads the greeting and answers it. A greeting of another version, or
/// one that does not decrypt (a wrong token), is refused in clear with a reason the peer can
/// read whatever its version; the error says which it was.
pub async fn accept<S: AsyncRead + AsyncWrite + Unpin>(
    mut stream: S,
    key: &LinkKey,
    ephemeral: Option<[u8; 32]>,
) -> Result<SecureStream<S>, ChannelError> {
    let greeting = read_frame(&mut stream).await?;
    let header = greeting_header();
    let Some(noise) = greeting.strip_prefix(header.as_slice()) else {
        let err = match version_of(&greeting) {
            Some(v) => ChannelError::OtherVersion(v),
            None => ChannelError::NotParrt,
        };
        if let ChannelError::OtherVersion(v) = err {
            let reason = format!("protocol version {v}; this master speaks {PROTOCOL_VERSION}");
            refuse_in_clear(&mut stream, reason).await;
        }
        return Err(err);
    };
    let prologue = prologue(&header);
    let mut hs = builder(key, &prologue, ephemeral.as_ref())?
        .build_responder()
        .map_err(ChannelError::Noise)?;
    let mut payload = vec![0u8; noise.len()];
    if hs.read_message(noise, &mut payload).is_err() {
        refuse_in_clear(&mut stream, "wrong token".into()).await;
        return Err(ChannelError::WrongKey);
    }
    let mut msg = [0u8; 128];
    let n = hs
        .write_message(&[], &mut msg)
        .map_err(ChannelError::Noise)?;
    write_frame(&mut stream, &[&[NOISE_REPLY], &msg[..n]]).await?;
    let t = hs.into_transport_mode().map_err(ChannelError::Noise)?;
    Ok(SecureStream::new(stream, t))
}

/// The version a greeting (or an older version's Hello) names: variant 0, then a varint.
fn version_of(greeting: &[u8]) -> Option<u32> {
    match decode_payload(greeting) {
        Err(ProtocolError::OtherVersion(v)) => Some(v),
        Ok(Message::Hello { version, .. }) => Some(version),
        _ => {
            let (&variant, rest) = greeting.split_first()?;
            if variant != 0 {
                return None;
            }
            let (v, _) = postcard::take_from_bytes::<u32>(rest).ok()?;
            Some(v)
        }
    }
}

/// Sends `reason` as a Refused message in clear (best effort): any version's codec reads it.
async fn refuse_in_clear<S: AsyncWrite + Unpin>(stream: &mut S, reason: String) {
    if let Ok(p) = encode_payload(&Message::Refused { reason }) {
        let _ = write_frame(stream, &[&p]).await;
    }
}

/// A byte stream inside the channel: what is written is cut into chunks of at most
/// [`MAX_CHUNK`] bytes, each encrypted and sent with a 2-byte length; what is read is
/// decrypted chunk by chunk. A chunk that fails authentication is an
/// [`io::ErrorKind::InvalidData`] error ([`ChannelError::Tampered`]) and the stream yields
/// nothing more. Buffers are kept and reused: no allocation per chunk once warm.
pub struct SecureStream<S> {
    inner: S,
    noise: snow::TransportState,
    /// Ciphertext read and not yet decrypted.
    rx: BytesMut,
    /// The last chunk's plaintext, and how much of it was handed out.
    plain: Vec<u8>,
    plain_pos: usize,
    /// Ciphertext encrypted and not yet written.
    tx: BytesMut,
    /// An authentication failure: sticky, so nothing after it is ever read.
    broken: bool,
}

impl<S> fmt::Debug for SecureStream<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SecureStream")
            .field("rx", &self.rx.len())
            .field("plain", &(self.plain.len() - self.plain_pos))
            .field("tx", &self.tx.len())
            .finish()
    }
}

impl<S> SecureStream<S> {
    fn new(inner: S, noise: snow::TransportState) -> Self {
        SecureStream {
            inner,
            noise,
            rx: BytesMut::with_capacity(CHUNK_PREFIX + MAX_NOISE_MESSAGE),
            plain: Vec::with_capacity(MAX_CHUNK),
            plain_pos: 0,
            tx: BytesMut::with_capacity(CHUNK_PREFIX + MAX_NOISE_MESSAGE),
            broken: false,
        }
    }

    /// The stream underneath (carrying ciphertext).
    pub fn get_ref(&self) -> &S {
        &self.inner
    }

    /// The stream underneath, mutably: bytes written to it bypass the channel (tests of
    /// tampering do that).
    pub fn get_mut(&mut self) -> &mut S {
        &mut self.inner
    }

    /// Decrypts the next whole chunk in `rx`, if one is there.
    fn open_chunk(&mut self) -> io::Result<bool> {
        if self.rx.len() < CHUNK_PREFIX {
            return Ok(false);
        }
        let len = u16::from_be_bytes([self.rx[0], self.rx[1]]) as usize;
        if self.rx.len() < CHUNK_PREFIX + len {
            return Ok(false);
        }
        let opened = if len < TAG_LEN {
            Err(ChannelError::Tampered)
        } else {
            // Only as long as this chunk's plaintext: no 64 KiB fill for a heartbeat.
            self.plain.resize(len - TAG_LEN, 0);
            self.noise
                .read_message(&self.rx[CHUNK_PREFIX..CHUNK_PREFIX + len], &mut self.plain)
                .map_err(|_| ChannelError::Tampered)
        };
        match opened {
            Ok(n) => {
                self.plain.truncate(n);
                self.plain_pos = 0;
                self.rx.advance(CHUNK_PREFIX + len);
                Ok(true)
            }
            Err(e) => {
                self.plain.clear();
                self.plain_pos = 0;
                self.broken = true;
                Err(e.into())
            }
        }
    }
}

impl<S: AsyncWrite + Unpin> SecureStream<S> {
    /// Writes out every encrypted byte waiting.
    fn poll_drain(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        while !self.tx.is_empty() {
            let n = ready!(Pin::new(&mut self.inner).poll_write(cx, &self.tx))?;
            if n == 0 {
                return Poll::Ready(Err(io::ErrorKind::WriteZero.into()));
            }
            self.tx.advance(n);
        }
        Poll::Ready(Ok(()))
    }
}

impl<S: AsyncRead + Unpin> AsyncRead for SecureStream<S> {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let me = self.get_mut();
        loop {
            if me.broken {
                return Poll::Ready(Err(ChannelError::Tampered.into()));
            }
            if me.plain_pos < me.plain.len() {
                let n = buf.remaining().min(me.plain.len() - me.plain_pos);
                buf.put_slice(&me.plain[me.plain_pos..me.plain_pos + n]);
                me.plain_pos += n;
                return Poll::Ready(Ok(()));
            }
            if me.open_chunk()? {
                continue;
            }
            me.rx
                .reserve(CHUNK_PREFIX + MAX_NOISE_MESSAGE - me.rx.len());
            let n = ready!(tokio_util::io::poll_read_buf(
                Pin::new(&mut me.inner),
                cx,
                &mut me.rx
            ))?;
            if n == 0 {
                return Poll::Ready(if me.rx.is_empty() {
                    Ok(())
                } else {
                    Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "closed in the middle of an encrypted chunk",
                    ))
                });
            }
        }
    }
}

impl<S: AsyncWrite + Unpin> AsyncWrite for SecureStream<S> {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let me = self.get_mut();
        // At most one chunk waits: a peer that reads nothing holds back our writer, not our
        // memory.
        ready!(me.poll_drain(cx))?;
        if buf.is_empty() {
            return Poll::Ready(Ok(0));
        }
        let n = buf.len().min(MAX_CHUNK);
        let start = me.tx.len();
        me.tx.resize(start + CHUNK_PREFIX + n + TAG_LEN, 0);
        let sealed = me
            .noise
            .write_message(&buf[..n], &mut me.tx[start + CHUNK_PREFIX..])
            .map_err(|e| io::Error::other(ChannelError::Noise(e)))?;
        me.tx[start..start + CHUNK_PREFIX].copy_from_slice(&(sealed as u16).to_be_bytes());
        me.tx.truncate(start + CHUNK_PREFIX + sealed);
        // Start sending at once; what does not go now goes at the next write or flush.
        if let Poll::Ready(Err(e)) = me.poll_drain(cx) {
            return Poll::Ready(Err(e));
        }
        Poll::Ready(Ok(n))
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let me = self.get_mut();
        ready!(me.poll_drain(cx))?;
        Pin::new(&mut me.inner).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let me = self.get_mut();
        ready!(me.poll_drain(cx))?;
        Pin::new(&mut me.inner).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Connection;
    use tokio::io::duplex;

    fn key(t: &str) -> LinkKey {
        LinkKey::from_token(&Token::new(t).unwrap())
    }

    async fn pair(
        worker_key: &LinkKey,
        master_key: &LinkKey,
    ) -> (
        Result<SecureStream<tokio::io::DuplexStream>, ChannelError>,
        Result<SecureStream<tokio::io::DuplexStream>, ChannelError>,
    ) {
        let (a, b) = duplex(1 << 20);
        tokio::join!(connect(a, worker_key, None), accept(b, master_key, None))
    }

    #[test]
    fn the_link_key_is_one_way_and_labelled() {
        let t = Token::new("secret").unwrap();
        let k = LinkKey::from_token(&t);
        assert_eq!(k, LinkKey::from_token(&Token::new("secret\n").unwrap()));
        assert_ne!(k, key("Secret"));
        assert_ne!(&k.0[..], t.as_bytes());
        assert!(!format!("{k:?}").contains("secret"));
        // Not the bare HMAC of the token: the label is in it.
        use hmac::Mac;
        let bare = hmac::Hmac::<sha2::Sha256>::new_from_slice(b"")
            .unwrap()
            .chain_update(t.as_bytes())
            .finalize()
            .into_bytes();
        assert_ne!(&k.0[..], &bare[..]);
    }

    /// The channel's cipher runs on ring's assembly where it can (snow's `ring-accelerated`:
    /// 1.5 GB/s against the portable RustCrypto code's 0.9 on this machine's AVX2). Peers of
    /// earlier releases use the portable code: both must put the same bytes on the wire. Seeded ephemerals make the handshake deterministic, so the two are compared byte
    /// for byte, one chunk at the largest size and one short, both ways.
    #[test]
    fn the_accelerated_cipher_writes_the_portable_ciphers_bytes() {
        fn portable<'a>(k: &'a LinkKey, p: &'a [u8], eph: &'a [u8; 32]) -> snow::Builder<'a> {
            let params = NOISE_PARAMS.parse().unwrap();
            snow::Builder::with_resolver(params, Box::new(snow::resolvers::DefaultResolver))
                .psk(0, &k.0)
                .unwrap()
                .prologue(p)
                .unwrap()
                .fixed_ephemeral_key_for_testing_only(eph)
        }
        // Runs a handshake and one exchange each way; returns every byte that crossed.
        fn run(mut i: snow::HandshakeState, mut r: snow::HandshakeState) -> Vec<u8> {
            let mut wire = Vec::new();
            let (mut a, mut b) = (vec![0u8; MAX_NOISE_MESSAGE], vec![0u8; MAX_NOISE_MESSAGE]);
            let n = i.write_message(&[], &mut a).unwrap();
            r.read_message(&a[..n], &mut b).unwrap();
            wire.extend_from_slice(&a[..n]);
            let n = r.write_message(&[], &mut a).unwrap();
            i.read_message(&a[..n], &mut b).unwrap();
            wire.extend_from_slice(&a[..n]);
            let (mut i, mut r) = (
                i.into_transport_mode().unwrap(),
                r.into_transport_mode().unwrap(),
            );
            let big: Vec<u8> = (0..MAX_CHUNK).map(|x| (x * 31 % 251) as u8).collect();
            for msg in [&big[..], b"heartbeat"] {
                let n = i.write_message(msg, &mut a).unwrap();
                let m = r.read_message(&a[..n], &mut b).unwrap();
                assert_eq!(&b[..m], msg);
                wire.extend_from_slice(&a[..n]);
                let n = r.write_message(msg, &mut a).unwrap();
                let m = i.read_message(&a[..n], &mut b).unwrap();
                assert_eq!(&b[..m], msg);
                wire.extend_from_slice(&a[..n]);
            }
            wire
        }
        let k = key("t");
        let p = prologue(&greeting_header());
        let (ei, er) = ([7u8; 32], [9u8; 32]);
        let ours = |eph| builder(&k, &p, Some(eph)).unwrap();
        let fast = run(
            ours(&ei).build_initiator().unwrap(),
            ours(&er).build_responder().unwrap(),
        );
        let slow = run(
            portable(&k, &p, &ei).build_initiator().unwrap(),
            portable(&k, &p, &er).build_responder().unwrap(),
        );
        assert_eq!(fast.len(), slow.len());
        assert!(
            fast == slow,
            "the two ciphers put different bytes on the wire"
        );
        // And each side of a mixed pair reads the other.
        let mixed = run(
            ours(&ei).build_initiator().unwrap(),
            portable(&k, &p, &er).build_responder().unwrap(),
        );
        assert!(mixed == slow);
    }

    #[tokio::test]
    async fn a_large_message_crosses_in_chunks_and_comes_back_whole() {
        let k = key("t");
        let (w, m) = pair(&k, &k).await;
        let (mut w, mut m) = (
            Connection::new(w.unwrap(), 1 << 22),
            Connection::new(m.unwrap(), 1 << 22),
        );
        let big = Message::Error {
            reason: "x".repeat(3 * MAX_CHUNK + 17),
        };
        let (sent, got) = tokio::join!(w.write(&big), m.read());
        sent.unwrap();
        assert_eq!(got.unwrap().unwrap(), big);
        m.write(&Message::Heartbeat).await.unwrap();
        assert_eq!(w.read().await.unwrap(), Some(Message::Heartbeat));
        // A clean close between messages is a clean end.
        drop(m);
        assert_eq!(w.read().await.unwrap(), None);
    }

    #[tokio::test]
    async fn a_wrong_token_fails_on_the_first_message_and_is_told() {
        let (w, m) = pair(&key("one"), &key("two")).await;
        assert!(matches!(m, Err(ChannelError::WrongKey)), "{m:?}");
        match w {
            Err(ChannelError::Refused(r)) => assert!(r.contains("wrong token"), "{r}"),
            other => panic!("expected a refusal, got {other:?}"),
        }
    }

    #[tokio::test]
    async fn a_master_without_the_token_is_found_out() {
        // A peer that answers with its own Noise message 2 under another key.
        let (a, b) = duplex(1 << 16);
        let squatter = async move {
            let mut b = b;
            let greeting = read_frame(&mut b).await.unwrap();
            let header = greeting_header();
            let p = prologue(&header);
            let other = key("guess");
            let mut hs = builder(&other, &p, None)
                .unwrap()
                .build_responder()
                .unwrap();
            let mut buf = [0u8; 128];
            // It cannot read message 1; it answers anyway with a fresh message of its own.
            let _ = hs.read_message(&greeting[header.len()..], &mut buf);
            let mut hs = builder(&other, &p, None)
                .unwrap()
                .build_initiator()
                .unwrap();
            let n = hs.write_message(&[], &mut buf).unwrap();
            write_frame(&mut b, &[&[NOISE_REPLY], &buf[..n]])
                .await
                .unwrap();
            b
        };
        let ours = key("t");
        let (w, _b) = tokio::join!(connect(a, &ours, None), squatter);
        assert!(matches!(w, Err(ChannelError::WrongKey)), "{w:?}");
    }

    #[tokio::test]
    async fn other_versions_are_refused_with_their_version() {
        let (mut a, b) = duplex(1 << 16);
        let old_hello = [0u8, 2, 1, b'w', 1];
        write_frame(&mut a, &[&old_hello]).await.unwrap();
        let m = accept(b, &key("t"), None).await;
        assert!(matches!(m, Err(ChannelError::OtherVersion(2))), "{m:?}");
        let mut c = Connection::new(a, 1 << 16);
        match c.read().await.unwrap() {
            Some(Message::Refused { reason }) => {
                assert!(reason.contains("protocol version 2"), "{reason}")
            }
            other => panic!("expected Refused, got {other:?}"),
        }
        // Not a greeting at all, and an oversized first frame.
        let (mut a, b) = duplex(1 << 16);
        write_frame(&mut a, &[&[7u8, 1, 2, 3]]).await.unwrap();
        assert!(matches!(
            accept(b, &key("t"), None).await,
            Err(ChannelError::NotParrt)
        ));
        let (mut a, b) = duplex(1 << 16);
        a.write_all(&[0xff, 0xff, 0xff, 0xff]).await.unwrap();
        let e = accept(b, &key("t"), None).await.unwrap_err();
        assert!(e.to_string().contains("larger than the limit"), "{e}");
    }

    #[tokio::test]
    async fn one_flipped_byte_ends_the_stream() {
        let k = key("t");
        let (a, b) = duplex(1 << 20);
        // A relay between the two that flips a byte in the first transport chunk it carries
        // from master to worker, after the two handshake frames.
        let (w, m) = tokio::join!(connect(a, &k, None), accept(b, &k, None));
        let (mut w, mut m) = (w.unwrap(), m.unwrap());
        m.write_all(b"the scene: sphere 1 2 3").await.unwrap();
        m.flush().await.unwrap();
        // Flip a byte of the ciphertext in flight: read it raw from below the worker's channel.
        let mut raw = [0u8; 64];
        let n = w.get_mut().read(&mut raw).await.unwrap();
        assert!(
            !raw[..n].windows(5).any(|x| x == b"scene"),
            "plaintext on the wire"
        );
        raw[n / 2] ^= 1;
        w.rx.extend_from_slice(&raw[..n]);
        let mut got = [0u8; 64];
        let e = w.read(&mut got).await.unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("failed authentication"), "{e}");
        // And it stays broken.
        assert!(w.read(&mut got).await.is_err());
    }

    #[tokio::test(start_paused = true)]
    async fn seeded_ephemerals_give_the_same_bytes() {
        async fn greeting(seed: u64) -> Vec<u8> {
            let (a, mut b) = duplex(1 << 16);
            let k = key("t");
            let w = tokio::spawn(async move { connect(a, &k, Some(seeded_ephemeral(seed))).await });
            let g = read_frame(&mut b).await.unwrap();
            w.abort();
            g
        }
        assert_eq!(greeting(1).await, greeting(1).await);
        assert_ne!(greeting(1).await, greeting(2).await);
    }
}
