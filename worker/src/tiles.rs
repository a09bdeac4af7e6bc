//! The bridge between the async message loop and the rayon pool: each tile of a batch is handed
//! to rayon with `ThreadPool::spawn`, rendered there, and the batch's results come back together
//! on a bounded channel of [`UNSENT_RESULTS`] batches, so the loop wakes and writes once per
//! batch; when the master stops taking results, render threads wait instead of piling up
//! pixels. Never renders on the runtime. How one tile becomes its result message is shared
//! with the inline executor ([`crate::exec::InlineExec`]).

use crate::exec::PixelFn;
use parrt_protocol::{Message, PixelFormat, SharedPixels, TilePixels};
use parrt_render::film::Rgb;
use parrt_render::render::Renderer;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::mpsc::Sender;

/// The most rendered results waiting to be sent; a render thread with one more waits.
pub const UNSENT_RESULTS: usize = 64;

/// One job's renderer and its cancel flag, shared with the tiles in flight.
#[derive(Clone)]
pub struct JobHandle {
    /// The job's id.
    pub job_id: u64,
    /// The renderer, built once per job.
    pub renderer: Arc<Renderer>,
    /// Set when the job is cancelled: queued tiles are skipped.
    pub cancelled: Arc<AtomicBool>,
    /// How the job wants pixels sent.
    pub pixel_format: PixelFormat,
    /// Whether 8-bit pixels are sent packed.
    pub pack_pixels: bool,
}

/// Renders tiles on a rayon pool and sends the results of each batch (or errors) to `out`
/// together, when the batch's last tile is done.
pub struct TileRenderer {
    pool: rayon::ThreadPool,
    out: Sender<Vec<Message>>,
    delay: Option<Duration>,
    pixels: Option<PixelFn>,
    shared: Option<Arc<SharedPixels>>,
}

/// A batch in progress: its finished messages and how many tiles are still to come.
struct Batch {
    done: Mutex<Vec<Message>>,
    left: AtomicUsize,
    out: Sender<Vec<Message>>,
}

impl Batch {
    /// Adds a tile's message (none for a skipped tile); the last tile sends the lot.
    fn finish_one(&self, msg: Option<Message>) {
        let mut done = self.done.lock().unwrap_or_else(|p| p.into_inner());
        done.extend(msg);
        if self.left.fetch_sub(1, Ordering::AcqRel) == 1 && !done.is_empty() {
            // The loop may have ended (shutdown); then nobody wants the results. Waits while
            // the queue is full (on a rayon thread, not the runtime's).
            let _ = self.out.blocking_send(std::mem::take(&mut *done));
        }
    }
}

impl TileRenderer {
    /// Wraps `pool`; results go to `out`; `delay` is the test hook slept before each tile;
    /// `pixels`, when given, gives each tile's pixels instead of tracing them (a replaying
    /// worker, [`crate::exec::ReplayExec`]).
    pub fn new(
        pool: rayon::ThreadPool,
        out: Sender<Vec<Message>>,
        delay: Option<Duration>,
        pixels: Option<PixelFn>,
    ) -> Self {
        TileRenderer {
            pool,
            out,
            delay,
            pixels,
            shared: None,
        }
    }

    /// Leaves the pixels in `shared` when it has a free slot (a worker its master started on
    /// the same machine, [`parrt_protocol::shared_pixels`]).
    pub fn with_shared(mut self, shared: Option<Arc<SharedPixels>>) -> Self {
        self.shared = shared;
        self
    }

    /// Queues a batch of tiles (each with its attempt) for rendering, spread over the pool's
    /// threads. Returns at once; the results arrive on the channel together.
    pub fn submit(&self, job: &JobHandle, tiles: Vec<(Tile, u32)>) {
        let batch = Arc::new(Batch {
            done: Mutex::new(Vec::with_capacity(tiles.len())),
            left: AtomicUsize::new(tiles.len()),
            out: self.out.clone(),
        });
        for (tile, attempt) in tiles {
            let (job, batch, delay) = (job.clone(), batch.clone(), self.delay);
            let pixels = self.pixels.clone();
            let shared = self.shared.clone();
            self.pool.spawn(move || {
                if job.cancelled.load(Ordering::Relaxed) {
                    batch.finish_one(None);
                    return;
                }
                if let Some(d) = delay {
                    std::thread::sleep(d);
                }
                let shared = shared.as_deref();
                batch.finish_one(Some(render_one(
                    &job,
                    tile,
                    attempt,
                    pixels.as_ref(),
                    shared,
                )));
            });
        }
    }
}

/// What tracing one tile gave: its pixels and ray statistics, or why it could not be traced.
pub(crate) type Traced = Result<(Vec<Rgb>, RayStats), String>;

