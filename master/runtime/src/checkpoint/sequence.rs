//! The checkpoint of a sequence rendered through workers: its header pins the whole sequence
//! (every frame's scene and settings, in order; the frame count, the tile edge, the pixel
//! format), and it is opened as a one-frame checkpoint is (created 0600, or an existing file
//! of this user checked, locked and its header matched), its records read back by frame.
//!
//! ## Header (all integers little-endian), [`SEQUENCE_HEADER_LEN`] bytes
//! The magic `PARRTSQ1`; tile edge, frame count and tiles over every frame (`u32` each); the
//! pixel format (`u8`: 0 f32, 1 rgb8); the seal (`u8`: 0 plain, 1 keyed); SHA-256 of the
//! frames' scene digests in order (each the SHA-256 of a frame's scene description, as a
//! one-frame checkpoint has it); SHA-256 of the frames' settings digests in order; the file's
//! job identity (16 random bytes); the first 8 bytes of the seal of everything before them.
//! The records are in `sequence_record`.

use super::header::{tiling_differences, BadHeader, Fields, JobKey};
use super::open::{scan_and_cut, start, Started};
use super::seal::Seal;
use super::sequence_record::{scan_sequence, SequenceCheckpoint, SequenceScan};
use super::{CheckpointError, JOB_ID_LEN, MAGIC};
use parrt_protocol::PixelFormat;
use parrt_render::description::SceneDescription;
use parrt_render::settings::RenderSettings;
use parrt_render::tile::Tile;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The first bytes of a sequence's checkpoint (the digit is the format's version).
pub const SEQUENCE_MAGIC: &[u8; 8] = b"PARRTSQ1";
/// Bytes in a sequence checkpoint's header.
pub const SEQUENCE_HEADER_LEN: usize = Fields::<3>::LEN;

/// What pins a checkpoint to one sequence.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SequenceKey {
    /// SHA-256 of the frames' scene digests, in order.
    pub scenes: [u8; 32],
    /// SHA-256 of the frames' settings digests, in order.
    pub settings: [u8; 32],
    /// Tile edge.
    pub tile: u32,
    /// Frames in the sequence.
    pub frames: u32,
    /// Tiles over every frame.
    pub tiles: u32,
    /// How pixels are stored.
    pub format: PixelFormat,
    /// How the header and the records are sealed.
    pub seal: Seal,
    /// The file's job identity (drawn when the file is created; read back on resume).
    pub job: [u8; JOB_ID_LEN],
}

impl SequenceKey {
    /// The key of rendering `frames` (each frame's scene and settings, in order) in tiles of
    /// `tile` pixels sent as `format`.
    pub fn new<'a>(
        frames: impl IntoIterator<Item = (&'a SceneDescription, &'a RenderSettings)>,
        tile: u32,
        format: PixelFormat,
    ) -> Result<SequenceKey, CheckpointError> {
        let (mut scenes, mut settings) = (Sha256::new(), Sha256::new());
        let (mut count, mut tiles) = (0u32, 0u32);
        for (desc, s) in frames {
            let k = JobKey::new(desc, s, tile, format)?;
            scenes.update(k.scene);
            settings.update(k.settings);
            count = count.saturating_add(1);
            tiles = tiles.saturating_add(k.tiles);
        }
        Ok(SequenceKey {
            scenes: scenes.finalize().into(),
            settings: settings.finalize().into(),
            tile,
            frames: count,
            tiles,
            format,
            seal: Seal::Plain,
            job: [0; JOB_ID_LEN],
        })
    }

    /// This key with records sealed by the job's lasting secret ([`Seal::from_secret`]).
    pub fn sealed_with(mut self, secret: &[u8]) -> SequenceKey {
        self.seal = Seal::from_secret(secret);
        self
    }

    pub(super) fn header(&self) -> [u8; SEQUENCE_HEADER_LEN] {
        let fields = Fields {
            ints: [self.tile, self.frames, self.tiles],
            format: self.format,
            digests: [self.scenes, self.settings],
            job: self.job,
        };
        fields.write(SEQUENCE_MAGIC, &self.seal)
    }

    fn parse(h: &[u8; SEQUENCE_HEADER_LEN], seal: &Seal) -> Result<SequenceKey, BadHeader> {
        let f = Fields::parse(h, SEQUENCE_MAGIC, seal)?;
        let [tile, frames, tiles] = f.ints;
        let [scenes, settings] = f.digests;
        Ok(SequenceKey {
            tile,
            frames,
            tiles,
            format: f.format,
            scenes,
            settings,
            seal: seal.clone(),
            job: f.job,
        })
    }

    /// What differs in `file`'s key from this run's, for the user (the scenes are checked
    /// separately).
    fn differences(&self, file: &SequenceKey) -> Vec<String> {
        let mut d = Vec::new();
        if self.frames != file.frames {
            d.push(format!(
                "the file has {} frames, this run {}",
                file.frames, self.frames
            ));
        }
        tiling_differences(&mut d, (self.tile, self.format), (file.tile, file.format));
        if self.settings != file.settings && d.is_empty() {
            d.push(
                "image size or render flags such as --spp, --max-depth, --cutoff, --accel or \
                 --precision"
                    .into(),
            );
        }
        d
    }
}

