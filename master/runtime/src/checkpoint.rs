//! The checkpoint file of a distributed render: a sink for the tiles the scheduler accepts while
//! the master runs, and their source when a killed master is started again with `--resume`.
//!
//! ## Format (all integers little-endian)
//! - Header, [`HEADER_LEN`] bytes: the magic `PARRTCK1`; tile edge, width, height and tile
//!   count (`u32` each); the pixel format (`u8`: 0 f32, 1 rgb8); SHA-256 of the scene
//!   description's postcard encoding; SHA-256 of the settings' postcard encoding; the first 8
//!   bytes of the SHA-256 of everything before them.
//! - Then one record per accepted tile: the payload length (`u32`); the payload — tile id
//!   (`u32`), render seconds (`f64`), the 11 ray counters of [`RayStats`] (`u64` each, in
//!   declaration order), the pixels as the job's workers sent them; the first 8 bytes of the
//!   SHA-256 of the length and the payload.
//!
//! The file is only ever appended to; each batch of records is written with one `write` (so a
//! killed process leaves whole records) and synced to the disk at least every
//! [`SYNC_INTERVAL`] and at the end (so a power loss costs at most that much). On resume a
//! record is trusted only if its checksum holds and it names a tile of this job with the right
//! pixel count; a bad record in the middle is skipped (its tile is rendered again), and a torn
//! or unreadable tail is cut off before anything is appended.

use super::scheduler::AcceptedTile;
use parrt::description::SceneDescription;
use parrt::protocol::{PixelFormat, TilePixels};
use parrt::settings::RenderSettings;
use parrt::stats::RayStats;
use parrt::tile::Tile;
use sha2::{Digest, Sha256};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;
// tokio's clock: the real one in a real run, the virtual one under the deterministic
// simulation (so when a sync happens replays exactly).
use thiserror::Error;
use tokio::time::Instant;

/// The first bytes of every checkpoint (the digit is the format's version).
pub const MAGIC: &[u8; 8] = b"PARRTCK1";
/// Bytes in the header.
pub const HEADER_LEN: usize = 8 + 4 * 4 + 1 + 32 + 32 + CHECK_LEN;
/// Bytes of each checksum (a truncated SHA-256).
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
        let n = parrt::tile::tiles(settings.width, settings.height, tile.max(1)).len();
        Ok(JobKey {
            scene: hash(postcard::to_io(desc, HashWriter(Sha256::new())))?,
            settings: hash(postcard::to_io(settings, HashWriter(Sha256::new())))?,
            tile,
            width: settings.width,
            height: settings.height,
            tiles: u32::try_from(n).unwrap_or(u32::MAX),
            format,
        })
    }

    fn header(&self) -> [u8; HEADER_LEN] {
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
        put(&[format_byte(self.format)]);
        put(&self.scene);
        put(&self.settings);
        let check = checksum(&[&h[..HEADER_LEN - CHECK_LEN]]);
        h[HEADER_LEN - CHECK_LEN..].copy_from_slice(&check);
        h
    }

    /// Parses a header; `None` when it is not one (wrong magic, bad checksum, unknown format).
    fn parse(h: &[u8; HEADER_LEN]) -> Option<JobKey> {
        let body = &h[..HEADER_LEN - CHECK_LEN];
        if &h[..8] != MAGIC || checksum(&[body])[..] != h[HEADER_LEN - CHECK_LEN..] {
            return None;
        }
        let u = |i: usize| u32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
        let format = match h[24] {
            0 => PixelFormat::F32,
            1 => PixelFormat::Rgb8,
            _ => return None,
        };
        Some(JobKey {
            tile: u(8),
            width: u(12),
            height: u(16),
            tiles: u(20),
            format,
            scene: h[25..57].try_into().ok()?,
            settings: h[57..89].try_into().ok()?,
        })
    }

    /// What differs in `file`'s key from this run's, for the user (the scene is checked
    /// separately).
    fn differences(&self, file: &JobKey) -> Vec<String> {
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

/// Feeds what is written into a SHA-256.
struct HashWriter(Sha256);

impl Write for HashWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.update(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn format_byte(f: PixelFormat) -> u8 {
    match f {
        PixelFormat::F32 => 0,
        PixelFormat::Rgb8 => 1,
    }
}

fn checksum(parts: &[&[u8]]) -> [u8; CHECK_LEN] {
    let mut h = Sha256::new();
    for p in parts {
        h.update(p);
    }
    let d = h.finalize();
    let mut out = [0u8; CHECK_LEN];
    out.copy_from_slice(&d[..CHECK_LEN]);
    out
}

/// Appends the record of `t` to `out`.
pub fn encode_record(t: &AcceptedTile, out: &mut Vec<u8>) {
    let len = (RECORD_FIXED + t.pixels.bytes.len()) as u32;
    let start = out.len();
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&t.tile_id.to_le_bytes());
    out.extend_from_slice(&t.seconds.to_bits().to_le_bytes());
    for v in RayStats::to_array(&t.stats) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&t.pixels.bytes);
    let check = checksum(&[&out[start..]]);
    out.extend_from_slice(&check);
}

