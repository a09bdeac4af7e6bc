//! A sequence checkpoint's records and the open file taking them. Each record is framed and
//! sealed as a one-frame checkpoint's (the payload length, `u32`; the payload; the first 8
//! bytes of the seal of the whole header, the length and the payload), and its payload starts
//! with the frame's index (`u32`) and a kind (`u8`):
//! - 0, an accepted tile: then exactly a one-frame record's payload (tile id, render seconds,
//!   the 11 ray counters, the pixels as the workers sent them);
//! - 1, the frame written: its file renamed into place, then the file's length (`u64`) and
//!   its SHA-256, by which a resume knows the file is still there and whole.
//!
//! Tiles are appended with one `write` a batch and synced at least every
//! [`super::SYNC_INTERVAL`]; a frame written is synced at once.

use super::file::Checkpoint;
use super::record::{decode_payload, encode_payload, read_sealed, Sealed};
use super::seal::Seal;
use super::sequence::SEQUENCE_HEADER_LEN;
use super::{CheckpointError, CHECK_LEN, RECORD_FIXED};
use crate::scheduler::AcceptedTile;
use parrt_protocol::PixelFormat;
use parrt_render::tile::Tile;
use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Bytes before a record's kind-specific part: the frame index and the kind.
const FRAME_FIXED: usize = 4 + 1;
/// The kind of a tile record.
const KIND_TILE: u8 = 0;
/// The kind of a frame-written record.
const KIND_WRITTEN: u8 = 1;
/// A frame-written record's payload.
const WRITTEN_LEN: usize = FRAME_FIXED + 8 + 32;

/// A frame's file as it was written: what a resume checks before it skips the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Written {
    /// The file's length in bytes.
    pub len: u64,
    /// SHA-256 of its bytes.
    pub sha256: [u8; 32],
}

/// What a sequence checkpoint held.
#[derive(Debug, Default)]
pub struct SequenceScan {
    /// By frame: the good tile records, the first one of each tile, in file order (each with
    /// its frame).
    pub tiles: Vec<Vec<AcceptedTile>>,
    /// By frame: its file as it was written, if the file says it was (the last such record).
    pub written: Vec<Option<Written>>,
    /// Records skipped: a checksum that did not hold, or a frame or tile not this sequence's.
    pub bad_records: usize,
    /// Bytes after the last good record that were cut off.
    pub cut_bytes: u64,
    /// Where the last good record ends: the file's new length.
    pub good_len: u64,
}

impl Written {
    /// The length and SHA-256 of the file at `path` as it is now.
    pub fn of_file(path: &Path) -> std::io::Result<Written> {
        use sha2::{Digest, Sha256};
        let mut f = File::open(path)?;
        let mut h = Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut len = 0u64;
        loop {
            let n = match f.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            h.update(&buf[..n]);
            len += n as u64;
        }
        Ok(Written {
            len,
            sha256: h.finalize().into(),
        })
    }
}

impl SequenceScan {
    /// Nothing, for a sequence of `frames` frames.
    pub(super) fn new(frames: usize) -> SequenceScan {
        SequenceScan {
            tiles: (0..frames).map(|_| Vec::new()).collect(),
            written: vec![None; frames],
            ..SequenceScan::default()
        }
    }
}

/// Appends the record of tile `t` (of frame `t.frame`), sealed with `seal` and bound to the
/// checkpoint whose header is `header`, to `out`.
pub fn encode_frame_tile(t: &AcceptedTile, seal: &Seal, header: &[u8], out: &mut Vec<u8>) {
    let len = (FRAME_FIXED + RECORD_FIXED + t.pixels.bytes.len()) as u32;
    let start = out.len();
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&(t.frame as u32).to_le_bytes());
    out.push(KIND_TILE);
    encode_payload(t, out);
    let check = seal.tag(&[header, &out[start..]]);
    out.extend_from_slice(&check);
}

/// Appends the record of frame `frame` written as `w`, sealed and bound as
/// [`encode_frame_tile`] is, to `out`.
pub fn encode_written(frame: usize, w: &Written, seal: &Seal, header: &[u8], out: &mut Vec<u8>) {
    let start = out.len();
    out.extend_from_slice(&(WRITTEN_LEN as u32).to_le_bytes());
    out.extend_from_slice(&(frame as u32).to_le_bytes());
    out.push(KIND_WRITTEN);
    out.extend_from_slice(&w.len.to_le_bytes());
    out.extend_from_slice(&w.sha256);
    let check = seal.tag(&[header, &out[start..]]);
    out.extend_from_slice(&check);
}

