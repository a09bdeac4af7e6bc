//! The rendezvous file through which the ranks of one `parrt cluster` job meet: rank 0 (the
//! master) publishes its address and a fresh token in a directory every rank sees; the other
//! ranks wait for it, check that it is their job's, and dial. No MPI library: only a file.
//!
//! Rules: the file is named after the job, written under a temporary name with mode 0600 and
//! linked into place (readers never see half a file, an existing file is never overwritten),
//! removed by rank 0 at the end; a file left by a dead job (its pid gone on this host, or older
//! than the timeout) or by another job is refused, not trusted.
//!
//! The directory may be shared with other users (a sticky `/tmp`, a cluster's scratch), so a
//! file is read only if it is a regular file of this user that no one else may read or write
//! (it holds the job's token), opened without following a link and without blocking
//! ([`crate::file_guard`]): a file planted by someone else, a link or a FIFO is refused at
//! once, naming what is wrong, and no rank dials the master it names.

use crate::file_guard::{self, GuardError, Privacy, Refusal};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use thiserror::Error;

/// The format version written in every file.
pub const VERSION: u32 = 1;

/// The most bytes read from a rendezvous file (a real one is a few hundred).
pub const MAX_FILE_BYTES: u64 = 64 * 1024;

/// How often a waiting rank looks for the file.
pub const POLL: Duration = Duration::from_millis(100);

/// What rank 0 publishes.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rendezvous {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// The job's id (from the launcher's environment); ranks of another job refuse the file.
    pub job: String,
    /// Ranks in the job (master included).
    pub size: usize,
    /// Where the master listens, HOST:PORT as the other ranks should dial it.
    pub address: String,
    /// The shared secret of this job.
    pub token: String,
    /// The master's process id and host, to tell a dead job's file from a live one.
    pub pid: u32,
    /// The master's host name.
    pub host: String,
    /// When the file was written (seconds since the Unix epoch).
    pub created: u64,
}

/// Errors of the rendezvous (all but [`RendezvousError::Io`] are bad input, exit 2).
#[derive(Debug, Error)]
pub enum RendezvousError {
    /// Rank 0 found a file already there: never overwritten.
    #[error("rendezvous file {path} already exists ({why}); remove it if no job is using it")]
    Exists {
        /// The file.
        path: PathBuf,
        /// Whose it is and whether it is stale.
        why: String,
    },
    /// The file is another job's.
    #[error("rendezvous file {path} belongs to job {theirs:?}, not to this job {ours:?}; ranks of two jobs do not meet")]
    Foreign {
        /// The file.
        path: PathBuf,
        /// The job in the file.
        theirs: String,
        /// This rank's job.
        ours: String,
    },
    /// The file was left by a job that is gone.
    #[error("rendezvous file {path} is stale ({why}); remove it and start the job again")]
    Stale {
        /// The file.
        path: PathBuf,
        /// Why it is considered stale.
        why: String,
    },
    /// The file says the job has another number of ranks.
    #[error(
        "rendezvous file {path} is for {theirs} ranks but this rank was started as one of {ours}"
    )]
    SizeMismatch {
        /// The file.
        path: PathBuf,
        /// Ranks in the file.
        theirs: usize,
        /// Ranks this process was told.
        ours: usize,
    },
    /// Not a rendezvous file (or a version this parrt does not read).
    #[error("rendezvous file {path} is not readable as parrt's: {reason}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Rank 0 did not publish in time.
    #[error("no rendezvous file {path} appeared within {waited:?}: rank 0 (the master) did not start, or sees another directory (give every rank the same --rendezvous DIR on a shared file system)")]
    Timeout {
        /// The file waited for.
        path: PathBuf,
        /// How long.
        waited: Duration,
    },
    /// The file is not one this user may trust: another user's, readable or writable by
    /// others, a link, a FIFO or a device. Never read, never removed.
    #[error("rendezvous file {path} {refusal}; remove it if no job of yours is using it")]
    Refused {
        /// The file.
        path: PathBuf,
        /// Why.
        refusal: Refusal,
    },
    /// The file could not be written or read.
    #[error("rendezvous file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl RendezvousError {
    /// Whether the user's input (the directory, a leftover file, the launch) caused it.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, RendezvousError::Io { .. })
    }
}

/// The file of job `job` in `dir`: `parrt-rendezvous-<job>.json`, the job id reduced to
/// `[A-Za-z0-9._-]` and at most 64 characters (the full id is inside and compared).
pub fn path_for(dir: &Path, job: &str) -> PathBuf {
    let safe: String = job
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                c
            } else {
                '_'
            }
        })
        .take(64)
        .collect();
    dir.join(format!("parrt-rendezvous-{safe}.json"))
}

