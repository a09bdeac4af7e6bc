//! How a tile's pixels travel from worker to master: as the image's output needs them. An
//! 8-bit output (PNG, PPM) needs 3 bytes a pixel, quantized on the worker by the very function
//! the film's 8-bit writer applies ([`parrt_render::film::to_u8`]), so the written image is the same
//! bytes as an SMP render's; a float output (EXR) and the library API get the exact f32 bits
//! (12 bytes a pixel). Either way the pixels are one byte blob, copied in and out without a
//! per-value encoding step.
//!
//! On the wire, when the job asks (a master across a network does), an 8-bit blob is packed
//! with LZ4 whenever that makes it smaller ([`TilePixels::pack`]): rendered tiles repeat (a
//! background, a flat-shaded facet, a shadow), so a 32² tile of mount-8 at 4096² travels in a
//! tenth of its bytes for about 3 µs of a worker's CPU and 3 µs of the master's. That is what
//! keeps a 1 Gbit/s master link from binding a thousand cores. The receiver unpacks
//! ([`TilePixels::unpack`]) into exactly the tile's byte count, never more, before any other
//! check.

use crate::shared_pixels::SharedPixels;
use parrt_render::film::{to_u8_into, unit, Rgb};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The precision pixels travel in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PixelFormat {
    /// Three little-endian `f32` per pixel: exact.
    #[default]
    F32,
    /// Three bytes per pixel, each [`to_u8`](parrt_render::film::to_u8) of the linear value: what
    /// 8-bit outputs keep.
    Rgb8,
}

impl PixelFormat {
    /// Bytes per pixel on the wire.
    pub fn bytes_per_pixel(self) -> usize {
        match self {
            PixelFormat::F32 => 12,
            PixelFormat::Rgb8 => 3,
        }
    }
}

/// How a tile's byte blob is packed on the wire.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Packing {
    /// The bytes as [`PixelFormat`] lays them out.
    #[default]
    Raw,
    /// Those bytes as one LZ4 block (no size prefix: the receiver knows the tile's size).
    Lz4,
    /// Those bytes in a slot of the memory a master shares with a worker it started
    /// ([`crate::shared_pixels`]); `bytes` is empty. The master's connection task takes them
    /// out of the slot, so the scheduler only ever sees them raw.
    Shared {
        /// The region's id.
        region: u64,
        /// The slot.
        slot: u32,
        /// Bytes written in the slot.
        len: u32,
    },
}

/// A tile's pixels as they travel: row-major within the tile.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TilePixels {
    /// The encoding of the unpacked bytes.
    pub format: PixelFormat,
    /// How `bytes` are packed.
    pub packing: Packing,
    /// The encoded pixels.
    #[serde(with = "serde_bytes")]
    pub bytes: Vec<u8>,
}

/// Pixels that cannot be decoded into a tile.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PixelError {
    /// Sent in a format the job did not ask for.
    #[error("pixels sent as {got:?}, the job asked for {want:?}")]
    Format {
        /// What came.
        got: PixelFormat,
        /// What the job asked for.
        want: PixelFormat,
    },
    /// The byte count is not the tile's pixel count times the bytes per pixel.
    #[error("{bytes} bytes of {format:?} pixels for a tile of {pixels} pixels")]
    Count {
        /// Bytes received.
        bytes: usize,
        /// Their format.
        format: PixelFormat,
        /// Pixels in the tile.
        pixels: usize,
    },
    /// Packed bytes that do not unpack to the tile's byte count.
    #[error("packed pixels do not unpack to the {want} bytes of the tile")]
    Unpack {
        /// Bytes a tile of this size holds.
        want: usize,
    },
    /// Packed bytes given to a step that needs them unpacked (a receiver's bug, not a peer's).
    #[error("pixels still packed")]
    Packed,
    /// Pixels said to be in shared memory, reaching a step that cannot read it (a master that
    /// shares none with this worker takes them out before).
    #[error("pixels in shared memory this receiver does not hold")]
    NotShared,
    /// An f32 value is NaN or infinite (no render produces one; the film must never hold one).
    #[error("pixel {index} has a non-finite value ({value})")]
    NonFinite {
        /// The pixel's index within the tile.
        index: usize,
        /// The value.
        value: f32,
    },
}

