//! The simulation executor: everything on the calling task, in a fixed order, in tokio time. A
//! renderer is built at once (then counts as ready after a configured build cost); a tile is
//! traced at once with the real [`parrt_render::render::Renderer`] (or its pixels come from a
//! caller's function) and then occupies one of the worker's simulated threads for a configured
//! cost. The threads take queued tiles first come, first served, as a rayon pool does; a batch's
//! messages are delivered in tile order when its last tile's cost has elapsed. Under a paused
//! clock or turmoil the costs are virtual, so a run is the same every time. It blocks the runtime
//! while it traces: never use it on a real network.

use super::{build_renderer, Built, ExecEvent, Execute};
use crate::error::WorkerError;
use crate::options::WorkerOptions;
use crate::tiles::{result_message, trace, JobHandle, Source};
use parrt_protocol::{JobSpec, Message};
use parrt_render::film::Rgb;
use parrt_render::tile::Tile;
use std::collections::{BTreeMap, VecDeque};
use std::panic::AssertUnwindSafe;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;
use tokio::time::{sleep_until, Instant};

/// The simulated cost of one tile (e.g. a constant, or its recorded one-thread time).
pub type CostFn = Arc<dyn Fn(&Tile) -> Duration + Send + Sync>;

/// A tile's pixels without tracing (e.g. from a recording), row-major into the vector; an
/// error is answered with an Error message, as a replaying worker does.
pub type PixelFn = Arc<dyn Fn(&Tile, &mut Vec<Rgb>) -> Result<(), String> + Send + Sync>;

/// The simulated cost of one tile of a given job: a simulated sequence's frames are jobs whose
/// tiles cost (and show) what that frame recorded.
pub type JobCostFn = Arc<dyn Fn(&JobHandle, &Tile) -> Duration + Send + Sync>;

/// A tile's pixels of a given job without tracing (see [`JobCostFn`]).
pub type JobPixelFn =
    Arc<dyn Fn(&JobHandle, &Tile, &mut Vec<Rgb>) -> Result<(), String> + Send + Sync>;

/// A cost too large to add to an instant stands for this long (never in practice).
const FAR: Duration = Duration::from_secs(100 * 365 * 24 * 3600);

/// Renders inline and spends simulated time; see the module doc.
pub struct InlineExec {
    cost: JobCostFn,
    pixels: Option<JobPixelFn>,
    build_cost: Duration,
    /// The simulated threads: the tile each one is busy with.
    lanes: Vec<Option<Running>>,
    /// Tiles no thread has taken yet, in the order given.
    queue: VecDeque<Queued>,
    /// Batches with tiles still to finish, by number.
    batches: BTreeMap<u64, Batch>,
    next_batch: u64,
    /// Finished batches' messages, in the order they finished.
    done: VecDeque<Vec<Message>>,
    /// Renderer builds and when each counts as done, in the order started.
    builds: VecDeque<(Instant, Built)>,
}

/// A tile waiting for a thread.
struct Queued {
    batch: u64,
    slot: usize,
    job: JobHandle,
    tile: Tile,
    attempt: u32,
}

/// A tile traced already, its thread busy until its cost has elapsed.
struct Running {
    until: Instant,
    batch: u64,
    slot: usize,
    msg: Message,
}

/// A batch's messages by tile position, and how many tiles are still to finish.
struct Batch {
    msgs: Vec<Option<Message>>,
    left: usize,
}

impl InlineExec {
    /// Traces with the job's renderer; each tile costs `cost(tile)` of simulated time.
    pub fn new(cost: impl Fn(&Tile) -> Duration + Send + Sync + 'static) -> Self {
        InlineExec::per_job(move |_, t| cost(t))
    }

    /// Traces with the job's renderer; each tile costs `cost(job, tile)` of simulated time.
    pub fn per_job(cost: impl Fn(&JobHandle, &Tile) -> Duration + Send + Sync + 'static) -> Self {
        InlineExec {
            cost: Arc::new(cost),
            pixels: None,
            build_cost: Duration::ZERO,
            lanes: vec![None],
            queue: VecDeque::new(),
            batches: BTreeMap::new(),
            next_batch: 0,
            done: VecDeque::new(),
            builds: VecDeque::new(),
        }
    }