/// A sequence's checkpoint just opened, with what an earlier run left in it.
#[derive(Debug)]
pub struct SequenceOpened {
    /// The file, ready for appending.
    pub checkpoint: SequenceCheckpoint,
    /// What was read from it (empty for a new file).
    pub scan: SequenceScan,
    /// Whether the file was created now.
    pub created: bool,
}

/// Opens the checkpoint at `path` for the sequence `key` whose frame k has the tiles
/// `frame_tiles[k]`, as [`super::open()`] opens one frame's: without `resume` the file must not
/// exist; with it, an existing file must be of the same sequence (else it is refused and left
/// as it is; a one-frame checkpoint is refused too), its good records are returned by frame and
/// anything after the last good one is cut off; a missing (or empty) file is started.
pub fn open_sequence(
    path: &Path,
    key: &SequenceKey,
    frame_tiles: &[Vec<Tile>],
    resume: bool,
) -> Result<SequenceOpened, CheckpointError> {
    let fresh = |job| {
        let mut key = key.clone();
        if key.job == [0; JOB_ID_LEN] {
            key.job = job;
        }
        key.header()
    };
    let (mut file, head, file_len) = match start(path, resume, fresh, OTHER_KIND)? {
        Started::Created { file, header } => {
            let mut scan = SequenceScan::new(frame_tiles.len());
            scan.good_len = SEQUENCE_HEADER_LEN as u64;
            return Ok(SequenceOpened {
                checkpoint: SequenceCheckpoint::new(file, path, key.seal.clone(), &header),
                scan,
                created: true,
            });
        }
        Started::Existing {
            file,
            head,
            file_len,
        } => (file, head, file_len),
    };
    let theirs = SequenceKey::parse(&head, &key.seal).map_err(|e| e.at(path))?;
    let diff = key.differences(&theirs);
    if theirs.scenes != key.scenes && theirs.frames == key.frames {
        return Err(CheckpointError::OtherSequence(path.to_path_buf()));
    }
    if !diff.is_empty() {
        return Err(CheckpointError::OtherSettings {
            path: path.to_path_buf(),
            what: diff.join("; "),
        });
    }
    let scan = scan_and_cut(&mut file, path, |r| {
        let scan = scan_sequence(r, file_len, frame_tiles, key.format, &key.seal, &head)?;
        Ok((scan.good_len, scan.cut_bytes, scan))
    })?;
    Ok(SequenceOpened {
        checkpoint: SequenceCheckpoint::new(file, path, key.seal.clone(), &head),
        scan,
        created: false,
    })
}

