//! The master configuration the three distributed entry points (`render --workers`, `master`,
//! `cluster`) share, with their flags ([`JobFlags`]): who observes the render, the checkpoint and how its records are sealed,
//! the tile size, how many workers to wait for and the pixel format the output needs. Each
//! command adds what only it has (spawned workers, a listen address and token, schedule
//! tuning).

use crate::cli_args::JobFlags;
use parrt_runtime::observer::Observers;
use parrt_runtime::{CheckpointAt, MasterConfig};
use std::path::Path;

/// What every distributed entry point decides about its master.
pub struct MasterSetup<'a> {
    /// Who watches the render (progress, timeline, live view).
    pub observers: Observers,
    /// The job's flags (`--checkpoint FILE`, `--resume`).
    pub job: &'a JobFlags,
    /// Whether checkpoint records are sealed with the token: only when the token outlives the
    /// run (the user gives it again to resume); a token made for one run keys nothing.
    pub keyed: bool,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Workers that must be ready before rendering starts.
    pub min_workers: usize,
    /// The output image, whose kind decides the pixels' format on the wire.
    pub output: &'a Path,
}

/// The master configuration of `s`, every other field at its default.
pub fn master_config(s: MasterSetup<'_>) -> MasterConfig {
    let mut config = MasterConfig {
        observers: s.observers,
        checkpoint: s.job.checkpoint.as_ref().map(|path| CheckpointAt {
            path: path.clone(),
            resume: s.job.resume,
            keyed: s.keyed,
        }),
        ..MasterConfig::default()
    };
    config.schedule.tile = s.tile;
    config.schedule.min_workers = s.min_workers;
    config.schedule.pixel_format = parrt_runtime::pixel_format_for(s.output);
    config
}

/// A sequence's frames for the distributed runtime ([`parrt_runtime::FrameSource`]): frame
/// k's scene (the sequence's, turned for an orbit) and settings, and each finished frame given
/// to `write` as soon as it is complete.
pub struct SequenceFrames<'a> {
    /// The frames.
    pub sequence: &'a parrt_render::sequence::Sequence,
    /// Each frame's settings, as rendering it alone would make them.
    pub settings: &'a [parrt_render::settings::RenderSettings],
    /// Writes frame k's film (to the file the `-o` pattern names for it).
    pub write: &'a dyn Fn(usize, &parrt_render::film::Film) -> anyhow::Result<()>,
}

impl parrt_runtime::FrameSource for SequenceFrames<'_> {
    fn count(&self) -> usize {
        self.sequence.len()
    }

    fn frame(
        &mut self,
        k: usize,
    ) -> Result<
        (
            parrt_render::description::SceneDescription,
            parrt_render::settings::RenderSettings,
        ),
        parrt_runtime::DistError,
    > {
        let missing = || parrt_runtime::DistError::Frame {
            frame: k,
            reason: format!("the sequence has {} frames", self.sequence.len()),
        };
        let frame = self.sequence.frames().get(k).ok_or_else(missing)?;
        let settings = self.settings.get(k).ok_or_else(missing)?;
        Ok((frame.description().into_owned(), settings.clone()))
    }

    fn finished(
        &mut self,
        k: usize,
        frame: parrt_runtime::FrameFinished,
    ) -> Result<(), parrt_runtime::DistError> {
        (self.write)(k, &frame.film).map_err(|e| parrt_runtime::DistError::Frame {
            frame: k,
            reason: format!("{e:#}"),
        })
    }
}
