//! The one progress bar (indicatif) of every render: tiles done of all, an ETA, and Mrays/s
//! for an SMP render or each worker's tiles per second for a distributed one. It is an
//! [`Observer`] of the distributed runtime and is fed tile by tile by the SMP path. Drawn only
//! when stdout and stderr are both terminals, so logs, pipes and tests stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use parrt_runtime::observer::Observer;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// A progress bar over a render's tiles.
pub struct Progress {
    bar: ProgressBar,
    started: Instant,
    rays: AtomicU64,
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
            started: Instant::now(),
            rays: AtomicU64::new(0),
        }
    }

    /// Sets the number of tiles in the image.
    pub fn set_total(&self, tiles: usize) {
        self.bar.set_length(tiles as u64);
    }

    /// One more tile done here (SMP), having traced `rays` rays.
    pub fn tile_done(&self, rays: u64) {
        let total = self.rays.fetch_add(rays, Ordering::Relaxed) + rays;
        let secs = self.started.elapsed().as_secs_f64().max(1e-9);
        self.bar
            .set_message(format!("{:.2} Mrays/s", total as f64 / secs / 1e6));
        self.bar.inc(1);
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Observer for Progress {
    fn progress(&self, done: usize, total: usize, workers: &[(String, f64)]) {
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
        let msg = workers
            .iter()
            .map(|(n, r)| format!("{n} {r:.1} tiles/s"))
            .collect::<Vec<_>>()
            .join(", ");
        self.bar.set_message(msg);
    }

    fn finished(&self, _complete: bool, _now: tokio::time::Instant) {
        self.finish();
    }
}
