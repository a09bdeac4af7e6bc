//! The frames a scheduler works on: one frame's tiles, their states and its film ([`Frame`]),
//! and, in a sequence, the window of frames open at once ([`Frames`]). When no tile of the
//! frames open is left to hand out and fewer than the window are open, the next frame given
//! opens: its Job goes to every worker and its tiles are dealt at once, so they fill the tail
//! of the frames before. A frame whose every tile is in closes: the workers are told to drop
//! its scene (Cancel), and it waits for the driver ([`Scheduler::take_complete`]).
//!
//! A frame's tiles are dealt costliest first by their predicted times
//! ([`crate::prediction`]: the latest frame closed, carried on by the motion between the two
//! closed last). The sequence's last frame has no frame after it to fill its tail, so it opens
//! *early*, while the frames before still have tiles queued, once what they have not done
//! (queued or in flight) is less work than every ready thread running its costliest tile: a
//! tile that long must start before the work left runs out, or the threads that finish the
//! rest wait for it. Such a tile is *urgent* and dealt before the frames before it
//! ([`Scheduler::deal`]).

use super::*;
use crate::prediction::{predict, Grid, Motion, Risk, Track, RADIUS};
use parrt_protocol::{SceneKey, ViewSpec};
use parrt_render::description::View;
use std::collections::HashMap;

/// The most frames of a sequence open at once: what a worker keeps built
/// ([`parrt_protocol::limits::MAX_JOBS_HELD`]) less the one base it may also keep.
pub const MAX_FRAMES_WINDOW: usize = parrt_protocol::limits::MAX_JOBS_HELD - 1;

/// One frame's state: its job, its tiles (queued, in flight, done), the workers holding each,
/// the film and the statistics of the tiles accepted.
pub(super) struct Frame {
    /// The frame's index in the sequence (0 for a render of one frame).
    pub(super) index: usize,
    pub(super) job_id: u64,
    /// The frame's settings: what a result's statistics are checked against.
    pub(super) settings: RenderSettings,
    /// Lights in the scene (each hit casts at most one shadow ray per light).
    pub(super) lights: usize,
    pub(super) tiles: Vec<Tile>,
    pub(super) state: Vec<TileState>,
    pub(super) attempts: Vec<u32>,
    /// Per tile, the workers holding it in a live (unexpired) assignment: kept as assignments
    /// come and go so that the question costs nothing (a scan of every worker per tile made
    /// the tail of a 4 096-worker frame quadratic and more).
    pub(super) holders: Vec<u16>,
    pub(super) queue: VecDeque<u32>,
    /// The queue is in an order given by cost ([`Frame::set_order`]): workers with room are
    /// dealt in rounds ([`Scheduler::fill`]).
    pub(super) deal_in_rounds: bool,
    pub(super) done: usize,
    pub(super) film: Film,
    pub(super) stats: RayStats,
    pub(super) tile_seconds: Vec<f64>,
    /// When its first tile was handed out.
    pub(super) first_out: Option<Instant>,
    /// Each tile's predicted seconds, as long as it may take ([`crate::prediction::predict`]):
    /// the order its tiles are dealt in and whether one is urgent ([`Scheduler::deal`]); empty
    /// when nothing predicts them (a sequence's first frame).
    pub(super) predicted: Vec<f64>,
    /// Each tile's expected seconds (the latest measured at its place), whose sum is the work
    /// predicted; empty with `predicted`.
    pub(super) expected: Vec<f64>,
    /// The expected seconds of the tiles not done (queued or in flight): kept as states
    /// change ([`Frame::set_state`]), so the work left costs nothing to ask for.
    pub(super) left_cost: f64,
}

impl Frame {
    /// Frame `index`, job `job_id`: every tile queued in raster order, an empty film.
    pub(super) fn new(
        index: usize,
        job_id: u64,
        settings: &RenderSettings,
        lights: usize,
        tiles: Vec<Tile>,
        format: PixelFormat,
    ) -> Self {
        let n = tiles.len();
        Frame {
            index,
            job_id,
            settings: settings.clone(),
            lights,
            state: vec![TileState::Queued; n],
            attempts: vec![0; n],
            holders: vec![0; n],
            queue: (0..n as u32).collect(),
            deal_in_rounds: false,
            tiles,
            done: 0,
            // An 8-bit output's film keeps bytes: 8-bit results go in with a copy.
            film: match format {
                PixelFormat::Rgb8 => Film::new_rgb8(settings.width, settings.height),
                PixelFormat::F32 => Film::new(settings.width, settings.height),
            },
            stats: RayStats::default(),
            tile_seconds: vec![0.0; n],
            first_out: None,
            predicted: Vec::new(),
            expected: Vec::new(),
            left_cost: 0.0,
        }
    }

