//! Where the live view's address is told. A view without a key (loopback) is printed on
//! stderr as it is. A view's key is printed only to a terminal: `parrt master`'s and
//! `parrt cluster`'s stderr is often a log (Slurm keeps it in the job's output file), so when
//! stderr is not a terminal the address is printed without its key and the address with it is
//! written to a new file readable by its owner only (mode 0600, created, never opened if it
//! exists, in `$XDG_RUNTIME_DIR` or else the temporary directory), whose path is printed
//! instead. The file is removed when the view stops, and on every way out that unwinds (an
//! error, a render ended by SIGINT or SIGTERM): its [`Announced`] removes it when dropped.

use super::server::LiveView;
use anyhow::Context;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;

/// A file the address with its key was written to, if one was.
#[derive(Debug, Default)]
pub struct Announced {
    /// The file's path.
    pub file: Option<PathBuf>,
}

impl Announced {
    /// Removes the file (the key is no use once the view stopped).
    pub fn remove(&mut self) {
        if let Some(f) = self.file.take() {
            let _ = std::fs::remove_file(f);
        }
    }
}

impl Drop for Announced {
    fn drop(&mut self) {
        self.remove();
    }
}

/// Tells `view`'s address on `err`: with its key only when `err` is the process's stderr and a
/// terminal, else by a 0600 file's path (see the module's doc).
pub fn announce(view: &LiveView, err: &mut std::io::Stderr) -> anyhow::Result<Announced> {
    let terminal = err.is_terminal();
    announce_to(view.url(), view.base_url(), err, terminal, &key_dir())
}

/// Where the file with the key goes: `$XDG_RUNTIME_DIR` (a directory only its user may enter)
/// when set to a directory, else the temporary directory.
fn key_dir() -> PathBuf {
    std::env::var_os("XDG_RUNTIME_DIR")
        .map(PathBuf::from)
        .filter(|d| d.is_absolute() && d.is_dir())
        .unwrap_or_else(std::env::temp_dir)
}

/// [`announce`] of `url` (the address with its key, or `base` itself when it needs none) to
/// `out`, `terminal` or not, the file (if any) in `dir`.
pub fn announce_to(
    url: &str,
    base: &str,
    out: &mut impl Write,
    terminal: bool,
    dir: &std::path::Path,
) -> anyhow::Result<Announced> {
    if url == base || terminal {
        // A failed write to stderr is no reason to stop a render.
        let _ = writeln!(out, "parrt: live view at {url}");
        return Ok(Announced::default());
    }
    let file = write_private(dir, url)?;
    let _ = writeln!(
        out,
        "parrt: live view at {base} (its key is not printed: the address with it is in {}, readable by you only)",
        file.display()
    );
    Ok(Announced { file: Some(file) })
}

/// Writes `url` to a new file in `dir` that only its owner may read, under a name nobody can
/// have made ready for it (a random part; an existing file, or a link, is never opened).
fn write_private(dir: &std::path::Path, url: &str) -> anyhow::Result<PathBuf> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut last = None;
    for _ in 0..8 {
        let path = dir.join(format!(
            "parrt-live-view-{:016x}.url",
            rand::random::<u64>()
        ));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(&path)
        {
            Ok(mut f) => {
                f.write_all(format!("{url}\n").as_bytes())
                    .with_context(|| {
                        format!("cannot write the live view's address to {}", path.display())
                    })?;
                return Ok(path);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => {
                return Err(e).with_context(|| {
                    format!(
                        "cannot create {} for the live view's address",
                        path.display()
                    )
                })
            }
        }
    }
    Err(anyhow::anyhow!(
        "cannot create a file for the live view's address in {}: {}",
        dir.display(),
        last.map_or_else(String::new, |e| e.to_string())
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn a_key_goes_to_a_terminal_or_a_private_file_never_to_a_log() {
        let dir = tempfile::tempdir().expect("a directory");
        let (url, base) = ("http://localhost:9/?key=abc123", "http://localhost:9/");
        let mut log = Vec::new();
        let a = announce_to(url, base, &mut log, false, dir.path()).expect("announced");
        let log = String::from_utf8(log).expect("text");
        assert!(!log.contains("abc123"), "{log}");
        assert!(
            log.starts_with("parrt: live view at http://localhost:9/ "),
            "{log}"
        );
        let file = a.file.clone().expect("a file");
        assert!(log.contains(&file.display().to_string()), "{log}");
        assert_eq!(
            std::fs::read_to_string(&file).expect("read"),
            format!("{url}\n")
        );
        let mode = std::fs::metadata(&file).expect("meta").permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        let mut a = a;
        a.remove();
        assert!(!file.exists());
        // A run that fails or is stopped drops its view without `end`: the file goes too.
        let a = announce_to(url, base, &mut Vec::new(), false, dir.path()).expect("announced");
        let file = a.file.clone().expect("a file");
        assert!(file.exists());
        drop(a);
        assert!(!file.exists(), "the key file outlived the view");

        let mut tty = Vec::new();
        let a = announce_to(url, base, &mut tty, true, dir.path()).expect("announced");
        assert!(a.file.is_none());
        assert_eq!(tty, format!("parrt: live view at {url}\n").into_bytes());
        let mut open = Vec::new();
        announce_to(base, base, &mut open, false, dir.path()).expect("announced");
        assert_eq!(open, format!("parrt: live view at {base}\n").into_bytes());
    }
}
