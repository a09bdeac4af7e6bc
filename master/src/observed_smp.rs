//! An SMP render reported to the runtime's observers the way a distributed render is: each
//! render thread is a worker (`thread N`, of one thread) that joins, is ready, is assigned the
//! tiles it renders and returns them, accepted. So the progress bar, the live view and any
//! other watcher read one interface ([`Observer`]) however the image is made. The observers
//! are called on the render threads, after each tile is in the film: as in a distributed
//! render, they must be quick and never wait.
//!
//! [`Observer`]: parrt_runtime::observer::Observer

use parrt_render::film::Film;
use parrt_render::render::Renderer;
use parrt_render::smp::{render_smp_into, SmpOptions, SmpResult};
use parrt_runtime::observer::Observers;
use parrt_runtime::scheduler::WorkerId;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;
use tokio::time::Instant;

/// Renders `renderer`'s image on this machine's cores with `opts`, telling `observers` what
/// happens: each thread joins and is ready, the trace starts, each tile is assigned to the
/// thread that rendered it (at the time it began) and its result comes in with its pixels,
/// then the progress, and at the end the render finishes, complete. Returns what
/// [`parrt_render::smp::render_smp_with`] returns, in `film` (a black film of the image's size, 8-bit for an
/// 8-bit output: [`parrt_render::film::Film::for_output`]): the image is the same bits whoever
/// watches.
pub fn render_smp_observed(
    renderer: &Renderer,
    opts: &SmpOptions,
    film: Film,
    observers: &Observers,
) -> SmpResult {
    let s = renderer.settings();
    let total = parrt_render::tile::tiles(s.width, s.height, opts.tile).len();
    let threads = opts.threads.max(1);
    observers.each(|o| o.progress(0, total, &[]));
    let now = Instant::now();
    for t in 0..threads {
        let (id, name) = (t as WorkerId, format!("thread {t}"));
        observers.each(|o| {
            o.joined(id, &name, 1, now);
            o.ready(id, now);
        });
    }
    let origin = Instant::now();
    observers.each(|o| o.started(origin));
    let done = AtomicUsize::new(0);
    let result = render_smp_into(renderer, opts, film, &|tile| {
        let id = WorkerId::from(tile.span.thread);
        let began = Duration::try_from_secs_f64(tile.span.start_s).unwrap_or_default();
        let seconds = (tile.span.end_s - tile.span.start_s).max(0.0);
        let n = done.fetch_add(1, Ordering::Relaxed) + 1;
        observers.each(|o| {
            o.assigned(id, tile.tile, 1, false, origin + began);
            o.result(id, tile.tile, tile.pixels, tile.stats, seconds, true);
            o.progress(n, total, &[]);
        });
    });
    observers.each(|o| o.finished(true, Instant::now()));
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_render::film::Rgb;
    use parrt_render::smp::Executor;
    use parrt_render::stats::RayStats;
    use parrt_render::tile::Tile;
    use parrt_runtime::observer::Observer;
    use std::sync::{Arc, Mutex};

    /// Notes what it is told.
    #[derive(Default)]
    struct Log(Mutex<Vec<String>>);

    impl Log {
        fn push(&self, s: String) {
            self.0.lock().unwrap().push(s);
        }
    }

    impl Observer for Log {
        fn started(&self, _now: Instant) {
            self.push("started".into());
        }
        fn joined(&self, id: WorkerId, name: &str, threads: u32, _now: Instant) {
            self.push(format!("joined {id} {name} {threads}"));
        }
        fn ready(&self, id: WorkerId, _now: Instant) {
            self.push(format!("ready {id}"));
        }
        fn assigned(&self, _id: WorkerId, tile: &Tile, attempt: u32, backup: bool, _n: Instant) {
            self.push(format!("assigned {} {attempt} {backup}", tile.id));
        }
        fn result(
            &self,
            _id: WorkerId,
            tile: &Tile,
            pixels: &[Rgb],
            _stats: &RayStats,
            seconds: f64,
            accepted: bool,
        ) {
            assert_eq!(pixels.len(), tile.pixel_count());
            assert!(seconds >= 0.0);
            self.push(format!("result {} {accepted}", tile.id));
        }
        fn progress(&self, done: usize, total: usize, workers: &[(String, f64)]) {
            assert!(workers.is_empty());
            self.push(format!("progress {done}/{total}"));
        }
        fn finished(&self, complete: bool, _now: Instant) {
            self.push(format!("finished {complete}"));
        }
    }

    #[test]
    fn threads_are_workers_and_every_tile_is_assigned_then_accepted() {
        let desc = parrt_scenes::generate("balls", Some(1)).unwrap();
        let settings = parrt_render::settings::RenderSettings::new(16, 8);
        let renderer = Renderer::new(&desc, &settings).unwrap();
        let opts = SmpOptions {
            threads: 2,
            tile: 8,
            executor: Executor::Queue,
        };
        let log = Arc::new(Log::default());
        let watched = render_smp_observed(
            &renderer,
            &opts,
            Film::new(16, 8),
            &Observers(vec![log.clone()]),
        );
        let plain = parrt_render::smp::render_smp(&renderer, &opts, &|_, _| {});
        assert_eq!(watched.film, plain.film, "the same bits");
        let log = log.0.lock().unwrap().clone();
        assert_eq!(
            log[..6],
            [
                "progress 0/2",
                "joined 0 thread 0 1",
                "ready 0",
                "joined 1 thread 1 1",
                "ready 1",
                "started"
            ]
        );
        let mut results: Vec<&String> = log.iter().filter(|l| l.starts_with("result")).collect();
        results.sort();
        assert_eq!(results, ["result 0 true", "result 1 true"]);
        assert_eq!(log.iter().filter(|l| l.starts_with("assigned")).count(), 2);
        assert!(log.contains(&"progress 2/2".to_string()));
        assert_eq!(log.last().map(String::as_str), Some("finished true"));
    }
}
