//! A checkpoint's header: the [`JobKey`] that pins the file to one job (scene and settings
//! digests, tiling, pixel format, seal, the file's job identity), written as the file's first
//! [`HEADER_LEN`] bytes and read back, with what differs from this run for the user.

use super::seal::Seal;
use super::{CheckpointError, CHECK_LEN, HEADER_LEN, JOB_ID_LEN, MAGIC};
use parrt_protocol::PixelFormat;
use parrt_render::description::SceneDescription;
use parrt_render::settings::RenderSettings;
use sha2::{Digest, Sha256};
use std::io::Write;

/// What pins a checkpoint to one job: the scene, the settings, the tiling and the pixel format.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JobKey {
    /// SHA-256 of the scene description's postcard encoding.
    pub scene: [u8; 32],
    /// SHA-256 of the settings' postcard encoding.
    pub settings: [u8; 32],
    /// Tile edge.
    pub tile: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tiles in the image.
    pub tiles: u32,
    /// How pixels are stored.
    pub format: PixelFormat,
    /// How the header and the records are sealed.
    pub seal: Seal,
    /// The file's job identity (drawn when the file is created; read back on resume).
    pub job: [u8; JOB_ID_LEN],
}

/// Why a header is not this run's.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum BadHeader {
    /// Not a checkpoint header at all, or a damaged plain one.
    NotOne,
    /// Sealed otherwise than this run seals (say how).
    Seal(String),
}

impl JobKey {
    /// The key of rendering `desc` with `settings` in tiles of `tile` pixels sent as `format`.
    pub fn new(
        desc: &SceneDescription,
        settings: &RenderSettings,
        tile: u32,
        format: PixelFormat,
    ) -> Result<JobKey, CheckpointError> {
        // Streamed into the hash: a large scene is not encoded into memory once more.
        let hash = |w: Result<HashWriter, postcard::Error>| -> Result<[u8; 32], CheckpointError> {
            let w = w.map_err(|e| CheckpointError::Encode(e.to_string()))?;
            Ok(w.0.finalize().into())
        };
        let n = parrt_render::tile::tiles(settings.width, settings.height, tile.max(1)).len();
        Ok(JobKey {
            scene: hash(postcard::to_io(desc, HashWriter(Sha256::new())))?,
            settings: hash(postcard::to_io(settings, HashWriter(Sha256::new())))?,
            tile,
            width: settings.width,
            height: settings.height,
            tiles: u32::try_from(n).unwrap_or(u32::MAX),
            format,
            seal: Seal::Plain,
            job: [0; JOB_ID_LEN],
        })
    }

    /// This key with records sealed by the job's lasting secret ([`Seal::from_secret`]).
    pub fn sealed_with(mut self, secret: &[u8]) -> JobKey {
        self.seal = Seal::from_secret(secret);
        self
    }

    pub(super) fn header(&self) -> [u8; HEADER_LEN] {
        let mut h = [0u8; HEADER_LEN];
        let mut at = 0;
        let mut put = |b: &[u8]| {
            h[at..at + b.len()].copy_from_slice(b);
            at += b.len();
        };
        put(MAGIC);
        for v in [self.tile, self.width, self.height, self.tiles] {
            put(&v.to_le_bytes());
        }
        put(&[format_byte(self.format), self.seal.byte()]);
        put(&self.scene);
        put(&self.settings);
        put(&self.job);
        let check = self.seal.tag(&[&h[..HEADER_LEN - CHECK_LEN]]);
        h[HEADER_LEN - CHECK_LEN..].copy_from_slice(&check);
        h
    }

    /// Parses a header sealed as `seal` seals: not one at all (wrong magic, a plain checksum
    /// that fails, an unknown format), or sealed otherwise (plain where this run has a secret,
    /// keyed where it has none, or a keyed checksum that fails: another token, or altered).
    pub(super) fn parse(h: &[u8; HEADER_LEN], seal: &Seal) -> Result<JobKey, BadHeader> {
        if &h[..8] != MAGIC {
            return Err(BadHeader::NotOne);
        }
        check_seal(h, h[25], seal)?;
        let u = |i: usize| u32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
        let format = match h[24] {
            0 => PixelFormat::F32,
            1 => PixelFormat::Rgb8,
            _ => return Err(BadHeader::NotOne),
        };
        let bytes = |r: std::ops::Range<usize>| -> Result<[u8; 32], BadHeader> {
            h[r].try_into().map_err(|_| BadHeader::NotOne)
        };
        Ok(JobKey {
            tile: u(8),
            width: u(12),
            height: u(16),
            tiles: u(20),
            format,
            scene: bytes(26..58)?,
            settings: bytes(58..90)?,
            seal: seal.clone(),
            job: h[90..90 + JOB_ID_LEN]
                .try_into()
                .map_err(|_| BadHeader::NotOne)?,
        })
    }

    /// What differs in `file`'s key from this run's, for the user (the scene is checked
    /// separately).
    pub(super) fn differences(&self, file: &JobKey) -> Vec<String> {
        let mut d = Vec::new();
        if (self.width, self.height) != (file.width, file.height) {
            d.push(format!(
                "the file has image {}x{}, this run {}x{}",
                file.width, file.height, self.width, self.height
            ));
        }
        if self.tile != file.tile {
            d.push(format!(
                "the file has tile {}, this run {}",
                file.tile, self.tile
            ));
        }
        if self.format != file.format {
            d.push(format!(
                "the file has {:?} pixels, this run {:?}: the output's kind decides (.exr keeps \
                 f32, .png and .ppm 8-bit)",
                file.format, self.format
            ));
        }
        if self.settings != file.settings && d.is_empty() {
            d.push(
                "render flags such as --spp, --max-depth, --cutoff, --accel or --precision".into(),
            );
        }
        d
    }
}

/// Checks the seal of the header `h` (its last [`CHECK_LEN`] bytes seal the rest), which says
/// it was sealed as `byte` says (0 plain, 1 keyed), against the seal this run uses.
pub(super) fn check_seal(h: &[u8], byte: u8, seal: &Seal) -> Result<(), BadHeader> {
    let (body, check) = h.split_at(h.len() - CHECK_LEN);
    let sealed_ok = seal.tag(&[body])[..] == check[..];
    match (byte, seal) {
        (0, Seal::Plain) | (1, Seal::Keyed(_)) if sealed_ok => Ok(()),
        (0, Seal::Keyed(_)) if Seal::Plain.tag(&[body])[..] == check[..] => Err(BadHeader::Seal(
            "was written without a token (by `render --workers` or `cluster`), so its records \
             cannot be authenticated with this master's token"
                .into(),
        )),
        (1, Seal::Plain) => Err(BadHeader::Seal(
            "was written by a master with a token; give `parrt master` the same token to \
             resume it"
                .into(),
        )),
        (1, Seal::Keyed(_)) => Err(BadHeader::Seal(
            "was not written with this master's token (or was altered since)".into(),
        )),
        _ => Err(BadHeader::NotOne),
    }
}

/// Feeds what is written into a SHA-256.
pub(super) struct HashWriter(pub(super) Sha256);

impl Write for HashWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.update(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

pub(super) fn format_byte(f: PixelFormat) -> u8 {
    match f {
        PixelFormat::F32 => 0,
        PixelFormat::Rgb8 => 1,
    }
}
