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
use std::path::Path;

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
        let fields = Fields {
            ints: [self.tile, self.width, self.height, self.tiles],
            format: self.format,
            digests: [self.scene, self.settings],
            job: self.job,
        };
        fields.write(MAGIC, &self.seal)
    }

    /// Parses a header sealed as `seal` seals: not one at all (wrong magic, a plain checksum
    /// that fails, an unknown format), or sealed otherwise (plain where this run has a secret,
    /// keyed where it has none, or a keyed checksum that fails: another token, or altered).
    pub(super) fn parse(h: &[u8; HEADER_LEN], seal: &Seal) -> Result<JobKey, BadHeader> {
        let f = Fields::parse(h, MAGIC, seal)?;
        let [tile, width, height, tiles] = f.ints;
        let [scene, settings] = f.digests;
        Ok(JobKey {
            tile,
            width,
            height,
            tiles,
            format: f.format,
            scene,
            settings,
            seal: seal.clone(),
            job: f.job,
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
        tiling_differences(&mut d, (self.tile, self.format), (file.tile, file.format));
        if self.settings != file.settings && d.is_empty() {
            d.push(
                "render flags such as --spp, --max-depth, --cutoff, --accel or --precision".into(),
            );
        }
        d
    }
}

/// Says in `d` how the tile edge and the pixel format of a file (`file`) differ from this
/// run's (`run`).
pub(super) fn tiling_differences(
    d: &mut Vec<String>,
    run: (u32, PixelFormat),
    file: (u32, PixelFormat),
) {
    if run.0 != file.0 {
        d.push(format!("the file has tile {}, this run {}", file.0, run.0));
    }
    if run.1 != file.1 {
        d.push(format!(
            "the file has {:?} pixels, this run {:?}: the output's kind decides (.exr keeps \
             f32, .png and .ppm 8-bit)",
            file.1, run.1
        ));
    }
}

/// The fields every checkpoint header holds after its magic, in this order: `INTS` counts
/// (`u32` each: the tiling and sizes), the pixel format (`u8`), the seal (`u8`), two SHA-256
/// digests (scene and settings), the file's job identity; then the first [`CHECK_LEN`] bytes of
/// the seal of everything before.
pub(super) struct Fields<const INTS: usize> {
    pub(super) ints: [u32; INTS],
    pub(super) format: PixelFormat,
    pub(super) digests: [[u8; 32]; 2],
    pub(super) job: [u8; JOB_ID_LEN],
}

impl<const INTS: usize> Fields<INTS> {
    /// Bytes in a header of these fields.
    pub(super) const LEN: usize = MAGIC.len() + 4 * INTS + 2 + 2 * 32 + JOB_ID_LEN + CHECK_LEN;

    /// The header `magic` + these fields, sealed with `seal` (`LEN` must be [`Self::LEN`]).
    pub(super) fn write<const LEN: usize>(&self, magic: &[u8; 8], seal: &Seal) -> [u8; LEN] {
        const { assert!(LEN == Self::LEN) };
        let mut h = [0u8; LEN];
        let mut at = 0;
        let mut put = |b: &[u8]| {
            h[at..at + b.len()].copy_from_slice(b);
            at += b.len();
        };
        put(magic);
        for v in self.ints {
            put(&v.to_le_bytes());
        }
        put(&[format_byte(self.format), seal.byte()]);
        for d in &self.digests {
            put(d);
        }
        put(&self.job);
        let check = seal.tag(&[&h[..LEN - CHECK_LEN]]);
        h[LEN - CHECK_LEN..].copy_from_slice(&check);
        h
    }

    /// The fields of the header `h` if it starts with `magic` and is sealed as `seal` seals.
    pub(super) fn parse(h: &[u8], magic: &[u8; 8], seal: &Seal) -> Result<Self, BadHeader> {
        if h.len() != Self::LEN || &h[..magic.len()] != magic {
            return Err(BadHeader::NotOne);
        }
        let at = magic.len() + 4 * INTS;
        check_seal(h, h[at + 1], seal)?;
        let mut ints = [0u32; INTS];
        for (i, v) in ints.iter_mut().enumerate() {
            let b = magic.len() + 4 * i;
            *v = u32::from_le_bytes([h[b], h[b + 1], h[b + 2], h[b + 3]]);
        }
        let format = match h[at] {
            0 => PixelFormat::F32,
            1 => PixelFormat::Rgb8,
            _ => return Err(BadHeader::NotOne),
        };
        let bytes = |from: usize| h[from..from + 32].try_into().map_err(|_| BadHeader::NotOne);
        let d = at + 2;
        Ok(Fields {
            ints,
            format,
            digests: [bytes(d)?, bytes(d + 32)?],
            job: h[d + 64..d + 64 + JOB_ID_LEN]
                .try_into()
                .map_err(|_| BadHeader::NotOne)?,
        })
    }
}

impl BadHeader {
    /// The error of opening `path` whose header is this.
    pub(super) fn at(self, path: &Path) -> CheckpointError {
        match self {
            BadHeader::NotOne => CheckpointError::NotACheckpoint(path.to_path_buf()),
            BadHeader::Seal(why) => CheckpointError::Unauthenticated {
                path: path.to_path_buf(),
                why,
            },
        }
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