/// Decodes a payload whose checksum held; `None` unless it names a tile of `tiles` with that
/// tile's pixel count in `format`.
fn decode_payload(p: &[u8], tiles: &[Tile], format: PixelFormat) -> Option<AcceptedTile> {
    let fixed = p.get(..RECORD_FIXED)?;
    let tile_id = u32::from_le_bytes(fixed[..4].try_into().ok()?);
    let seconds = f64::from_bits(u64::from_le_bytes(fixed[4..12].try_into().ok()?));
    let mut v = [0u64; 11];
    for (i, c) in fixed[12..].chunks_exact(8).enumerate() {
        v[i] = u64::from_le_bytes(c.try_into().ok()?);
    }
    let tile = tiles.get(tile_id as usize)?;
    let bytes = &p[RECORD_FIXED..];
    if bytes.len() != tile.pixel_count().checked_mul(format.bytes_per_pixel())? {
        return None;
    }
    Some(AcceptedTile {
        tile_id,
        pixels: TilePixels {
            format,
            bytes: bytes.to_vec(),
        },
        stats: RayStats::from_array(v),
        seconds,
    })
}

/// What reading a checkpoint's records found.
#[derive(Debug, Default)]
pub struct Scan {
    /// The good records, the first one of each tile, in file order.
    pub tiles: Vec<AcceptedTile>,
    /// Records skipped: a checksum that did not hold, or a tile that is not this job's.
    pub bad_records: usize,
    /// Bytes after the last good record that were cut off (a torn or unreadable tail, and
    /// any bad records at the end).
    pub cut_bytes: u64,
    /// Where the last good record ends: the file's new length.
    pub good_len: u64,
}

/// Reads the records after the header from `r` (positioned just past it), for a job of `tiles`
/// whose pixels travel as `format`. Never trusts a record whose checksum fails; stops at a
/// length that cannot be (the framing is lost) or at a torn end.
pub fn scan_records(
    r: &mut impl Read,
    file_len: u64,
    tiles: &[Tile],
    format: PixelFormat,
) -> std::io::Result<Scan> {
    let max_pixels = tiles.iter().map(|t| t.pixel_count()).max().unwrap_or(0);
    let max_payload = RECORD_FIXED + max_pixels * format.bytes_per_pixel();
    let mut seen = vec![false; tiles.len()];
    let mut scan = Scan::default();
    let mut pos = HEADER_LEN as u64;
    scan.good_len = pos;
    let mut buf = Vec::new();
    loop {
        let mut len = [0u8; 4];
        if !read_full(r, &mut len)? {
            break; // The end, or a torn length.
        }
        let n = u32::from_le_bytes(len) as usize;
        if !(RECORD_FIXED..=max_payload).contains(&n) {
            break; // Not a length this job's records can have: the framing is lost.
        }
        buf.resize(n + CHECK_LEN, 0);
        if !read_full(r, &mut buf)? {
            if crate::mutation::is(crate::mutation::Mutation::TrustTornRecord) {
                if let Some(t) = decode_payload(&buf[..n], tiles, format) {
                    if !std::mem::replace(&mut seen[t.tile_id as usize], true) {
                        scan.tiles.push(t);
                    }
                }
            }
            break; // Torn.
        }
        pos += (4 + n + CHECK_LEN) as u64;
        let (payload, check) = buf.split_at(n);
        if checksum(&[&len, payload])[..] != check[..] {
            scan.bad_records += 1;
            continue;
        }
        match decode_payload(payload, tiles, format) {
            None => scan.bad_records += 1,
            Some(t) => {
                let first = !std::mem::replace(&mut seen[t.tile_id as usize], true);
                if first {
                    scan.tiles.push(t);
                }
                scan.good_len = pos;
            }
        }
    }
    scan.cut_bytes = file_len.saturating_sub(scan.good_len);
    Ok(scan)
}

