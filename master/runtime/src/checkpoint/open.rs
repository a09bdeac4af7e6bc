//! Opening a checkpoint: created new (mode 0600, a fresh job identity in its header) or, with
//! `--resume`, an existing file checked (this user's, no one else may write it), locked against a
//! second master, its header matched against this run's job and its good records read back,
//! anything after the last good one cut off before appending.

use super::file::{io, sync_parent, Checkpoint};
use super::header::JobKey;
use super::record::{read_full, scan_sealed_records, Scan};
use super::sequence::SEQUENCE_MAGIC;
use super::{CheckpointError, HEADER_LEN, JOB_ID_LEN, MAGIC};
use crate::file_guard::{self, GuardError, Privacy};
use parrt_render::tile::Tile;
use std::fs::{File, OpenOptions};
use std::io::{BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

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
    let fresh = |job| {
        let mut key = key.clone();
        if key.job == [0; JOB_ID_LEN] {
            key.job = job;
        }
        key.header()
    };
    let (mut file, head, file_len) = match start(path, resume, fresh, OTHER_KIND)? {
        Started::Created { file, header } => {
            return Ok(Opened {
                checkpoint: Checkpoint::new(file, path, key.seal.clone(), &header),
                scan: Scan {
                    good_len: HEADER_LEN as u64,
                    ..Scan::default()
                },
                created: true,
            })
        }
        Started::Existing {
            file,
            head,
            file_len,
        } => (file, head, file_len),
    };
    let theirs = JobKey::parse(&head, &key.seal).map_err(|e| e.at(path))?;
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
    let scan = scan_and_cut(&mut file, path, |r| {
        let scan = scan_sealed_records(r, file_len, tiles, key.format, &key.seal, &head)?;
        Ok((scan.good_len, scan.cut_bytes, scan))
    })?;
    Ok(Opened {
        checkpoint: Checkpoint::new(file, path, key.seal.clone(), &head),
        scan,
        created: false,
    })
}

/// A sequence's checkpoint given where one frame's is expected.
const OTHER_KIND: (&[u8; 8], fn(PathBuf) -> CheckpointError) =
    (SEQUENCE_MAGIC, CheckpointError::SequenceForOneFrame);

/// A checkpoint file as [`start`] found it.
pub(super) enum Started<const LEN: usize> {
    /// Created now (or found empty), its header written and synced.
    Created { file: File, header: [u8; LEN] },
    /// An earlier run's, positioned just past its header `head`; `file_len` bytes long.
    Existing {
        file: File,
        head: [u8; LEN],
        file_len: u64,
    },
}

/// The start both kinds of checkpoint share: the file created or locked ([`create_or_lock`]);
/// a new (or empty: a master killed between creating the file and writing its header, nothing
/// to lose) one given the header `fresh` makes with a job identity drawn now, which every
/// record is bound to; an existing one's header read, refused as `other.1` says when it starts
/// with the other kind's magic `other.0`, and as not a checkpoint when it is too short.
pub(super) fn start<const LEN: usize>(
    path: &Path,
    resume: bool,
    fresh: impl FnOnce([u8; JOB_ID_LEN]) -> [u8; LEN],
    other: (&[u8; 8], fn(PathBuf) -> CheckpointError),
) -> Result<Started<LEN>, CheckpointError> {
    let (mut file, created) = create_or_lock(path, resume)?;
    let file_len = file.metadata().map_err(io("read", path))?.len();
    if created || file_len == 0 {
        let header = fresh(rand::random());
        file.write_all(&header)
            .and_then(|()| file.sync_all())
            .map_err(io("write", path))?;
        if created {
            sync_parent(path);
        }
        return Ok(Started::Created { file, header });
    }
    let mut head = [0u8; LEN];
    let (magic, rest) = head.split_at_mut(MAGIC.len());
    let whole = read_full(&mut file, magic).map_err(io("read", path))?;
    if whole && magic == other.0 {
        return Err(other.1(path.to_path_buf()));
    }
    if !whole || !read_full(&mut file, rest).map_err(io("read", path))? {
        return Err(CheckpointError::NotACheckpoint(path.to_path_buf()));
    }
    Ok(Started::Existing {
        file,
        head,
        file_len,
    })
}

/// Reads an existing checkpoint's records with `scan` (from just past the header; it says
/// where the last good record ends and how many bytes followed it), cuts `file` back to that
/// end when anything followed, and goes to its end for appending.
pub(super) fn scan_and_cut<S>(
    file: &mut File,
    path: &Path,
    scan: impl FnOnce(&mut BufReader<&mut File>) -> std::io::Result<(u64, u64, S)>,
) -> Result<S, CheckpointError> {
    let (good_len, cut_bytes, scanned) =
        scan(&mut BufReader::new(&mut *file)).map_err(io("read", path))?;
    if cut_bytes > 0 {
        file.set_len(good_len)
            .and_then(|()| file.sync_all())
            .map_err(io("truncate", path))?;
    }
    file.seek(SeekFrom::End(0)).map_err(io("seek", path))?;
    Ok(scanned)
}

/// Creates the checkpoint at `path` (mode 0600, never through a link) or, with `resume`, opens
/// the file there if it is one this user may trust; either way locked against a second master.
/// Says whether it was created now. Without `resume` an existing file is refused.
pub(super) fn create_or_lock(
    path: &Path,
    resume: bool,
) -> Result<(std::fs::File, bool), CheckpointError> {
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
    let (file, fresh) = match created {
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
    Ok((file, fresh))
}
