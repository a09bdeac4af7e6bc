//! The one progress bar (indicatif) of every render: tiles done of all, an ETA, and each
//! worker's tiles per second while a distributed render reports them, else the Mrays/s of the
//! tiles in so far (an SMP render, whose threads report no rates). A plain [`Observer`] of the
//! render, SMP or distributed alike. Drawn only when stdout and stderr are both terminals, so
//! logs, pipes and tests stay clean; hidden, it formats nothing.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use parrt_render::film::Rgb;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use parrt_runtime::observer::Observer;
use parrt_runtime::scheduler::WorkerId;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::OnceLock;
use std::time::Instant;

/// A progress bar over a render's tiles.
pub struct Progress {
    bar: ProgressBar,
    /// When the bar was made: the rate's origin until the trace starts.
    created: Instant,
    /// When the trace started (the runtime's `started`).
    started: OnceLock<Instant>,
    /// Rays of the accepted tiles.
    rays: AtomicU64,
    /// The most tiles reported done (reports from several threads may come out of order).
    done: AtomicUsize,
}

impl Progress {
    /// A bar, hidden when `enabled` is false or stdout or stderr is not a terminal.
    pub fn new(enabled: bool) -> Self {
        let drawn = enabled && std::io::stdout().is_terminal() && std::io::stderr().is_terminal();
        let target = if drawn {
            ProgressDrawTarget::stderr_with_hz(5)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(None, target);
        let style = ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} tiles  ETA {eta}  {wide_msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        Progress {
            bar,
            created: Instant::now(),
            started: OnceLock::new(),
            rays: AtomicU64::new(0),
            done: AtomicUsize::new(0),
        }
    }

    /// Mrays/s of the accepted tiles since the trace started (empty before any).
    fn ray_rate(&self) -> String {
        let rays = self.rays.load(Ordering::Relaxed);
        if rays == 0 {
            return String::new();
        }
        let origin = *self.started.get().unwrap_or(&self.created);
        let secs = origin.elapsed().as_secs_f64().max(1e-9);
        format!("{:.2} Mrays/s", rays as f64 / secs / 1e6)
    }
}

impl Observer for Progress {
    fn started(&self, _now: tokio::time::Instant) {
        self.started.get_or_init(Instant::now);
    }

    fn result(
        &self,
        _id: WorkerId,
        _tile: &Tile,
        _pixels: &[Rgb],
        stats: &RayStats,
        _seconds: f64,
        accepted: bool,
    ) {
        if accepted {
            self.rays.fetch_add(stats.total_rays(), Ordering::Relaxed);
        }
    }

    fn progress(&self, done: usize, total: usize, workers: &[(String, f64)]) {
        let done = self.done.fetch_max(done, Ordering::Relaxed).max(done);
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
        if self.bar.is_hidden() {
            return;
        }
        let msg = if workers.is_empty() {
            self.ray_rate()
        } else {
            workers
                .iter()
                .map(|(n, r)| format!("{n} {r:.1} tiles/s"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        self.bar.set_message(msg);
    }

    fn finished(&self, _complete: bool, _now: tokio::time::Instant) {
        self.bar.finish_and_clear();
    }
}
