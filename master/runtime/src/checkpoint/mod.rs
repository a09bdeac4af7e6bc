//! The checkpoint file of a distributed render: a sink for the tiles the scheduler accepts while
//! the master runs, and their source when a killed master is started again with `--resume`.
//!
//! ## Format (all integers little-endian)
//! - Header, [`HEADER_LEN`] bytes: the magic `PARRTCK3`; tile edge, width, height and tile
//!   count (`u32` each); the pixel format (`u8`: 0 f32, 1 rgb8); the seal (`u8`: 0 plain,
//!   1 keyed); SHA-256 of the scene description's postcard encoding; SHA-256 of the settings'
//!   postcard encoding; the file's job identity (16 random bytes drawn when it was created);
//!   the first 8 bytes of the seal of everything before them.
//! - Then one record per accepted tile: the payload length (`u32`); the payload — tile id
//!   (`u32`), render seconds (`f64`), the 11 ray counters of [`RayStats`](parrt_render::stats::RayStats) (`u64` each, in
//!   declaration order), the pixels as the job's workers sent them; the first 8 bytes of the
//!   seal of the whole header, the length and the payload. A record is thereby bound to its
//!   job (scene and settings digests, image and tile sizes, the job identity) and to its tile:
//!   a record of another scene, another frame or another checkpoint file, even one sealed with
//!   the same token, does not verify here.
//!
//! ## Seals
//! A [`Seal::Plain`] checkpoint (`render --workers`, `cluster`: their token lives only as long
//! as the run) is sealed with SHA-256: it finds damage, but anyone who can write the file can
//! also write records with fresh checksums. A master given a lasting secret (`parrt master`'s
//! token) seals with [`Seal::Keyed`]: HMAC-SHA256 under a key derived from the token, so
//! records written without the token are not trusted, and a file sealed otherwise (plain, or
//! with another token) is refused as a whole.
//!
//! ## Who may use the file
//! An existing checkpoint is opened without following a symbolic link and without blocking,
//! and used only if it is a regular file of this user that no one else may write
//! ([`crate::file_guard`]); a new one is created with mode 0600. The open file is locked
//! (`flock`) for as long as the master runs: a second master on the same file is refused and
//! told which process holds it.
//!
//! The file is only ever appended to; each batch of records is written with one `write` (so a
//! killed process leaves whole records) and synced to the disk at least every
//! [`SYNC_INTERVAL`] and at the end (so a power loss costs at most that much). On resume a
//! record is trusted only if its checksum holds and it names a tile of this job with the right
//! pixel count; a bad record in the middle is skipped (its tile is rendered again), and a torn
//! or unreadable tail is cut off before anything is appended.

//!
//! ## Layout
//! - `header`: the [`JobKey`] and the header it writes and reads back.
//! - `seal`: plain or keyed seals ([`Seal`]) of the header and records.
//! - `record`: records encoded and scanned back ([`scan_sealed_records`]).
//! - `file`: the open file taking records ([`Checkpoint`]), and its syncs.
//! - `open`: creating, locking and resuming a file ([`open()`]).
//! - `sequence`: the checkpoint of a whole sequence ([`SequenceKey`], [`open_sequence`]), and
//!   `sequence_record` its records (tiles with their frame, frames written) and open file
//!   ([`SequenceCheckpoint`]).

mod file;
mod header;
mod open;
mod record;
mod seal;
mod sequence;
mod sequence_record;

pub use file::Checkpoint;
pub use header::JobKey;
pub use open::{open, Opened};
pub use record::{encode_record, encode_sealed_record, scan_records, scan_sealed_records, Scan};
pub use seal::Seal;
pub use sequence::{
    open_sequence, SequenceKey, SequenceOpened, SEQUENCE_HEADER_LEN, SEQUENCE_MAGIC,
};
pub use sequence_record::{
    encode_frame_tile, encode_written, scan_sequence, SequenceCheckpoint, SequenceScan, Written,
};

use crate::file_guard;
use std::path::PathBuf;
use std::time::Duration;
use thiserror::Error;

