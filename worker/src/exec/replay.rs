//! The replaying executor: a worker that plays a recorded render ([`crate::replay::Replay`])
//! instead of tracing, handed to the session by whoever builds the worker (the `--replay` flag
//! of `parrt worker`, the simulation's scale runs). Each tile's pixels are the recorded ones
//! (a tile the recording lacks is answered with an Error) and it lasts its recorded
//! one-thread cost × the replay's scale: slept on a rayon thread of the real pool
//! ([`ReplayExec::pool`]), or spent in tokio time by the inline executor
//! ([`ReplayExec::simulated`]). Everything else is the wrapped executor's.

use super::{ExecEvent, Execute, InlineExec, RayonExec};
use crate::error::WorkerError;
use crate::options::WorkerOptions;
use crate::replay::Replay;
use crate::tiles::JobHandle;
use parrt_protocol::JobSpec;
use parrt_render::tile::Tile;
use std::sync::Arc;
use std::time::Duration;

/// Replays a recorded render on the real pool or in simulated time; see the module doc.
pub enum ReplayExec {
    /// On a rayon pool, each tile's thread sleeping for its cost (a bench worker).
    Pool(RayonExec),
    /// Inline, each tile's cost spent in tokio time (a simulated worker).
    Simulated(InlineExec),
}

impl ReplayExec {
    /// The real worker's pool, replaying `replay` (`parrt worker --replay FILE`).
    pub fn pool(replay: Arc<Replay>) -> Self {
        ReplayExec::Pool(
            RayonExec::new()
                .with_pixels(move |t, out| replay.play(t, out).map_err(|e| e.to_string())),
        )
    }

    /// The inline executor replaying `replay` in tokio time, for a simulation.
    pub fn simulated(replay: Arc<Replay>) -> Self {
        let r = replay.clone();
        ReplayExec::Simulated(
            InlineExec::new(move |t| r.cost(t).unwrap_or(Duration::ZERO))
                .with_pixels(move |t, out| replay.pixels(t, out).map_err(|e| e.to_string())),
        )
    }
}

impl Execute for ReplayExec {
    fn start(&mut self, opts: &WorkerOptions) {
        match self {
            ReplayExec::Pool(e) => e.start(opts),
            ReplayExec::Simulated(e) => e.start(opts),
        }
    }

    fn build(&mut self, spec: JobSpec) {
        match self {
            ReplayExec::Pool(e) => e.build(spec),
            ReplayExec::Simulated(e) => e.build(spec),
        }
    }

    fn submit(&mut self, job: &JobHandle, tiles: Vec<(Tile, u32)>) {
        match self {
            ReplayExec::Pool(e) => e.submit(job, tiles),
            ReplayExec::Simulated(e) => e.submit(job, tiles),
        }
    }

    async fn next(&mut self) -> Result<ExecEvent, WorkerError> {
        match self {
            ReplayExec::Pool(e) => e.next().await,
            ReplayExec::Simulated(e) => e.next().await,
        }
    }
}