    /// Sets tile `t`'s state, keeping the expected seconds of the tiles not done.
    pub(super) fn set_state(&mut self, t: usize, state: TileState) {
        let was = std::mem::replace(&mut self.state[t], state);
        let cost = self.expected.get(t).copied().unwrap_or(0.0);
        match (was == TileState::Done, state == TileState::Done) {
            (false, true) => self.left_cost -= cost,
            (true, false) => self.left_cost += cost,
            _ => {}
        }
    }

    /// Predicts each tile's seconds: as long as `predicted` and on average `expected` (one
    /// each per tile).
    pub(super) fn predict(&mut self, predicted: Vec<f64>, expected: &[f64]) {
        self.predicted = predicted;
        self.expected = expected.to_vec();
        self.left_cost = (0..self.tiles.len())
            .filter(|&t| self.state[t] != TileState::Done)
            .map(|t| expected[t])
            .sum();
    }

    /// The seconds of work not done (queued, or handed out and not in: a tile dealt waits
    /// behind the worker's others, so what is in flight delays a tile as what is queued
    /// does): expected tile by tile, or, with no prediction, the mean cost seen so far
    /// (`mean`) for each tile; `None` when neither is known.
    pub(super) fn work_left(&self, mean: Option<f64>) -> Option<f64> {
        let left = self.tiles.len().saturating_sub(self.done);
        if left == 0 {
            Some(0.0)
        } else if self.predicted.is_empty() {
            mean.map(|m| m * left as f64)
        } else {
            Some(self.left_cost.max(0.0))
        }
    }

    /// The predicted seconds of the next queued tile, infinite for a frame nothing predicts;
    /// `None` when no tile is queued.
    pub(super) fn front_cost(&mut self) -> Option<f64> {
        if !self.has_queued() {
            return None;
        }
        let t = *self.queue.front()? as usize;
        Some(self.predicted.get(t).copied().unwrap_or(f64::INFINITY))
    }

    /// Queues the tiles in `order` (see [`Scheduler::set_order`]).
    pub(super) fn set_order(&mut self, order: &[u32]) {
        let n = self.tiles.len();
        let mut placed = vec![false; n];
        let mut queue = VecDeque::with_capacity(n);
        for &t in order {
            if let Some(p) = placed.get_mut(t as usize) {
                if !std::mem::replace(p, true) {
                    queue.push_back(t);
                }
            }
        }
        queue.extend((0..n as u32).filter(|&t| !placed[t as usize]));
        // Only what is still queued (a restored tile is done).
        queue.retain(|&t| self.state[t as usize] == TileState::Queued);
        self.queue = queue;
        self.deal_in_rounds = true;
    }

    /// The next queued tile, dropping from the queue's front the tiles no longer queued.
    pub(super) fn next_queued(&mut self) -> Option<u32> {
        while let Some(t) = self.queue.pop_front() {
            if self.state[t as usize] == TileState::Queued {
                return Some(t);
            }
        }
        None
    }

    /// Whether a tile waits in the queue (tiles no longer queued are dropped from its front).
    pub(super) fn has_queued(&mut self) -> bool {
        while let Some(&t) = self.queue.front() {
            if self.state[t as usize] == TileState::Queued {
                return true;
            }
            self.queue.pop_front();
        }
        false
    }

    pub(super) fn is_complete(&self) -> bool {
        self.done == self.tiles.len()
    }

