//! The bridge between the async message loop and the rayon pool: a tile is handed to rayon with
//! `ThreadPool::spawn`, rendered there, and its result comes back as a message on an unbounded
//! channel (the master's window bounds how many are outstanding). Never renders on the runtime.

use parrt::protocol::Message;
use parrt::render::Renderer;
use parrt::stats::RayStats;
use parrt::tile::Tile;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc::UnboundedSender;

/// One job's renderer and its cancel flag, shared with the tiles in flight.
#[derive(Clone)]
pub struct JobHandle {
    /// The job's id.
    pub job_id: u64,
    /// The renderer, built once per job.
    pub renderer: Arc<Renderer>,
    /// Set when the job is cancelled: queued tiles are skipped.
    pub cancelled: Arc<AtomicBool>,
}

/// Renders tiles on a rayon pool and sends each result (or an error) to `out`.
pub struct TileRenderer {
    pool: rayon::ThreadPool,
    out: UnboundedSender<Message>,
    delay: Option<Duration>,
}

impl TileRenderer {
    /// Wraps `pool`; results go to `out`; `delay` is the test hook slept before each tile.
    pub fn new(
        pool: rayon::ThreadPool,
        out: UnboundedSender<Message>,
        delay: Option<Duration>,
    ) -> Self {
        TileRenderer { pool, out, delay }
    }

    /// Queues `tile` for rendering. Returns at once; the result arrives on the channel.
    pub fn submit(&self, job: &JobHandle, tile: Tile, attempt: u32) {
        let job = job.clone();
        let out = self.out.clone();
        let delay = self.delay;
        self.pool.spawn(move || {
            if job.cancelled.load(Ordering::Relaxed) {
                return;
            }
            if let Some(d) = delay {
                std::thread::sleep(d);
            }
            let t0 = Instant::now();
            let rendered = std::panic::catch_unwind(AssertUnwindSafe(|| {
                let mut pixels = Vec::with_capacity(tile.pixel_count());
                let mut stats = RayStats::default();
                // A replaying worker (bench aid, `--replay`) returns recorded pixels instead.
                match crate::replay::installed() {
                    Some(r) => r.play(&tile, &mut pixels).map_err(|e| e.to_string())?,
                    None => job.renderer.render_tile(&tile, &mut pixels, &mut stats),
                }
                Ok::<_, String>((pixels, stats))
            }));
            let msg = match rendered {
                Ok(Err(reason)) => Message::Error { reason },
                Ok(Ok((pixels, stats))) => Message::TileResult {
                    job_id: job.job_id,
                    tile_id: tile.id,
                    attempt,
                    pixels,
                    stats,
                    seconds: t0.elapsed().as_secs_f64(),
                },
                Err(_) => Message::Error {
                    reason: format!("rendering tile {} panicked", tile.id),
                },
            };
            // The loop may have ended (shutdown); then nobody wants the result.
            let _ = out.send(msg);
        });
    }
}