/// Fills `buf` from `r`: `false` if the input ended first (having read any part of it).
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => return Ok(false),
            Ok(k) => got += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// An open checkpoint, positioned at its end, taking records.
#[derive(Debug)]
pub struct Checkpoint {
    file: File,
    path: PathBuf,
    last_sync: Instant,
    unsynced: bool,
    buf: Vec<u8>,
    /// Bytes of the file written so far.
    written: u64,
    /// Bytes of the file known to be on the disk (written before the last sync).
    durable: Arc<AtomicU64>,
}

/// A checkpoint just opened, with what an earlier run left in it.
#[derive(Debug)]
pub struct Opened {
    /// The file, ready for appending.
    pub checkpoint: Checkpoint,
    /// What was read from it (empty for a new file).
    pub scan: Scan,
    /// Whether the file was created now.
    pub created: bool,
}

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> CheckpointError {
    let path = path.to_path_buf();
    move |source| CheckpointError::Io {
        action,
        path,
        source,
    }
}

/// Opens the checkpoint at `path` for the job `key` of `tiles`. Without `resume` the file must
/// not exist; with it, an existing file must be of the same job (else it is refused and left
/// as it is), its good records are returned and anything after the last good one is cut off;
/// a missing (or empty) file is started either way.
pub fn open(
    path: &Path,
    key: &JobKey,
    tiles: &[Tile],
    resume: bool,
) -> Result<Opened, CheckpointError> {
    let created = OpenOptions::new()
        .read(true)
        .write(true)
        .create_new(true)
        .open(path);
    match created {
        Ok(mut file) => {
            file.write_all(&key.header())
                .and_then(|()| file.sync_all())
                .map_err(io("write", path))?;
            sync_parent(path);
            return Ok(Opened {
                checkpoint: Checkpoint::new(file, path),
                scan: Scan {
                    good_len: HEADER_LEN as u64,
                    ..Scan::default()
                },
                created: true,
            });
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            if !resume {
                return Err(CheckpointError::Exists(path.to_path_buf()));
            }
        }
        Err(e) => return Err(io("create", path)(e)),
    }
    let mut file = OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .map_err(io("open", path))?;
    let file_len = file.metadata().map_err(io("read", path))?.len();
    if file_len == 0 {
        // A master killed between creating the file and writing its header: nothing to lose.
        file.write_all(&key.header())
            .and_then(|()| file.sync_all())
            .map_err(io("write", path))?;
        return Ok(Opened {
            checkpoint: Checkpoint::new(file, path),
            scan: Scan {
                good_len: HEADER_LEN as u64,
                ..Scan::default()
            },
            created: true,
        });
    }
    let mut head = [0u8; HEADER_LEN];
    let mut reader = std::io::BufReader::new(&mut file);
    if !read_full(&mut reader, &mut head).map_err(io("read", path))? {
        return Err(CheckpointError::NotACheckpoint(path.to_path_buf()));
    }
    let Some(theirs) = JobKey::parse(&head) else {
        return Err(CheckpointError::NotACheckpoint(path.to_path_buf()));
    };
    if theirs.scene != key.scene {
        return Err(CheckpointError::OtherScene(path.to_path_buf()));
    }
    let diff = key.differences(&theirs);
    if !diff.is_empty() {
        return Err(CheckpointError::OtherSettings {
            path: path.to_path_buf(),
            what: diff.join("; "),
        });
    }
    let scan = scan_records(&mut reader, file_len, tiles, key.format).map_err(io("read", path))?;
    drop(reader);
    if scan.cut_bytes > 0 {
        file.set_len(scan.good_len)
            .and_then(|()| file.sync_all())
            .map_err(io("truncate", path))?;
    }
    file.seek(SeekFrom::End(0)).map_err(io("seek", path))?;
    Ok(Opened {
        checkpoint: Checkpoint::new(file, path),
        scan,
        created: false,
    })
}

