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
//!   (`u32`), render seconds (`f64`), the 11 ray counters of [`RayStats`] (`u64` each, in
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

use super::file_guard::{self, GuardError, Privacy};
use super::scheduler::AcceptedTile;
use hmac::{Hmac, Mac};
use parrt_protocol::{PixelFormat, TilePixels};
use parrt_render::description::SceneDescription;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
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
pub const MAGIC: &[u8; 8] = b"PARRTCK3";
/// Bytes of a checkpoint's job identity.
pub const JOB_ID_LEN: usize = 16;
/// Bytes in the header.
pub const HEADER_LEN: usize = 8 + 4 * 4 + 1 + 1 + 32 + 32 + JOB_ID_LEN + CHECK_LEN;
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

/// How the header and each record are checksummed: a plain SHA-256 (finds damage only), or an
/// HMAC-SHA256 under a key derived from the job's secret (also finds records written without
/// it).
#[derive(Clone, PartialEq, Eq)]
pub enum Seal {
    /// SHA-256: anyone who can write the file can seal a record.
    Plain,
    /// HMAC-SHA256 under this key.
    Keyed([u8; 32]),
}

impl std::fmt::Debug for Seal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Seal::Plain => write!(f, "Plain"),
            Seal::Keyed(_) => write!(f, "Keyed(<key>)"),
        }
    }
}

type HmacSha256 = Hmac<Sha256>;

impl Seal {
    /// The keyed seal of a job whose secret is `secret` (the master's token): the key is
    /// HMAC-SHA256(secret, a label), so the checkpoint's key is not the handshake's.
    pub fn from_secret(secret: &[u8]) -> Seal {
        let mut m =
            <HmacSha256 as Mac>::new_from_slice(secret).expect("HMAC takes a key of any length");
        m.update(b"parrt checkpoint records v1");
        Seal::Keyed(m.finalize().into_bytes().into())
    }

    fn byte(&self) -> u8 {
        match self {
            Seal::Plain => 0,
            Seal::Keyed(_) => 1,
        }
    }

    /// The first [`CHECK_LEN`] bytes of the seal of `parts`, concatenated.
    fn tag(&self, parts: &[&[u8]]) -> [u8; CHECK_LEN] {
        let mut out = [0u8; CHECK_LEN];
        match self {
            Seal::Plain => {
                let mut h = Sha256::new();
                for p in parts {
                    h.update(p);
                }
                out.copy_from_slice(&h.finalize()[..CHECK_LEN]);
            }
            Seal::Keyed(key) => {
                let mut m = <HmacSha256 as Mac>::new_from_slice(key)
                    .expect("HMAC takes a key of any length");
                for p in parts {
                    m.update(p);
                }
                out.copy_from_slice(&m.finalize().into_bytes()[..CHECK_LEN]);
            }
        }
        out
    }
}