    /// [`Scheduler::restore`] into this frame (`decoded`: scratch for the pixels).
    pub(super) fn restore(
        &mut self,
        done: Vec<AcceptedTile>,
        format: PixelFormat,
        decoded: &mut Vec<Rgb>,
    ) -> usize {
        let mut taken = 0;
        for t in done {
            let Some(&tile) = self.tiles.get(t.tile_id as usize) else {
                continue;
            };
            let ok = t
                .pixels
                .decode_into(format, tile.pixel_count(), decoded)
                .is_ok()
                && t.stats
                    .check_tile(&tile, &self.settings, self.lights)
                    .is_ok();
            let i = tile.id as usize;
            if ok
                && self.state[i] == TileState::Queued
                && self.film.write_tile(&tile, decoded).is_ok()
            {
                self.set_state(i, TileState::Done);
                self.stats += t.stats;
                self.tile_seconds[i] = t.seconds;
                self.done += 1;
                taken += 1;
            }
        }
        let state = &self.state;
        self.queue
            .retain(|&t| state[t as usize] == TileState::Queued);
        taken
    }
}

/// Tiles a row of `tiles` (in raster order).
fn columns(tiles: &[Tile]) -> usize {
    let y0 = tiles.first().map(|t| t.y);
    tiles.iter().take_while(|t| Some(t.y) == y0).count()
}

/// A frame given to the scheduler but not open yet: no film, no tile state.
pub(super) struct NextFrame {
    index: usize,
    job_id: u64,
    settings: RenderSettings,
    lights: usize,
    tiles: Vec<Tile>,
    job: FrameJob,
    /// Its tiles an earlier run left (a checkpoint), restored when it opens.
    restored: Vec<AcceptedTile>,
}

impl NextFrame {
    /// Its tiles still to render: those an earlier run did not leave.
    pub(super) fn to_render(&self) -> usize {
        self.tiles.len().saturating_sub(self.restored.len())
    }
}

/// What a frame's camera-only form needs: the key of its built scene and the view and settings
/// a View carries.
#[derive(Clone, Debug)]
pub struct FrameCamera {
    /// The frame's scene key ([`parrt_protocol::scene_key()`]).
    pub key: SceneKey,
    /// Its view.
    pub view: View,
    /// Its settings.
    pub settings: RenderSettings,
    /// The tile edge a View names.
    pub tile_size: u32,
}

/// A frame's Job as workers get it: encoded whole once for every worker, and, when its scene
/// has a key, the camera alone for a worker whose base has that key.
#[derive(Clone, Debug)]
pub struct FrameJob {
    /// The whole Job.
    pub job: WholeJob,
    /// The camera-only form's parts; `None`: always the whole Job.
    pub camera: Option<FrameCamera>,
}

impl From<Encoded> for FrameJob {
    fn from(job: Encoded) -> Self {
        FrameJob {
            job: WholeJob::Encoded(job),
            camera: None,
        }
    }
}

/// A frame's whole Job: encoded when the frame is given, or, for a frame whose scene key is
/// the frame before's (a camera path), the first time a worker needs it whole. Workers that
/// hold that scene are sent the camera alone, so an orbit's later frames are never encoded
/// whole unless a worker holds another scene.
#[derive(Clone)]
pub enum WholeJob {
    /// Encoded already.
    Encoded(Encoded),
    /// The Job message, encoded once when first asked for.
    Deferred(Arc<DeferredJob>),
}

/// How to make a Job message and, once asked for, its encoding ([`WholeJob::Deferred`]).
pub struct DeferredJob {
    make: Box<dyn Fn() -> Message + Send + Sync>,
    max_frame: usize,
    made: std::sync::OnceLock<Result<Encoded, String>>,
}

impl WholeJob {
    /// The message `make` makes, made and encoded when first asked for (`make` is called at
    /// most once), refused then if it is over `max_frame` bytes.
    pub fn deferred(make: impl Fn() -> Message + Send + Sync + 'static, max_frame: usize) -> Self {
        WholeJob::Deferred(Arc::new(DeferredJob {
            make: Box::new(make),
            max_frame,
            made: std::sync::OnceLock::new(),
        }))
    }

