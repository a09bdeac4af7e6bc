//! The pure codec: bytes in, messages out, and back. Frames are length-delimited (4-byte
//! big-endian length, tokio-util's `LengthDelimitedCodec`) with a maximum size for each
//! direction; payloads are postcard. It also notes when bytes last arrived and when the frame
//! being read began (and how long it is), so a connection can tell a slow peer from a dead one.
//! Never touches a socket, so it is tested on byte buffers alone.

use super::message::Message;
use super::PROTOCOL_VERSION;
use bytes::{BufMut, BytesMut};
use std::io;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use thiserror::Error;
use tokio::time::Instant;
use tokio_util::codec::{Decoder, Encoder, LengthDelimitedCodec, LengthDelimitedCodecError};

/// Bytes of the length prefix in front of every frame.
pub const LENGTH_PREFIX: usize = 4;

/// Errors reading or writing messages.
#[derive(Debug, Error)]
pub enum ProtocolError {
    /// The socket failed.
    #[error("i/o error: {0}")]
    Io(#[from] io::Error),
    /// A length prefix announced a frame larger than this connection accepts.
    #[error("frame larger than the limit of {max} bytes")]
    FrameTooLarge {
        /// The limit in force.
        max: usize,
    },
    /// The peer closed the connection in the middle of a frame.
    #[error("connection closed in the middle of a frame ({0} bytes pending)")]
    Truncated(usize),
    /// A frame's payload is not a valid message.
    #[error("malformed message: {0}")]
    Decode(postcard::Error),
    /// A frame holds a valid message followed by extra bytes.
    #[error("malformed message: {0} trailing bytes after the message")]
    TrailingBytes(usize),
    /// A message could not be encoded.
    #[error("cannot encode message: {0}")]
    Encode(postcard::Error),
    /// A Hello of another protocol version whose fields differ from ours: only its version
    /// could be read (so it can still be refused with a reason).
    #[error("a Hello of protocol version {0}")]
    OtherVersion(u32),
}

/// Frame and byte counts of one connection, shared so they can be read while it runs.
#[derive(Debug, Default)]
pub struct WireCounters {
    /// Bytes written (prefixes included).
    pub bytes_sent: AtomicU64,
    /// Bytes read (prefixes included).
    pub bytes_received: AtomicU64,
    /// Frames written.
    pub frames_sent: AtomicU64,
    /// Frames read.
    pub frames_received: AtomicU64,
}

impl WireCounters {
    /// Bytes sent so far.
    pub fn sent(&self) -> u64 {
        self.bytes_sent.load(Ordering::Relaxed)
    }
    /// Bytes received so far.
    pub fn received(&self) -> u64 {
        self.bytes_received.load(Ordering::Relaxed)
    }
}

/// Encodes a message's payload (without the length prefix).
pub fn encode_payload(msg: &Message) -> Result<Vec<u8>, ProtocolError> {
    postcard::to_stdvec(msg).map_err(ProtocolError::Encode)
}

/// Decodes one frame's payload; the whole payload must be one message. A payload that is not a
/// message but starts like a Hello (variant 0) of another version is
/// [`ProtocolError::OtherVersion`].
pub fn decode_payload(payload: &[u8]) -> Result<Message, ProtocolError> {
    let (msg, rest) =
        postcard::take_from_bytes::<Message>(payload).map_err(|e| {
            match hello_version(payload) {
                Some(v) if v != PROTOCOL_VERSION => ProtocolError::OtherVersion(v),
                _ => ProtocolError::Decode(e),
            }
        })?;
    if !rest.is_empty() {
        return Err(ProtocolError::TrailingBytes(rest.len()));
    }
    Ok(msg)
}

/// The version of a payload that starts as a Hello does (variant 0, then the version as a
/// postcard varint), whatever follows.
fn hello_version(payload: &[u8]) -> Option<u32> {
    #[derive(serde::Deserialize)]
    enum Head {
        Hello { version: u32 },
    }
    match postcard::take_from_bytes::<Head>(payload) {
        Ok((Head::Hello { version }, _)) => Some(version),
        Err(_) => None,
    }
}

/// The message codec: `LengthDelimitedCodec` framing with a maximum frame length (one for
/// frames read, one for frames written), postcard payloads, byte counters, and the instants
/// that tell a slow peer from a dead one.
#[derive(Debug)]
pub struct MessageCodec {
    frames: LengthDelimitedCodec,
    max: usize,
    max_send: usize,
    counters: Arc<WireCounters>,
    /// The framing codec has consumed a length prefix whose payload has not arrived yet.
    mid_frame: bool,
    /// Bytes buffered after the last `decode` call (more at the next call means bytes arrived).
    seen: usize,
    /// When bytes last arrived (or the codec was made).
    last_bytes: Instant,
    /// The frame being read: when its length prefix arrived, and its length.
    pending: Option<(Instant, usize)>,
}

impl MessageCodec {
    /// A codec reading and writing frames of at most `max_frame` payload bytes.
    pub fn new(max_frame: usize) -> Self {
        MessageCodec {
            frames: LengthDelimitedCodec::builder()
                .max_frame_length(max_frame)
                .length_field_length(LENGTH_PREFIX)
                .new_codec(),
            max: max_frame,
            max_send: max_frame,
            counters: Arc::new(WireCounters::default()),
            mid_frame: false,
            seen: 0,
            last_bytes: Instant::now(),
            pending: None,
        }
    }

