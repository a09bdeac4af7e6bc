//! The master's progress line (indicatif): tiles done, per-worker throughput and an ETA. Drawn
//! only when stderr is a terminal, so logs and tests stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A progress bar over a job's tiles.
pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A bar over `tiles` tiles; hidden when `enabled` is false or stderr is not a terminal.
    pub fn new(tiles: usize, enabled: bool) -> Self {
        let target = if enabled && std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr_with_hz(5)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(Some(tiles as u64), target);
        let style =
            ProgressStyle::with_template("{bar:30} {pos}/{len} tiles  eta {eta}  {wide_msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        Progress { bar }
    }

    /// Updates the count and the per-worker throughput (`name tiles/s`).
    pub fn update(&self, done: usize, workers: &[(String, f64)]) {
        self.bar.set_position(done as u64);
        let msg = workers
            .iter()
            .map(|(n, r)| format!("{n} {r:.1} tiles/s"))
            .collect::<Vec<_>>()
            .join(", ");
        self.bar.set_message(msg);
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
