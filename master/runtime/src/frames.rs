//! The frames of a sequence as the master's loop drives them ([`crate::Master::render_sequence`]):
//! where the later frames come from and where finished ones go ([`FrameSource`]), and the one
//! loop over the whole sequence: the scheduler always has the next frame in hand
//! ([`crate::scheduler::Scheduler::push_frame`]) to open when the frames open run out of tiles
//! to hand out, and each frame complete goes to the source as soon as the round that
//! completed it ends ([`crate::scheduler::Scheduler::take_complete`]), summing what the
//! sequence did.

use crate::options::MasterConfig;
use crate::scheduler::{AcceptedTile, FrameCamera, FrameFinished, FrameJob, Scheduler, WholeJob};
use crate::server::{drive, encode_job, JobForm, Loop};
use crate::DistError;
use parrt_protocol::{SceneContent, SceneKey};
use parrt_render::description::SceneDescription;
use parrt_render::sequence::Frame;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use parrt_render::tile::{tiles, Tile};
use rand::Rng;
use std::sync::Arc;

/// The later frames of a sequence ([`crate::Master::render_sequence`]): what each is, and where each
/// finished frame goes.
pub trait FrameSource {
    /// Frames in the sequence, the first included.
    fn count(&self) -> usize;
    /// Frame `k` and its settings: frame 0 once, for its scene key, then each later frame in
    /// order, when the frame before is given to the scheduler (before it opens). A frame's
    /// scene is shared ([`Frame::scene`]) by every frame that shows it (a camera path's frames
    /// share one): the master hashes a scene's content once, not once a frame, and copies it
    /// only to send it whole.
    fn frame(&mut self, k: usize) -> Result<(Frame, RenderSettings), DistError>;
    /// Frame `k` is complete (every frame but the last, which is the render's result), each
    /// once, as soon as it is: frames may complete out of order.
    fn finished(&mut self, k: usize, frame: FrameFinished) -> Result<(), DistError>;
    /// Whether the source keeps the tiles accepted (a checkpoint of the sequence): then it
    /// is asked for frame `k`'s tiles an earlier run left before the frame opens
    /// ([`Self::restored`]), and given every tile accepted, with its frame, after each round
    /// of the master's loop and before the frames completed in it ([`Self::accepted`]).
    fn keeps_tiles(&self) -> bool {
        false
    }
    /// Frame `k`'s tiles an earlier run left (never all of them).
    fn restored(&mut self, _k: usize) -> Vec<AcceptedTile> {
        Vec::new()
    }
    /// The tiles accepted in the last round of the master's loop.
    fn accepted(&mut self, _tiles: Vec<AcceptedTile>) -> Result<(), DistError> {
        Ok(())
    }
    /// Every tile is in: make what the source recorded durable now, before any worker is told
    /// to go (a machine that crashes after the goodbye must leave a record that needs no worker
    /// to finish, as a one-frame checkpoint is closed before it).
    fn make_durable(&mut self) -> Result<(), DistError> {
        Ok(())
    }
}

/// No later frames: the type of a render of one frame.
pub(crate) enum NoFrames {}

impl FrameSource for NoFrames {
    fn count(&self) -> usize {
        match *self {}
    }
    fn frame(&mut self, _: usize) -> Result<(Frame, RenderSettings), DistError> {
        match *self {}
    }
    fn finished(&mut self, _: usize, _: FrameFinished) -> Result<(), DistError> {
        match *self {}
    }
}

/// What a sequence sums over its frames beside the last one's film.
#[derive(Default)]
pub(crate) struct SequenceSums {
    /// Tiles in every frame opened.
    pub(crate) tiles: usize,
    /// Ray statistics of the frames before the last.
    pub(crate) stats: RayStats,
    /// The master's CPU seconds when the first tile went out.
    pub(crate) cpu_at_start: f64,
    /// The most events that waited at once, over the frames.
    pub(crate) events_peak: usize,
    /// The last frame, once complete: the render's result.
    pub(crate) last: Option<FrameFinished>,
}

/// A frame as the scheduler is given it ([`Scheduler::push_frame`]).
struct Opened {
    job_id: u64,
    settings: RenderSettings,
    lights: usize,
    tiles: Vec<Tile>,
    job: FrameJob,
}

/// Frame `k` of `src`: a fresh job id, its settings, lights and tiles, and its Job encoded
/// once for every worker (refused if it would not fit a frame) with its camera-only form.
fn open_frame<F: FrameSource + ?Sized>(
    src: &mut F,
    k: usize,
    rng: &mut rand::rngs::StdRng,
    config: &MasterConfig,
    hashes: &mut SceneHashes,
) -> Result<Opened, DistError> {
    let (frame, settings) = src.frame(k)?;
    let job_id = rng.gen::<u64>();
    let key = hashes.key(&frame, &settings);
    // The frame before had the same key, so every worker holds a base of this scene or is
    // sent frame 0's: this frame's whole Job waits until a worker needs it.
    let defer = key.is_some() && key == hashes.last_key;
    hashes.last_key = key;
    let lights = frame.scene.lights.len();
    let job = frame_job(job_id, frame, &settings, key, defer, config)?;
    let tiles = tiles(settings.width, settings.height, config.schedule.tile);
    Ok(Opened {
        job_id,
        settings,
        lights,
        tiles,
        job,
    })
}

