//! Opening a checkpoint: created new (mode 0600, a fresh job identity in its header) or, with
//! `--resume`, an existing file checked (this user's, no one else may write it), locked against a
//! second master, its header matched against this run's job and its good records read back,
//! anything after the last good one cut off before appending.

use super::file::{io, sync_parent, Checkpoint};
use super::header::{BadHeader, JobKey};
use super::record::{read_full, scan_sealed_records, Scan};
use super::sequence::SEQUENCE_MAGIC;
use super::{CheckpointError, HEADER_LEN, JOB_ID_LEN, MAGIC};
use crate::file_guard::{self, GuardError, Privacy};
use parrt_render::tile::Tile;
use std::fs::OpenOptions;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

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
    let (mut file, fresh) = create_or_lock(path, resume)?;
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
    let (magic, rest) = head.split_at_mut(MAGIC.len());
    let whole = read_full(&mut reader, magic).map_err(io("read", path))?;
    if whole && magic == SEQUENCE_MAGIC {
        return Err(CheckpointError::SequenceForOneFrame(path.to_path_buf()));
    }
    if !whole || !read_full(&mut reader, rest).map_err(io("read", path))? {
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
