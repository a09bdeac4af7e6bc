//! The frames a scheduler works on: one frame's tiles, their states and its film ([`Frame`]),
//! and, in a sequence, the window of frames open at once ([`Frames`]). When no tile of the
//! frames open is left to hand out and fewer than the window are open, the next frame given
//! opens: its Job goes to every worker and its tiles are dealt at once, so they fill the tail
//! of the frames before. A frame whose every tile is in closes: the workers are told to drop
//! its scene (Cancel), and it waits for the driver ([`Scheduler::take_complete`]).

use super::*;

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
        }
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
                self.state[i] = TileState::Done;
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

/// A frame given to the scheduler but not open yet: no film, no tile state.
pub(super) struct NextFrame {
    index: usize,
    job_id: u64,
    settings: RenderSettings,
    lights: usize,
    tiles: Vec<Tile>,
    job: Encoded,
    /// Its tiles an earlier run left (a checkpoint), restored when it opens.
    restored: Vec<AcceptedTile>,
}

/// The frames of a sequence rendered on the same workers, up to `window` at once.
pub(super) struct Frames {
    /// The most frames open at once.
    pub(super) window: usize,
    /// Frame 0's job id: the Job every connection starts with.
    pub(super) first_job: u64,
    /// The encoded Job of each frame open, by frame index, one copy for every worker: sent
    /// to a worker that joins.
    pub(super) jobs: BTreeMap<usize, Encoded>,
    /// Frames given and not open yet, in order.
    pub(super) pending: VecDeque<NextFrame>,
    /// Ids of the frames closed: a late Ready or result naming one is stale, not a fault.
    pub(super) past: Vec<u64>,
    /// Frames complete that [`Scheduler::take_complete`] has not taken.
    pub(super) complete: Vec<(usize, FrameFinished)>,
    /// The latest measured seconds of each tile, for images of this size: the order of the
    /// next frame of the same size.
    pub(super) latest: ((u32, u32), Vec<f64>),
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
    /// Makes this scheduler's job frame 0 of a sequence whose encoded Job is `job`, with up to
    /// `window` frames open at once (at least 1, at most what a worker keeps built,
    /// [`parrt_protocol::limits::MAX_JOBS_HELD`]): later frames are given by
    /// [`Self::push_frame`], complete ones taken by [`Self::take_complete`].
    pub fn start_frames(&mut self, window: usize, job: Encoded) {
        let Some(f) = self.open.first() else {
            return;
        };
        let size = (f.settings.width, f.settings.height);
        let n = f.tiles.len();
        self.frames = Some(Frames {
            window: window.clamp(1, parrt_protocol::limits::MAX_JOBS_HELD),
            first_job: f.job_id,
            jobs: BTreeMap::from([(f.index, job)]),
            pending: VecDeque::new(),
            past: Vec::new(),
            complete: Vec::new(),
            latest: (size, vec![0.0; n]),
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
        job: Encoded,
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

    /// Opens the frames given while no tile of those open is left to hand out and the window
    /// has room. A frame of the same size as the latest measured goes out costliest first by
    /// each tile's latest measured time (ties, and tiles not measured, in the usual order);
    /// its Job goes to every worker connected.
    pub(super) fn open_next(&mut self) {
        let Some(s) = &mut self.frames else {
            return;
        };
        while self.open.len() < s.window && !self.open.iter_mut().any(|f| f.has_queued()) {
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
            if s.latest.0 == (next.settings.width, next.settings.height)
                && s.latest.1.len() == f.tiles.len()
            {
                let costs = &s.latest.1;
                let mut order: Vec<u32> = (0..f.tiles.len() as u32).collect();
                // Costliest first; ties keep the usual order (a stable sort), so the order is
                // the same on every run with the same measured times.
                order.sort_by(|&a, &b| costs[b as usize].total_cmp(&costs[a as usize]));
                f.set_order(&order);
            }
            for w in self.workers.values() {
                let _ = w.outbox.send(Outgoing::Encoded(next.job.clone()));
            }
            s.jobs.insert(next.index, next.job);
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
        }
        s.latest.1[t] = seconds;
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
        for w in self.workers.values_mut() {
            w.inflight.retain(|&(k, _), _| k != f.index);
            let _ = w.outbox.send(Message::Cancel { job_id: f.job_id }.into());
        }
        s.jobs.remove(&f.index);
        s.past.push(f.job_id);
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

    /// A worker joined a sequence: it starts with frame 0's Job (every connection does), so it
    /// is sent the Jobs of the later frames open, and told to drop frame 0 if that is closed.
    pub(super) fn joined_sequence(&mut self, id: WorkerId) {
        let (Some(s), Some(w)) = (&self.frames, self.workers.get(&id)) else {
            return;
        };
        for (&k, job) in &s.jobs {
            if k != 0 {
                let _ = w.outbox.send(Outgoing::Encoded(job.clone()));
            }
        }
        if !s.jobs.contains_key(&0) {
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