/// Seconds since the Unix epoch now.
pub fn now_unix() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// This machine's host name (`localhost` if it cannot be read).
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "localhost".into())
}

fn pid_alive(pid: u32) -> bool {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return false;
    };
    if pid <= 0 {
        return false;
    }
    // SAFETY: kill with signal 0 only checks whether the process exists.
    let r = unsafe { libc::kill(pid, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
}

/// Why `r` (seen at `now`) is stale, if it is: its pid is gone on this host, or it is older
/// than `stale_after`.
pub fn staleness(r: &Rendezvous, now: u64, stale_after: Duration) -> Option<String> {
    if r.host == host_name() && !pid_alive(r.pid) {
        return Some(format!(
            "written by pid {} on {}, which is no longer running",
            r.pid, r.host
        ));
    }
    let age = now.saturating_sub(r.created);
    if age > stale_after.as_secs() {
        return Some(format!(
            "written {age} s ago by pid {} on {}, longer ago than the {} s rendezvous timeout",
            r.pid,
            r.host,
            stale_after.as_secs()
        ));
    }
    None
}

/// Reads and parses a rendezvous file; `Ok(None)` when it does not exist.
pub fn read(path: &Path) -> Result<Option<Rendezvous>, RendezvousError> {
    use std::io::Read;
    let file = match file_guard::open_existing(path, false, Privacy::OwnerOnly) {
        Ok(f) => f,
        Err(GuardError::Io(e)) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(GuardError::Refused(refusal)) => {
            return Err(RendezvousError::Refused {
                path: path.into(),
                refusal,
            })
        }
        Err(GuardError::Io(source)) => {
            return Err(RendezvousError::Io {
                path: path.into(),
                source,
            })
        }
    };
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|source| RendezvousError::Io {
            path: path.into(),
            source,
        })?;
    let corrupt = |reason: String| RendezvousError::Corrupt {
        path: path.into(),
        reason,
    };
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(corrupt(format!("larger than {MAX_FILE_BYTES} bytes")));
    }
    let r: Rendezvous = serde_json::from_slice(&bytes).map_err(|e| corrupt(e.to_string()))?;
    if r.version != VERSION {
        return Err(corrupt(format!(
            "version {} (this parrt reads {VERSION})",
            r.version
        )));
    }
    Ok(Some(r))
}

/// A published rendezvous file; dropping it removes the file (if it is still this one).
#[derive(Debug)]
pub struct Published {
    path: PathBuf,
    token: String,
}

impl Published {
    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for Published {
    fn drop(&mut self) {
        if let Ok(Some(r)) = read(&self.path) {
            if r.token == self.token {
                let _ = std::fs::remove_file(&self.path);
            }
        }
    }
}

/// Refuses to go on when `dir` already holds a file for `job` (whatever its state, it is never
/// overwritten): says whose it is and whether it looks stale.
pub fn check_free(
    dir: &Path,
    job: &str,
    stale_after: Duration,
) -> Result<PathBuf, RendezvousError> {
    let path = path_for(dir, job);
    let existing = match read(&path) {
        Ok(None) => return Ok(path),
        Ok(Some(r)) => r,
        Err(RendezvousError::Corrupt { reason, .. }) => {
            return Err(RendezvousError::Exists {
                path: path.clone(),
                why: format!("not a parrt rendezvous file: {reason}"),
            })
        }
        Err(e) => return Err(e),
    };
    let why = if existing.job != job {
        format!("it belongs to job {:?}", existing.job)
    } else if let Some(s) = staleness(&existing, now_unix(), stale_after) {
        format!("stale: {s}")
    } else {
        format!(
            "in use by pid {} on {}, rank 0 of this job id",
            existing.pid, existing.host
        )
    };
    Err(RendezvousError::Exists { path, why })
}

/// Publishes `r` in `dir`: written to a temporary file of mode 0600, then linked to its name,
/// which fails if any file is already there (nothing is overwritten).
pub fn publish(
    dir: &Path,
    r: &Rendezvous,
    stale_after: Duration,
) -> Result<Published, RendezvousError> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let path = check_free(dir, &r.job, stale_after)?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        path.file_name()
            .map(|n| n.to_string_lossy())
            .unwrap_or_default(),
        std::process::id()
    ));
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |source| RendezvousError::Io { path: p, source }
    };
    let text = serde_json::to_vec_pretty(r).map_err(|e| RendezvousError::Corrupt {
        path: path.clone(),
        reason: e.to_string(),
    })?;
    let _ = std::fs::remove_file(&tmp);
    let written = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&tmp)?;
        f.write_all(&text)?;
        f.sync_all()
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(&tmp)(e));
    }
    let linked = std::fs::hard_link(&tmp, &path);
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Ok(()) => Ok(Published {
            path,
            token: r.token.clone(),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(RendezvousError::Exists {
            path,
            why: "another process created it a moment ago".into(),
        }),
        Err(e) => Err(io(&path)(e)),
    }
}