impl TilePixels {
    /// Encodes rendered pixels in `format`.
    pub fn encode(pixels: &[Rgb], format: PixelFormat) -> Self {
        // Sized once and filled in a straight loop, not grown four bytes at a time.
        let mut bytes = vec![0; pixels.len() * format.bytes_per_pixel()];
        write_bytes(pixels, format, &mut bytes);
        TilePixels {
            format,
            packing: Packing::Raw,
            bytes,
        }
    }

    /// Encodes rendered pixels in `format` straight into a free slot of `region`, or `None`
    /// when no slot takes them (the caller encodes them inline).
    pub fn encode_shared(
        pixels: &[Rgb],
        format: PixelFormat,
        region: &SharedPixels,
    ) -> Option<Self> {
        let len = pixels.len() * format.bytes_per_pixel();
        let len32 = u32::try_from(len).ok()?;
        let slot = region.put(len, |bytes| write_bytes(pixels, format, bytes))?;
        Some(TilePixels {
            format,
            packing: Packing::Shared {
                region: region.id(),
                slot,
                len: len32,
            },
            bytes: Vec::new(),
        })
    }

    /// Packs raw 8-bit pixels with LZ4 when that makes them smaller; otherwise (already
    /// packed, f32, or not smaller) returns them as they are. f32 pixels stay raw: their low
    /// mantissa bytes rarely repeat, so a 32² tile packs only 1.1–2.8× (gears-4, mount-6 at
    /// 2048²) for 13–23 µs of the worker's CPU and 5–7 µs of the master's to unpack, more
    /// than the bytes saved cost to send and decrypt on a local pair.
    pub fn pack(self) -> Self {
        if self.packing != Packing::Raw || self.format != PixelFormat::Rgb8 {
            return self;
        }
        let packed = lz4_flex::block::compress(&self.bytes);
        if packed.len() >= self.bytes.len() {
            return self;
        }
        TilePixels {
            packing: Packing::Lz4,
            bytes: packed,
            ..self
        }
    }

    /// The raw bytes of a tile of `count` pixels: as they are when sent raw, unpacked when
    /// packed, refused when they do not unpack to exactly `count` pixels in their format
    /// (a bomb cannot make it write more: the output is allocated at the tile's size).
    pub fn unpack(self, count: usize) -> Result<Self, PixelError> {
        match self.packing {
            Packing::Raw => return Ok(self),
            Packing::Shared { .. } => return Err(PixelError::NotShared),
            Packing::Lz4 => {}
        }
        let want = count.saturating_mul(self.format.bytes_per_pixel());
        let mut bytes = vec![0; want];
        match lz4_flex::block::decompress_into(&self.bytes, &mut bytes) {
            Ok(n) if n == want => Ok(TilePixels {
                format: self.format,
                packing: Packing::Raw,
                bytes,
            }),
            _ => Err(PixelError::Unpack { want }),
        }
    }

    /// The 8-bit bytes of a tile of `count` pixels sent for a job that asked for `want`, after
    /// the checks [`TilePixels::decode_into`] makes (an 8-bit value needs no other).
    pub fn rgb8(&self, want: PixelFormat, count: usize) -> Result<&[u8], PixelError> {
        self.check(want, count)?;
        match self.format {
            PixelFormat::Rgb8 => Ok(&self.bytes),
            PixelFormat::F32 => Err(PixelError::Format {
                got: self.format,
                want: PixelFormat::Rgb8,
            }),
        }
    }

    /// Checks the format against `want` and the byte count against `count` pixels.
    fn check(&self, want: PixelFormat, count: usize) -> Result<(), PixelError> {
        if self.packing != Packing::Raw {
            return Err(PixelError::Packed);
        }
        if self.format != want {
            return Err(PixelError::Format {
                got: self.format,
                want,
            });
        }
        let per = self.format.bytes_per_pixel();
        if self.bytes.len() != count.saturating_mul(per) {
            return Err(PixelError::Count {
                bytes: self.bytes.len(),
                format: self.format,
                pixels: count,
            });
        }
        Ok(())
    }