/// The first bytes of every checkpoint (the digit is the format's version).
pub const MAGIC: &[u8; 8] = b"PARRTCK3";
/// Bytes of a checkpoint's job identity.
pub const JOB_ID_LEN: usize = 16;
/// Bytes in the header.
pub const HEADER_LEN: usize = header::Fields::<4>::LEN;
/// Bytes of each checksum (a truncated SHA-256 or HMAC-SHA256).
pub const CHECK_LEN: usize = 8;
/// The payload bytes before the pixels: tile id, seconds, 11 counters.
pub const RECORD_FIXED: usize = 4 + 8 + 11 * 8;
/// Records are synced to the disk at least this often while tiles arrive.
pub const SYNC_INTERVAL: Duration = Duration::from_secs(1);

/// What goes wrong with a checkpoint.
#[derive(Debug, Error)]
pub enum CheckpointError {
    /// The file exists and `--resume` was not given.
    #[error("checkpoint {0} exists; pass --resume to continue it, or remove it")]
    Exists(PathBuf),
    /// The file is of another scene.
    #[error(
        "checkpoint {0} is of another scene; it was left unchanged (resume with the scene that \
         wrote it, or remove it)"
    )]
    OtherScene(PathBuf),
    /// The file is of another sequence (its frames' scenes differ).
    #[error(
        "checkpoint {0} is of another sequence (its frames' scenes differ); it was left \
         unchanged (resume with the frames that wrote it, or remove it)"
    )]
    OtherSequence(PathBuf),
    /// A one-frame checkpoint given to a sequence.
    #[error(
        "checkpoint {0} holds one frame, not a sequence; it was left unchanged (resume it with \
         the one-frame command that wrote it, or remove it)"
    )]
    OneFrameForSequence(PathBuf),
    /// A sequence's checkpoint given to a render of one frame.
    #[error(
        "checkpoint {0} holds a sequence, not one frame; it was left unchanged (resume it with \
         the sequence that wrote it, or remove it)"
    )]
    SequenceForOneFrame(PathBuf),
    /// The file is of the same scene with other settings.
    #[error(
        "checkpoint {path} was written with other settings ({what}); it was left unchanged \
         (resume with the same flags, or remove it)"
    )]
    OtherSettings {
        /// The file.
        path: PathBuf,
        /// What differs.
        what: String,
    },
    /// The file does not start with a valid checkpoint header.
    #[error("{0} is not a parrt checkpoint (or its header is damaged); it was left unchanged")]
    NotACheckpoint(PathBuf),
    /// The file's seal is not this run's: written with another token, without one, or altered.
    #[error("checkpoint {path} {why}; it was left unchanged")]
    Unauthenticated {
        /// The file.
        path: PathBuf,
        /// What does not match.
        why: String,
    },
    /// The path is not a file this user may trust (a link, a FIFO, a device, another user's
    /// file, one others may write).
    #[error("checkpoint {path} {refusal}; it was left unchanged")]
    Refused {
        /// The file.
        path: PathBuf,
        /// Why.
        refusal: file_guard::Refusal,
    },
    /// Another master has the file open.
    #[error(
        "checkpoint {path} is locked by another process, another master most likely ({holder}); \
         one checkpoint, one master"
    )]
    Locked {
        /// The file.
        path: PathBuf,
        /// Who holds its lock.
        holder: String,
    },
    /// The scene or settings could not be encoded for hashing.
    #[error("cannot encode the job for its checkpoint hash: {0}")]
    Encode(String),
    /// Reading or writing failed.
    #[error("cannot {action} checkpoint {path}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The thread writing the checkpoint ended without saying why.
    #[error("the checkpoint writer stopped")]
    WriterGone,
}

