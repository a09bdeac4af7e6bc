//! An open checkpoint file taking records: each batch appended with one `write` (a killed
//! process leaves whole records), synced to the disk at least every [`SYNC_INTERVAL`], and how
//! much of it is known to be on the disk.

use super::record::encode_sealed_record;
use super::seal::Seal;
use super::{CheckpointError, SYNC_INTERVAL};
use crate::scheduler::AcceptedTile;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
// tokio's clock: the real one in a real run, the virtual one under the deterministic
// simulation (so when a sync happens replays exactly).
use tokio::time::Instant;

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
    header: Box<[u8]>,
}

pub(super) fn io(
    action: &'static str,
    path: &Path,
) -> impl FnOnce(std::io::Error) -> CheckpointError {
    let path = path.to_path_buf();
    move |source| CheckpointError::Io {
        action,
        path,
        source,
    }
}

/// Syncs the directory holding `path` so a new file's name survives a power loss (best
/// effort: not every system can open a directory).
pub(super) fn sync_parent(path: &Path) {
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
    /// `header` is the file's (of either kind: one frame or a sequence).
    pub(super) fn new(file: File, path: &Path, seal: Seal, header: &[u8]) -> Checkpoint {
        let len = file.metadata().map_or(0, |m| m.len());
        Checkpoint {
            seal,
            header: header.into(),
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
            self.write_records(|seal, header, out| {
                for t in tiles {
                    encode_sealed_record(t, seal, header, out);
                }
            })?;
        }
        self.sync_if_due()
    }

    /// Appends in one write the records `encode` puts in its buffer, given the file's seal and
    /// header (which every record's seal covers).
    pub(super) fn write_records(
        &mut self,
        encode: impl FnOnce(&Seal, &[u8], &mut Vec<u8>),
    ) -> Result<(), CheckpointError> {
        self.buf.clear();
        encode(&self.seal, &self.header, &mut self.buf);
        self.file
            .write_all(&self.buf)
            .map_err(io("write", &self.path))?;
        self.written += self.buf.len() as u64;
        self.unsynced = true;
        Ok(())
    }

    /// Syncs if something is unsynced and the last sync is [`SYNC_INTERVAL`] old.
    pub(super) fn sync_if_due(&mut self) -> Result<(), CheckpointError> {
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