/// Reads the records after `header` from `r` (positioned just past it) for a sequence whose
/// frame k has the tiles `frame_tiles[k]`, pixels sent as `format`. Never trusts a record
/// whose seal fails; stops at a length that cannot be or at a torn end.
pub fn scan_sequence(
    r: &mut impl Read,
    file_len: u64,
    frame_tiles: &[Vec<Tile>],
    format: PixelFormat,
    seal: &Seal,
    header: &[u8],
) -> std::io::Result<SequenceScan> {
    let max_pixels = frame_tiles
        .iter()
        .flatten()
        .map(|t| t.pixel_count())
        .max()
        .unwrap_or(0);
    let max_payload = FRAME_FIXED + RECORD_FIXED + max_pixels * format.bytes_per_pixel();
    let mut seen: Vec<Vec<bool>> = frame_tiles.iter().map(|t| vec![false; t.len()]).collect();
    let mut scan = SequenceScan::new(frame_tiles.len());
    let mut pos = SEQUENCE_HEADER_LEN as u64;
    scan.good_len = pos;
    let mut buf = Vec::new();
    let len_ok =
        |n: usize| n == WRITTEN_LEN || (FRAME_FIXED + RECORD_FIXED..=max_payload).contains(&n);
    loop {
        let n = match read_sealed(r, &mut buf, len_ok, seal, header)? {
            Sealed::End | Sealed::Torn(_) => break,
            Sealed::Forged(n) => {
                pos += (4 + n + CHECK_LEN) as u64;
                scan.bad_records += 1;
                continue;
            }
            Sealed::Good(n) => n,
        };
        pos += (4 + n + CHECK_LEN) as u64;
        let payload = &buf[..n];
        let frame = u32::from_le_bytes([payload[0], payload[1], payload[2], payload[3]]) as usize;
        let Some(tiles) = frame_tiles.get(frame) else {
            scan.bad_records += 1;
            continue;
        };
        match payload[4] {
            KIND_WRITTEN if n == WRITTEN_LEN => {
                let mut l = [0u8; 8];
                l.copy_from_slice(&payload[FRAME_FIXED..FRAME_FIXED + 8]);
                let mut sha256 = [0u8; 32];
                sha256.copy_from_slice(&payload[FRAME_FIXED + 8..]);
                scan.written[frame] = Some(Written {
                    len: u64::from_le_bytes(l),
                    sha256,
                });
                scan.good_len = pos;
            }
            KIND_TILE => match decode_payload(&payload[FRAME_FIXED..], tiles, format) {
                None => scan.bad_records += 1,
                Some(mut t) => {
                    t.frame = frame;
                    if !std::mem::replace(&mut seen[frame][t.tile_id as usize], true) {
                        scan.tiles[frame].push(t);
                    }
                    scan.good_len = pos;
                }
            },
            _ => scan.bad_records += 1,
        }
    }
    scan.cut_bytes = file_len.saturating_sub(scan.good_len);
    Ok(scan)
}

/// An open sequence checkpoint, positioned at its end, taking records: written and synced
/// as a one-frame checkpoint's file is, with records of its own kinds.
#[derive(Debug)]
pub struct SequenceCheckpoint {
    records: Checkpoint,
}

impl SequenceCheckpoint {
    /// `file` has just been synced, positioned at its end.
    pub(super) fn new(file: File, path: &Path, seal: Seal, header: &[u8]) -> SequenceCheckpoint {
        SequenceCheckpoint {
            records: Checkpoint::new(file, path, seal, header),
        }
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        self.records.path()
    }

    /// How many bytes from the file's start are known to be on the disk (see
    /// [`Checkpoint::durable`]).
    pub fn durable(&self) -> std::sync::Arc<std::sync::atomic::AtomicU64> {
        self.records.durable()
    }

    /// Appends the records of `tiles` (each of its frame) in one write, and syncs if the last
    /// sync is [`super::SYNC_INTERVAL`] old.
    pub fn append(&mut self, tiles: &[AcceptedTile]) -> Result<(), CheckpointError> {
        if !tiles.is_empty() {
            self.records.write_records(|seal, header, out| {
                for t in tiles {
                    encode_frame_tile(t, seal, header, out);
                }
            })?;
        }
        self.records.sync_if_due()
    }

    /// Records that frame `frame`'s file was written (renamed into place) as `w`, and syncs.
    pub fn written(&mut self, frame: usize, w: &Written) -> Result<(), CheckpointError> {
        self.records
            .write_records(|seal, header, out| encode_written(frame, w, seal, header, out))?;
        self.sync()
    }

    /// Syncs what was written to the disk.
    pub fn sync(&mut self) -> Result<(), CheckpointError> {
        self.records.sync()
    }
}