/// Why a header is not this run's.
#[derive(Debug, PartialEq, Eq)]
enum BadHeader {
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
    fn parse(h: &[u8; HEADER_LEN], seal: &Seal) -> Result<JobKey, BadHeader> {
        if &h[..8] != MAGIC {
            return Err(BadHeader::NotOne);
        }
        let body = &h[..HEADER_LEN - CHECK_LEN];
        let sealed_ok = seal.tag(&[body])[..] == h[HEADER_LEN - CHECK_LEN..];
        match (h[25], seal) {
            (0, Seal::Plain) | (1, Seal::Keyed(_)) if sealed_ok => {}
            (0, Seal::Keyed(_)) if Seal::Plain.tag(&[body])[..] == h[HEADER_LEN - CHECK_LEN..] => {
                return Err(BadHeader::Seal(
                    "was written without a token (by `render --workers` or `cluster`), so its                      records cannot be authenticated with this master's token"
                        .into(),
                ))
            }
            (1, Seal::Plain) => {
                return Err(BadHeader::Seal(
                    "was written by a master with a token; give `parrt master` the same token                      to resume it"
                        .into(),
                ))
            }
            (1, Seal::Keyed(_)) => {
                return Err(BadHeader::Seal(
                    "was not written with this master's token (or was altered since)".into(),
                ))
            }
            _ => return Err(BadHeader::NotOne),
        }
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

/// Appends the record of `t`, sealed plain, for the checkpoint whose header is `header`, to
/// `out`.
pub fn encode_record(t: &AcceptedTile, header: &[u8; HEADER_LEN], out: &mut Vec<u8>) {
    encode_sealed_record(t, &Seal::Plain, header, out);
}

/// Appends the record of `t`, sealed with `seal` and bound to the checkpoint whose header is
/// `header` (its job), to `out`.
pub fn encode_sealed_record(
    t: &AcceptedTile,
    seal: &Seal,
    header: &[u8; HEADER_LEN],
    out: &mut Vec<u8>,
) {
    let len = (RECORD_FIXED + t.pixels.bytes.len()) as u32;
    let start = out.len();
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&t.tile_id.to_le_bytes());
    out.extend_from_slice(&t.seconds.to_bits().to_le_bytes());
    for v in RayStats::to_array(&t.stats) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&t.pixels.bytes);
    let check = seal.tag(&[header, &out[start..]]);
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

/// Reads the plainly sealed records after `header` from `r` (positioned just past it), for
/// a job of `tiles` whose pixels travel as `format`: [`scan_sealed_records`] with
/// [`Seal::Plain`].
pub fn scan_records(
    r: &mut impl Read,
    file_len: u64,
    tiles: &[Tile],
    format: PixelFormat,
    header: &[u8; HEADER_LEN],
) -> std::io::Result<Scan> {
    scan_sealed_records(r, file_len, tiles, format, &Seal::Plain, header)
}

/// Reads the records after `header` from `r` (positioned just past it), for a job of `tiles`
/// whose pixels travel as `format`. Never trusts a record whose seal fails (damaged, written
/// without the key, or bound to another header: another job, frame or file); stops at a
/// length that cannot be (the framing is lost) or at a torn end.
pub fn scan_sealed_records(
    r: &mut impl Read,
    file_len: u64,
    tiles: &[Tile],
    format: PixelFormat,
    seal: &Seal,
    header: &[u8; HEADER_LEN],
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
        if seal.tag(&[header, &len, payload])[..] != check[..] {
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
    seal: Seal,
    /// The file's header: every record's seal covers it (binds the record to this job).
    header: [u8; HEADER_LEN],
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
    use std::os::unix::fs::OpenOptionsExt;
    let refused = |refusal| CheckpointError::Refused {
        path: path.to_path_buf(),
        refusal,
    };
    // O_EXCL never follows a link: a link planted at the path is "already there".
    let created = OpenOptions::new()
        .read(true)
        .write(true)
        .create_new(true)
        .mode(0o600)
        .custom_flags(libc::O_CLOEXEC)
        .open(path);
    let (mut file, fresh) = match created {
        Ok(file) => (file, true),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            if !resume {
                return Err(CheckpointError::Exists(path.to_path_buf()));
            }
            let file = file_guard::open_existing(path, true, Privacy::OwnerWrites).map_err(
                |e| match e {
                    GuardError::Refused(r) => refused(r),
                    GuardError::Io(e) => io("open", path)(e),
                },
            )?;
            (file, false)
        }
        Err(e) => return Err(io("create", path)(e)),
    };
    if let Some(holder) = file_guard::try_lock(&file).map_err(io("lock", path))? {
        return Err(CheckpointError::Locked {
            path: path.to_path_buf(),
            holder,
        });
    }
    let file_len = file.metadata().map_err(io("read", path))?.len();
    if fresh || file_len == 0 {
        // New, or a master killed between creating the file and writing its header: nothing
        // to lose. The file gets a job identity of its own, which every record is bound to.
        let mut key = key.clone();
        if key.job == [0; JOB_ID_LEN] {
            key.job = rand::random();
        }
        let header = key.header();
        file.write_all(&header)
            .and_then(|()| file.sync_all())
            .map_err(io("write", path))?;
        if fresh {
            sync_parent(path);
        }
        return Ok(Opened {
            checkpoint: Checkpoint::new(file, path, key.seal.clone(), header),
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
    let theirs = match JobKey::parse(&head, &key.seal) {
        Ok(k) => k,
        Err(BadHeader::NotOne) => return Err(CheckpointError::NotACheckpoint(path.to_path_buf())),
        Err(BadHeader::Seal(why)) => {
            return Err(CheckpointError::Unauthenticated {
                path: path.to_path_buf(),
                why,
            })
        }
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
    let scan = scan_sealed_records(&mut reader, file_len, tiles, key.format, &key.seal, &head)
        .map_err(io("read", path))?;
    drop(reader);
    if scan.cut_bytes > 0 {
        file.set_len(scan.good_len)
            .and_then(|()| file.sync_all())
            .map_err(io("truncate", path))?;
    }
    file.seek(SeekFrom::End(0)).map_err(io("seek", path))?;
    Ok(Opened {
        checkpoint: Checkpoint::new(file, path, key.seal.clone(), head),
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
    fn new(file: File, path: &Path, seal: Seal, header: [u8; HEADER_LEN]) -> Checkpoint {
        let len = file.metadata().map_or(0, |m| m.len());
        Checkpoint {
            seal,
            header,
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
                encode_sealed_record(t, &self.seal, &self.header, &mut self.buf);
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
        (k, parrt_render::tile::tiles(20, 12, tile))
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