    /// Decodes into `out` (cleared first) the pixels of a tile of `count` pixels sent for a job
    /// that asked for `want`, checking the format, the count and that every value is finite.
    /// An 8-bit value `b` becomes [`unit()`] of `b`, which [`to_u8`](parrt_render::film::to_u8) maps
    /// back to `b` exactly.
    pub fn decode_into(
        &self,
        want: PixelFormat,
        count: usize,
        out: &mut Vec<Rgb>,
    ) -> Result<(), PixelError> {
        self.check(want, count)?;
        out.clear();
        out.reserve(count);
        match self.format {
            // Two straight passes the compiler vectorizes (convert, then one test of every
            // value), the pixel found only when a value is bad.
            PixelFormat::F32 => {
                let v = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                out.extend(
                    self.bytes
                        .chunks_exact(12)
                        .map(|px| [v(&px[0..4]), v(&px[4..8]), v(&px[8..12])]),
                );
                let finite = out
                    .as_flattened()
                    .iter()
                    .fold(true, |ok, x| ok & x.is_finite());
                let bad = (!finite)
                    .then(|| {
                        out.iter().enumerate().find_map(|(index, px)| {
                            let value = *px.iter().find(|x| !x.is_finite())?;
                            Some(PixelError::NonFinite { index, value })
                        })
                    })
                    .flatten();
                if let Some(e) = bad {
                    out.clear();
                    return Err(e);
                }
            }
            PixelFormat::Rgb8 => out.extend(
                self.bytes
                    .chunks_exact(3)
                    .map(|px| [unit(px[0]), unit(px[1]), unit(px[2])]),
            ),
        }
        Ok(())
    }
}

