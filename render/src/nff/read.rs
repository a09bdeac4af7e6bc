//! Reading a file the user named, bounded: only a regular file (a directory, FIFO, device or
//! socket is refused before it is opened for reading, so `/dev/zero` cannot fill memory) and at
//! most a byte limit ([`Limits::max_file_bytes`](super::Limits::max_file_bytes)), checked on the
//! size and again while reading, in case the file grows.

use std::fs::FileType;
use std::io::Read;
use std::path::Path;
use thiserror::Error;

/// Why a file could not be read. The messages do not repeat the path: callers prefix it.
#[derive(Debug, Error)]
pub enum ReadError {
    /// The path names something other than a regular file.
    #[error("is {0}, not a regular file")]
    NotAFile(&'static str),
    /// The file is larger than the limit.
    #[error("is larger than the limit of {max} bytes (raise it with --max-file-bytes)")]
    TooLarge {
        /// The limit.
        max: u64,
    },
    /// The operating system refused (missing, unreadable). Shown in the message, not as a
    /// source, so `{:#}` prints it once.
    #[error("cannot read the file: {0}")]
    Io(std::io::Error),
}

/// What kind of thing a non-regular file is, for messages (shared with the master's file
/// guard, which also meets links: it opens without following them).
pub fn kind_of(t: FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

/// Reads the regular file at `path` (symbolic links followed), at most `max_bytes` of it.
pub fn read_bounded(path: &Path, max_bytes: u64) -> Result<Vec<u8>, ReadError> {
    // Look before opening: opening a FIFO for reading blocks until a writer comes.
    let meta = std::fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile(kind_of(meta.file_type())));
    }
    // Non-blocking, in case the path became a FIFO since: the open returns at once, and the
    // check below refuses it. (On a regular file the flag changes nothing.)
    let file = {
        use std::os::unix::fs::OpenOptionsExt;
        std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(path)
            .map_err(ReadError::Io)?
    };
    // The opened file is what is read: check it too (the path may have changed since).
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile(kind_of(meta.file_type())));
    }
    if meta.len() > max_bytes {
        return Err(ReadError::TooLarge { max: max_bytes });
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(ReadError::TooLarge { max: max_bytes });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_what_is_not_a_small_regular_file() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(
            read_bounded(dir.path(), 100).unwrap_err().to_string(),
            "is a directory, not a regular file"
        );
        assert_eq!(
            read_bounded(Path::new("/dev/zero"), 100)
                .unwrap_err()
                .to_string(),
            "is a character device, not a regular file"
        );
        let f = dir.path().join("f");
        std::fs::write(&f, b"12345").unwrap();
        assert_eq!(read_bounded(&f, 5).unwrap(), b"12345");
        assert!(matches!(
            read_bounded(&f, 4),
            Err(ReadError::TooLarge { max: 4 })
        ));
        let e = read_bounded(&dir.path().join("missing"), 5).unwrap_err();
        assert!(e.to_string().starts_with("cannot read the file: "), "{e}");
    }
}
