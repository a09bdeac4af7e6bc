//! `parrt bench efficiency --frames N`: every run renders the orbit of N frames as one job, on
//! this machine's threads ([`render_sequence`], a window of frames in flight) or through local
//! one-thread workers ([`parrt_runtime::run_sequence`]); t₁ and tₙ are the whole sequence's
//! times, so the tables show how well frames fill each other's tails. No timeline or schedule
//! model is drawn for a sequence.

use super::{Case, Report};
use crate::cli_args::sequence::DEFAULT_WINDOW;
use crate::exit::input_error;
use crate::plot::Series;
use crate::studies::efficiency::{median, EfficiencyTable};
use anyhow::Context;
use parrt_render::render::Renderer;
use parrt_render::sequence::Sequence;
use parrt_render::sequence_build::FrameBuilder;
use parrt_render::sequence_smp::{render_sequence, FrameDone, SequenceOptions};
use parrt_render::settings::RenderSettings;
use parrt_render::smp::Executor;
use parrt_runtime::{DistError, FrameFinished, FrameSource};
use std::sync::atomic::AtomicBool;

impl Case<'_> {
    /// The SMP executor `ex` (frame 0's order; later frames go costliest first) at every tile
    /// size and thread count, each run the whole sequence.
    pub(super) fn smp_sequence(
        &self,
        seq: &Sequence,
        settings: &RenderSettings,
        ex: Executor,
        out: &mut Report,
    ) -> anyhow::Result<Vec<Series>> {
        let title = format!(
            "{} {}px {:?} smp {}",
            self.label,
            self.size,
            self.accel,
            ex.name()
        );
        let time = |n: usize, tile: u32| -> anyhow::Result<f64> {
            let runs = (0..self.args.repeat)
                .map(|_| smp_once(seq, settings, n, tile, ex))
                .collect::<anyhow::Result<Vec<f64>>>()?;
            Ok(median(&runs))
        };
        let trace = self.sequence_tables(&title, out, &time)?;
        Ok(self.series(ex.name(), &trace))
    }

    /// Local one-thread workers at every tile size and count, each run the whole sequence.
    pub(super) fn distributed_sequence(
        &self,
        seq: &Sequence,
        settings: &RenderSettings,
        out: &mut Report,
    ) -> anyhow::Result<Vec<Series>> {
        let title = format!(
            "{} {}px {:?} distributed (n workers × 1 thread, loopback)",
            self.label, self.size, self.accel
        );
        let time = |n: usize, tile: u32| -> anyhow::Result<f64> {
            let runs = (0..self.args.repeat)
                .map(|_| distributed_once(seq, settings, n, tile))
                .collect::<anyhow::Result<Vec<f64>>>()?;
            Ok(median(&runs))
        };
        let trace = self.sequence_tables(&title, out, &time)?;
        Ok(self.series("distributed", &trace))
    }

    /// Measures `time(n, tile)` for every tile size and thread count (t₁ once a tile size)
    /// into the tracing and whole-render tables titled `title`, writes them, and returns the
    /// tracing table.
    fn sequence_tables(
        &self,
        title: &str,
        out: &mut Report,
        time: &dyn Fn(usize, u32) -> anyhow::Result<f64>,
    ) -> anyhow::Result<EfficiencyTable> {
        let (mut trace, mut whole) = self.tables(title);
        for &tile in &self.args.tiles {
            let t1 = time(1, tile)?;
            for &n in self.threads {
                let tn = if n == 1 { t1 } else { time(n, tile)? };
                trace.set(n, tile, t1, tn);
                whole.set(n, tile, self.pre + t1, self.pre + tn);
            }
        }
        Self::write_tables(&mut out.md, &mut out.csv, &trace, &whole)?;
        Ok(trace)
    }
}

/// Seconds of one SMP render of `seq` as `parrt render` of a sequence makes it (a frame that
/// only moves the camera shares the scene's build; the builds overlap the tracing of the
/// frames before), its films dropped.
fn smp_once(
    seq: &Sequence,
    settings: &RenderSettings,
    threads: usize,
    tile: u32,
    executor: Executor,
) -> anyhow::Result<f64> {
    let opts = SequenceOptions {
        threads,
        tile,
        executor,
        window: DEFAULT_WINDOW,
        rgb8: true,
    };
    let builder = FrameBuilder::new(seq);
    let build =
        |k: usize| -> anyhow::Result<Renderer> { builder.build(k, settings).map_err(input_error) };
    let write = |_: FrameDone| -> anyhow::Result<()> { Ok(()) };
    let r = render_sequence(
        seq.len(),
        &opts,
        &build,
        &write,
        &|_| {},
        &AtomicBool::new(false),
    )?;
    Ok(r.wall_s)
}

/// The frames after the first, for the runtime: each frame's scene and the shared settings,
/// finished frames dropped.
struct Frames<'a> {
    seq: &'a Sequence,
    settings: &'a RenderSettings,
}

impl FrameSource for Frames<'_> {
    fn count(&self) -> usize {
        self.seq.len()
    }

    fn frame(
        &mut self,
        k: usize,
    ) -> Result<(parrt_render::sequence::Frame, RenderSettings), DistError> {
        let frame = self.seq.frames().get(k).ok_or_else(|| DistError::Frame {
            frame: k,
            reason: format!("the sequence has {} frames", self.seq.len()),
        })?;
        Ok((frame.clone(), self.settings.clone()))
    }

    fn finished(&mut self, _k: usize, _frame: FrameFinished) -> Result<(), DistError> {
        Ok(())
    }
}

/// The trace seconds of one render of `seq` through `n` local one-thread workers, as
/// `parrt render --workers N` of a sequence runs (8-bit pixels on the wire, the default window).
fn distributed_once(
    seq: &Sequence,
    settings: &RenderSettings,
    n: usize,
    tile: u32,
) -> anyhow::Result<f64> {
    let mut config = parrt_runtime::MasterConfig::default();
    crate::commands::distributed::local_workers(&mut config, n, 1);
    config.schedule.tile = tile;
    config.schedule.min_workers = n;
    config.schedule.frames_window = DEFAULT_WINDOW;
    config.schedule.pixel_format = parrt_protocol::PixelFormat::Rgb8;
    let first = seq.frames()[0].description().into_owned();
    let job = parrt_runtime::Job::<DistError>::ready(first, settings.clone());
    let mut frames = Frames { seq, settings };
    let done = parrt_runtime::run_sequence(&config, job, &mut frames, &mut |_| Ok(None), None)
        .context("distributed sequence failed")?;
    Ok(done.result.trace_s)
}
