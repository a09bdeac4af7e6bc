//! Outputs named on the command line, checked before any work: an image's format and a writable
//! place for it (`-o`), other files (`--stats-json`, `--report-json`, `--tile-costs`) and the
//! output directories of the bench studies. A bad output is bad input (exit 2), found before a
//! render that could take hours rather than after it.

use crate::exit::input_error;
use std::path::Path;

/// Checks an image output (`-o`): a format parrt writes and a place it can be written.
pub fn check_image_output(path: &Path) -> anyhow::Result<()> {
    parrt::film::check_output(path).map_err(input_error)?;
    Ok(())
}

/// Checks a non-image output file: a place it can be written.
pub fn check_file_output(path: &Path) -> anyhow::Result<()> {
    parrt::film::check_writable(path).map_err(input_error)
}

/// Refuses a `--checkpoint` file that is also another output of the run (it would be
/// overwritten by it, or overwrite it).
pub fn check_checkpoint_apart(checkpoint: &Path, others: &[&Path]) -> anyhow::Result<()> {
    if others.contains(&checkpoint) {
        return Err(input_error(anyhow::anyhow!(
            "--checkpoint {} is also an output of this run; give it a file of its own",
            checkpoint.display()
        )));
    }
    Ok(())
}

/// Creates an output directory (and its parents) and checks that files can be written in it.
pub fn prepare_out_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| input_error(anyhow::anyhow!("cannot create {}: {e}", dir.display())))?;
    check_file_output(&dir.join("probe"))
}
