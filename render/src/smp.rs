//! Shared-memory parallel rendering: executors that hand tiles to threads. `queue` is the paper's
//! design (N threads take the next tile from a locked queue, row by row); `rayon` is work
//! stealing; `morton` takes tiles in Z-order from an atomic counter (neighbouring tiles share
//! cache lines of the scene); `guided` hands out runs of Z-ordered tiles whose length shrinks as
//! the work runs out (OpenMP's guided schedule), so small tiles cost no locality and big chunks
//! leave no thread idle at the end. The image never depends on the executor, the thread count or
//! the tile size.

use crate::film::{Film, Rgb};
use crate::render::Renderer;
use crate::stats::RayStats;
use crate::tile::{tiles, Tile};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// How tiles are handed to threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum Executor {
    /// The paper's: N OS threads pop the next tile (row-major) from a mutex-guarded queue.
    #[default]
    Queue,
    /// rayon's work-stealing pool over the tile list.
    Rayon,
    /// N OS threads take tiles in Morton (Z) order from an atomic counter.
    Morton,
    /// N OS threads take runs of Morton-ordered tiles, each run `remaining / (2·N)` tiles long
    /// (at least one): large first, shrinking towards the end.
    Guided,
}

impl Executor {
    /// Every executor, for studies.
    pub const ALL: [Executor; 4] = [
        Executor::Queue,
        Executor::Rayon,
        Executor::Morton,
        Executor::Guided,
    ];

    /// Lower-case name as used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Executor::Queue => "queue",
            Executor::Rayon => "rayon",
            Executor::Morton => "morton",
            Executor::Guided => "guided",
        }
    }
}

/// Options of an SMP render.
#[derive(Clone, Copy, Debug)]
pub struct SmpOptions {
    /// Render threads (at least 1).
    pub threads: usize,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Executor.
    pub executor: Executor,
}

/// What an SMP render produced.
#[derive(Debug)]
pub struct SmpResult {
    /// The image.
    pub film: Film,
    /// Summed ray statistics.
    pub stats: RayStats,
    /// Seconds each tile took, by tile id.
    pub tile_seconds: Vec<f64>,
    /// Wall time of the tracing phase.
    pub trace_s: f64,
    /// When and on which thread each tile was rendered, by tile id (one slot per tile, filled
    /// as the tile lands: the timeline of `parrt render --timeline`).
    pub tile_spans: Vec<TileSpan>,
}

/// When and where one tile of an SMP render was rendered.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TileSpan {
    /// The render thread's index (0-based; rayon's pool index with the `rayon` executor).
    pub thread: u32,
    /// Seconds from the start of the trace phase to the tile's start.
    pub start_s: f64,
    /// Seconds from the start of the trace phase to the tile's end (pixels written).
    pub end_s: f64,
}

/// One finished tile, as [`render_smp_with`] reports it.
pub struct TileDone<'a> {
    /// The tile.
    pub tile: &'a Tile,
    /// Its ray statistics.
    pub stats: &'a RayStats,
    /// Its pixels, row by row (the film's values).
    pub pixels: &'a [Rgb],
    /// When and on which thread it was rendered.
    pub span: TileSpan,
}

/// Interleaves the bits of `x` and `y` (x in the even bits).
pub fn morton2(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = v as u64;
        v = (v | (v << 16)) & 0x0000_FFFF_0000_FFFF;
        v = (v | (v << 8)) & 0x00FF_00FF_00FF_00FF;
        v = (v | (v << 4)) & 0x0F0F_0F0F_0F0F_0F0F;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        v = (v | (v << 1)) & 0x5555_5555_5555_5555;
        v
    }
    spread(x) | (spread(y) << 1)
}

/// The tile list in Morton order of the tiles' grid positions.
pub fn morton_order(list: &[Tile], tile: u32) -> Vec<Tile> {
    let mut v = list.to_vec();
    let t = tile.max(1);
    v.sort_by_key(|tl| (morton2(tl.x / t, tl.y / t), tl.id));
    v
}

/// The run length the guided schedule hands out when `remaining` tiles are left.
#[inline]
pub fn guided_chunk(remaining: usize, threads: usize) -> usize {
    (remaining / (2 * threads.max(1))).max(1)
}

/// Renders the whole image. `progress` is called after each tile with the tile and its stats.
pub fn render_smp(
    renderer: &Renderer,
    opts: &SmpOptions,
    progress: &(dyn Fn(&Tile, &RayStats) + Sync),
) -> SmpResult {
    render_smp_with(renderer, opts, &|done| progress(done.tile, done.stats))
}