impl CheckpointError {
    /// Whether this is the user's input (exit 2) rather than a failure of the machine.
    pub fn is_bad_input(&self) -> bool {
        !matches!(
            self,
            CheckpointError::Io { .. } | CheckpointError::Encode(_) | CheckpointError::WriterGone
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scheduler::AcceptedTile;
    use parrt_protocol::{Packing, PixelFormat, TilePixels};
    use parrt_render::settings::RenderSettings;
    use parrt_render::stats::RayStats;
    use parrt_render::tile::Tile;
    use std::fs::OpenOptions;
    use std::io::Read;
    use std::path::Path;

    fn key(tile: u32) -> (JobKey, Vec<Tile>) {
        let desc = parrt_scenes::generate("balls", Some(1)).unwrap();
        let settings = RenderSettings::new(20, 12);
        let k = JobKey::new(&desc, &settings, tile, PixelFormat::Rgb8).unwrap();
        (k, parrt_render::tile::tiles(20, 12, tile))
    }

    fn tile_result(t: &Tile, v: u8) -> AcceptedTile {
        AcceptedTile {
            frame: 0,
            tile_id: t.id,
            pixels: TilePixels {
                format: PixelFormat::Rgb8,
                packing: Packing::Raw,
                bytes: vec![v; t.pixel_count() * 3],
            },
            stats: RayStats {
                eye_rays: t.pixel_count() as u64,
                box_tests: 1000 + t.id as u64,
                ..RayStats::default()
            },
            seconds: 0.25 * t.id as f64,
        }
    }

    fn file_of(k: &JobKey, records: &[AcceptedTile]) -> Vec<u8> {
        let h = k.header();
        let mut f = h.to_vec();
        for r in records {
            encode_record(r, &h, &mut f);
        }
        f
    }

    fn scan(bytes: &[u8], tiles: &[Tile]) -> Scan {
        let h: [u8; HEADER_LEN] = bytes[..HEADER_LEN].try_into().unwrap();
        let mut r = &bytes[HEADER_LEN..];
        scan_records(&mut r, bytes.len() as u64, tiles, PixelFormat::Rgb8, &h).unwrap()
    }

    #[test]
    fn header_round_trips_and_a_changed_byte_is_not_a_header() {
        let (k, _) = key(8);
        let h = k.header();
        assert_eq!(JobKey::parse(&h, &Seal::Plain), Ok(k.clone()));
        for i in 0..HEADER_LEN {
            let mut bad = h;
            bad[i] ^= 0x10;
            assert!(JobKey::parse(&bad, &Seal::Plain).is_err(), "byte {i}");
        }
        let keyed = k.clone().sealed_with(b"secret");
        let h = keyed.header();
        assert_eq!(JobKey::parse(&h, &keyed.seal), Ok(keyed.clone()));
        for i in 0..HEADER_LEN {
            let mut bad = h;
            bad[i] ^= 0x10;
            assert!(JobKey::parse(&bad, &keyed.seal).is_err(), "byte {i}");
        }
    }

    fn sealed_file_of(k: &JobKey, records: &[AcceptedTile], seal: &Seal) -> Vec<u8> {
        let h = k.header();
        let mut f = h.to_vec();
        for r in records {
            encode_sealed_record(r, seal, &h, &mut f);
        }
        f
    }

    /// Records of another job sealed with the same lasting token (another scene, an earlier
    /// frame of the same scene, another checkpoint file) appended to this job's checkpoint:
    /// none verifies, so each is dropped and its tile rendered again.
    #[test]
    fn records_spliced_from_another_job_or_file_do_not_verify() {
        let dir = tempfile::tempdir().unwrap();
        let token = b"the lasting token";
        let (plain, tiles) = key(8);
        let k = plain.clone().sealed_with(token);
        let p = dir.path().join("a.ckpt");
        let mut o = open(&p, &k, &tiles, false).unwrap();
        o.checkpoint.append(&[tile_result(&tiles[0], 7)]).unwrap();
        o.checkpoint.sync().unwrap();
        drop(o);
        let own = std::fs::read(&p).unwrap();
        // Another scene, same token, same image and tiling.
        let desc_b = parrt_scenes::generate("balls", Some(2)).unwrap();
        let kb = JobKey::new(&desc_b, &RenderSettings::new(20, 12), 8, PixelFormat::Rgb8)
            .unwrap()
            .sealed_with(token);
        let pb = dir.path().join("b.ckpt");
        // The same scene, another file (an earlier frame's, or a second run's).
        let pc = dir.path().join("c.ckpt");
        for (other, key_other) in [(&pb, &kb), (&pc, &k)] {
            let mut o = open(other, key_other, &tiles, false).unwrap();
            let white: Vec<_> = tiles.iter().map(|t| tile_result(t, 255)).collect();
            o.checkpoint.append(&white).unwrap();
            o.checkpoint.sync().unwrap();
            drop(o);
            let foreign = std::fs::read(other).unwrap();
            let mut spliced = own.clone();
            spliced.extend_from_slice(&foreign[HEADER_LEN..]);
            std::fs::write(&p, &spliced).unwrap();
            let o = open(&p, &k, &tiles, true).unwrap();
            assert_eq!(
                o.scan.tiles.len(),
                1,
                "{} tiles restored from {}",
                o.scan.tiles.len(),
                other.display()
            );
            assert_eq!(o.scan.tiles[0].pixels.bytes[0], 7, "the file's own record");
            assert_eq!(o.scan.bad_records, tiles.len());
            drop(o);
            std::fs::write(&p, &own).unwrap();
        }
    }

    /// Someone who can write a keyed checkpoint but has not the token rewrites
    /// every record (white pixels) with fresh plain checksums; the resume trusts none of them.
    #[test]
    fn a_keyed_checkpoint_trusts_no_record_sealed_without_the_token() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.ckpt");
        let (plain, tiles) = key(8);
        let k = plain.clone().sealed_with(b"the master's token");
        let mut o = open(&p, &k, &tiles, false).unwrap();
        let honest: Vec<_> = tiles.iter().map(|t| tile_result(t, 7)).collect();
        o.checkpoint.append(&honest).unwrap();
        o.checkpoint.sync().unwrap();
        drop(o);
        let o = open(&p, &k, &tiles, true).unwrap();
        assert_eq!(
            o.scan.tiles.len(),
            tiles.len(),
            "its own records are trusted"
        );
        drop(o);
        // Forged: the header kept, every record white with a plain checksum.
        let white: Vec<_> = tiles.iter().map(|t| tile_result(t, 255)).collect();
        let mut forged = k.header().to_vec();
        forged.extend_from_slice(&sealed_file_of(&k, &white, &Seal::Plain)[HEADER_LEN..]);
        std::fs::write(&p, &forged).unwrap();
        let o = open(&p, &k, &tiles, true).unwrap();
        assert!(
            o.scan.tiles.is_empty(),
            "{} forged tiles trusted",
            o.scan.tiles.len()
        );
        drop(o);
        // Forged with another token: the same.
        let other = plain.clone().sealed_with(b"not the token");
        let mut forged = k.header().to_vec();
        forged.extend_from_slice(&sealed_file_of(&k, &white, &other.seal)[HEADER_LEN..]);
        std::fs::write(&p, &forged).unwrap();
        let o = open(&p, &k, &tiles, true).unwrap();
        assert!(o.scan.tiles.is_empty());
        drop(o);
        // A whole plain file, or one of another token: refused, left unchanged.
        for f in [
            sealed_file_of(&plain, &white, &Seal::Plain),
            sealed_file_of(&other, &white, &other.seal),
        ] {
            std::fs::write(&p, &f).unwrap();
            let e = open(&p, &k, &tiles, true).unwrap_err();
            assert!(matches!(e, CheckpointError::Unauthenticated { .. }), "{e}");
            assert!(e.is_bad_input());
            assert_eq!(std::fs::read(&p).unwrap(), f);
        }
        // And a keyed file resumed without the token.
        let f = sealed_file_of(&k, &honest, &k.seal);
        std::fs::write(&p, &f).unwrap();
        let e = open(&p, &plain, &tiles, true).unwrap_err();
        assert!(e.to_string().contains("with a token"), "{e}");
    }

    /// A FIFO, a device or a link at the checkpoint's path is refused at once (bad input) and
    /// nothing is written into it.
    #[test]
    fn resume_refuses_what_is_not_a_regular_file_and_writes_nothing() {
        use std::os::unix::fs::OpenOptionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (k, tiles) = key(8);
        let fifo = dir.path().join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo with a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let mut reader = OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(&fifo)
            .unwrap();
        let e = open(&fifo, &k, &tiles, true).unwrap_err();
        assert!(e.to_string().contains("a FIFO, not a regular file"), "{e}");
        assert!(e.is_bad_input());
        let mut got = [0u8; 8];
        let read = reader.read(&mut got);
        assert!(
            matches!(read, Ok(0)) || read.is_err(),
            "written into: {read:?}"
        );
        let e = open(Path::new("/dev/zero"), &k, &tiles, true).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
        assert!(e.is_bad_input());
        let dangling = dir.path().join("dangling");
        std::os::unix::fs::symlink(dir.path().join("nowhere"), &dangling).unwrap();
        let e = open(&dangling, &k, &tiles, true).unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert!(
            !dir.path().join("nowhere").exists(),
            "created through the link"
        );
        let target = dir.path().join("target");
        let mut o = open(&target, &k, &tiles, false).unwrap();
        o.checkpoint.append(&[tile_result(&tiles[0], 1)]).unwrap();
        drop(o);
        let before = std::fs::read(&target).unwrap();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let e = open(&link, &k, &tiles, true).unwrap_err();
        assert!(matches!(e, CheckpointError::Refused { .. }), "{e}");
        assert_eq!(std::fs::read(&target).unwrap(), before);
    }

    /// Another user's file, or one others may write, is not resumed.
    #[test]
    fn resume_refuses_another_users_or_a_writable_file() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.ckpt");
        let (k, tiles) = key(8);
        drop(open(&p, &k, &tiles, false).unwrap());
        assert_eq!(
            std::fs::metadata(&p).unwrap().permissions().mode() & 0o777,
            0o600
        );
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o666)).unwrap();
        let e = open(&p, &k, &tiles, true).unwrap_err();
        assert!(e.to_string().contains("mode 0666"), "{e}");
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o644)).unwrap();
        assert!(open(&p, &k, &tiles, true).is_ok());
        if file_guard::effective_uid() != 0 {
            eprintln!("not root: the other-owner case needs chown");
            return;
        }
        std::os::unix::fs::chown(&p, Some(65534), Some(65534)).unwrap();
        let e = open(&p, &k, &tiles, true).unwrap_err();
        assert!(e.to_string().contains("owned by uid 65534"), "{e}");
        assert!(e.is_bad_input());
    }

    /// One checkpoint, one master: the lock turns a second master away and names the holder.
    #[test]
    fn a_second_master_on_the_same_checkpoint_is_refused_and_told_who_holds_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.ckpt");
        let (k, tiles) = key(8);
        let first = open(&p, &k, &tiles, false).unwrap();
        let e = open(&p, &k, &tiles, true).unwrap_err();
        assert!(matches!(e, CheckpointError::Locked { .. }), "{e}");
        assert!(
            e.to_string()
                .contains(&format!("process {}", std::process::id())),
            "{e}"
        );
        assert!(e.is_bad_input());
        drop(first);
        assert!(
            open(&p, &k, &tiles, true).is_ok(),
            "free once the first ends"
        );
    }

    #[test]
    fn keys_differ_by_scene_settings_tile_and_format() {
        let desc = parrt_scenes::generate("balls", Some(1)).unwrap();
        let s = RenderSettings::new(20, 12);
        let k = JobKey::new(&desc, &s, 8, PixelFormat::F32).unwrap();
        let mut other = desc.clone();
        other.view.angle += 1.0;
        assert_ne!(
            JobKey::new(&other, &s, 8, PixelFormat::F32).unwrap().scene,
            k.scene
        );
        let mut s2 = s.clone();
        s2.spp = 4;
        let k2 = JobKey::new(&desc, &s2, 8, PixelFormat::F32).unwrap();
        assert_eq!(k2.scene, k.scene);
        assert_eq!(k.differences(&k2).len(), 1);
        let k3 = JobKey::new(&desc, &s, 4, PixelFormat::Rgb8).unwrap();
        assert_eq!(k.differences(&k3).len(), 2, "{:?}", k.differences(&k3));
        assert!(k.differences(&k).is_empty());
    }

    #[test]
    fn records_round_trip_bit_for_bit() {
        let (k, tiles) = key(8);
        let records: Vec<_> = tiles.iter().map(|t| tile_result(t, t.id as u8)).collect();
        let f = file_of(&k, &records);
        let s = scan(&f, &tiles);
        assert_eq!(s.bad_records, 0);
        assert_eq!(s.cut_bytes, 0);
        assert_eq!(s.good_len, f.len() as u64);
        assert_eq!(s.tiles.len(), tiles.len());
        for (a, b) in s.tiles.iter().zip(&records) {
            assert_eq!(a.tile_id, b.tile_id);
            assert_eq!(a.pixels, b.pixels);
            assert_eq!(a.stats, b.stats);
            assert_eq!(a.seconds.to_bits(), b.seconds.to_bits());
        }
    }

    #[test]
    fn a_torn_tail_is_cut_at_every_length() {
        let (k, tiles) = key(8);
        let records: Vec<_> = tiles.iter().map(|t| tile_result(t, 7)).collect();
        let two = file_of(&k, &records[..2]).len();
        let f = file_of(&k, &records[..3]);
        for end in two..f.len() {
            let s = scan(&f[..end], &tiles);
            assert_eq!(s.tiles.len(), 2, "cut at {end}");
            assert_eq!(s.good_len, two as u64);
            assert_eq!(s.cut_bytes, (end - two) as u64);
        }
    }

    #[test]
    fn a_flipped_byte_drops_only_its_record_unless_it_breaks_the_framing() {
        let (k, tiles) = key(8);
        let records: Vec<_> = tiles.iter().map(|t| tile_result(t, 9)).collect();
        let f = file_of(&k, &records);
        let one = file_of(&k, &records[..1]).len();
        let two = file_of(&k, &records[..2]).len();
        // Every byte of the middle record after its length: only that record goes.
        for i in one + 4..two {
            let mut bad = f.clone();
            bad[i] ^= 0x01;
            let s = scan(&bad, &tiles);
            let ids: Vec<u32> = s.tiles.iter().map(|t| t.tile_id).collect();
            assert_eq!(s.bad_records, 1, "byte {i}");
            assert!(!ids.contains(&1), "byte {i}");
            assert_eq!(ids.len(), tiles.len() - 1, "byte {i}");
            assert_eq!(s.good_len, f.len() as u64);
        }
        // Its length: nothing after the first record is trusted.
        let mut bad = f.clone();
        bad[one + 1] ^= 0x40;
        let s = scan(&bad, &tiles);
        assert_eq!(s.tiles.len(), 1);
        assert_eq!(s.good_len, one as u64);
    }

    #[test]
    fn records_of_tiles_not_in_the_job_are_not_trusted() {
        let (k, tiles) = key(8);
        let mut wrong = tile_result(&tiles[0], 1);
        wrong.tile_id = 99;
        let mut short = tile_result(&tiles[1], 1);
        short.pixels.bytes.pop();
        let f = file_of(&k, &[wrong, short, tile_result(&tiles[2], 3)]);
        let s = scan(&f, &tiles);
        assert_eq!(s.bad_records, 2);
        assert_eq!(s.tiles.len(), 1);
        assert_eq!(s.tiles[0].tile_id, 2);
    }

    #[test]
    fn open_refuses_an_existing_file_without_resume_and_another_job_with_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.ckpt");
        let (k, tiles) = key(8);
        let mut o = open(&p, &k, &tiles, false).unwrap();
        assert!(o.created);
        o.checkpoint.append(&[tile_result(&tiles[0], 5)]).unwrap();
        o.checkpoint.sync().unwrap();
        drop(o);
        let before = std::fs::read(&p).unwrap();
        let e = open(&p, &k, &tiles, false).unwrap_err();
        assert!(matches!(e, CheckpointError::Exists(_)), "{e}");
        assert!(e.to_string().contains("pass --resume"), "{e}");
        let (k4, tiles4) = key(4);
        let e = open(&p, &k4, &tiles4, true).unwrap_err();
        assert!(
            e.to_string().contains("the file has tile 8, this run 4"),
            "{e}"
        );
        let mut other = k.clone();
        other.scene[0] ^= 1;
        let e = open(&p, &other, &tiles, true).unwrap_err();
        assert!(matches!(e, CheckpointError::OtherScene(_)), "{e}");
        assert!(e.is_bad_input());
        assert_eq!(std::fs::read(&p).unwrap(), before, "left unchanged");
        // Resumed: the record is back, a torn tail is cut, and appending continues.
        let mut torn = before.clone();
        torn.extend_from_slice(&[1, 2, 3]);
        std::fs::write(&p, &torn).unwrap();
        let mut o = open(&p, &k, &tiles, true).unwrap();
        assert_eq!(o.scan.tiles.len(), 1);
        assert_eq!(o.scan.cut_bytes, 3);
        o.checkpoint.append(&[tile_result(&tiles[1], 6)]).unwrap();
        o.checkpoint.sync().unwrap();
        drop(o);
        let o = open(&p, &k, &tiles, true).unwrap();
        assert_eq!(o.scan.tiles.len(), 2);
        assert_eq!(o.scan.cut_bytes, 0);
        drop(o);
        std::fs::write(&p, b"").unwrap();
        let o = open(&p, &k, &tiles, true).unwrap();
        assert!(o.created, "an empty file is a header never written");
        drop(o);
        assert_eq!(std::fs::read(&p).unwrap().len(), HEADER_LEN);
        std::fs::write(&p, b"not a checkpoint").unwrap();
        let e = open(&p, &k, &tiles, true).unwrap_err();
        assert!(matches!(e, CheckpointError::NotACheckpoint(_)), "{e}");
    }
}