/// Writes `pixels` into `out` (exactly their size) in `format`: little-endian f32 values (a copy
/// on a little-endian machine), or the 8-bit values the film's writer would store.
fn write_bytes(pixels: &[Rgb], format: PixelFormat, out: &mut [u8]) {
    debug_assert_eq!(out.len(), pixels.len() * format.bytes_per_pixel());
    match format {
        PixelFormat::F32 => {
            for (d, v) in out.chunks_exact_mut(4).zip(pixels.as_flattened()) {
                d.copy_from_slice(&v.to_le_bytes());
            }
        }
        PixelFormat::Rgb8 => to_u8_into(out, pixels.as_flattened()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_render::film::to_u8;

    #[test]
    fn every_byte_survives_the_round_trip_through_the_film() {
        for b in 0..=255u8 {
            let t = TilePixels {
                format: PixelFormat::Rgb8,
                packing: Packing::Raw,
                bytes: vec![b; 3],
            };
            let mut out = Vec::new();
            t.decode_into(PixelFormat::Rgb8, 1, &mut out).unwrap();
            assert_eq!(to_u8(out[0][0]), b);
        }
    }

    #[test]
    fn rgb8_keeps_exactly_what_the_8bit_writer_keeps() {
        let px: Vec<Rgb> = (0..2000)
            .map(|i| {
                let x = i as f32 / 1500.0 - 0.2;
                [x, x * 0.37 + 1e-7, -x]
            })
            .collect();
        let t = TilePixels::encode(&px, PixelFormat::Rgb8);
        assert_eq!(t.bytes.len(), px.len() * 3);
        let mut out = Vec::new();
        t.decode_into(PixelFormat::Rgb8, px.len(), &mut out)
            .unwrap();
        for (a, b) in px.iter().zip(&out) {
            assert_eq!(a.map(to_u8), b.map(to_u8));
        }
    }

    #[test]
    fn f32_is_exact_and_non_finite_count_and_format_are_refused() {
        let px = vec![[0.1f32, -0.0, 3.5e-39], [1e30, 0.5, 0.25]];
        let t = TilePixels::encode(&px, PixelFormat::F32);
        let mut out = Vec::new();
        t.decode_into(PixelFormat::F32, 2, &mut out).unwrap();
        let bits = |v: &Vec<Rgb>| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&out), bits(&px));
        assert!(matches!(
            t.decode_into(PixelFormat::Rgb8, 2, &mut out),
            Err(PixelError::Format { .. })
        ));
        assert!(matches!(
            t.decode_into(PixelFormat::F32, 3, &mut out),
            Err(PixelError::Count { bytes: 24, .. })
        ));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let t = TilePixels::encode(&[[0.0, 0.0, 0.0], [0.0, bad, 0.0]], PixelFormat::F32);
            assert!(matches!(
                t.decode_into(PixelFormat::F32, 2, &mut out),
                Err(PixelError::NonFinite { index: 1, .. })
            ));
        }
    }

    #[test]
    fn packing_round_trips_shrinks_repeats_and_refuses_what_does_not_unpack_to_the_tile() {
        // A tile with a flat background and a gradient: packs, and comes back bit for bit.
        let px: Vec<Rgb> = (0..1024)
            .map(|i| {
                if i < 600 {
                    [0.1, 0.3, 0.7]
                } else {
                    [i as f32 * 1e-3, 0.5, -0.0]
                }
            })
            .collect();
        for format in [PixelFormat::Rgb8, PixelFormat::F32] {
            let raw = TilePixels::encode(&px, format);
            // Only 8-bit pixels are packed; f32 ones a peer chose to pack unpack all the same.
            let packed = match format {
                PixelFormat::Rgb8 => raw.clone().pack(),
                PixelFormat::F32 => {
                    assert_eq!(raw.clone().pack(), raw);
                    TilePixels {
                        packing: Packing::Lz4,
                        bytes: lz4_flex::block::compress(&raw.bytes),
                        ..raw.clone()
                    }
                }
            };
            assert_eq!(packed.packing, Packing::Lz4);
            assert!(packed.bytes.len() * 3 < raw.bytes.len(), "{format:?}");
            // Unpacking is only for the tile it was packed for.
            assert_eq!(
                packed.clone().unpack(1023),
                Err(PixelError::Unpack {
                    want: 1023 * format.bytes_per_pixel()
                })
            );
            assert_eq!(
                packed.clone().unpack(1025),
                Err(PixelError::Unpack {
                    want: 1025 * format.bytes_per_pixel()
                })
            );
            let mut out = Vec::new();
            assert_eq!(
                packed.decode_into(format, 1024, &mut out),
                Err(PixelError::Packed)
            );
            assert_eq!(packed.unpack(1024).as_ref(), Ok(&raw));
        }
        // Bytes that do not pack smaller travel raw.
        let mut x = 0x9e37_79b9u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / 16_777_216.0
        };
        let noise: Vec<Rgb> = (0..64).map(|_| [next(), next(), next()]).collect();
        let raw = TilePixels::encode(&noise, PixelFormat::Rgb8);
        assert_eq!(raw.clone().pack(), raw);
        // Garbage claiming to be packed is refused, never a panic.
        let junk = TilePixels {
            format: PixelFormat::Rgb8,
            packing: Packing::Lz4,
            bytes: vec![0xff; 40],
        };
        assert_eq!(junk.unpack(16), Err(PixelError::Unpack { want: 48 }));
    }

    proptest::proptest! {
        /// Whatever a peer sends as packed pixels, unpacking ends in the tile's exact byte
        /// count or in an error, never a panic or a larger buffer.
        #[test]
        fn any_packed_bytes_unpack_to_the_tile_or_are_refused(
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..300),
            count in 0usize..200,
            f32s in proptest::prelude::any::<bool>(),
        ) {
            let format = if f32s { PixelFormat::F32 } else { PixelFormat::Rgb8 };
            let t = TilePixels { format, packing: Packing::Lz4, bytes };
            if let Ok(raw) = t.unpack(count) {
                proptest::prop_assert_eq!(raw.packing, Packing::Raw);
                proptest::prop_assert_eq!(raw.bytes.len(), count * format.bytes_per_pixel());
            }
        }
    }
}