/// [`render_smp`] telling `progress` more of each finished tile: its pixels and when and on
/// which thread it was rendered (what the live view and the timeline need). Called on the
/// render thread, after the tile is in the film: it must be quick and never wait.
pub fn render_smp_with(
    renderer: &Renderer,
    opts: &SmpOptions,
    progress: &(dyn Fn(TileDone<'_>) + Sync),
) -> SmpResult {
    let s = renderer.settings();
    render_smp_into(renderer, opts, Film::new(s.width, s.height), progress)
}

/// [`render_smp_with`] into `film`, a black film of the renderer's size: an 8-bit one
/// ([`Film::for_output`]) for an 8-bit output keeps 3 bytes a pixel instead of 12, each tile
/// converted as it lands; the progress still sees the tile's linear pixels.
pub fn render_smp_into(
    renderer: &Renderer,
    opts: &SmpOptions,
    film: Film,
    progress: &(dyn Fn(TileDone<'_>) + Sync),
) -> SmpResult {
    let s = renderer.settings();
    assert_eq!(
        (film.width, film.height),
        (s.width, s.height),
        "the film is the image's size"
    );
    let list = tiles(s.width, s.height, opts.tile);
    let threads = opts.threads.max(1);
    let film = Mutex::new(film);
    let totals = Mutex::new((
        RayStats::default(),
        vec![0.0f64; list.len()],
        vec![TileSpan::default(); list.len()],
    ));
    let start = Instant::now();
    let finish = |tile: &Tile, buf: &[Rgb], st: RayStats, span: TileSpan| {
        film.lock()
            .unwrap_or_else(|e| e.into_inner())
            .write_tile(tile, buf)
            .expect("tiles come from the film's own size");
        let mut t = totals.lock().unwrap_or_else(|e| e.into_inner());
        t.0 += st;
        t.1[tile.id as usize] = span.end_s - span.start_s;
        t.2[tile.id as usize] = span;
        drop(t);
        progress(TileDone {
            tile,
            stats: &st,
            pixels: buf,
            span,
        });
    };
    let render_one = |thread: usize, tile: &Tile, buf: &mut Vec<Rgb>| {
        let start_s = start.elapsed().as_secs_f64();
        let mut st = RayStats::default();
        renderer.render_tile(tile, buf, &mut st);
        let span = TileSpan {
            thread: thread as u32,
            start_s,
            end_s: start.elapsed().as_secs_f64(),
        };
        finish(tile, buf, st, span);
    };
    run_tiles(opts.executor, &list, opts.tile, threads, &render_one);
    let trace_s = start.elapsed().as_secs_f64();
    let (stats, tile_seconds, tile_spans) = totals.into_inner().unwrap_or_else(|e| e.into_inner());
    SmpResult {
        film: film.into_inner().unwrap_or_else(|e| e.into_inner()),
        stats,
        tile_seconds,
        trace_s,
        tile_spans,
    }
}

/// Renders every tile of `list` once with `render_one` (given the thread's index, the tile and
/// the thread's pixel buffer) on `threads` threads, handed out as `executor` says.
fn run_tiles(
    executor: Executor,
    list: &[Tile],
    tile: u32,
    threads: usize,
    render_one: &(dyn Fn(usize, &Tile, &mut Vec<Rgb>) + Sync),
) {
    // N threads, each running `work` (given its index) until it returns: the calling thread
    // is thread 0 and N − 1 are spawned, so a one-thread render starts no thread and waits
    // for none to be scheduled (on a loaded machine that wake-up costs milliseconds).
    let run_threads = |work: &(dyn Fn(usize, &mut Vec<Rgb>) + Sync)| {
        std::thread::scope(|scope| {
            for i in 1..threads {
                scope.spawn(move || work(i, &mut Vec::new()));
            }
            work(0, &mut Vec::new());
        });
    };
    match executor {
        Executor::Queue => {
            let queue = Mutex::new(list.iter().copied().collect::<VecDeque<Tile>>());
            run_threads(&|i, buf| loop {
                let next = queue.lock().unwrap_or_else(|e| e.into_inner()).pop_front();
                match next {
                    Some(tile) => render_one(i, &tile, buf),
                    None => break,
                }
            });
        }
        Executor::Rayon => {
            use rayon::prelude::*;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a rayon pool of a valid size builds");
            pool.install(|| {
                list.par_iter()
                    .with_max_len(1)
                    .for_each_init(Vec::new, |buf, tile| {
                        render_one(rayon::current_thread_index().unwrap_or(0), tile, buf)
                    });
            });
        }
        Executor::Morton => {
            let order = morton_order(list, tile);
            let next = AtomicUsize::new(0);
            run_threads(&|t, buf| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                match order.get(i) {
                    Some(tile) => render_one(t, tile, buf),
                    None => break,
                }
            });
        }
        Executor::Guided => {
            let order = morton_order(list, tile);
            let next = Mutex::new(0usize);
            run_threads(&|t, buf| loop {
                let (lo, hi) = {
                    let mut n = next.lock().unwrap_or_else(|e| e.into_inner());
                    let lo = *n;
                    let len = guided_chunk(order.len().saturating_sub(lo), threads);
                    *n = (lo + len).min(order.len());
                    (lo, *n)
                };
                if lo >= hi {
                    break;
                }
                for tile in &order[lo..hi] {
                    render_one(t, tile, buf);
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_interleaves() {
        assert_eq!(morton2(0, 0), 0);
        assert_eq!(morton2(1, 0), 1);
        assert_eq!(morton2(0, 1), 2);
        assert_eq!(morton2(3, 3), 15);
        assert_eq!(morton2(4, 0), 16);
    }

    #[test]
    fn morton_order_is_a_permutation() {
        let list = tiles(100, 70, 16);
        let m = morton_order(&list, 16);
        let mut ids: Vec<u32> = m.iter().map(|t| t.id).collect();
        ids.sort_unstable();
        assert_eq!(ids, (0..list.len() as u32).collect::<Vec<_>>());
        assert_eq!(m[0].id, 0);
    }

    #[test]
    fn guided_chunks_shrink_and_cover_everything() {
        let (mut left, mut sizes) = (256usize, Vec::new());
        while left > 0 {
            let c = guided_chunk(left, 2).min(left);
            sizes.push(c);
            left -= c;
        }
        assert_eq!(sizes.iter().sum::<usize>(), 256);
        assert_eq!(sizes[0], 64);
        assert!(sizes.windows(2).all(|w| w[1] <= w[0]));
        assert_eq!(*sizes.last().unwrap(), 1);
    }
}
