//! The progress bar of a sequence: tiles done over the whole sequence, frames written of all,
//! and an ETA (indicatif). Drawn only when stdout and stderr are both terminals, as the
//! single-frame bar ([`crate::progress`]), so logs, pipes and tests stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A progress bar over a sequence's tiles and frames.
pub struct SequenceProgress {
    bar: ProgressBar,
    frames: usize,
    written: AtomicUsize,
}

impl SequenceProgress {
    /// A bar over `tiles` tiles in `frames` frames, hidden when not on a terminal.
    pub fn new(tiles: usize, frames: usize) -> Self {
        let drawn = std::io::stdout().is_terminal() && std::io::stderr().is_terminal();
        let target = if drawn {
            ProgressDrawTarget::stderr_with_hz(5)
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(Some(tiles as u64), target);
        let style = ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} tiles  {msg}  ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        bar.set_message(format!("frames 0/{frames}"));
        SequenceProgress {
            bar,
            frames,
            written: AtomicUsize::new(0),
        }
    }

    /// One more tile done.
    pub fn tile(&self) {
        self.bar.inc(1);
    }

    /// One more frame written.
    pub fn frame(&self) {
        let n = self.written.fetch_add(1, Ordering::Relaxed) + 1;
        if !self.bar.is_hidden() {
            self.bar.set_message(format!("frames {n}/{}", self.frames));
        }
    }

    /// Whether the bar is drawn (a terminal): only then is it worth watching a distributed
    /// render's tiles.
    pub fn drawn(&self) -> bool {
        !self.bar.is_hidden()
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// A distributed sequence's tiles count on the bar as the master accepts them.
impl parrt_runtime::observer::Observer for SequenceProgress {
    fn result(
        &self,
        _id: parrt_runtime::scheduler::WorkerId,
        _tile: &parrt_render::tile::Tile,
        _pixels: &[parrt_render::film::Rgb],
        _stats: &parrt_render::stats::RayStats,
        _seconds: f64,
        accepted: bool,
    ) {
        if accepted {
            self.tile();
        }
    }
}