/// Pixels of a tile from elsewhere than tracing (see [`Source::Given`]).
pub(crate) type GivenPixels<'a> = dyn Fn(&Tile, &mut Vec<Rgb>) -> Result<(), String> + 'a;

/// Where a tile's pixels come from.
pub(crate) enum Source<'a> {
    /// The job's renderer traces them.
    Render,
    /// A recording gives them (bench and simulation aid); the statistics are only the eye rays
    /// the tile casts (the master checks those).
    Given(&'a GivenPixels<'a>),
}

/// Traces `tile` of `job` from `source`. May panic if the renderer does: callers catch it.
pub(crate) fn trace(job: &JobHandle, tile: &Tile, source: Source<'_>) -> Traced {
    let mut pixels = Vec::with_capacity(tile.pixel_count());
    let mut stats = RayStats::default();
    match source {
        Source::Given(f) => {
            f(tile, &mut pixels)?;
            stats.eye_rays = RayStats::expected_eye_rays(tile, job.renderer.settings());
        }
        Source::Render => job.renderer.render_tile(tile, &mut pixels, &mut stats),
    }
    Ok((pixels, stats))
}

/// The message answering one tile: its result, or an Error when tracing failed or panicked.
/// The pixels go into a slot of `shared` when there is one free, else inline (packed if the
/// job asks). `seconds` is asked for once the pixels are encoded and packed (the time the tile
/// took, as reported).
pub(crate) fn result_message(
    job: &JobHandle,
    tile: &Tile,
    attempt: u32,
    traced: std::thread::Result<Traced>,
    shared: Option<&SharedPixels>,
    seconds: impl FnOnce() -> f64,
) -> Message {
    match traced {
        Ok(Err(reason)) => Message::Error { reason },
        Ok(Ok((pixels, stats))) => Message::TileResult {
            job_id: job.job_id,
            tile_id: tile.id,
            attempt,
            pixels: match shared
                .and_then(|r| TilePixels::encode_shared(&pixels, job.pixel_format, r))
            {
                Some(p) => p,
                None if job.pack_pixels => TilePixels::encode(&pixels, job.pixel_format).pack(),
                None => TilePixels::encode(&pixels, job.pixel_format),
            },
            stats,
            seconds: seconds(),
        },
        Err(_) => Message::Error {
            reason: format!("rendering tile {} panicked", tile.id),
        },
    }
}

/// Renders one tile into its result message (an Error if rendering panicked), or takes its
/// pixels from `pixels` when given (a replaying worker); the pixels go into `shared` if given.
fn render_one(
    job: &JobHandle,
    tile: Tile,
    attempt: u32,
    pixels: Option<&PixelFn>,
    shared: Option<&SharedPixels>,
) -> Message {
    let t0 = Instant::now();
    let traced = std::panic::catch_unwind(AssertUnwindSafe(|| match pixels {
        Some(f) => trace(job, &tile, Source::Given(&**f)),
        None => trace(job, &tile, Source::Render),
    }));
    result_message(job, &tile, attempt, traced, shared, || {
        t0.elapsed().as_secs_f64()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_render::settings::RenderSettings;

    fn renderer() -> Renderer {
        let desc = parrt_test_support::scene::one_sphere(8);
        Renderer::new(&desc, &RenderSettings::new(8, 8)).unwrap()
    }

    /// When nobody takes results (the master stopped reading), render threads wait once
    /// UNSENT_RESULTS batches are queued, so a worker never piles up pixels.
    #[test]
    fn unsent_results_are_bounded() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let (tx, mut rx) = tokio::sync::mpsc::channel(UNSENT_RESULTS);
        let tiles = TileRenderer::new(pool, tx, None, None);
        let job = JobHandle {
            job_id: 1,
            renderer: Arc::new(renderer()),
            cancelled: Arc::new(AtomicBool::new(false)),
            pixel_format: PixelFormat::Rgb8,
            pack_pixels: true,
        };
        let tile = Tile {
            id: 0,
            x: 0,
            y: 0,
            w: 8,
            h: 8,
        };
        for attempt in 0..3 * UNSENT_RESULTS as u32 {
            tiles.submit(&job, vec![(tile, attempt)]);
        }
        let t0 = Instant::now();
        while rx.len() < UNSENT_RESULTS && t0.elapsed() < Duration::from_secs(20) {
            std::thread::sleep(Duration::from_millis(10));
        }
        std::thread::sleep(Duration::from_millis(200));
        assert_eq!(rx.len(), UNSENT_RESULTS, "results queued beyond the bound");
        // Taking results lets the rest through.
        let mut got = 0;
        while got < 3 * UNSENT_RESULTS {
            if rx.blocking_recv().is_some() {
                got += 1;
            }
        }
    }
}