    /// Changes the maximum frame length of both directions (e.g. raised once a peer has
    /// authenticated).
    pub fn set_max_frame(&mut self, max_frame: usize) {
        self.set_max_receive(max_frame);
        self.max_send = max_frame;
    }

    /// Changes the maximum length of frames read only.
    pub fn set_max_receive(&mut self, max_frame: usize) {
        self.frames.set_max_frame_length(max_frame);
        self.max = max_frame;
    }

    /// The maximum length of frames read.
    pub fn max_frame(&self) -> usize {
        self.max
    }

    /// When bytes last arrived (the codec's creation if none have).
    pub fn last_bytes(&self) -> Instant {
        self.last_bytes
    }

    /// The frame being read, if one has begun: when its length prefix arrived, and its length.
    pub fn pending_frame(&self) -> Option<(Instant, usize)> {
        self.pending
    }

    /// The byte counters of this codec.
    pub fn counters(&self) -> Arc<WireCounters> {
        self.counters.clone()
    }

    fn map_frame_err(&self, e: io::Error) -> ProtocolError {
        if e.get_ref()
            .is_some_and(|inner| inner.is::<LengthDelimitedCodecError>())
        {
            ProtocolError::FrameTooLarge { max: self.max }
        } else {
            ProtocolError::Io(e)
        }
    }
}

impl Decoder for MessageCodec {
    type Item = Message;
    type Error = ProtocolError;

    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<Message>, ProtocolError> {
        let before = src.len();
        if before > self.seen {
            self.last_bytes = Instant::now();
        }
        let announced = (!self.mid_frame && before >= LENGTH_PREFIX)
            .then(|| u32::from_be_bytes([src[0], src[1], src[2], src[3]]) as usize);
        let result = self.decode_frame(src, before, announced);
        self.seen = src.len();
        result
    }

    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<Message>, ProtocolError> {
        match self.decode(src)? {
            Some(m) => Ok(Some(m)),
            None if src.is_empty() && !self.mid_frame => Ok(None),
            None => Err(ProtocolError::Truncated(
                src.len() + if self.mid_frame { LENGTH_PREFIX } else { 0 },
            )),
        }
    }
}

impl MessageCodec {
    fn decode_frame(
        &mut self,
        src: &mut BytesMut,
        before: usize,
        announced: Option<usize>,
    ) -> Result<Option<Message>, ProtocolError> {
        match self.frames.decode(src) {
            Ok(Some(frame)) => {
                self.mid_frame = false;
                self.pending = None;
                self.counters
                    .bytes_received
                    .fetch_add((frame.len() + LENGTH_PREFIX) as u64, Ordering::Relaxed);
                self.counters
                    .frames_received
                    .fetch_add(1, Ordering::Relaxed);
                decode_payload(&frame).map(Some)
            }
            Ok(None) => {
                if src.len() < before {
                    self.mid_frame = true;
                    if let Some(len) = announced {
                        self.pending = Some((Instant::now(), len));
                    }
                }
                Ok(None)
            }
            Err(e) => Err(self.map_frame_err(e)),
        }
    }
}

impl Encoder<Message> for MessageCodec {
    type Error = ProtocolError;

