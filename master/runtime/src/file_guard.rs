//! Opening the files a master keeps where other users may reach (the checkpoint, the
//! rendezvous file): never through a symbolic link, never blocking on a FIFO or a device, and
//! only a regular file that this user owns and no one else may write. Also the exclusive lock
//! that makes one checkpoint one master's, and who holds it when it is taken.

use std::fs::{File, OpenOptions};
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::Path;
use thiserror::Error;

/// Why an existing file is not used (bad input: the caller leaves it as it is).
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// The path is a symbolic link (it could point anywhere, another user's file included).
    #[error("is a symbolic link, not a regular file (links are not followed)")]
    Link,
    /// A FIFO, a device, a directory or a socket.
    #[error("is {0}, not a regular file")]
    NotRegular(&'static str),
    /// Another user's file.
    #[error("is owned by uid {owner}, not by this user (uid {ours}): not trusted")]
    Owner {
        /// Its owner.
        owner: u32,
        /// This process's effective uid.
        ours: u32,
    },
    /// Others than its owner may change it (or, for a secret, read it).
    #[error("has mode {mode:04o}, which lets {who} {what} it: not trusted (chmod {want:o} it, or remove it)")]
    Mode {
        /// The permission bits.
        mode: u32,
        /// `group`, `others` or both.
        who: &'static str,
        /// `write` or `read or write`.
        what: &'static str,
        /// The mode it should have.
        want: u32,
    },
}

/// Opening a guarded file failed: refused, or the system failed (missing file included).
#[derive(Debug, Error)]
pub enum GuardError {
    /// The file is there but not to be trusted.
    #[error(transparent)]
    Refused(#[from] Refusal),
    /// The file could not be opened or examined (`NotFound` when it is absent).
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// Which permission bits a guarded file may not have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Privacy {
    /// No one but the owner may write it (a checkpoint): `mode & 0o022 == 0`.
    OwnerWrites,
    /// A secret: no one but the owner may read or write it (the rendezvous file, which holds
    /// the job's token): `mode & 0o077 == 0`.
    OwnerOnly,
}

/// This process's effective user id.
pub fn effective_uid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// Checks an opened file's metadata: a regular file of this user, with no permission bits
/// that `privacy` forbids.
pub fn check(m: &std::fs::Metadata, privacy: Privacy) -> Result<(), Refusal> {
    if !m.file_type().is_file() {
        return Err(Refusal::NotRegular(parrt_render::nff::read::kind_of(
            m.file_type(),
        )));
    }
    let ours = effective_uid();
    if m.uid() != ours {
        return Err(Refusal::Owner {
            owner: m.uid(),
            ours,
        });
    }
    let mode = m.mode() & 0o7777;
    let (forbidden, what, want) = match privacy {
        Privacy::OwnerWrites => (0o022, "write", mode & !0o022),
        Privacy::OwnerOnly => (0o077, "read or write", 0o600),
    };
    let bad = mode & forbidden;
    if bad != 0 {
        let who = match (bad & 0o070 != 0, bad & 0o007 != 0) {
            (true, true) => "group and others",
            (true, false) => "its group",
            _ => "others",
        };
        return Err(Refusal::Mode {
            mode,
            who,
            what,
            want,
        });
    }
    Ok(())
}

/// Opens an existing file at `path` (for reading, and writing when `write`) without following
/// a symbolic link at its last component and without blocking (a FIFO opens at once and is
/// then refused), and checks the opened file with [`check`]. A missing file is
/// `GuardError::Io` of kind `NotFound`.
pub fn open_existing(path: &Path, write: bool, privacy: Privacy) -> Result<File, GuardError> {
    let file = OpenOptions::new()
        .read(true)
        .write(write)
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_CLOEXEC)
        .open(path)
        .map_err(|e| match e.raw_os_error() {
            Some(libc::ELOOP) => GuardError::Refused(Refusal::Link),
            _ => GuardError::Io(e),
        })?;
    let m = file.metadata()?;
    check(&m, privacy)?;
    Ok(file)
}

/// Takes an exclusive lock on `file` without waiting (`flock`, released when the file is
/// closed, by this process's exit too). `Ok(None)` when taken; `Ok(Some(holder))` when another
/// open file holds it, with who that is as far as `/proc/locks` tells.
pub fn try_lock(file: &File) -> std::io::Result<Option<String>> {
    use std::os::fd::AsRawFd;
    // SAFETY: flock on a descriptor this `File` owns; it only changes the lock state.
    let r = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
    if r == 0 {
        return Ok(None);
    }
    let e = std::io::Error::last_os_error();
    if e.raw_os_error() != Some(libc::EWOULDBLOCK) {
        return Err(e);
    }
    // Named only when device and inode both match, and worded as what /proc/locks says, not
    // as a certainty: a user may act on it (stop that process).
    let holder = file
        .metadata()
        .ok()
        .and_then(|m| lock_holder(FileId::of(m.dev(), m.ino())))
        .map_or_else(
            || "another process; /proc/locks does not say which".to_string(),
            |pid| {
                format!(
                    "process {pid} holds its lock, as /proc/locks says; check with \
                     `ps -p {pid}` that it is a parrt master before stopping it"
                )
            },
        );
    Ok(Some(holder))
}

/// A file as `/proc/locks` names it: the device's major and minor numbers and the inode (an
/// inode number alone is unique only within one file system).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct FileId {
    major: u64,
    minor: u64,
    ino: u64,
}

impl FileId {
    fn of(dev: u64, ino: u64) -> FileId {
        FileId {
            major: libc::major(dev) as u64,
            minor: libc::minor(dev) as u64,
            ino,
        }
    }