    /// Traces with the job's renderer; every tile costs `per_tile`.
    pub fn constant(per_tile: Duration) -> Self {
        InlineExec::new(move |_| per_tile)
    }

    /// Takes tiles' pixels from `pixels` instead of tracing them (cost-only simulation).
    pub fn with_pixels(
        mut self,
        pixels: impl Fn(&Tile, &mut Vec<Rgb>) -> Result<(), String> + Send + Sync + 'static,
    ) -> Self {
        self.pixels = Some(Arc::new(
            move |_: &JobHandle, t: &Tile, out: &mut Vec<Rgb>| pixels(t, out),
        ));
        self
    }

    /// Takes tiles' pixels from `pixels(job, tile, out)` instead of tracing them.
    pub fn with_job_pixels(
        mut self,
        pixels: impl Fn(&JobHandle, &Tile, &mut Vec<Rgb>) -> Result<(), String> + Send + Sync + 'static,
    ) -> Self {
        self.pixels = Some(Arc::new(pixels));
        self
    }

    /// A renderer counts as built `cost` after the Job arrived (zero by default); Ready
    /// reports it as the build time.
    pub fn with_build_cost(mut self, cost: Duration) -> Self {
        self.build_cost = cost;
        self
    }

    /// Finishes every running tile due by `now`, earliest first (then by thread), each thread
    /// taking the next queued tile at the instant it became free.
    fn settle(&mut self, now: Instant) {
        loop {
            let due = self
                .lanes
                .iter()
                .enumerate()
                .filter_map(|(i, l)| l.as_ref().map(|r| (r.until, i)))
                .filter(|&(until, _)| until <= now)
                .min();
            let Some((at, lane)) = due else { break };
            if let Some(r) = self.lanes[lane].take() {
                self.finish(r.batch, r.slot, Some(r.msg));
            }
            self.feed(lane, at);
        }
    }

    /// Gives thread `lane`, free at `at`, the next queued tile: skipped at once if its job was
    /// cancelled, else traced now and busy for its cost.
    fn feed(&mut self, lane: usize, at: Instant) {
        while let Some(q) = self.queue.pop_front() {
            if q.job.cancelled.load(Ordering::Relaxed) {
                self.finish(q.batch, q.slot, None);
                continue;
            }
            let traced = std::panic::catch_unwind(AssertUnwindSafe(|| match &self.pixels {
                Some(f) => {
                    let given = |t: &Tile, out: &mut Vec<Rgb>| f(&q.job, t, out);
                    trace(&q.job, &q.tile, Source::Given(&given))
                }
                None => trace(&q.job, &q.tile, Source::Render),
            }));
            let cost = (self.cost)(&q.job, &q.tile);
            let msg = result_message(&q.job, &q.tile, q.attempt, traced, None, || {
                cost.as_secs_f64()
            });
            self.lanes[lane] = Some(Running {
                until: later(at, cost),
                batch: q.batch,
                slot: q.slot,
                msg,
            });
            return;
        }
    }

    /// Records a tile's message (none when skipped); the batch's last tile releases the lot.
    fn finish(&mut self, batch: u64, slot: usize, msg: Option<Message>) {
        let Some(b) = self.batches.get_mut(&batch) else {
            return;
        };
        if let Some(s) = b.msgs.get_mut(slot) {
            *s = msg;
        }
        b.left = b.left.saturating_sub(1);
        if b.left == 0 {
            if let Some(b) = self.batches.remove(&batch) {
                let msgs: Vec<Message> = b.msgs.into_iter().flatten().collect();
                if !msgs.is_empty() {
                    self.done.push_back(msgs);
                }
            }
        }
    }
}

/// `at + d`, or [`FAR`] after `at` when that does not fit.
fn later(at: Instant, d: Duration) -> Instant {
    at.checked_add(d).unwrap_or(at + FAR)
}