    /// The encoded Job, or why it cannot be (it does not encode, or is over the frame limit:
    /// neither can happen to a Job whose scene an earlier frame's Job sent whole).
    pub fn encoded(&self) -> Result<Encoded, String> {
        match self {
            WholeJob::Encoded(e) => Ok(e.clone()),
            WholeJob::Deferred(d) => d
                .made
                .get_or_init(|| {
                    let e = Encoded::new(&(d.make)()).map_err(|e| e.to_string())?;
                    if e.len() > d.max_frame {
                        return Err(format!(
                            "the Job is {} bytes, over the {}-byte frame limit",
                            e.len(),
                            d.max_frame
                        ));
                    }
                    Ok(e)
                })
                .clone(),
        }
    }
}

impl std::fmt::Debug for WholeJob {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WholeJob::Encoded(e) => write!(f, "WholeJob::Encoded({} bytes)", e.len()),
            WholeJob::Deferred(d) => {
                let made = d.made.get().map(|r| r.as_ref().map(Encoded::len));
                write!(f, "WholeJob::Deferred({made:?})")
            }
        }
    }
}

/// Sends frame job `job_id` to worker `id`: a View of its base when the keys match, else the
/// whole Job, which becomes its base (the previous base, if its frame is closed, is dropped).
fn send_frame(
    bases: &mut HashMap<WorkerId, (SceneKey, u64)>,
    past: &[u64],
    id: WorkerId,
    w: &Slot,
    job_id: u64,
    fj: &FrameJob,
    opts: &SchedOptions,
) {
    let base = bases.get(&id).copied();
    match (&fj.camera, base) {
        (Some(c), Some((key, base_job_id))) if key == c.key => {
            let view = Message::View(Box::new(ViewSpec {
                job_id,
                base_job_id,
                view: c.view.clone(),
                settings: c.settings.clone(),
                tile_size: c.tile_size,
                pixel_format: opts.pixel_format,
                pack_pixels: opts.pack_pixels,
            }));
            let _ = w.outbox.send(view.into());
        }
        _ => {
            let job = match fj.job.encoded() {
                Ok(job) => job,
                Err(reason) => {
                    // The worker cannot be given this frame; it keeps its base, and a tile of
                    // the frame it is dealt comes back as a fault.
                    warn!("frame job {job_id} cannot go to worker {id} whole: {reason}");
                    return;
                }
            };
            let _ = w.outbox.send(Outgoing::Encoded(job));
            if let Some(c) = &fj.camera {
                bases.insert(id, (c.key, job_id));
                if let Some((_, old)) = base.filter(|(_, old)| past.contains(old)) {
                    let _ = w.outbox.send(Message::Cancel { job_id: old }.into());
                }
            }
        }
    }
}

/// The frames of a sequence rendered on the same workers, up to `window` at once.
pub(super) struct Frames {
    /// The most frames open at once.
    pub(super) window: usize,
    /// Frames in the sequence.
    pub(super) count: usize,
    /// Frame 0's job id: the Job every connection starts with.
    pub(super) first_job: u64,
    /// Frame 0's scene key: every connection's first base.
    pub(super) first_key: Option<SceneKey>,
    /// The Job of each frame open, by frame index, with its job id, one copy for every
    /// worker: sent to a worker that joins.
    pub(super) jobs: BTreeMap<usize, (u64, FrameJob)>,
    /// Each worker's base: the key and job id of the latest whole Job it was sent with a key
    /// and not told to drop.
    pub(super) bases: HashMap<WorkerId, (SceneKey, u64)>,
    /// Frames given and not open yet, in order.
    pub(super) pending: VecDeque<NextFrame>,
    /// Ids of the frames closed: a late Ready or result naming one is stale, not a fault.
    pub(super) past: Vec<u64>,
    /// Frames complete that [`Scheduler::take_complete`] has not taken.
    pub(super) complete: Vec<(usize, FrameFinished)>,
    /// The latest measured seconds of each tile, for images of this size: the order of the
    /// next frame of the same size.
    pub(super) latest: ((u32, u32), Vec<f64>),
    /// The longest of `latest`'s times, taken again from them as each frame closes and raised
    /// by each measured time between: the next frame's costliest tile, predicted.
    pub(super) latest_max: f64,
    /// Where the predictions of the frames closed fell short, and by how much.
    pub(super) risk: Risk,
    /// The latest frame closed (its index, and each tile's seconds; empty before one closes
    /// or when one of another size does), and the motion of the frames closed one after
    /// another: what the next frames are predicted from.
    pub(super) closed: (usize, Vec<f64>),
    pub(super) motion: Track,
    /// The most frames that were open at once.
    pub(super) most_open: usize,
}