    fn encode(&mut self, msg: Message, dst: &mut BytesMut) -> Result<(), ProtocolError> {
        self.encode(&msg, dst)
    }
}

impl Encoder<&Message> for MessageCodec {
    type Error = ProtocolError;

    fn encode(&mut self, msg: &Message, dst: &mut BytesMut) -> Result<(), ProtocolError> {
        let payload = encode_payload(msg)?;
        self.put_frame(&payload, dst)
    }
}

/// A message encoded once, to be sent to many peers (the job, with its scene) without encoding
/// it again for each.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Encoded {
    payload: bytes::Bytes,
}

impl Encoded {
    /// Encodes `msg`.
    pub fn new(msg: &Message) -> Result<Self, ProtocolError> {
        Ok(Encoded {
            payload: encode_payload(msg)?.into(),
        })
    }

    /// Bytes of the payload (without the length prefix).
    pub fn len(&self) -> usize {
        self.payload.len()
    }

    /// Whether the payload is empty (never, for a message).
    pub fn is_empty(&self) -> bool {
        self.payload.is_empty()
    }
}

impl Encoder<&Encoded> for MessageCodec {
    type Error = ProtocolError;

    fn encode(&mut self, msg: &Encoded, dst: &mut BytesMut) -> Result<(), ProtocolError> {
        self.put_frame(&msg.payload, dst)
    }
}