/// Syncs the directory holding `path` so a new file's name survives a power loss (best
/// effort: not every system can open a directory).
fn sync_parent(path: &Path) {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

impl Checkpoint {
    /// `file` has just been synced, positioned at its end.
    fn new(file: File, path: &Path) -> Checkpoint {
        let len = file.metadata().map_or(0, |m| m.len());
        Checkpoint {
            file,
            path: path.to_path_buf(),
            last_sync: Instant::now(),
            unsynced: false,
            buf: Vec::new(),
            written: len,
            durable: Arc::new(AtomicU64::new(len)),
        }
    }

    /// How many bytes from the file's start are known to be on the disk, kept up to date as
    /// the checkpoint syncs: what a crash of the machine cannot take back.
    pub fn durable(&self) -> Arc<AtomicU64> {
        self.durable.clone()
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends the records of `tiles` in one write, and syncs if the last sync is
    /// [`SYNC_INTERVAL`] old.
    pub fn append(&mut self, tiles: &[AcceptedTile]) -> Result<(), CheckpointError> {
        if !tiles.is_empty() {
            self.buf.clear();
            for t in tiles {
                encode_record(t, &mut self.buf);
            }
            self.file
                .write_all(&self.buf)
                .map_err(io("write", &self.path))?;
            self.written += self.buf.len() as u64;
            self.unsynced = true;
        }
        if self.unsynced && self.last_sync.elapsed() >= SYNC_INTERVAL {
            self.sync()?;
        }
        Ok(())
    }

    /// Syncs what was written to the disk.
    pub fn sync(&mut self) -> Result<(), CheckpointError> {
        self.file.sync_data().map_err(io("sync", &self.path))?;
        self.durable.store(self.written, Ordering::Release);
        self.unsynced = false;
        self.last_sync = Instant::now();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(tile: u32) -> (JobKey, Vec<Tile>) {
        let desc = parrt_scenes::generate("balls", Some(1)).unwrap();
        let settings = RenderSettings::new(20, 12);
        let k = JobKey::new(&desc, &settings, tile, PixelFormat::Rgb8).unwrap();
        (k, parrt::tile::tiles(20, 12, tile))
    }

    fn tile_result(t: &Tile, v: u8) -> AcceptedTile {
        AcceptedTile {
            tile_id: t.id,
            pixels: TilePixels {
                format: PixelFormat::Rgb8,
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
        let mut f = k.header().to_vec();
        for r in records {
            encode_record(r, &mut f);
        }
        f
    }

    fn scan(bytes: &[u8], tiles: &[Tile]) -> Scan {
        let mut r = &bytes[HEADER_LEN..];
        scan_records(&mut r, bytes.len() as u64, tiles, PixelFormat::Rgb8).unwrap()
    }

    #[test]
    fn header_round_trips_and_a_changed_byte_is_not_a_header() {
        let (k, _) = key(8);
        let h = k.header();
        assert_eq!(JobKey::parse(&h), Some(k.clone()));
        for i in 0..HEADER_LEN {
            let mut bad = h;
            bad[i] ^= 0x10;
            assert_eq!(JobKey::parse(&bad), None, "byte {i}");
        }
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
