//! A sequence rendered through workers, with or without `--checkpoint FILE` / `--resume`: the
//! frames the runtime is given ([`parrt_runtime::FrameSource`]) are those still to render, and
//! with a checkpoint every accepted tile is recorded with its frame and every frame once its
//! file is renamed into place (docs/checkpoint.md, *Sequences*).
//!
//! On `--resume` a frame is skipped when the file says it was written **and** the frame's
//! output is still there with the length and SHA-256 recorded when it was written; a frame
//! whose every tile is in the file is assembled from them and written without any worker; the
//! others are rendered, starting from the tiles the file holds. Every frame is the same bytes
//! as an uninterrupted run's.

use anyhow::Context;
use parrt_protocol::PixelFormat;
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::sequence::Frame;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use parrt_render::tile::{tiles, Tile};
use parrt_runtime::checkpoint::{open_sequence, SequenceCheckpoint, SequenceKey, Written};
use parrt_runtime::scheduler::AcceptedTile;
use parrt_runtime::{DistError, FrameFinished, FrameSource};
use std::path::PathBuf;

/// Writes frame k's film to its output.
pub type WriteFrame<'a> = &'a dyn Fn(usize, &Film) -> anyhow::Result<()>;

/// The frames of a sequence as the runtime renders them: those still to render (`todo`, by
/// the sequence's index), each finished one written and, with a checkpoint, recorded.
pub struct ResumableFrames<'a> {
    sequence: &'a parrt_render::sequence::Sequence,
    settings: &'a [RenderSettings],
    outputs: &'a [PathBuf],
    write: WriteFrame<'a>,
    /// The sequence's index of each frame the runtime renders, in order.
    todo: Vec<usize>,
    /// By the sequence's index: the tiles the checkpoint held for that frame.
    restored: Vec<Vec<AcceptedTile>>,
    checkpoint: Option<SequenceCheckpoint>,
}

/// What resuming a sequence's checkpoint found, for the user.
#[derive(Debug, Default)]
pub struct Resumed {
    /// Whether the checkpoint existed (a resume) rather than being created now.
    pub resumed: bool,
    /// Frames skipped: written before, their files still whole.
    pub skipped: usize,
    /// Frames assembled from the checkpoint's tiles alone and written now.
    pub assembled: usize,
    /// Tiles of the frames still to render taken from the checkpoint.
    pub restored_tiles: usize,
    /// Records not trusted.
    pub bad_records: usize,
    /// Tiles of the frames skipped or assembled (not rendered in this run).
    pub tiles_before: usize,
    /// Ray statistics of those frames, summed from their records.
    pub stats_before: RayStats,
}

impl<'a> ResumableFrames<'a> {
    /// Every frame of `sequence` to render, none recorded.
    pub fn all(
        sequence: &'a parrt_render::sequence::Sequence,
        settings: &'a [RenderSettings],
        outputs: &'a [PathBuf],
        write: WriteFrame<'a>,
    ) -> Self {
        ResumableFrames {
            sequence,
            settings,
            outputs,
            write,
            todo: (0..sequence.len()).collect(),
            restored: (0..sequence.len()).map(|_| Vec::new()).collect(),
            checkpoint: None,
        }
    }

    /// Opens (or, with `resume`, continues) the sequence's checkpoint at `path`, sealed with
    /// `secret` when given, for tiles of `tile` pixels sent as `format`: skips the frames
    /// written whose files are still whole, writes those the file holds every tile of, and
    /// keeps the rest to render with their tiles. A checkpoint of another sequence, of one
    /// frame, or of other settings is refused (bad input) and left as it is.
    pub fn with_checkpoint(
        mut self,
        path: &std::path::Path,
        resume: bool,
        secret: Option<&[u8]>,
        tile: u32,
        format: PixelFormat,
    ) -> anyhow::Result<(Self, Resumed)> {
        let descs: Vec<std::borrow::Cow<'_, SceneDescription>> = self
            .sequence
            .frames()
            .iter()
            .map(|f| f.description())
            .collect();
        let mut key = SequenceKey::new(
            descs.iter().map(|d| d.as_ref()).zip(self.settings),
            tile,
            format,
        )
        .map_err(DistError::from)?;
        drop(descs);
        if let Some(s) = secret {
            key = key.sealed_with(s);
        }
        let frame_tiles: Vec<Vec<Tile>> = self
            .settings
            .iter()
            .map(|s| tiles(s.width, s.height, tile.max(1)))
            .collect();
        let opened = open_sequence(path, &key, &frame_tiles, resume).map_err(DistError::from)?;
        let mut scan = opened.scan;
        let mut info = Resumed {
            resumed: !opened.created,
            bad_records: scan.bad_records,
            ..Resumed::default()
        };
        self.checkpoint = Some(opened.checkpoint);
        self.todo.clear();
        for (k, list) in frame_tiles.iter().enumerate() {
            let done = std::mem::take(&mut scan.tiles[k]);
            let whole = scan.written[k]
                .is_some_and(|w| Written::of_file(&self.outputs[k]).is_ok_and(|now| now == w));
            let film = (!whole && done.len() == list.len())
                .then(|| assemble(&self.settings[k], list, &done, format))
                .flatten();
            if whole || film.is_some() {
                info.tiles_before += list.len();
                for t in &done {
                    info.stats_before += t.stats;
                }
            }
            if whole {
                info.skipped += 1;
            } else if let Some(film) = film {
                self.write_frame(k, &film)?;
                info.assembled += 1;
            } else if done.len() < list.len() {
                info.restored_tiles += done.len();
                self.restored[k] = done;
                self.todo.push(k);
            } else {
                // Every tile, but one the film refuses: the frame is rendered whole again
                // (restored alone, it would be complete before it opened).
                self.todo.push(k);
            }
        }
        Ok((self, info))
    }