/// One finished frame of a sequence ([`Scheduler::take_complete`]).
#[derive(Debug)]
pub struct FrameFinished {
    /// The frame's image.
    pub film: Film,
    /// Its ray statistics.
    pub stats: RayStats,
    /// Seconds each of its tiles took, by tile id.
    pub tile_seconds: Vec<f64>,
    /// When its first tile was handed out (`None` if every tile came from elsewhere).
    pub first_out: Option<Instant>,
    /// When its last tile was accepted.
    pub done_at: Instant,
}

impl Scheduler {
    /// Makes this scheduler's job frame 0 of a sequence of `count` frames whose Job is `job`,
    /// with up to `window` frames open at once (at least 1, at most one less than what a
    /// worker keeps built, [`parrt_protocol::limits::MAX_JOBS_HELD`]: a worker also keeps its
    /// base): later frames are given by [`Self::push_frame`], complete ones taken by
    /// [`Self::take_complete`].
    pub fn start_frames(&mut self, window: usize, count: usize, job: FrameJob) {
        let Some(f) = self.open.first() else {
            return;
        };
        let size = (f.settings.width, f.settings.height);
        let n = f.tiles.len();
        self.frames = Some(Frames {
            window: window.clamp(1, MAX_FRAMES_WINDOW),
            count,
            first_job: f.job_id,
            first_key: job.camera.as_ref().map(|c| c.key),
            // Every worker connected has frame 0's Job: its base.
            bases: match &job.camera {
                Some(c) => self
                    .workers
                    .keys()
                    .map(|&id| (id, (c.key, f.job_id)))
                    .collect(),
                None => HashMap::new(),
            },
            jobs: BTreeMap::from([(f.index, (f.job_id, job))]),
            pending: VecDeque::new(),
            past: Vec::new(),
            complete: Vec::new(),
            latest: (size, vec![0.0; n]),
            latest_max: 0.0,
            risk: Risk::default(),
            closed: (0, Vec::new()),
            motion: Track::default(),
            most_open: 1,
        });
    }

    /// Gives the next frame of the sequence: frame `index`, job `job_id` of `tiles` in the
    /// image `settings` describe (`lights` lights), whose encoded Job `job` goes to every
    /// worker when the frame opens (the same bytes to each). It opens when no tile of the frames open is left to hand
    /// out and fewer than the window are open.
    pub fn push_frame(
        &mut self,
        index: usize,
        job_id: u64,
        settings: &RenderSettings,
        lights: usize,
        tiles: Vec<Tile>,
        job: FrameJob,
    ) {
        if let Some(s) = &mut self.frames {
            s.pending.push_back(NextFrame {
                index,
                job_id,
                settings: settings.clone(),
                lights,
                tiles,
                job,
                restored: Vec::new(),
            });
        }
    }

    /// Gives the frame last given by [`Self::push_frame`] the tiles `done` an earlier run left
    /// (a checkpoint's): they are restored as [`Self::restore`] does when it opens, before
    /// any of its tiles is handed out. The frame must not be complete by them alone.
    pub fn restore_pending(&mut self, done: Vec<AcceptedTile>) {
        if let Some(next) = self.frames.as_mut().and_then(|s| s.pending.back_mut()) {
            next.restored = done;
        }
    }

    /// Frames given and not open yet.
    pub fn pending_frames(&self) -> usize {
        self.frames.as_ref().map_or(0, |s| s.pending.len())
    }

    /// Frames open now.
    pub fn open_frames(&self) -> usize {
        self.open.len()
    }

    /// The most frames that were open at once (1 for a render of one frame).
    pub fn most_open_frames(&self) -> usize {
        self.frames.as_ref().map_or(1, |s| s.most_open)
    }

    /// The frames completed since the last call, by index, each once.
    pub fn take_complete(&mut self) -> Vec<(usize, FrameFinished)> {
        self.frames
            .as_mut()
            .map(|s| std::mem::take(&mut s.complete))
            .unwrap_or_default()
    }

