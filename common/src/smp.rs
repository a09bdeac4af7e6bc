//! Shared-memory parallel rendering: executors that hand tiles to threads. `queue` is the paper's
//! design (N threads take the next tile from a locked queue); `rayon` is work stealing. The image
//! never depends on the executor, the thread count or the tile size.

use crate::film::{Film, Rgb};
use crate::render::Renderer;
use crate::stats::RayStats;
use crate::tile::{tiles, Tile};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::sync::Mutex;
use std::time::Instant;

/// How tiles are handed to threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum Executor {
    /// The paper's: N OS threads pop the next tile from a mutex-guarded queue.
    #[default]
    Queue,
    /// rayon's work-stealing pool over the tile list.
    Rayon,
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
}

/// Renders the whole image. `progress` is called after each tile with the tile and its stats.
pub fn render_smp(
    renderer: &Renderer,
    opts: &SmpOptions,
    progress: &(dyn Fn(&Tile, &RayStats) + Sync),
) -> SmpResult {
    let s = renderer.settings();
    let list = tiles(s.width, s.height, opts.tile);
    let threads = opts.threads.max(1);
    let film = Mutex::new(Film::new(s.width, s.height));
    let totals = Mutex::new((RayStats::default(), vec![0.0f64; list.len()]));
    let start = Instant::now();
    let finish = |tile: &Tile, buf: &[Rgb], st: RayStats, secs: f64| {
        film.lock()
            .unwrap_or_else(|e| e.into_inner())
            .write_tile(tile, buf)
            .expect("tiles come from the film's own size");
        let mut t = totals.lock().unwrap_or_else(|e| e.into_inner());
        t.0 += st;
        t.1[tile.id as usize] = secs;
        drop(t);
        progress(tile, &st);
    };
    let render_one = |tile: &Tile, buf: &mut Vec<Rgb>| {
        let t0 = Instant::now();
        let mut st = RayStats::default();
        renderer.render_tile(tile, buf, &mut st);
        finish(tile, buf, st, t0.elapsed().as_secs_f64());
    };
    match opts.executor {
        Executor::Queue => {
            let queue = Mutex::new(list.iter().copied().collect::<VecDeque<Tile>>());
            std::thread::scope(|scope| {
                for _ in 0..threads {
                    scope.spawn(|| {
                        let mut buf = Vec::new();
                        loop {
                            let next = queue.lock().unwrap_or_else(|e| e.into_inner()).pop_front();
                            match next {
                                Some(tile) => render_one(&tile, &mut buf),
                                None => break,
                            }
                        }
                    });
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
                    .for_each_init(Vec::new, |buf, tile| render_one(tile, buf));
            });
        }
    }
    let trace_s = start.elapsed().as_secs_f64();
    let (stats, tile_seconds) = totals.into_inner().unwrap_or_else(|e| e.into_inner());
    SmpResult {
        film: film.into_inner().unwrap_or_else(|e| e.into_inner()),
        stats,
        tile_seconds,
        trace_s,
    }
}