impl MessageCodec {
    /// Writes one frame: the length prefix and `payload`, within the sending limit.
    fn put_frame(&mut self, payload: &[u8], dst: &mut BytesMut) -> Result<(), ProtocolError> {
        let len = payload.len();
        if len > self.max_send || u32::try_from(len).is_err() {
            return Err(ProtocolError::FrameTooLarge { max: self.max_send });
        }
        dst.reserve(LENGTH_PREFIX + len);
        dst.put_u32(len as u32);
        dst.extend_from_slice(payload);
        self.counters
            .bytes_sent
            .fetch_add((len + LENGTH_PREFIX) as u64, Ordering::Relaxed);
        self.counters.frames_sent.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::JobSpec;
    use parrt_render::description::{Light, Material, Primitive, SceneDescription, Shape, View};
    use parrt_render::settings::RenderSettings;
    use parrt_render::stats::RayStats;
    use parrt_render::tile::Tile;
    use parrt_render::vec3::Vec3d;

    fn scene() -> SceneDescription {
        SceneDescription {
            background: Vec3d::new(0.1, 0.2, 0.3),
            view: View {
                from: Vec3d::new(0.0, 0.0, 5.0),
                at: Vec3d::zero(),
                up: Vec3d::new(0.0, 1.0, 0.0),
                angle: 40.0,
                hither: 0.01,
                width: 8,
                height: 8,
            },
            lights: vec![Light {
                position: Vec3d::new(1.0, 2.0, 3.0),
                color: None,
            }],
            materials: vec![Material::default_white()],
            primitives: vec![
                Primitive {
                    shape: Shape::Sphere {
                        center: Vec3d::zero(),
                        radius: 1.0,
                    },
                    material: 0,
                },
                Primitive {
                    shape: Shape::Polygon(
                        vec![
                            Vec3d::new(0.0, 0.0, 0.0),
                            Vec3d::new(1.0, 0.0, 0.0),
                            Vec3d::new(0.0, 1.0, 0.0),
                        ]
                        .into(),
                    ),
                    material: 0,
                },
            ],
        }
    }

    fn all_messages() -> Vec<Message> {
        let tile = Tile {
            id: 3,
            x: 8,
            y: 0,
            w: 8,
            h: 5,
        };
        vec![
            Message::Hello {
                version: 1,
                name: "host-1".into(),
                threads: 4,
                nonce: [5; 32],
                isa: parrt_render::isa::Isa::Avx512,
            },
            Message::Challenge {
                nonce: [9; 32],
                proof: [4; 32],
            },
            Message::Auth { mac: vec![1; 32] },
            Message::Welcome,
            Message::Refused {
                reason: "wrong token".into(),
            },
            Message::Job(Box::new(JobSpec {
                job_id: u64::MAX,
                scene: scene(),
                settings: RenderSettings::new(8, 8),
                tile_size: 8,
                pixel_format: crate::PixelFormat::Rgb8,
                pack_pixels: true,
            })),
            Message::Ready {
                job_id: 5,
                build_s: 0.25,
            },
            Message::Assign {
                job_id: 5,
                tile,
                attempt: 2,
            },
            Message::TileResult {
                job_id: 5,
                tile_id: 3,
                attempt: 2,
                pixels: crate::TilePixels::encode(
                    &[[0.5, f32::MIN_POSITIVE, -0.0]; 40],
                    crate::PixelFormat::F32,
                ),
                stats: RayStats {
                    eye_rays: 40,
                    primitive_tests: 1 << 40,
                    ..RayStats::default()
                },
                seconds: 0.001,
            },
            Message::Heartbeat,
            Message::Cancel { job_id: 5 },
            Message::Shutdown,
            Message::Error {
                reason: "cannot build".into(),
            },
            Message::AssignBatch {
                job_id: 5,
                tiles: vec![(tile, 1), (Tile { id: 4, ..tile }, 3)],
            },
        ]
    }

    #[test]
    fn every_message_round_trips_through_frames() {
        let mut codec = MessageCodec::new(1 << 20);
        let mut buf = BytesMut::new();
        let msgs = all_messages();
        for m in &msgs {
            codec.encode(m, &mut buf).unwrap();
        }
        let sent = codec.counters().sent();
        assert_eq!(sent as usize, buf.len());
        let mut back = Vec::new();
        while let Some(m) = codec.decode(&mut buf).unwrap() {
            back.push(m);
        }
        assert_eq!(back, msgs);
        assert_eq!(codec.counters().received(), sent);
        assert!(codec.decode_eof(&mut buf).unwrap().is_none());
    }

    #[test]
    fn bytes_arriving_one_at_a_time_decode_the_same() {
        let mut codec = MessageCodec::new(1 << 20);
        let mut all = BytesMut::new();
        for m in all_messages() {
            codec.encode(m, &mut all).unwrap();
        }
        let mut buf = BytesMut::new();
        let mut back = Vec::new();
        for b in all.iter() {
            buf.extend_from_slice(&[*b]);
            if let Some(m) = codec.decode(&mut buf).unwrap() {
                back.push(m);
            }
        }
        assert_eq!(back, all_messages());
    }

    #[test]
    fn hello_is_variant_zero_with_version_first() {
        let p = encode_payload(&Message::Hello {
            version: 7,
            name: String::new(),
            threads: 1,
            nonce: [0; 32],
            isa: parrt_render::isa::Isa::Scalar,
        })
        .unwrap();
        assert_eq!(&p[..2], &[0, 7]);
    }

    #[test]
    fn a_hello_of_another_shape_is_reported_with_its_version() {
        // Version 1's Hello had no nonce: it does not decode as ours, but its version reads.
        let mut v1 = vec![0u8, 1, 2, b'w', b'1', 4];
        assert!(matches!(
            decode_payload(&v1),
            Err(ProtocolError::OtherVersion(1))
        ));
        // Our own version with a missing field is just malformed.
        v1[1] = PROTOCOL_VERSION as u8;
        assert!(matches!(decode_payload(&v1), Err(ProtocolError::Decode(_))));
    }

    #[test]
    fn send_and_receive_limits_differ_when_asked() {
        let mut codec = MessageCodec::new(1 << 20);
        codec.set_max_receive(64);
        let big = Message::Error {
            reason: "z".repeat(500),
        };
        let mut buf = BytesMut::new();
        codec.encode(&big, &mut buf).unwrap();
        assert!(matches!(
            codec.decode(&mut buf),
            Err(ProtocolError::FrameTooLarge { max: 64 })
        ));
    }

    #[tokio::test(start_paused = true)]
    async fn arriving_bytes_and_the_pending_frame_are_noted() {
        let mut codec = MessageCodec::new(1 << 20);
        let t0 = Instant::now();
        let mut all = BytesMut::new();
        codec
            .encode(
                Message::Error {
                    reason: "q".repeat(1000),
                },
                &mut all,
            )
            .unwrap();
        let total = all.len();
        let mut buf = BytesMut::from(&all[..10]);
        tokio::time::advance(std::time::Duration::from_secs(3)).await;
        assert!(codec.decode(&mut buf).unwrap().is_none());
        let (began, len) = codec.pending_frame().expect("a frame has begun");
        assert_eq!(len, total - LENGTH_PREFIX);
        assert_eq!(began, t0 + std::time::Duration::from_secs(3));
        assert_eq!(codec.last_bytes(), began);
        // No new bytes: nothing moves.
        tokio::time::advance(std::time::Duration::from_secs(2)).await;
        assert!(codec.decode(&mut buf).unwrap().is_none());
        assert_eq!(codec.last_bytes(), began);
        // More bytes: progress, same frame.
        buf.extend_from_slice(&all[10..20]);
        assert!(codec.decode(&mut buf).unwrap().is_none());
        assert_eq!(codec.last_bytes(), t0 + std::time::Duration::from_secs(5));
        assert_eq!(codec.pending_frame().unwrap().0, began);
        buf.extend_from_slice(&all[20..]);
        assert!(codec.decode(&mut buf).unwrap().is_some());
        assert!(codec.pending_frame().is_none());
    }

    #[test]
    fn garbage_payload_is_a_decode_error() {
        let mut codec = MessageCodec::new(1024);
        // Unknown variant 200, then noise.
        let mut buf = BytesMut::from(&[0, 0, 0, 3, 200, 1, 2][..]);
        assert!(matches!(
            codec.decode(&mut buf),
            Err(ProtocolError::Decode(_))
        ));
        // A valid message followed by junk inside the same frame.
        let mut payload = encode_payload(&Message::Heartbeat).unwrap();
        payload.extend_from_slice(&[1, 2, 3]);
        let mut buf = BytesMut::new();
        buf.extend_from_slice(&(payload.len() as u32).to_be_bytes());
        buf.extend_from_slice(&payload);
        assert!(matches!(
            codec.decode(&mut buf),
            Err(ProtocolError::TrailingBytes(3))
        ));
        // A string whose length runs past the frame.
        let mut buf = BytesMut::from(&[0, 0, 0, 3, 4, 100, b'x'][..]);
        assert!(matches!(
            codec.decode(&mut buf),
            Err(ProtocolError::Decode(_))
        ));
    }

    #[test]
    fn random_garbage_never_panics() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(42);
        for _ in 0..2000 {
            let mut codec = MessageCodec::new(4096);
            let n = rng.gen_range(0..64);
            let mut buf: BytesMut = (0..n).map(|_| rng.gen::<u8>()).collect::<Vec<u8>>()[..].into();
            // Small frames so that the payload decoder is exercised too.
            if n >= 4 && rng.gen_bool(0.5) {
                buf[..4].copy_from_slice(&((n as u32 - 4).min(60)).to_be_bytes());
            }
            while let Ok(Some(_)) = codec.decode(&mut buf) {}
        }
    }

