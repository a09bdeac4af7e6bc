//! The master configuration the three distributed entry points (`render --workers`, `master`,
//! `cluster`) share, with their flags ([`JobFlags`]): who observes the render, the checkpoint and how its records are sealed,
//! the tile size, how many workers to wait for and the pixel format the output needs. Each
//! command adds what only it has (spawned workers, a listen address and token, schedule
//! tuning).

use crate::cli_args::JobFlags;
use parrt_runtime::observer::Observers;
use parrt_runtime::{CheckpointAt, MasterConfig};
use std::path::Path;

/// What every distributed entry point decides about its master.
pub struct MasterSetup<'a> {
    /// Who watches the render (progress, timeline, live view).
    pub observers: Observers,
    /// The job's flags (`--checkpoint FILE`, `--resume`).
    pub job: &'a JobFlags,
    /// Whether checkpoint records are sealed with the token: only when the token outlives the
    /// run (the user gives it again to resume); a token made for one run keys nothing.
    pub keyed: bool,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Workers that must be ready before rendering starts.
    pub min_workers: usize,
    /// The output image, whose kind decides the pixels' format on the wire.
    pub output: &'a Path,
}

/// The master configuration of `s`, every other field at its default.
pub fn master_config(s: MasterSetup<'_>) -> MasterConfig {
    let mut config = MasterConfig {
        observers: s.observers,
        checkpoint: s.job.checkpoint.as_ref().map(|path| CheckpointAt {
            path: path.clone(),
            resume: s.job.resume,
            keyed: s.keyed,
        }),
        ..MasterConfig::default()
    };
    config.schedule.tile = s.tile;
    config.schedule.min_workers = s.min_workers;
    config.schedule.pixel_format = parrt_runtime::pixel_format_for(s.output);
    config
}

/// Makes `config` start `count` workers of `threads` threads on this machine. They do not pack
/// their pixels: the loopback costs nothing to cross, and packing would only take CPU from the
/// render threads.
pub fn local_workers(config: &mut MasterConfig, count: usize, threads: usize) {
    config.spawn.count = count;
    config.spawn.threads = threads;
    config.schedule.pack_pixels = false;
}