    /// How many bytes of the checkpoint are known to be on the disk, when there is one.
    pub fn durable(&self) -> Option<std::sync::Arc<std::sync::atomic::AtomicU64>> {
        self.checkpoint.as_ref().map(SequenceCheckpoint::durable)
    }

    /// The sequence's indices of the frames still to render, in order.
    pub fn todo(&self) -> &[usize] {
        &self.todo
    }

    /// Writes frame `k` (the sequence's index) and, with a checkpoint, records it written:
    /// its length and SHA-256 as it is in place.
    pub fn write_frame(&mut self, k: usize, film: &Film) -> anyhow::Result<()> {
        (self.write)(k, film)?;
        if let Some(c) = &mut self.checkpoint {
            let out = &self.outputs[k];
            let w = Written::of_file(out)
                .with_context(|| format!("cannot read back frame {k}, {}", out.display()))?;
            c.written(k, &w).map_err(DistError::from)?;
        }
        Ok(())
    }

    /// Makes what is recorded durable (the end of the run).
    pub fn close(&mut self) -> anyhow::Result<()> {
        if let Some(c) = &mut self.checkpoint {
            c.sync().map_err(DistError::from)?;
        }
        Ok(())
    }

    fn global(&self, k: usize) -> Result<usize, DistError> {
        self.todo.get(k).copied().ok_or_else(|| DistError::Frame {
            frame: k,
            reason: format!("the run has {} frames to render", self.todo.len()),
        })
    }
}

/// Frame `settings`' film from `done`, a record for each of its `tiles`, as the scheduler would
/// have filled it (`None` if a record does not fit).
fn assemble(
    settings: &RenderSettings,
    tiles: &[Tile],
    done: &[AcceptedTile],
    format: PixelFormat,
) -> Option<Film> {
    let mut film = match format {
        PixelFormat::Rgb8 => Film::new_rgb8(settings.width, settings.height),
        PixelFormat::F32 => Film::new(settings.width, settings.height),
    };
    let mut decoded = Vec::new();
    for t in done {
        let tile = tiles.get(t.tile_id as usize)?;
        t.pixels
            .decode_into(format, tile.pixel_count(), &mut decoded)
            .ok()?;
        film.write_tile(tile, &decoded).ok()?;
    }
    Some(film)
}

impl FrameSource for ResumableFrames<'_> {
    fn count(&self) -> usize {
        self.todo.len()
    }

    fn frame(&mut self, k: usize) -> Result<(Frame, RenderSettings), DistError> {
        let g = self.global(k)?;
        let missing = || DistError::Frame {
            frame: g,
            reason: format!("the sequence has {} frames", self.sequence.len()),
        };
        let frame = self.sequence.frames().get(g).ok_or_else(missing)?;
        let settings = self.settings.get(g).ok_or_else(missing)?;
        Ok((frame.clone(), settings.clone()))
    }

    fn finished(&mut self, k: usize, frame: FrameFinished) -> Result<(), DistError> {
        let g = self.global(k)?;
        self.write_frame(g, &frame.film)
            .map_err(|e| DistError::Frame {
                frame: g,
                reason: format!("{e:#}"),
            })
    }

    fn keeps_tiles(&self) -> bool {
        self.checkpoint.is_some()
    }

    fn restored(&mut self, k: usize) -> Vec<AcceptedTile> {
        match self.todo.get(k) {
            Some(&g) => std::mem::take(&mut self.restored[g]),
            None => Vec::new(),
        }
    }

    fn make_durable(&mut self) -> Result<(), DistError> {
        match &mut self.checkpoint {
            Some(c) => c.sync().map_err(DistError::from),
            None => Ok(()),
        }
    }

    fn accepted(&mut self, mut tiles: Vec<AcceptedTile>) -> Result<(), DistError> {
        for t in &mut tiles {
            t.frame = self.global(t.frame)?;
        }
        match &mut self.checkpoint {
            Some(c) => c.append(&tiles).map_err(DistError::from),
            None => Ok(()),
        }
    }
}
