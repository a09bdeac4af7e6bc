//! The pure codec: bytes in, messages out, and back. Frames are length-delimited (4-byte
//! big-endian length, tokio-util's `LengthDelimitedCodec`) with a maximum size; payloads are
//! postcard. Never touches a socket, so it is tested on byte buffers alone.

use super::message::Message;
use bytes::{Bytes, BytesMut};
use std::io;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use thiserror::Error;
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

/// Decodes one frame's payload; the whole payload must be one message.
pub fn decode_payload(payload: &[u8]) -> Result<Message, ProtocolError> {
    let (msg, rest) =
        postcard::take_from_bytes::<Message>(payload).map_err(ProtocolError::Decode)?;
    if !rest.is_empty() {
        return Err(ProtocolError::TrailingBytes(rest.len()));
    }
    Ok(msg)
}

/// The message codec: `LengthDelimitedCodec` framing with a maximum frame length, postcard
/// payloads, and byte counters.
#[derive(Debug)]
pub struct MessageCodec {
    frames: LengthDelimitedCodec,
    max: usize,
    counters: Arc<WireCounters>,
    /// The framing codec has consumed a length prefix whose payload has not arrived yet.
    mid_frame: bool,
}

impl MessageCodec {
    /// A codec accepting frames of at most `max_frame` payload bytes.
    pub fn new(max_frame: usize) -> Self {
        MessageCodec {
            frames: LengthDelimitedCodec::builder()
                .max_frame_length(max_frame)
                .length_field_length(LENGTH_PREFIX)
                .new_codec(),
            max: max_frame,
            counters: Arc::new(WireCounters::default()),
            mid_frame: false,
        }
    }

    /// Changes the maximum frame length (e.g. raised once a peer has authenticated).
    pub fn set_max_frame(&mut self, max_frame: usize) {
        self.frames.set_max_frame_length(max_frame);
        self.max = max_frame;
    }

    /// The maximum frame length in force.
    pub fn max_frame(&self) -> usize {
        self.max
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
        match self.frames.decode(src) {
            Ok(Some(frame)) => {
                self.mid_frame = false;
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
                }
                Ok(None)
            }
            Err(e) => Err(self.map_frame_err(e)),
        }
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
        let len = payload.len();
        self.frames
            .encode(Bytes::from(payload), dst)
            .map_err(|e| self.map_frame_err(e))?;
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
    use crate::description::{Light, Material, Primitive, SceneDescription, Shape, View};
    use crate::protocol::message::JobSpec;
    use crate::settings::RenderSettings;
    use crate::stats::RayStats;
    use crate::tile::Tile;
    use crate::vec3::Vec3d;

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
                    shape: Shape::Polygon(vec![
                        Vec3d::new(0.0, 0.0, 0.0),
                        Vec3d::new(1.0, 0.0, 0.0),
                        Vec3d::new(0.0, 1.0, 0.0),
                    ]),
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
            },
            Message::Challenge { nonce: [9; 32] },
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
                pixel_format: crate::protocol::PixelFormat::Rgb8,
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
                pixels: crate::protocol::TilePixels::encode(
                    &[[0.5, f32::MIN_POSITIVE, -0.0]; 40],
                    crate::protocol::PixelFormat::F32,
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
        })
        .unwrap();
        assert_eq!(&p[..2], &[0, 7]);
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
                    pixels: crate::protocol::TilePixels::encode(&pixels, crate::protocol::PixelFormat::F32),
                    stats: RayStats { eye_rays: job_id, ..RayStats::default() }, seconds,
                },
                Message::Hello { version: attempt, name, threads: tile_id },
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