/// The content hash of the scene the latest frame showed, kept while the frames after it
/// show the same shared scene ([`FrameSource::scene`]), and the latest frame's key.
#[derive(Default)]
struct SceneHashes {
    latest: Option<(Arc<SceneDescription>, Option<SceneContent>)>,
    last_key: Option<SceneKey>,
}

impl SceneHashes {
    /// The scene key of `frame` built with `settings`: its scene's content hashed only when it
    /// is not the latest frame's.
    fn key(&mut self, frame: &Frame, settings: &RenderSettings) -> Option<SceneKey> {
        let known = matches!(&self.latest, Some((s, _)) if Arc::ptr_eq(s, &frame.scene));
        if !known {
            let content = SceneContent::new(&frame.scene);
            self.latest = Some((frame.scene.clone(), content));
        }
        let (_, content) = self.latest.as_ref()?;
        content.as_ref()?.key(&frame.view, settings)
    }
}

/// A frame's Job: whole (encoded now, or made and encoded when first needed if `defer`: a
/// camera path's later frames then never copy their scene), and its scene key (`None`: none)
/// and camera, so that a worker holding a Job of the same key is sent the camera alone.
fn frame_job(
    job_id: u64,
    frame: Frame,
    settings: &RenderSettings,
    key: Option<SceneKey>,
    defer: bool,
    config: &MasterConfig,
) -> Result<FrameJob, DistError> {
    let view = frame.view.clone();
    let job = if defer {
        let (form, settings) = (JobForm::of(config), settings.clone());
        WholeJob::deferred(
            move || form.message(job_id, &frame.description(), &settings),
            config.net.max_frame,
        )
    } else {
        WholeJob::Encoded(encode_job(job_id, &frame.description(), settings, config)?)
    };
    let camera = key.map(|key| FrameCamera {
        key,
        view,
        settings: settings.clone(),
        tile_size: config.schedule.tile,
    });
    Ok(FrameJob { job, camera })
}

/// Drives frame 0 (`first`: its job id and settings, already the scheduler's) and every
/// later frame of `frames` on the same workers, up to `window` frames open at once, in one run
/// of the master's loop; each finished frame but the last goes to `frames`, the last to
/// `seq.last`. Stops at the first failure.
pub(crate) async fn drive_frames<F: FrameSource + ?Sized>(
    l: &mut Loop<'_>,
    first: (u64, &RenderSettings),
    frames: Option<&mut F>,
    rng: &mut rand::rngs::StdRng,
    config: &MasterConfig,
    seq: &mut SequenceSums,
) -> Result<(), DistError> {
    let count = frames.as_ref().map_or(1, |f| f.count());
    let driven = match frames {
        Some(src) if count > 1 || src.keeps_tiles() => {
            let (job_id, settings) = first;
            let mut hashes = SceneHashes::default();
            let keeps = src.keeps_tiles();
            if keeps {
                l.sched.keep_accepted();
                l.sched.restore(src.restored(0));
            }
            if count > 1 {
                let (frame, _) = src.frame(0)?;
                hashes.last_key = hashes.key(&frame, settings);
                let job = frame_job(job_id, frame, settings, hashes.last_key, false, config)?;
                l.sched
                    .start_frames(config.schedule.frames_window, count, job);
            }
            let mut next = 1;
            let mut hook = |sched: &mut Scheduler| -> Result<(), DistError> {
                if keeps {
                    src.accepted(sched.take_accepted())?;
                }
                for (k, done) in sched.take_complete() {
                    if k + 1 == count {
                        seq.last = Some(done);
                    } else {
                        seq.stats += done.stats;
                        src.finished(k, done)?;
                    }
                }
                if next < count && sched.pending_frames() == 0 {
                    let f = open_frame(src, next, rng, config, &mut hashes)?;
                    seq.tiles += f.tiles.len();
                    sched.push_frame(next, f.job_id, &f.settings, f.lights, f.tiles, f.job);
                    if keeps {
                        sched.restore_pending(src.restored(next));
                    }
                    next += 1;
                }
                Ok(())
            };
            hook(l.sched)?;
            let frame_tiles = l.sched.progress().1;
            let mut driven = drive(l, frame_tiles, &mut hook).await;
            if keeps && driven.outcome.is_ok() && l.sched.is_done() {
                driven.outcome = src.make_durable();
            }
            driven
        }
        _ => {
            let frame_tiles = l.sched.progress().1;
            drive(l, frame_tiles, &mut |_: &mut Scheduler| Ok(())).await
        }
    };
    seq.cpu_at_start = driven.cpu_at_start;
    seq.events_peak = seq.events_peak.max(driven.events_peak);
    driven.outcome
}
