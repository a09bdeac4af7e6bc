//! What `/status` returns: the render's phase, a row per worker (or render thread), the
//! newest faults and the counts (keys documented in `docs/live-view.md`), as
//! [`super::state::LiveState`] keeps them.

use serde::Serialize;
use std::time::Instant;

/// A worker's (or render thread's) state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum WorkerState {
    /// Connected, building the scene.
    Building,
    /// Taking tiles.
    Rendering,
    /// Missed a deadline: its tiles were given to others (it may still deliver).
    Requeued,
    /// Left or was dropped.
    Lost,
    /// The render is over.
    Done,
}

/// One row of the page.
#[derive(Clone, Debug, Serialize)]
pub struct WorkerStatus {
    /// Its name (`thread N` for an SMP render thread).
    pub name: String,
    /// Its render threads.
    pub threads: u32,
    /// Its state.
    pub state: WorkerState,
    /// Tiles it delivered that are in the image.
    pub tiles: u64,
    /// Rays it traced for those tiles.
    pub rays: u64,
    /// Its rays per second (millions) since it was ready.
    pub mrays_per_s: f64,
    /// Why it left, if it did.
    pub left: Option<String>,
    #[serde(skip)]
    pub(super) id: u64,
    #[serde(skip)]
    pub(super) ready_at: Option<Instant>,
    #[serde(skip)]
    pub(super) end_at: Option<Instant>,
}

/// A fault the page lists.
#[derive(Clone, Debug, Serialize)]
pub struct Fault {
    /// Seconds since the live view began.
    pub t_s: f64,
    /// `worker-lost` or `tile-requeued`.
    pub kind: &'static str,
    /// The worker, if one.
    pub worker: Option<String>,
    /// The tile, if one.
    pub tile: Option<u32>,
    /// Why.
    pub detail: String,
}

/// The render's phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// Waiting for workers or building.
    Starting,
    /// Tracing.
    Rendering,
    /// Every tile is in the image.
    Done,
    /// Ended without every tile.
    Failed,
}

/// Everything `/status` returns (keys documented in `docs/live-view.md`).
#[derive(Clone, Debug, Serialize)]
pub struct Status {
    /// The scene's label.
    pub scene: String,
    /// `smp` or `distributed`.
    pub mode: &'static str,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile edge.
    pub tile_size: u32,
    /// The phase.
    pub state: Phase,
    /// Tiles in the image.
    pub tiles_total: usize,
    /// Tiles done.
    pub tiles_done: usize,
    /// Seconds since the trace began (0 before).
    pub elapsed_s: f64,
    /// Seconds left at the rate so far (`null` until a tile is done, 0 when done).
    pub eta_s: Option<f64>,
    /// Rays traced for the tiles done.
    pub rays: u64,
    /// Millions of rays per second since the trace began.
    pub mrays_per_s: f64,
    /// A row per worker (or render thread).
    pub workers: Vec<WorkerStatus>,
    /// The newest faults (at most 100).
    pub faults: Vec<Fault>,
    /// Faults in all.
    pub faults_total: u64,
    /// Tiles put back in the queue.
    pub requeued: u64,
    /// Workers lost.
    pub lost: u64,
    /// Departed workers no longer listed in `workers` (only the newest
    /// [`super::limits::KEPT_DEPARTED`] departures are; `lost` counts them all).
    pub departed_folded: u64,
    /// Changes so far (a page polls this to see whether anything moved).
    pub version: u64,
    /// A sequence's frame the image and the tile counts are of (`null` for one frame).
    pub frame: Option<usize>,
    /// Frames in the sequence (`null` for one frame).
    pub frames_total: Option<usize>,
    /// Frames every tile of which is in (`null` for one frame).
    pub frames_done: Option<usize>,
    /// Frames begun and not yet done (`null` for one frame).
    pub frames_in_flight: Option<usize>,
}