impl Execute for InlineExec {
    /// Simulates [`WorkerOptions::render_threads`] threads. The tile-delay hook is not used:
    /// the cost function says how long tiles take.
    fn start(&mut self, opts: &WorkerOptions) {
        self.lanes.resize_with(opts.render_threads(), || None);
    }

    fn build(&mut self, spec: JobSpec) {
        let result = build_renderer(&spec);
        let due = later(Instant::now(), self.build_cost);
        self.builds.push_back((
            due,
            Built {
                job_id: spec.job_id,
                result,
                seconds: self.build_cost.as_secs_f64(),
            },
        ));
    }

    fn submit(&mut self, job: &JobHandle, tiles: Vec<(Tile, u32)>) {
        let now = Instant::now();
        self.settle(now);
        if tiles.is_empty() {
            return;
        }
        let id = self.next_batch;
        self.next_batch += 1;
        self.batches.insert(
            id,
            Batch {
                msgs: (0..tiles.len()).map(|_| None).collect(),
                left: tiles.len(),
            },
        );
        for (slot, (tile, attempt)) in tiles.into_iter().enumerate() {
            self.queue.push_back(Queued {
                batch: id,
                slot,
                job: job.clone(),
                tile,
                attempt,
            });
        }
        for lane in 0..self.lanes.len() {
            if self.queue.is_empty() {
                break;
            }
            if self.lanes[lane].is_none() {
                self.feed(lane, now);
            }
        }
    }

    async fn next(&mut self) -> Result<ExecEvent, WorkerError> {
        loop {
            let now = Instant::now();
            self.settle(now);
            if self.builds.front().is_some_and(|(due, _)| *due <= now) {
                if let Some((_, b)) = self.builds.pop_front() {
                    return Ok(ExecEvent::Built(Box::new(b)));
                }
            }
            if let Some(msgs) = self.done.pop_front() {
                return Ok(ExecEvent::Results(msgs));
            }
            let wake = self
                .builds
                .front()
                .map(|(due, _)| *due)
                .into_iter()
                .chain(self.lanes.iter().flatten().map(|r| r.until))
                .min();
            match wake {
                Some(t) => sleep_until(t).await,
                // Nothing under way: the session calls submit or build, then polls again.
                None => std::future::pending::<()>().await,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_protocol::{PixelFormat, Token};
    use parrt_render::render::Renderer;
    use parrt_render::settings::RenderSettings;
    use parrt_render::tile::tiles;
    use std::sync::atomic::AtomicBool;

    fn job() -> JobHandle {
        let desc = parrt_test_support::scene::one_sphere(8);
        JobHandle {
            job_id: 1,
            renderer: Arc::new(Renderer::new(&desc, &RenderSettings::new(8, 8)).unwrap()),
            cancelled: Arc::new(AtomicBool::new(false)),
            pixel_format: PixelFormat::Rgb8,
            pack_pixels: true,
        }
    }

    /// A cancelled job's queued tiles are skipped, as on the pool; the tile already running
    /// still finishes and is delivered; a batch whose tiles were all skipped sends nothing.
    #[tokio::test(start_paused = true)]
    async fn cancel_skips_queued_tiles() {
        let mut exec = InlineExec::constant(Duration::from_millis(100));
        let mut opts = WorkerOptions::new("sim:1", Token::new("t").unwrap());
        opts.threads = 1;
        exec.start(&opts);
        let job = job();
        let list = tiles(8, 8, 4);
        let t0 = Instant::now();
        exec.submit(&job, list.iter().map(|t| (*t, 1)).collect());
        job.cancelled.store(true, Ordering::Relaxed);
        let Ok(ExecEvent::Results(msgs)) = exec.next().await else {
            panic!("expected results");
        };
        assert_eq!(t0.elapsed(), Duration::from_millis(100));
        assert_eq!(msgs.len(), 1);
        assert!(matches!(msgs[0], Message::TileResult { tile_id: 0, .. }));
        exec.submit(&job, vec![(list[1], 2)]);
        let waited = tokio::time::timeout(Duration::from_secs(10), exec.next()).await;
        assert!(waited.is_err(), "a skipped batch delivered something");
    }
}
