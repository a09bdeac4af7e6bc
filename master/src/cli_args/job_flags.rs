//! The flags about a render job's record that the three distributed entry points
//! (`render --workers`, `master`, `cluster`) share, declared once: the checkpoint, the resume,
//! the timeline and the live view. Each command flattens [`JobFlags`] into its own `Args`, and
//! checks and names its files through it, so the three cannot drift apart.

use super::live::LiveArgs;
use super::output::{check_distinct, check_file_output};
use clap::Args;
use std::path::{Path, PathBuf};

/// A render job's checkpoint, timeline and live view.
#[derive(Debug, Clone, Args)]
pub struct JobFlags {
    /// Record each accepted tile in FILE: append-only, every record checksummed, synced to disk
    /// at least every second. If the master dies, run the same command with --resume to render
    /// only the tiles not in FILE. An existing FILE is refused without --resume. (`parrt
    /// render` keeps a checkpoint only with --workers.)
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Continue the render recorded in --checkpoint FILE: its good records are kept (a torn or
    /// corrupt record is dropped and its tile rendered again), the rest is rendered. A FILE of
    /// another scene or other settings is refused (exit 2) and left unchanged.
    #[arg(long, requires = "checkpoint")]
    pub resume: bool,
    /// Write the render's timeline to FILE: per tile who rendered it (a thread or a worker),
    /// when, and which attempt; faults as events (CSV for .csv, else JSON; columns in
    /// docs/timeline.md).
    #[arg(long, value_name = "FILE")]
    pub timeline: Option<PathBuf>,
    /// Live view in a browser (off loopback: the master's token is required).
    #[command(flatten)]
    pub live: LiveArgs,
}

impl JobFlags {
    /// Refuses (bad input, before any work) a checkpoint or timeline that could not be
    /// written, and any two of the command's `files` (flag and path: its outputs and inputs)
    /// and these flags' files that are one file.
    pub fn check_outputs(&self, files: &[(&str, Option<&Path>)]) -> anyhow::Result<()> {
        let own = [
            ("--checkpoint", self.checkpoint.as_deref()),
            ("--timeline", self.timeline.as_deref()),
        ];
        for path in own.iter().filter_map(|&(_, p)| p) {
            check_file_output(path)?;
        }
        let all: Vec<(&str, Option<&Path>)> = files.iter().chain(&own).copied().collect();
        check_distinct(&all)
    }
}