    /// Parses `/proc/locks`' `MAJOR:MINOR:INODE` (the device numbers in hex, the inode in
    /// decimal).
    fn parse(text: &str) -> Option<FileId> {
        let mut it = text.split(':');
        let major = u64::from_str_radix(it.next()?, 16).ok()?;
        let minor = u64::from_str_radix(it.next()?, 16).ok()?;
        let ino = it.next()?.parse().ok()?;
        it.next().is_none().then_some(FileId { major, minor, ino })
    }
}

/// The process holding a `flock` on the file `id`, from `/proc/locks` (lines such as
/// `1: FLOCK  ADVISORY  WRITE 1234 fd:01:5678 0 EOF`).
///
/// The kernel lists the locks afresh on each `read`, so a file read in several calls can skip
/// a line when other locks come and go between them. The file is therefore read in one large
/// call, and read again (a few times) when the lock, known to be held, is not in it.
fn lock_holder(id: FileId) -> Option<u32> {
    use std::io::Read;
    const ONE_READ: usize = 1 << 20;
    let mut buf = vec![0u8; ONE_READ];
    (0..4).find_map(|_| {
        let n = File::open("/proc/locks").ok()?.read(&mut buf).ok()?;
        holder_in(std::str::from_utf8(&buf[..n]).ok()?, id)
    })
}

/// The pid of the `FLOCK` holder of the file `id` in a `/proc/locks` text (lines marked `->`
/// are processes waiting for a lock, not holding it).
fn holder_in(text: &str, id: FileId) -> Option<u32> {
    text.lines().find_map(|line| {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.contains(&"->") {
            return None;
        }
        let at = f.iter().position(|w| *w == "FLOCK")?;
        let pid: u32 = f.get(at + 3)?.parse().ok()?;
        (FileId::parse(f.get(at + 4)?)? == id).then_some(pid)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn chmod(p: &Path, mode: u32) {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
    }

    #[test]
    fn regular_own_private_files_open_and_others_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f");
        std::fs::write(&f, b"x").unwrap();
        chmod(&f, 0o600);
        assert!(open_existing(&f, true, Privacy::OwnerOnly).is_ok());
        chmod(&f, 0o644);
        assert!(open_existing(&f, true, Privacy::OwnerWrites).is_ok());
        let e = open_existing(&f, false, Privacy::OwnerOnly).unwrap_err();
        assert!(e.to_string().contains("mode 0644"), "{e}");
        chmod(&f, 0o666);
        let e = open_existing(&f, false, Privacy::OwnerWrites).unwrap_err();
        assert!(e.to_string().contains("group and others write"), "{e}");
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&f, &link).unwrap();
        let e = open_existing(&link, false, Privacy::OwnerWrites).unwrap_err();
        assert!(matches!(e, GuardError::Refused(Refusal::Link)), "{e}");
        let e = open_existing(Path::new("/dev/zero"), false, Privacy::OwnerWrites).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
        let e = open_existing(&dir.path().join("none"), false, Privacy::OwnerWrites).unwrap_err();
        assert!(
            matches!(&e, GuardError::Io(io) if io.kind() == std::io::ErrorKind::NotFound),
            "{e}"
        );
    }

    #[test]
    fn a_second_lock_is_refused_and_names_the_holder() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f");
        std::fs::write(&f, b"x").unwrap();
        let a = File::open(&f).unwrap();
        let b = File::open(&f).unwrap();
        assert_eq!(try_lock(&a).unwrap(), None);
        let held = try_lock(&b).unwrap().expect("held by the first");
        let pid = std::process::id();
        assert_eq!(
            held,
            format!(
                "process {pid} holds its lock, as /proc/locks says; check with `ps -p {pid}` \
                 that it is a parrt master before stopping it"
            )
        );
        drop(a);
        assert_eq!(try_lock(&b).unwrap(), None);
    }

    #[test]
    fn the_holder_is_read_from_flock_lines_only() {
        let text = "1: POSIX  ADVISORY  WRITE 77 fd:01:42 0 EOF\n\
                    2: -> FLOCK  ADVISORY  WRITE 99 fd:01:5678 0 EOF\n\
                    2: FLOCK  ADVISORY  WRITE 1234 fd:01:5678 0 EOF\n\
                    3: FLOCK  ADVISORY  WRITE -1 fd:01:7 0 EOF\n";
        let id = |ino| FileId {
            major: 0xfd,
            minor: 1,
            ino,
        };
        assert_eq!(
            holder_in(text, id(5678)),
            Some(1234),
            "the holder, not the waiter"
        );
        assert_eq!(holder_in(text, id(42)), None, "a POSIX lock is not a flock");
        assert_eq!(
            holder_in(text, id(7)),
            None,
            "a pid hidden from this namespace"
        );
        assert_eq!(holder_in(text, id(8)), None);
    }

    /// The same inode number on another file system (another device) is another file: its
    /// lock's holder is not named.
    #[test]
    fn a_lock_on_the_same_inode_of_another_device_names_no_one() {
        let text = "1: FLOCK  ADVISORY  WRITE 4321 08:02:5678 0 EOF\n\
                    2: FLOCK  ADVISORY  WRITE 1234 fd:01:5678 0 EOF\n";
        let ours = FileId {
            major: 0xfd,
            minor: 1,
            ino: 5678,
        };
        assert_eq!(holder_in(text, ours), Some(1234));
        let elsewhere = FileId {
            major: 0x103,
            minor: 0,
            ino: 5678,
        };
        assert_eq!(holder_in(text, elsewhere), None);
        assert_eq!(
            FileId::parse("103:00:5678"),
            Some(FileId {
                major: 0x103,
                minor: 0,
                ino: 5678
            })
        );
    }
}
