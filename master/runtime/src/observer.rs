//! Watchers of a distributed render: the scheduler tells each [`Observer`] what happens to
//! workers and tiles as it happens (the timeline recorder and the live view are two). Called
//! on the scheduler's task: an observer must be quick and must never wait for anything slow
//! (a client, a disk); it keeps what it needs and lets others do the rest.

use super::scheduler::WorkerId;
use parrt_render::film::Rgb;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use std::sync::Arc;
use tokio::time::Instant;

/// What the scheduler reports. Every method does nothing unless overridden. Methods without a
/// `now` happen deep in the scheduler's rules: read the (tokio) clock when they are called.
#[allow(unused_variables)]
pub trait Observer: Send + Sync {
    /// The first tiles are about to be handed out: the trace phase begins.
    fn started(&self, now: Instant) {}
    /// A worker authenticated and was sent the job.
    fn joined(&self, id: WorkerId, name: &str, threads: u32, now: Instant) {}
    /// A worker built the job.
    fn ready(&self, id: WorkerId, now: Instant) {}
    /// A tile was handed to a worker (`backup`: a copy of a tile in flight elsewhere).
    fn assigned(&self, id: WorkerId, tile: &Tile, attempt: u32, backup: bool, now: Instant) {}
    /// A checked result came in; `accepted` is false for a duplicate that was ignored. The
    /// pixels are only those of an accepted result (empty otherwise).
    fn result(
        &self,
        id: WorkerId,
        tile: &Tile,
        pixels: &[Rgb],
        stats: &RayStats,
        seconds: f64,
        accepted: bool,
    ) {
    }
    /// [`Self::assigned`] of a tile of frame `frame` of a sequence (0 for one frame): what
    /// the scheduler calls; an observer that tells frames apart overrides it.
    fn assigned_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        attempt: u32,
        backup: bool,
        now: Instant,
    ) {
        self.assigned(id, tile, attempt, backup, now)
    }
    /// [`Self::result`] of a tile of frame `frame` of a sequence (0 for one frame): what the
    /// scheduler calls; an observer that tells frames apart overrides it.
    #[allow(clippy::too_many_arguments)]
    fn result_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        pixels: &[Rgb],
        stats: &RayStats,
        seconds: f64,
        accepted: bool,
    ) {
        self.result(id, tile, pixels, stats, seconds, accepted)
    }
    /// A tile went back to the queue.
    fn requeued(&self, tile_id: u32) {}
    /// A worker left or was dropped; its tiles are requeued next.
    fn left(&self, id: WorkerId, reason: &str) {}
    /// Once per turn of the master's loop: tiles done of `total`, and each working
    /// worker's recent tiles per second (the progress bar draws these).
    fn progress(&self, done: usize, total: usize, workers: &[(String, f64)]) {}
    /// The render ended (`complete`: every tile is in the image).
    fn finished(&self, complete: bool, now: Instant) {}
}

/// The observers of one render, shared with the caller that reads them afterwards.
#[derive(Clone, Default)]
pub struct Observers(pub Vec<Arc<dyn Observer>>);

impl Observers {
    /// Calls `f` on each observer.
    pub fn each(&self, f: impl Fn(&dyn Observer)) {
        for o in &self.0 {
            f(o.as_ref());
        }
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl std::fmt::Debug for Observers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Observers({})", self.0.len())
    }
}
