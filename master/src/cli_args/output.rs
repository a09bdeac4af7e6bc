//! Outputs named on the command line, checked before any work: an image's format and a writable
//! place for it (`-o`), other files (`--stats-json`, `--report-json`, `--tile-costs`) and the
//! output directories of the bench studies. A bad output is bad input (exit 2), found before a
//! render that could take hours rather than after it. No two of a command's files may be one
//! file ([`check_distinct`]). Text outputs are written whole by [`write_whole`], as images are.

use super::ArgError;
use std::path::Path;

/// Checks an image output (`-o`): a format parrt writes and a place it can be written.
pub fn check_image_output(path: &Path) -> anyhow::Result<()> {
    parrt_render::film::check_output(path).map_err(ArgError::refused)?;
    Ok(())
}

/// Checks a non-image output file: a place it can be written.
pub fn check_file_output(path: &Path) -> anyhow::Result<()> {
    Ok(parrt_render::film::check_writable(path).map_err(ArgError::refused)?)
}

/// What a path is, as the file system sees it: an existing file by device and inode (so
/// `./out.png`, `out.png`, a hard link and a symbolic link to it are one), a file still to be
/// written by its directory's canonical path and its name.
#[derive(Debug, PartialEq, Eq)]
enum Identity {
    Inode(u64, u64),
    New(std::path::PathBuf),
}

fn identity(path: &Path) -> Option<Identity> {
    use std::os::unix::fs::MetadataExt;
    if let Ok(m) = std::fs::metadata(path) {
        return Some(Identity::Inode(m.dev(), m.ino()));
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let dir = std::fs::canonicalize(parent).ok()?;
    Some(Identity::New(dir.join(name)))
}

/// Refuses two of `files` that are one file (an output that would overwrite the scene, or
/// another output, or the checkpoint): compared by file identity, not by their text. Each is
/// the flag that names it (`-o`, `--timeline`, `the scene`, …) and its path, if given. Bad
/// input (exit 2) naming both flags. A path whose identity cannot be found (its directory
/// missing) is left to the output checks, which say why.
pub fn check_distinct(files: &[(&str, Option<&Path>)]) -> anyhow::Result<()> {
    let given: Vec<(&str, &Path, Option<Identity>)> = files
        .iter()
        .filter_map(|&(flag, p)| p.map(|p| (flag, p, identity(p))))
        .collect();
    for (i, (flag_a, a, id_a)) in given.iter().enumerate() {
        for (flag_b, b, id_b) in &given[i + 1..] {
            if id_a.is_some() && id_a == id_b {
                return Err(ArgError::Conflict(format!(
                    "{flag_a} {} and {flag_b} {} are the same file; give each its own",
                    a.display(),
                    b.display()
                ))
                .into());
            }
        }
    }
    Ok(())
}

/// Creates an output directory (and its parents) and checks that files can be written in it.
pub fn prepare_out_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| ArgError::Value(format!("cannot create {}: {e}", dir.display())))?;
    check_file_output(&dir.join("probe"))
}

/// Writes `bytes` to `path` as images are written: whole into a new temporary file beside it,
/// then renamed onto it, so a failure leaves no half-written file. What is already at `path`
/// must be a regular file (it is replaced) or nothing: a symbolic link there is not followed
/// (writing through it would overwrite whatever it points at) and a FIFO, device or
/// directory is not opened (a FIFO would block for ever); both are refused as bad input
/// (exit 2) naming the path.
pub fn write_whole(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt;
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            return Err(ArgError::file(
                path,
                "is a symbolic link, not a regular file (links are not followed)",
            )
            .into())
        }
        Ok(m) if !m.file_type().is_file() => {
            let kind = parrt_render::nff::read::kind_of(m.file_type());
            return Err(ArgError::file(path, format!("is {kind}, not a regular file")).into());
        }
        _ => {}
    }
    let tmp = parrt_render::film::temp_beside(path);
    let written = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
        .open(&tmp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(anyhow::Error::new(e).context(format!("cannot write {}", path.display())));
    }
    Ok(())
}
