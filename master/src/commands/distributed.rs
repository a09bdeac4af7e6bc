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

/// The most work, in seconds at the mean tile cost, in one assignment to a worker on this
/// machine: ten times a remote worker's ([`parrt_runtime::batch::BATCH_SECONDS`]). Here the
/// master and the workers' network threads share the cores with the render threads, so every
/// message, each way, wakes a thread that takes a render thread's core for a while: a 24-frame
/// orbit of mount:6 at 512² (tiles of about 0.4 ms) through two workers of one thread went from
/// 0.83 of two SMP threads' speed with 2 ms batches two to a thread to 0.93–0.95 with 20 ms
/// batches four to a thread (10 ms: 0.89 two to a thread, 0.93 four; 40 ms: 0.95).
const LOCAL_BATCH_SECONDS: f64 = 0.02;

/// The most tiles in one assignment to a worker on this machine (a remote worker's default is
/// 8): 20 ms of cheap tiles is more than that.
const LOCAL_MAX_BATCH: usize = 64;

/// Assignments a worker on this machine holds per render thread: four, so that the one being
/// rendered has three behind it while results and new batches wait for a core.
const LOCAL_WINDOW: usize = 4;

/// Makes `config` start `count` workers of `threads` threads on this machine. They leave their
/// pixels in memory shared with the master ([`parrt_protocol::shared_pixels`]) rather than
/// sealing and sending them through the kernel, where every process shares the cores; and what
/// goes over the loopback is not packed, which would only take CPU from the render threads.
/// Their batches are larger and their windows deeper than a remote worker's
/// (20 ms of work, 64 tiles, four to a thread): a message costs more here, where every process
/// shares the cores.
pub fn local_workers(config: &mut MasterConfig, count: usize, threads: usize) {
    config.spawn.count = count;
    config.spawn.threads = threads;
    config.spawn.share_pixels = true;
    config.schedule.pack_pixels = false;
    config.schedule.batch_seconds = LOCAL_BATCH_SECONDS;
    config.schedule.max_batch = LOCAL_MAX_BATCH;
    config.schedule.window = parrt_runtime::window::Window::PerThread(LOCAL_WINDOW);
}
