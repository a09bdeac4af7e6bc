//! The real executor: the rayon pool is built on a blocking thread (starting thousands of
//! threads takes seconds), each job's renderer too, and tiles run on the pool through
//! [`TileRenderer`]; everything comes back through channels. Nothing here runs on the runtime.

use super::{build_renderer, Built, ExecEvent, Execute, PixelFn};
use crate::error::WorkerError;
use crate::options::WorkerOptions;
use crate::tiles::{JobHandle, TileRenderer, UNSENT_RESULTS};
use parrt_protocol::{JobSpec, Message};
use parrt_render::tile::Tile;
use std::time::Duration;
use tokio::sync::mpsc;
use tokio::task::{JoinError, JoinHandle};

type PoolBuild = JoinHandle<Result<rayon::ThreadPool, rayon::ThreadPoolBuildError>>;

/// Renders on a rayon pool of the session's thread count.
pub struct RayonExec {
    /// The pool being built, until it is up.
    pool_build: Option<PoolBuild>,
    threads: usize,
    tile_delay: Option<Duration>,
    /// Where tiles' pixels come from instead of tracing (a replaying worker), if anywhere.
    pixels: Option<PixelFn>,
    /// The region its master shares for pixels, if it started this worker.
    shared: Option<std::sync::Arc<parrt_protocol::SharedPixels>>,
    /// The pool, once up.
    tiles: Option<TileRenderer>,
    /// Batches given before the pool was up, in order.
    early: Vec<(JobHandle, Vec<(Tile, u32)>)>,
    /// Handed to the pool once up; results wait in this bounded channel.
    out_tx: Option<mpsc::Sender<Vec<Message>>>,
    out_rx: mpsc::Receiver<Vec<Message>>,
    built_tx: mpsc::UnboundedSender<Built>,
    built_rx: mpsc::UnboundedReceiver<Built>,
}

impl Default for RayonExec {
    fn default() -> Self {
        RayonExec::new()
    }
}

impl RayonExec {
    /// An executor with no pool yet ([`Execute::start`] builds it).
    pub fn new() -> Self {
        let (out_tx, out_rx) = mpsc::channel(UNSENT_RESULTS);
        let (built_tx, built_rx) = mpsc::unbounded_channel();
        RayonExec {
            pool_build: None,
            threads: 1,
            tile_delay: None,
            pixels: None,
            shared: None,
            tiles: None,
            early: Vec::new(),
            out_tx: Some(out_tx),
            out_rx,
            built_tx,
            built_rx,
        }
    }

    /// Takes tiles' pixels from `pixels` instead of tracing them, on the pool's threads (a
    /// replaying worker, [`super::ReplayExec`]).
    pub fn with_pixels(
        mut self,
        pixels: impl Fn(&Tile, &mut Vec<parrt_render::film::Rgb>) -> Result<(), String>
            + Send
            + Sync
            + 'static,
    ) -> Self {
        self.pixels = Some(std::sync::Arc::new(pixels));
        self
    }

    /// The pool build ended: keep the pool and hand it the batches that waited for it.
    fn pool_ready(
        &mut self,
        built: Result<Result<rayon::ThreadPool, rayon::ThreadPoolBuildError>, JoinError>,
    ) -> Result<(), WorkerError> {
        let pool = match built {
            Ok(Ok(pool)) => pool,
            Ok(Err(source)) => {
                return Err(WorkerError::Pool {
                    threads: self.threads,
                    source,
                })
            }
            Err(e) => return Err(WorkerError::PoolTask(e.to_string())),
        };
        let Some(tx) = self.out_tx.take() else {
            return Ok(());
        };
        let r = TileRenderer::new(pool, tx, self.tile_delay, self.pixels.clone())
            .with_shared(self.shared.clone());
        for (job, batch) in self.early.drain(..) {
            r.submit(&job, batch);
        }
        self.tiles = Some(r);
        Ok(())
    }
}

/// Waits for the pool build, or forever when none is under way.
async fn pool_built(
    build: &mut Option<PoolBuild>,
) -> Result<Result<rayon::ThreadPool, rayon::ThreadPoolBuildError>, JoinError> {
    match build {
        Some(h) => h.await,
        None => std::future::pending().await,
    }
}

impl Execute for RayonExec {
    fn start(&mut self, opts: &WorkerOptions) {
        let threads = opts.render_threads();
        self.threads = threads;
        self.tile_delay = opts.tile_delay;
        self.shared = opts.shared_pixels.clone();
        // Starting thousands of threads takes seconds: never on the runtime's thread, so the
        // loop keeps reading and beating meanwhile.
        self.pool_build = Some(tokio::task::spawn_blocking(move || {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .thread_name(|i| format!("parrt-render-{i}"))
                .build()
        }));
    }

    fn build(&mut self, spec: JobSpec) {
        let done = self.built_tx.clone();
        tokio::task::spawn_blocking(move || {
            let t0 = std::time::Instant::now();
            let result = build_renderer(&spec);
            let _ = done.send(Built {
                job_id: spec.job_id,
                result,
                seconds: t0.elapsed().as_secs_f64(),
            });
        });
    }

    fn submit(&mut self, job: &JobHandle, tiles: Vec<(Tile, u32)>) {
        match &self.tiles {
            Some(r) => r.submit(job, tiles),
            None => self.early.push((job.clone(), tiles)),
        }
    }

    async fn next(&mut self) -> Result<ExecEvent, WorkerError> {
        loop {
            tokio::select! {
                built = pool_built(&mut self.pool_build) => {
                    self.pool_build = None;
                    self.pool_ready(built)?;
                }
                Some(b) = self.built_rx.recv() => return Ok(ExecEvent::Built(Box::new(b))),
                Some(msgs) = self.out_rx.recv() => return Ok(ExecEvent::Results(msgs)),
                // Both senders live as long as we do; never reached.
                else => std::future::pending::<()>().await,
            }
        }
    }
}