/// A one-frame checkpoint given where a sequence's is expected.
const OTHER_KIND: (&[u8; 8], fn(PathBuf) -> CheckpointError) =
    (MAGIC, CheckpointError::OneFrameForSequence);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checkpoint::{Written, CHECK_LEN, RECORD_FIXED};
    use crate::scheduler::AcceptedTile;
    use parrt_protocol::{Packing, TilePixels};
    use parrt_render::stats::RayStats;

    /// Two frames of 20x12 in tiles of 8 (6 tiles each), 8-bit.
    fn key() -> (SequenceKey, Vec<Vec<Tile>>) {
        let a = parrt_scenes::generate("balls", Some(1)).unwrap();
        let b = parrt_scenes::generate("balls", Some(2)).unwrap();
        let s = RenderSettings::new(20, 12);
        let k = SequenceKey::new([(&a, &s), (&b, &s)], 8, PixelFormat::Rgb8).unwrap();
        let t = parrt_render::tile::tiles(20, 12, 8);
        (k, vec![t.clone(), t])
    }

    fn tile(frame: usize, t: &Tile) -> AcceptedTile {
        AcceptedTile {
            frame,
            tile_id: t.id,
            pixels: TilePixels {
                format: PixelFormat::Rgb8,
                packing: Packing::Raw,
                bytes: vec![frame as u8 + 1; t.pixel_count() * 3],
            },
            stats: RayStats {
                eye_rays: t.pixel_count() as u64,
                ..RayStats::default()
            },
            seconds: 0.5,
        }
    }

    #[test]
    fn the_header_pins_frames_and_order_and_a_changed_byte_is_not_a_header() {
        let (k, _) = key();
        assert_eq!((k.frames, k.tiles), (2, 12));
        let h = k.header();
        assert_eq!(SequenceKey::parse(&h, &Seal::Plain), Ok(k.clone()));
        for i in 0..SEQUENCE_HEADER_LEN {
            let mut bad = h;
            bad[i] ^= 0x10;
            assert!(SequenceKey::parse(&bad, &Seal::Plain).is_err(), "byte {i}");
        }
        // The same frames in the other order are another sequence.
        let a = parrt_scenes::generate("balls", Some(1)).unwrap();
        let b = parrt_scenes::generate("balls", Some(2)).unwrap();
        let s = RenderSettings::new(20, 12);
        let swapped = SequenceKey::new([(&b, &s), (&a, &s)], 8, PixelFormat::Rgb8).unwrap();
        assert_ne!(swapped.scenes, k.scenes);
    }

    #[test]
    fn records_come_back_by_frame_and_a_torn_tail_is_cut() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.ckpt");
        let (k, tiles) = key();
        let mut o = open_sequence(&p, &k, &tiles, false).unwrap();
        let w = Written {
            len: 7,
            sha256: [3; 32],
        };
        o.checkpoint
            .append(&[tile(0, &tiles[0][0]), tile(1, &tiles[1][4])])
            .unwrap();
        o.checkpoint.written(0, &w).unwrap();
        o.checkpoint.append(&[tile(1, &tiles[1][5])]).unwrap();
        o.checkpoint.sync().unwrap();
        drop(o);
        // A torn last record: cut off on resume, the rest kept.
        let whole = std::fs::read(&p).unwrap();
        std::fs::write(&p, &whole[..whole.len() - 5]).unwrap();
        let o = open_sequence(&p, &k, &tiles, true).unwrap();
        let s = &o.scan;
        assert_eq!(s.written, vec![Some(w), None]);
        let ids = |f: usize| s.tiles[f].iter().map(|t| t.tile_id).collect::<Vec<_>>();
        assert_eq!((ids(0), ids(1)), (vec![0], vec![4]));
        assert!(s.tiles[1]
            .iter()
            .all(|t| t.frame == 1 && t.pixels.bytes[0] == 2));
        assert_eq!(s.bad_records, 0);
        let last = (4 + 5 + RECORD_FIXED + tiles[1][5].pixel_count() * 3 + CHECK_LEN) as u64;
        assert_eq!(s.cut_bytes, last - 5);
        drop(o);
        let len = std::fs::metadata(&p).unwrap().len();
        assert_eq!(len, whole.len() as u64 - last);
        // The file keyed with a token is refused to a run without it, left unchanged.
        let q = dir.path().join("k.ckpt");
        let keyed = k.clone().sealed_with(b"token");
        drop(open_sequence(&q, &keyed, &tiles, false).unwrap());
        let before = std::fs::read(&q).unwrap();
        let e = open_sequence(&q, &k, &tiles, true).unwrap_err();
        assert!(matches!(e, CheckpointError::Unauthenticated { .. }), "{e}");
        assert_eq!(std::fs::read(&q).unwrap(), before);
    }
}