    /// Opens the frames given while the window has room and either no tile of those open is
    /// left to hand out or, the next frame the last and predicted, what those open have not
    /// done is less work than `threads` (the ready render threads) each running its
    /// costliest tile (a frame before the last needs no such start: the frame after it fills
    /// its tail). A frame of the same size as the latest measured goes out costliest first as
    /// [`crate::prediction::predict`] predicts it (ties in the usual order); its Job goes to
    /// every worker connected.
    pub(super) fn open_next(&mut self, threads: usize) {
        let mean = self.mean_cost();
        let Some(s) = &mut self.frames else {
            return;
        };
        while self.open.len() < s.window {
            let Some(next) = s.pending.front() else {
                return;
            };
            let predicted = s.latest.0 == (next.settings.width, next.settings.height)
                && s.latest.1.len() == next.tiles.len();
            if self.open.iter_mut().any(|f| f.has_queued()) {
                let left: Option<f64> = self.open.iter().map(|f| f.work_left(mean)).sum();
                let early = predicted
                    && next.index + 1 == s.count
                    && left.is_some_and(|w| w < threads as f64 * s.latest_max);
                if !early {
                    return;
                }
            }
            let Some(next) = s.pending.pop_front() else {
                return;
            };
            let mut f = Frame::new(
                next.index,
                next.job_id,
                &next.settings,
                next.lights,
                next.tiles,
                self.opts.pixel_format,
            );
            f.restore(next.restored, self.opts.pixel_format, &mut self.scratch);
            if predicted {
                let cols = columns(&f.tiles);
                // From the latest frame closed, carried on by the motion; before one has
                // closed, from the latest time of each tile, where it is.
                let costs = match &s.closed {
                    (g, c) if c.len() == f.tiles.len() => predict(
                        Grid { costs: c, cols },
                        s.motion.over(next.index.saturating_sub(*g)),
                        &s.risk,
                        RADIUS,
                    ),
                    _ => predict(
                        Grid {
                            costs: &s.latest.1,
                            cols,
                        },
                        Motion::default(),
                        &s.risk,
                        RADIUS,
                    ),
                };
                let mut order: Vec<u32> = (0..f.tiles.len() as u32).collect();
                // Costliest first; ties keep the usual order (a stable sort), so the order is
                // the same on every run with the same measured times.
                order.sort_by(|&a, &b| costs[b as usize].total_cmp(&costs[a as usize]));
                f.set_order(&order);
                f.predict(costs, &s.latest.1);
            }
            for (&id, w) in &self.workers {
                send_frame(
                    &mut s.bases,
                    &s.past,
                    id,
                    w,
                    next.job_id,
                    &next.job,
                    &self.opts,
                );
            }
            s.jobs.insert(next.index, (next.job_id, next.job));
            self.open.push(f);
            s.most_open = s.most_open.max(self.open.len());
        }
    }

    /// Records a tile's measured time for the order of later frames (in a sequence).
    pub(super) fn measured(&mut self, p: usize, t: usize, seconds: f64) {
        let (Some(s), Some(f)) = (&mut self.frames, self.open.get(p)) else {
            return;
        };
        let size = (f.settings.width, f.settings.height);
        if s.latest.0 != size || s.latest.1.len() != f.tiles.len() {
            s.latest = (size, vec![0.0; f.tiles.len()]);
            s.latest_max = 0.0;
        }
        // A worker's clock is its own word: an implausible figure predicts nothing.
        let plausible = seconds.is_finite() && (0.0..=86_400.0).contains(&seconds);
        let seconds = if plausible { seconds } else { 0.0 };
        s.latest.1[t] = seconds;
        s.latest_max = s.latest_max.max(seconds);
    }

