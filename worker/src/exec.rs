//! The execution seam: where a session's CPU work runs. A session hands its executor two kinds
//! of work, building a job's renderer and rendering a batch of tiles, and takes the outcomes
//! back as [`ExecEvent`]s from [`Execute::next`], one select branch among the connection's.
//! [`RayonExec`] is the real worker (a rayon pool, builds on blocking threads: never the
//! runtime); [`InlineExec`] does everything on the calling task and spends simulated costs in
//! tokio time, so a deterministic simulation (turmoil, a paused clock) runs the real session
//! loop; [`ReplayExec`] wraps either to play a recorded render instead of tracing. An executor
//! never touches the connection: the session writes what it delivers.

mod inline;
mod pool;
mod replay;

pub use inline::{CostFn, InlineExec, JobCostFn, JobPixelFn, PixelFn};
pub use pool::RayonExec;
pub use replay::ReplayExec;

use crate::error::WorkerError;
use crate::options::WorkerOptions;
use crate::tiles::JobHandle;
use parrt_protocol::{JobSpec, Message};
use parrt_render::render::Renderer;
use parrt_render::tile::Tile;
use std::future::Future;

/// A finished renderer build.
pub struct Built {
    /// The job it was built for.
    pub job_id: u64,
    /// The renderer, or why it cannot be built.
    pub result: Result<Renderer, String>,
    /// Seconds the build took, as reported in Ready.
    pub seconds: f64,
}

/// What an executor delivers to the session.
pub enum ExecEvent {
    /// A renderer build ended.
    Built(Box<Built>),
    /// A batch's messages (TileResults and Errors), to be written together.
    Results(Vec<Message>),
}

/// Runs a session's builds and tiles. The session calls [`Execute::start`] once, when
/// authenticated, then [`Execute::build`] per job and [`Execute::submit`] per batch, and polls
/// [`Execute::next`] in its loop.
pub trait Execute: Send {
    /// Gets ready to render with `opts` (threads, test hooks). Must not block.
    fn start(&mut self, opts: &WorkerOptions);

    /// Starts building the renderer of `spec`; the outcome comes from [`Execute::next`].
    fn build(&mut self, spec: JobSpec);

    /// A job that is another view of a job built here ([`parrt_protocol::Message::View`]): the
    /// session makes its renderer from the base's without a build. An executor that tells jobs
    /// apart by what they show learns the new one here; others need do nothing.
    fn viewed(&mut self, _spec: &parrt_protocol::ViewSpec) {}

    /// Queues a batch of tiles (each with its attempt) of `job`. Tiles still queued when the
    /// job's cancel flag is set are skipped; the batch's messages come from [`Execute::next`]
    /// together when its last tile is done (nothing when every tile was skipped).
    fn submit(&mut self, job: &JobHandle, tiles: Vec<(Tile, u32)>);

    /// The next outcome. Cancel-safe (it is one branch of the session's `select!`): dropping
    /// the future loses nothing. An error ends the session.
    fn next(&mut self) -> impl Future<Output = Result<ExecEvent, WorkerError>> + Send;
}

/// Builds `spec`'s renderer, turning a panic into an error.
pub(crate) fn build_renderer(spec: &JobSpec) -> Result<Renderer, String> {
    std::panic::catch_unwind(|| Renderer::new(&spec.scene, &spec.settings))
        .map_err(|_| "building the renderer panicked".to_string())
        .and_then(|r| r.map_err(|e| e.to_string()))
}