/// Waits up to `timeout` for rank 0's file of `job` in `dir` and checks it: this job's, this
/// number of ranks, not stale.
pub fn wait(
    dir: &Path,
    job: &str,
    size: usize,
    timeout: Duration,
) -> Result<Rendezvous, RendezvousError> {
    let path = path_for(dir, job);
    let start = Instant::now();
    let r = loop {
        if let Some(r) = read(&path)? {
            break r;
        }
        if start.elapsed() >= timeout {
            return Err(RendezvousError::Timeout {
                path,
                waited: timeout,
            });
        }
        std::thread::sleep(POLL);
    };
    check_joinable(&path, &r, job, size, timeout)?;
    Ok(r)
}

/// Checks that a rank of `job` with `size` ranks may use `r`.
pub fn check_joinable(
    path: &Path,
    r: &Rendezvous,
    job: &str,
    size: usize,
    stale_after: Duration,
) -> Result<(), RendezvousError> {
    if r.job != job {
        return Err(RendezvousError::Foreign {
            path: path.into(),
            theirs: r.job.clone(),
            ours: job.into(),
        });
    }
    if let Some(why) = staleness(r, now_unix(), stale_after) {
        return Err(RendezvousError::Stale {
            path: path.into(),
            why,
        });
    }
    if r.size != size {
        return Err(RendezvousError::SizeMismatch {
            path: path.into(),
            theirs: r.size,
            ours: size,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn sample(job: &str) -> Rendezvous {
        Rendezvous {
            version: VERSION,
            job: job.into(),
            size: 3,
            address: "127.0.0.1:4000".into(),
            token: "0123456789abcdef".into(),
            pid: std::process::id(),
            host: host_name(),
            created: now_unix(),
        }
    }

    const T: Duration = Duration::from_secs(60);

    /// Writes a file as rank 0 does: readable and writable by its owner only.
    fn write_private(path: &Path, bytes: impl AsRef<[u8]>) {
        std::fs::write(path, bytes).unwrap();
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600)).unwrap();
    }

    #[test]
    fn publish_then_wait_then_removed_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let r = sample("slurm-42.0");
        let p = publish(dir.path(), &r, T).unwrap();
        let mode = std::fs::metadata(p.path()).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        assert_eq!(wait(dir.path(), "slurm-42.0", 3, T).unwrap(), r);
        // Only the published file is in the directory: no temporary left.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        let path = p.path().to_path_buf();
        drop(p);
        assert!(!path.exists());
    }

    #[test]
    fn job_ids_are_made_safe_for_a_file_name() {
        let p = path_for(Path::new("d"), "../a b/c");
        assert_eq!(p, Path::new("d/parrt-rendezvous-.._a_b_c.json"));
        assert!(
            path_for(Path::new("d"), &"x".repeat(500))
                .to_string_lossy()
                .len()
                < 100
        );
    }

    #[test]
    fn existing_file_is_never_overwritten_and_says_why() {
        let dir = tempfile::tempdir().unwrap();
        let path = path_for(dir.path(), "j");
        // Live: this process.
        write_private(&path, serde_json::to_vec(&sample("j")).unwrap());
        let before = std::fs::read(&path).unwrap();
        let e = publish(dir.path(), &sample("j"), T).unwrap_err();
        assert!(e.to_string().contains("in use by pid"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), before);
        // Dead pid on this host.
        let mut dead = sample("j");
        dead.pid = u32::MAX - 1;
        write_private(&path, serde_json::to_vec(&dead).unwrap());
        let e = publish(dir.path(), &sample("j"), T).unwrap_err();
        assert!(e.to_string().contains("no longer running"), "{e}");
        // Old, from another host.
        let mut old = sample("j");
        old.host = "elsewhere".into();
        old.created -= 3600;
        let bytes = serde_json::to_vec(&old).unwrap();
        write_private(&path, &bytes);
        let e = publish(dir.path(), &sample("j"), T).unwrap_err();
        assert!(e.to_string().contains("3600 s ago"), "{e}");
        assert!(e.is_bad_input());
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
        // Garbage.
        write_private(&path, b"{");
        let e = publish(dir.path(), &sample("j"), T).unwrap_err();
        assert!(e.to_string().contains("not a parrt rendezvous file"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), b"{");
    }

    #[test]
    fn waiting_ranks_refuse_foreign_stale_and_resized_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = path_for(dir.path(), "j");
        write_private(&path, serde_json::to_vec(&sample("other")).unwrap());
        let e = wait(dir.path(), "j", 3, T).unwrap_err();
        assert!(matches!(e, RendezvousError::Foreign { .. }), "{e}");
        let mut dead = sample("j");
        dead.pid = u32::MAX - 1;
        write_private(&path, serde_json::to_vec(&dead).unwrap());
        let e = wait(dir.path(), "j", 3, T).unwrap_err();
        assert!(matches!(e, RendezvousError::Stale { .. }), "{e}");
        write_private(&path, serde_json::to_vec(&sample("j")).unwrap());
        let e = wait(dir.path(), "j", 4, T).unwrap_err();
        assert!(matches!(e, RendezvousError::SizeMismatch { .. }), "{e}");
        let mut v = sample("j");
        v.version = 99;
        write_private(&path, serde_json::to_vec(&v).unwrap());
        let e = wait(dir.path(), "j", 3, T).unwrap_err();
        assert!(matches!(e, RendezvousError::Corrupt { .. }), "{e}");
    }

    /// A file planted by another user (here `nobody`) naming their master is
    /// refused by every rank, and left alone.
    #[test]
    fn a_file_of_another_user_or_readable_by_others_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = path_for(dir.path(), "j");
        let mut planted = sample("j");
        planted.address = "127.0.0.1:1".into();
        let bytes = serde_json::to_vec(&planted).unwrap();
        std::fs::write(&path, &bytes).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = wait(dir.path(), "j", 3, T).unwrap_err();
        assert!(e.to_string().contains("mode 0644"), "{e}");
        assert!(e.is_bad_input());
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
        assert_eq!(
            wait(dir.path(), "j", 3, T).unwrap(),
            planted,
            "ours, private: read"
        );
        if file_guard::effective_uid() != 0 {
            eprintln!("not root: the other-owner case needs chown");
            return;
        }
        std::os::unix::fs::chown(&path, Some(65534), Some(65534)).unwrap();
        let e = wait(dir.path(), "j", 3, T).unwrap_err();
        assert!(matches!(e, RendezvousError::Refused { .. }), "{e}");
        assert!(e.to_string().contains("owned by uid 65534"), "{e}");
        assert!(e.is_bad_input());
        let e = publish(dir.path(), &sample("j"), T).unwrap_err();
        assert!(e.to_string().contains("owned by uid 65534"), "{e}");
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "left as it was");
    }

    /// A link or a FIFO at the path is refused at once, without waiting on the FIFO (which would
    /// hang every rank).
    #[test]
    fn a_link_or_a_fifo_is_refused_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let path = path_for(dir.path(), "j");
        let real = dir.path().join("real.json");
        std::fs::write(&real, serde_json::to_vec(&sample("j")).unwrap()).unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o600)).unwrap();
        std::os::unix::fs::symlink(&real, &path).unwrap();
        let e = wait(dir.path(), "j", 3, T).unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        std::fs::remove_file(&path).unwrap();
        let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo with a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let d = dir.path().to_path_buf();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send((wait(&d, "j", 3, T), check_free(&d, "j", T)));
        });
        // A hang guard, not a timing: without the check, opening the FIFO never returns.
        let (waited, free) = rx
            .recv_timeout(Duration::from_secs(30))
            .expect("reading a FIFO at the rendezvous path hung");
        let e = waited.unwrap_err();
        assert!(e.to_string().contains("a FIFO, not a regular file"), "{e}");
        assert!(e.is_bad_input());
        assert!(free.unwrap_err().to_string().contains("a FIFO"));
    }

    #[test]
    fn waiting_without_a_master_times_out() {
        let dir = tempfile::tempdir().unwrap();
        let e = wait(dir.path(), "j", 3, Duration::from_millis(250)).unwrap_err();
        assert!(matches!(e, RendezvousError::Timeout { .. }), "{e}");
        assert!(e.to_string().contains("--rendezvous DIR"), "{e}");
        assert!(e.is_bad_input());
    }
}