    /// Closes the open frame at `p` if it is complete and part of a sequence: every worker is
    /// told to drop its scene, assignments still out for it (backups) are forgotten (their
    /// results name a closed job and are ignored), and it waits for [`Self::take_complete`].
    pub(super) fn close_if_complete(&mut self, p: usize, now: Instant) {
        let Some(s) = &mut self.frames else {
            return;
        };
        if !self.open.get(p).is_some_and(Frame::is_complete) {
            return;
        }
        let f = self.open.remove(p);
        for (id, w) in self.workers.iter_mut() {
            w.inflight.retain(|&(k, _), _| k != f.index);
            // A worker's base stays until it is sent another.
            if s.bases.get(id).map(|b| b.1) != Some(f.job_id) {
                let _ = w.outbox.send(Message::Cancel { job_id: f.job_id }.into());
            }
        }
        s.jobs.remove(&f.index);
        s.past.push(f.job_id);
        s.latest_max = s.latest.1.iter().copied().fold(0.0, f64::max);
        let plausible = |&s: &f64| {
            if (0.0..=86_400.0).contains(&s) {
                s
            } else {
                0.0
            }
        };
        let measured: Vec<f64> = f.tile_seconds.iter().map(plausible).collect();
        if !f.predicted.is_empty() {
            s.risk.learn(&measured, &f.predicted);
        }
        let cols = columns(&f.tiles);
        let (g, before) = &s.closed;
        if *g + 1 == f.index && before.len() == measured.len() {
            let grid = |costs| Grid { costs, cols };
            s.motion
                .learn(Motion::between(grid(before), grid(&measured)));
        }
        if f.index >= *g || before.len() != measured.len() {
            s.closed = (f.index, measured);
        }
        s.complete.push((
            f.index,
            FrameFinished {
                film: f.film,
                stats: f.stats,
                tile_seconds: f.tile_seconds,
                first_out: f.first_out,
                done_at: now,
            },
        ));
    }

    /// A worker joined a sequence: it starts with frame 0's Job (every connection does, its
    /// first base), so it is sent the later frames open (a View of frame 0 where they share
    /// its scene), and told to drop frame 0 if that is closed and no longer its base.
    pub(super) fn joined_sequence(&mut self, id: WorkerId) {
        let (Some(s), Some(w)) = (&mut self.frames, self.workers.get(&id)) else {
            return;
        };
        if let Some(key) = s.first_key {
            s.bases.insert(id, (key, s.first_job));
        }
        for (&k, (job_id, job)) in &s.jobs {
            if k != 0 {
                send_frame(&mut s.bases, &s.past, id, w, *job_id, job, &self.opts);
            }
        }
        let base = s.bases.get(&id).map(|b| b.1);
        if !s.jobs.contains_key(&0) && base != Some(s.first_job) {
            let _ = w.outbox.send(
                Message::Cancel {
                    job_id: s.first_job,
                }
                .into(),
            );
        }
    }

    /// Whether `job_id` names a frame of this sequence already closed.
    pub(super) fn is_past(&self, job_id: u64) -> bool {
        self.frames
            .as_ref()
            .is_some_and(|f| f.past.contains(&job_id))
    }

    /// The position among the frames open of the frame of job `job_id`.
    pub(super) fn frame_of_job(&self, job_id: u64) -> Option<usize> {
        self.open.iter().position(|f| f.job_id == job_id)
    }

    /// The position among the frames open of frame `index`.
    pub(super) fn frame_at(&self, index: usize) -> Option<usize> {
        self.open.iter().position(|f| f.index == index)
    }
}

#[cfg(test)]
mod whole_job_tests {
    use super::*;

    #[test]
    fn a_deferred_job_encodes_as_an_eager_one_once_asked() {
        let msg = Message::Cancel { job_id: 7 };
        let eager = Encoded::new(&msg).expect("encodes");
        let made = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let counted = made.clone();
        let later = WholeJob::deferred(
            move || {
                counted.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                msg.clone()
            },
            1 << 20,
        );
        assert!(format!("{later:?}").contains("Deferred(None)"));
        assert_eq!(
            made.load(std::sync::atomic::Ordering::Relaxed),
            0,
            "not made yet"
        );
        assert_eq!(later.encoded(), Ok(eager.clone()));
        assert_eq!(later.clone().encoded(), Ok(eager));
        assert_eq!(
            made.load(std::sync::atomic::Ordering::Relaxed),
            1,
            "made once"
        );
    }

    #[test]
    fn a_deferred_job_over_the_frame_limit_is_refused_with_its_size() {
        let job = WholeJob::deferred(|| Message::Cancel { job_id: 7 }, 1);
        let err = job.encoded().expect_err("over the limit");
        assert!(err.contains("over the 1-byte frame limit"), "{err}");
    }
}