    proptest::proptest! {
        #[test]
        fn arbitrary_results_and_assigns_round_trip(
            job_id: u64, tile_id: u32, attempt: u32, x: u32, y: u32, w in 1u32..64, h in 1u32..64,
            bits in proptest::collection::vec(proptest::num::u32::ANY, 0..200),
            name in ".{0,40}", seconds: f64,
        ) {
            // Any f32 bit pattern (NaN payloads included) must come back bit for bit.
            let pixels: Vec<[f32; 3]> = bits
                .chunks(3)
                .map(|c| [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)].map(f32::from_bits))
                .collect();
            let msgs = vec![
                Message::Assign { job_id, tile: Tile { id: tile_id, x, y, w, h }, attempt },
                Message::TileResult {
                    job_id, tile_id, attempt,
                    pixels: crate::TilePixels::encode(&pixels, crate::PixelFormat::F32),
                    stats: RayStats { eye_rays: job_id, ..RayStats::default() }, seconds,
                },
                Message::Hello { version: attempt, name, threads: tile_id, nonce: [7; 32], isa: parrt_render::isa::Isa::Sse2 },
            ];
            let mut codec = MessageCodec::new(1 << 20);
            let mut buf = BytesMut::new();
            for m in &msgs {
                codec.encode(m, &mut buf).unwrap();
            }
            for m in &msgs {
                let back = codec.decode(&mut buf).unwrap().unwrap();
                // Compare through the encoding: NaN != NaN, but equal bytes are equal bits.
                proptest::prop_assert_eq!(encode_payload(&back).unwrap(), encode_payload(m).unwrap());
            }
            if let Message::TileResult { pixels: tp, .. } = decode_payload(&encode_payload(&msgs[1]).unwrap()).unwrap() {
                let p: Vec<[f32; 3]> = tp.bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect::<Vec<_>>().chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                let same = p.iter().flatten().zip(pixels.iter().flatten()).all(|(a, b)| a.to_bits() == b.to_bits());
                proptest::prop_assert!(same && p.len() == pixels.len());
            }
        }
    }

    #[test]
    fn truncated_frame_is_an_error_at_eof() {
        let mut codec = MessageCodec::new(1024);
        let mut full = BytesMut::new();
        codec
            .encode(
                Message::Error {
                    reason: "x".repeat(20),
                },
                &mut full,
            )
            .unwrap();
        for cut in 1..full.len() {
            // A fresh codec each time: a codec remembers a header it has consumed.
            let mut codec = MessageCodec::new(1024);
            let mut buf = BytesMut::from(&full[..cut]);
            assert!(codec.decode(&mut buf).unwrap().is_none());
            assert!(matches!(
                codec.decode_eof(&mut buf),
                Err(ProtocolError::Truncated(n)) if n > 0
            ));
        }
    }

    #[test]
    fn oversized_length_prefix_is_refused_without_buffering() {
        let mut codec = MessageCodec::new(1024);
        let mut buf = BytesMut::from(&[0xff, 0xff, 0xff, 0xff, 1, 2][..]);
        assert!(matches!(
            codec.decode(&mut buf),
            Err(ProtocolError::FrameTooLarge { max: 1024 })
        ));
        assert!(buf.capacity() < 1 << 20);
        let mut buf = BytesMut::from(&1025u32.to_be_bytes()[..]);
        assert!(matches!(
            codec.decode(&mut buf),
            Err(ProtocolError::FrameTooLarge { .. })
        ));
    }

    #[test]
    fn oversized_message_is_refused_when_encoding() {
        let mut codec = MessageCodec::new(16);
        let mut buf = BytesMut::new();
        let err = codec
            .encode(
                Message::Error {
                    reason: "y".repeat(100),
                },
                &mut buf,
            )
            .unwrap_err();
        assert!(
            matches!(err, ProtocolError::FrameTooLarge { max: 16 }),
            "{err}"
        );
        codec.set_max_frame(1000);
        assert!(codec
            .encode(
                Message::Error {
                    reason: "y".repeat(100)
                },
                &mut buf
            )
            .is_ok());
    }
}
