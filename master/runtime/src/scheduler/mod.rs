//! The tile scheduler: the one owner of a job's state (which tiles are queued, in flight where,
//! done; the film; the merged statistics; the workers and their windows). It does no I/O of its
//! own: connection tasks feed it [`Event`]s and it answers through each worker's outbox channel,
//! so its rules are tested without sockets. Time comes in as an argument (tokio's `Instant`, so
//! tests can pause the clock).
//!
//! Rules: tiles are handed out dynamically, up to a window of in-flight tiles per worker sized
//! to its threads; the first valid result for a tile wins and is written once, later ones are
//! ignored; a result must name this job, a tile this worker holds (with its attempt) and the
//! right pixel count, every pixel finite, and ray statistics a render of that tile could have
//! produced ([`RayStats::check_tile`]); a worker that leaves, or misses a deadline, loses its tiles to the front
//! of the queue; a worker that keeps failing is dropped; when the queue is empty, an idle worker
//! gets backup copies of tiles still in flight elsewhere.
//!
//! ## Layout
//! - this file: the state, the events it takes ([`Scheduler::handle`]) and what it leaves
//!   behind ([`Finished`]);
//! - `results.rs`: the checks a result must pass and how it lands in the film;
//! - `membership.rs`: failures, departures, requeues and deadlines;
//! - `frames.rs`: one frame's tiles and film, and the window of frames a sequence keeps open;
//! - `deal.rs`: batch sizes, the order tiles go out in, backups and assignments.

use crate::lifecycle::Lifecycle;
pub use crate::lifecycle::{Rules, Step, Verdict};
use crate::mutation::{self, Mutation};
pub use crate::outgoing::Outgoing;
use crate::window::Window;
use parrt_protocol::{Encoded, Message, PixelFormat, TilePixels, WireCounters};
use parrt_render::film::Film;
use parrt_render::film::Rgb;
use parrt_render::isa::Isa;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::mpsc::UnboundedSender;
use tokio::time::Instant;
use tracing::{debug, info, warn};

pub use crate::batch::BATCH_SECONDS;
use frames::{Frame, Frames};
pub use frames::{FrameCamera, FrameFinished, FrameJob, WholeJob, MAX_FRAMES_WINDOW};

mod deal;
mod frames;
mod membership;
mod results;

/// A worker's id, unique within one master run.
pub type WorkerId = u64;

/// What connection tasks tell the scheduler.
#[derive(Debug)]
pub enum Event {
    /// A peer failed the handshake.
    Refused {
        /// Its address.
        peer: String,
        /// Why it was refused.
        reason: String,
    },
    /// A peer authenticated and was sent the job.
    Joined {
        /// Its id.
        id: WorkerId,
        /// Its name.
        name: String,
        /// Its render threads.
        threads: u32,
        /// Its instruction-set tier, as its Hello said.
        isa: Isa,
        /// Where to send it messages.
        outbox: UnboundedSender<Outgoing>,
        /// Its connection's byte counters.
        counters: Arc<WireCounters>,
    },
    /// A worker built the job.
    Ready {
        /// Who.
        id: WorkerId,
        /// The job it built.
        job_id: u64,
        /// Its build seconds.
        build_s: f64,
        /// Seconds from sending the job to receiving Ready.
        job_to_ready_s: f64,
    },
    /// A worker sent a tile.
    Result {
        /// Who.
        id: WorkerId,
        /// The job named.
        job_id: u64,
        /// The tile named.
        tile_id: u32,
        /// The attempt named.
        attempt: u32,
        /// The pixels, as they came.
        pixels: TilePixels,
        /// Its statistics.
        stats: RayStats,
        /// Its render seconds.
        seconds: f64,
    },
    /// A worker reported an error.
    WorkerError {
        /// Who.
        id: WorkerId,
        /// What it said.
        reason: String,
    },
    /// A worker's connection ended (or broke the protocol, or fell silent).
    Gone {
        /// Who.
        id: WorkerId,
        /// Why.
        reason: String,
    },
}

/// Scheduling knobs.
#[derive(Clone, Copy, Debug)]
pub struct SchedOptions {
    /// Assignments in flight per worker ([`Window::Auto`]: its threads plus what its measured
    /// round trip needs).
    pub window: Window,
    /// A tile not returned this long after assignment is given to someone else.
    pub tile_deadline: Duration,
    /// Failures (deadline rounds, bad results, errors) after which a worker is dropped.
    pub max_failures: u32,
    /// Hand out backup copies of in-flight tiles when the queue is empty.
    pub backups: bool,
    /// The most tiles sent in one assignment ([`crate::batch::batch_size`]); 1 sends each tile
    /// on its own.
    pub max_batch: usize,
    /// The most work one batch may hold, seconds at the mean tile cost seen
    /// ([`crate::batch::BATCH_SECONDS`] by default).
    pub batch_seconds: f64,
    /// The pixel format the job asked results to use.
    pub pixel_format: PixelFormat,
    /// Whether workers pack 8-bit pixels (what a View tells them, as the Job did).
    pub pack_pixels: bool,
    /// When to stop waiting for workers ([`crate::lifecycle`]).
    pub rules: Rules,
}

/// A tile the scheduler accepted, as it came: what a checkpoint records and gives back.
#[derive(Clone, Debug)]
pub struct AcceptedTile {
    /// The frame's index in a sequence (0 for a render of one frame).
    pub frame: usize,
    /// The tile's id.
    pub tile_id: u32,
    /// Its pixels in the job's format, unpacked (as a checkpoint keeps them).
    pub pixels: TilePixels,
    /// Its ray statistics.
    pub stats: RayStats,
    /// Its render seconds.
    pub seconds: f64,
}

/// A tile of a sequence: the frame's index (0 for a render of one frame) and the tile's id.
type Key = (usize, u32);

/// A backup candidate: when its one live assignment was made, by whom, which tile.
type Candidate = (Instant, WorkerId, Key);

/// One assignment of a tile to a worker.
#[derive(Clone, Copy, Debug)]
struct Assignment {
    attempt: u32,
    since: Instant,
    /// Past its deadline: the tile was requeued, but a late result is still accepted if first.
    expired: bool,
    /// A backup copy of a tile in flight elsewhere.
    backup: bool,
    /// Sent alone (not in a batch): its turnaround measures the worker's round trip.
    single: bool,
}

/// What the scheduler knows about a worker.
struct Slot {
    name: String,
    threads: u32,
    isa: Isa,
    outbox: UnboundedSender<Outgoing>,
    counters: Arc<WireCounters>,
    ready_at: Option<Instant>,
    joined_at: Instant,
    /// Its assignments, by frame and tile.
    inflight: BTreeMap<Key, Assignment>,
    failures: u32,
    tiles: u64,
    render_s: f64,
    build_s: f64,
    job_to_ready_s: f64,
    /// The least time seen from assigning a single tile to its result, beyond the tile's
    /// render seconds: the round trip the window must cover.
    round_trip: Option<f64>,
}

impl Slot {
    /// Live assignments, primaries or backups.
    fn active(&self, backup: bool) -> usize {
        self.inflight
            .values()
            .filter(|a| !a.expired && a.backup == backup)
            .count()
    }
}

/// Per-worker figures of a finished run.
#[derive(Clone, Debug)]
pub struct WorkerReport {
    /// Its name.
    pub name: String,
    /// Its render threads.
    pub threads: u32,
    /// Its instruction-set tier.
    pub isa: Isa,
    /// Tiles it delivered first (those in the image).
    pub tiles: u64,
    /// Seconds it spent rendering those tiles (its own clock).
    pub render_s: f64,
    /// Its renderer build seconds.
    pub build_s: f64,
    /// Seconds from the job's send to its Ready, minus its build: the scene transfer.
    pub scene_transfer_s: f64,
    /// Bytes the master sent it.
    pub bytes_sent: u64,
    /// Bytes the master received from it.
    pub bytes_received: u64,
    /// Why it left before the end, if it did.
    pub left: Option<String>,
}

/// Counts of things that went wrong and were handled.
#[derive(Clone, Debug, Default)]
pub struct FaultCounts {
    /// Handshakes refused: a count and a bounded sample of reasons.
    pub refused: super::refusals::Refusals,
    /// Results rejected (wrong job, unassigned tile, bad pixel count, a NaN or infinite pixel,
    /// impossible ray statistics).
    pub rejected_results: u64,
    /// Valid results that came second and were ignored.
    pub duplicate_results: u64,
    /// Tiles put back in the queue (worker left or missed a deadline).
    pub requeued: u64,
    /// Backup copies handed out.
    pub backups: u64,
    /// Workers dropped for failing repeatedly or building nothing.
    pub dropped: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum TileState {
    Queued,
    InFlight,
    Done,
}

/// The scheduler of one job.
pub struct Scheduler {
    opts: SchedOptions,
    /// The frames open, oldest first: the job's one frame, or a sequence's window of frames
    /// ([`frames`]).
    open: Vec<Frame>,
    workers: BTreeMap<WorkerId, Slot>,
    gone: Vec<WorkerReport>,
    /// A result's decoded pixels, reused from one result to the next.
    scratch: Vec<Rgb>,
    /// Render seconds of the results accepted so far, and how many: the mean tile cost that
    /// caps the batch size.
    cost: (f64, u32),
    faults: FaultCounts,
    /// Tiles accepted since [`Scheduler::take_accepted`] last ran, when a sink wants them.
    accepted: Option<Vec<AcceptedTile>>,
    /// Who is told what happens (timeline, live view).
    observers: super::observer::Observers,
    /// The job's phase: waiting for workers, tracing, done.
    life: Lifecycle,
    /// In a sequence: the window, the frames given but not opened yet, the ids of the frames
    /// closed and the frames complete that the driver has not taken.
    frames: Option<Frames>,
}

impl Scheduler {
    /// A scheduler for `tiles` of the image `settings` describe, job `job_id`, in a scene with
    /// `lights` lights.
    pub fn new(
        job_id: u64,
        settings: &RenderSettings,
        lights: usize,
        tiles: Vec<Tile>,
        opts: SchedOptions,
    ) -> Self {
        Scheduler {
            open: vec![Frame::new(
                0,
                job_id,
                settings,
                lights,
                tiles,
                opts.pixel_format,
            )],
            opts,
            workers: BTreeMap::new(),
            gone: Vec::new(),
            scratch: Vec::new(),
            cost: (0.0, 0),
            faults: FaultCounts::default(),
            accepted: None,
            observers: Default::default(),
            life: Lifecycle::new(opts.rules, Instant::now()),
            frames: None,
        }
    }

    /// What the run loop does next ([`crate::lifecycle`]): stop, hand out tiles, wait, or
    /// give up. On the first step with enough workers, observers are told the trace began.
    pub fn step(&mut self, now: Instant) -> Step {
        let departures = self.departures_count();
        let step = self
            .life
            .step(now, self.is_done(), self.ready_workers(), departures);
        if step == (Step::Run { started: true }) {
            info!(
                workers = self.ready_workers(),
                tiles = self.progress().1,
                "starting"
            );
            self.observers.each(|o| o.started(now));
        }
        step
    }

    /// When tiles were first handed out (`None` while waiting for workers).
    pub fn started(&self) -> Option<Instant> {
        self.life.started()
    }

    /// Tells `observers` what happens from now on.
    pub fn set_observers(&mut self, observers: super::observer::Observers) {
        self.observers = observers;
    }

    /// Starts keeping each newly accepted tile for [`Self::take_accepted`] (a checkpoint's
    /// sink); without it nothing is kept.
    pub fn keep_accepted(&mut self) {
        self.accepted.get_or_insert_with(Vec::new);
    }

    /// The tiles accepted since the last call (none unless [`Self::keep_accepted`] was called).
    pub fn take_accepted(&mut self) -> Vec<AcceptedTile> {
        self.accepted
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Hands the tiles out in `order` (tile ids, e.g. costliest first by a previous frame's
    /// costs) instead of raster order. Ids out of range or repeated are ignored, and tiles
    /// the order leaves out follow in raster order, so every tile is still handed out once.
    /// Call before the first tile goes out.
    pub fn set_order(&mut self, order: &[u32]) {
        if let Some(f) = self.open.first_mut() {
            f.set_order(order);
        }
    }

    /// Marks tiles done before any worker came (from a checkpoint): each is checked as a
    /// result is, written into the film and counted in the statistics and tile seconds; a
    /// tile that fails the checks, or is already done, stays to be rendered. Returns how many
    /// were taken.
    pub fn restore(&mut self, done: Vec<AcceptedTile>) -> usize {
        let mut decoded = std::mem::take(&mut self.scratch);
        let format = self.opts.pixel_format;
        let taken = self
            .open
            .first_mut()
            .map_or(0, |f| f.restore(done, format, &mut decoded));
        self.scratch = decoded;
        taken
    }

    /// Whether every tile is in the film: of the one frame, or of every frame of a sequence
    /// given so far (none is waiting to open, every one open is complete).
    pub fn is_done(&self) -> bool {
        self.open.iter().all(|f| f.done == f.tiles.len())
            && self.frames.as_ref().is_none_or(|s| s.pending.is_empty())
    }

    /// Tiles done and in total, over the frames open.
    pub fn progress(&self) -> (usize, usize) {
        self.open
            .iter()
            .fold((0, 0), |(d, n), f| (d + f.done, n + f.tiles.len()))
    }

    /// Workers that have built the job.
    pub fn ready_workers(&self) -> usize {
        self.workers
            .values()
            .filter(|w| w.ready_at.is_some())
            .count()
    }

    /// Workers that left (or were dropped) so far, as `name: reason`.
    pub fn departures(&self) -> Vec<String> {
        self.gone
            .iter()
            .map(|r| format!("{}: {}", r.name, r.left.as_deref().unwrap_or("left")))
            .collect()
    }

    /// How many workers have left (failed, dropped or disconnected).
    pub fn departures_count(&self) -> usize {
        self.gone.len()
    }

    /// Workers connected (built or not).
    pub fn connected_workers(&self) -> usize {
        self.workers.len()
    }

    /// `name tiles/s` per ready worker, for the progress line.
    pub fn throughput(&self, now: Instant) -> Vec<(String, f64)> {
        self.workers
            .values()
            .filter_map(|w| {
                let t = now.duration_since(w.ready_at?).as_secs_f64();
                Some((
                    w.name.clone(),
                    if t > 0.0 { w.tiles as f64 / t } else { 0.0 },
                ))
            })
            .collect()
    }

    /// Applies one event.
    pub fn handle(&mut self, ev: Event, now: Instant) {
        match ev {
            Event::Refused { peer, reason } => self.faults.refused.record(&peer, reason, now),
            Event::Joined {
                id,
                name,
                threads,
                isa,
                outbox,
                counters,
            } => {
                info!(worker = id, %name, threads, "worker joined");
                self.observers.each(|o| o.joined(id, &name, threads, now));
                self.workers.insert(
                    id,
                    Slot {
                        name,
                        threads,
                        isa,
                        outbox,
                        counters,
                        ready_at: None,
                        joined_at: now,
                        inflight: BTreeMap::new(),
                        failures: 0,
                        tiles: 0,
                        render_s: 0.0,
                        build_s: 0.0,
                        job_to_ready_s: 0.0,
                        round_trip: None,
                    },
                );
                self.joined_sequence(id);
            }
            Event::Ready {
                id,
                job_id,
                build_s,
                job_to_ready_s,
            } => {
                if self.frame_of_job(job_id).is_some() {
                    if let Some(w) = self.workers.get_mut(&id) {
                        if w.ready_at.is_some() {
                            // A later frame of a sequence built beside the earlier ones.
                            w.build_s += build_s;
                        } else {
                            info!(worker = id, name = %w.name, build_s, job_to_ready_s, "worker ready");
                            w.ready_at = Some(now);
                            w.build_s = build_s;
                            w.job_to_ready_s = job_to_ready_s;
                            self.observers.each(|o| o.ready(id, now));
                        }
                    }
                } else if !self.is_past(job_id) {
                    // (A frame already closed was built by a worker that joined while it was
                    // open: the frames open were sent to it when it joined.)
                    let current = self.open.first().map_or(0, |f| f.job_id);
                    self.fail(id, format!("built job {job_id}, not {current}"));
                }
            }
            Event::Result {
                id,
                job_id,
                tile_id,
                attempt,
                pixels,
                stats,
                seconds,
            } => self.result(id, job_id, tile_id, attempt, pixels, stats, seconds, now),
            Event::WorkerError { id, reason } => {
                let ready = self.workers.get(&id).is_some_and(|w| w.ready_at.is_some());
                warn!(worker = id, %reason, "worker reported an error");
                if ready {
                    self.fail(id, reason);
                } else {
                    self.drop_worker(id, format!("cannot take the job: {reason}"));
                }
            }
            Event::Gone { id, reason } => {
                if self.workers.contains_key(&id) {
                    info!(worker = id, %reason, "worker left");
                    self.remove(id, reason);
                }
            }
        }
    }

    /// Tells every worker to shut down (their outboxes close) and returns the final figures.
    pub fn finish(mut self) -> Finished {
        let ids: Vec<WorkerId> = self.workers.keys().copied().collect();
        let mut reports = std::mem::take(&mut self.gone);
        for id in ids {
            if let Some(w) = self.workers.remove(&id) {
                let _ = w.outbox.send(Message::Shutdown.into());
                reports.push(report(&w, None));
            }
        }
        let complete = self.is_done();
        let (film, stats, tile_seconds) = match self.open.drain(..).next() {
            Some(f) => (f.film, f.stats, f.tile_seconds),
            None => (Film::new(0, 0), RayStats::default(), Vec::new()),
        };
        Finished {
            film,
            stats,
            tile_seconds,
            reports,
            faults: self.faults,
            complete,
        }
    }
}

fn report(w: &Slot, left: Option<String>) -> WorkerReport {
    let _ = w.joined_at;
    WorkerReport {
        name: w.name.clone(),
        threads: w.threads,
        isa: w.isa,
        tiles: w.tiles,
        render_s: w.render_s,
        build_s: w.build_s,
        scene_transfer_s: (w.job_to_ready_s - w.build_s).max(0.0),
        bytes_sent: w.counters.sent(),
        bytes_received: w.counters.received(),
        left,
    }
}

/// What a scheduler leaves behind.
#[derive(Debug)]
pub struct Finished {
    /// The image.
    pub film: Film,
    /// Merged statistics of the winning results.
    pub stats: RayStats,
    /// Render seconds per tile id (the winning result's).
    pub tile_seconds: Vec<f64>,
    /// Every worker that took part, including those that left.
    pub reports: Vec<WorkerReport>,
    /// Faults handled.
    pub faults: FaultCounts,
    /// Whether every tile was done.
    pub complete: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_render::tile::tiles;
    use tokio::sync::mpsc::{unbounded_channel, UnboundedReceiver};

    const JOB: u64 = 77;

    fn sched(max_failures: u32) -> Scheduler {
        Scheduler::new(
            JOB,
            &RenderSettings::new(16, 8),
            1,
            tiles(16, 8, 4), // 8 tiles of 4x4
            SchedOptions {
                window: Window::PerThread(2),
                tile_deadline: Duration::from_secs(5),
                max_failures,
                backups: true,
                max_batch: 1,
                batch_seconds: BATCH_SECONDS,
                pixel_format: PixelFormat::F32,
                pack_pixels: true,
                rules: Rules::default(),
            },
        )
    }

    fn join(s: &mut Scheduler, id: WorkerId, threads: u32) -> UnboundedReceiver<Outgoing> {
        let (tx, rx) = unbounded_channel();
        let now = Instant::now();
        s.handle(
            Event::Joined {
                id,
                name: format!("w{id}"),
                threads,
                isa: parrt_render::isa::Isa::Scalar,
                outbox: tx,
                counters: Arc::default(),
            },
            now,
        );
        s.handle(
            Event::Ready {
                id,
                job_id: JOB,
                build_s: 0.0,
                job_to_ready_s: 0.0,
            },
            now,
        );
        rx
    }

    #[test]
    fn departures_name_workers_that_could_not_build_the_job() {
        let mut s = sched(3);
        let (tx, _rx) = unbounded_channel();
        let now = Instant::now();
        s.handle(
            Event::Joined {
                id: 4,
                name: "w4".into(),
                threads: 1,
                isa: parrt_render::isa::Isa::Scalar,
                outbox: tx,
                counters: Arc::default(),
            },
            now,
        );
        s.handle(
            Event::WorkerError {
                id: 4,
                reason: "primitive 0 uses material 9".into(),
            },
            now,
        );
        assert_eq!(s.ready_workers(), 0);
        assert_eq!(
            s.departures(),
            ["w4: cannot take the job: primitive 0 uses material 9"]
        );
    }

    fn assigned(rx: &mut UnboundedReceiver<Outgoing>) -> Vec<(Tile, u32)> {
        let mut v = Vec::new();
        while let Ok(m) = rx.try_recv() {
            match m {
                Outgoing::Message(Message::Assign { tile, attempt, .. }) => v.push((tile, attempt)),
                Outgoing::Message(Message::AssignBatch { tiles, .. }) => v.extend(tiles),
                _ => {}
            }
        }
        v
    }

    fn result(id: WorkerId, tile: &Tile, attempt: u32, value: f32) -> Event {
        Event::Result {
            id,
            job_id: JOB,
            tile_id: tile.id,
            attempt,
            pixels: TilePixels::encode(&vec![[value; 3]; tile.pixel_count()], PixelFormat::F32),
            stats: RayStats {
                eye_rays: tile.pixel_count() as u64,
                ..RayStats::default()
            },
            seconds: 0.1,
        }
    }

    /// A result for `tile_id` carrying `pixels` as they are (of any size or packing).
    fn result_carrying(id: WorkerId, tile_id: u32, attempt: u32, pixels: TilePixels) -> Event {
        Event::Result {
            id,
            job_id: JOB,
            tile_id,
            attempt,
            pixels,
            stats: RayStats::default(),
            seconds: 0.0,
        }
    }

    fn accepted(tile: &Tile, value: f32) -> AcceptedTile {
        let Event::Result {
            pixels,
            stats,
            seconds,
            ..
        } = result(1, tile, 1, value)
        else {
            unreachable!()
        };
        AcceptedTile {
            frame: 0,
            tile_id: tile.id,
            pixels,
            stats,
            seconds,
        }
    }

    #[tokio::test(start_paused = true)]
    async fn tiles_go_out_in_the_order_asked_and_each_once() {
        let all = tiles(16, 8, 4);
        let mut s = sched(3);
        s.restore(vec![accepted(&all[2], 0.5)]);
        // Costliest first, with a repeat, an id out of range and two tiles left out.
        s.set_order(&[7, 2, 5, 7, 99, 0, 6, 1]);
        let mut rx = join(&mut s, 1, 4); // a window of 8: every queued tile at once
        s.fill(Instant::now());
        let ids: Vec<u32> = assigned(&mut rx).iter().map(|(t, _)| t.id).collect();
        assert_eq!(
            ids,
            [7, 5, 0, 6, 1, 3, 4],
            "restored 2 skipped; 3 and 4 last"
        );
    }

    /// Every message waiting in an outbox.
    fn drain(rx: &mut UnboundedReceiver<Outgoing>) -> Vec<Outgoing> {
        let mut v = Vec::new();
        while let Ok(m) = rx.try_recv() {
            v.push(m);
        }
        v
    }

    /// The `(job, tile, attempt)` of each tile assigned in `msgs`.
    fn assignments(msgs: &[Outgoing]) -> Vec<(u64, u32, u32)> {
        let mut v = Vec::new();
        for m in msgs {
            match m {
                Outgoing::Message(Message::Assign {
                    job_id,
                    tile,
                    attempt,
                }) => v.push((*job_id, tile.id, *attempt)),
                Outgoing::Message(Message::AssignBatch { job_id, tiles }) => {
                    v.extend(tiles.iter().map(|(t, a)| (*job_id, t.id, *a)))
                }
                _ => {}
            }
        }
        v
    }

    /// Worker `id`'s result for tile `tile` of job `job`, every pixel `value`.
    fn result_of(id: WorkerId, job: u64, tile: u32, attempt: u32, value: f32) -> Event {
        let all = tiles(16, 8, 4);
        let mut r = result(id, &all[tile as usize], attempt, value);
        if let Event::Result { job_id, .. } = &mut r {
            *job_id = job;
        }
        r
    }

    const NEXT: u64 = 78;

    /// A frame's encoded Job: the scheduler passes it through untouched, so any message stands
    /// for it here.
    fn job_of(frame: usize) -> Encoded {
        Encoded::new(&Message::Error {
            reason: format!("frame {frame}'s job"),
        })
        .unwrap()
    }

    /// What an outbox holds when a frame's Job was sent to it.
    fn sent_job(frame: usize) -> Outgoing {
        Outgoing::Encoded(job_of(frame))
    }

    /// What an outbox holds when a frame was closed.
    fn cancel(job_id: u64) -> Outgoing {
        Message::Cancel { job_id }.into()
    }

    /// A scheduler of a two-frame sequence (frames 0 and 1 of the same 8 tiles, jobs `JOB`
    /// and `NEXT`) with `window` frames open at most.
    fn two_frames(max_failures: u32, window: usize) -> Scheduler {
        let mut s = sched(max_failures);
        s.start_frames(window, 2, job_of(0).into());
        s.push_frame(
            1,
            NEXT,
            &RenderSettings::new(16, 8),
            1,
            tiles(16, 8, 4),
            job_of(1).into(),
        );
        s
    }

    #[tokio::test(start_paused = true)]
    async fn the_next_frame_goes_to_every_worker_costliest_first_and_stale_messages_are_no_fault() {
        let all = tiles(16, 8, 4);
        let mut s = two_frames(1, 1); // one failure drops a worker; one frame at a time
        let mut a = join(&mut s, 1, 4); // a window of 8: every tile at once
        s.fill(Instant::now());
        assert_eq!(assigned(&mut a).len(), 8);
        let costs = [0.1, 0.5, 0.2, 0.3, 0.3, 0.2, 0.05, 0.9];
        for t in &all {
            let mut r = result(1, t, 1, t.id as f32);
            if let Event::Result { seconds, .. } = &mut r {
                *seconds = costs[t.id as usize];
            }
            s.handle(r, Instant::now());
        }
        let done = s.take_complete();
        assert_eq!(done.len(), 1, "frame 0 complete, once");
        let (k, frame0) = &done[0];
        assert_eq!(*k, 0);
        assert_eq!(frame0.tile_seconds, costs);
        assert_eq!(frame0.film.get(5, 1), [1.0; 3], "tile 1's pixels");
        assert_eq!(frame0.stats.eye_rays, 128);
        assert!(s.take_complete().is_empty());
        assert_eq!(drain(&mut a), [cancel(JOB)], "frame 0's scene dropped");
        assert!(!s.is_done(), "frame 1 is still to come");
        // A late copy of a frame-0 result came second: no fault, nothing written.
        s.handle(result(1, &all[0], 1, 9.0), Instant::now());
        assert_eq!(s.faults.duplicate_results, 1);
        assert_eq!(s.faults.rejected_results, 0);
        // Frame 1 opens: its Job to the worker, then its tiles costliest first as frame 0's
        // times predict them (each as the costliest within a tile of it: 0.9 s for the four
        // beside tile 7, 0.5 s for the four beside tile 1; ties in tile order), dealt as an
        // order is, with no new Ready needed.
        s.fill(Instant::now());
        let msgs = drain(&mut a);
        assert_eq!(msgs[0], sent_job(1));
        let ids: Vec<u32> = assignments(&msgs).iter().map(|a| a.1).collect();
        assert_eq!(ids, [2, 3, 6, 7, 0, 1, 4, 5]);
        assert!(assignments(&msgs).iter().all(|a| a.0 == NEXT));
        // A worker that joins now built frame 0 (the job every connection starts with): it is
        // sent the frame open and told to drop frame 0, and its Ready for frame 0 is no fault.
        let mut b = join(&mut s, 2, 1);
        assert_eq!(drain(&mut b), [sent_job(1), cancel(JOB)]);
        assert_eq!((s.connected_workers(), s.ready_workers()), (2, 1));
        // A result for frame 1 lands in its film.
        s.handle(result_of(1, NEXT, 3, 1, 0.25), Instant::now());
        assert_eq!(s.progress(), (1, 8));
        assert_eq!(s.faults.rejected_results, 0);
    }

    /// Each assignment message in `msgs` as its job and its number of tiles, in order.
    fn batches(msgs: &[Outgoing]) -> Vec<(u64, usize)> {
        msgs.iter()
            .filter_map(|m| match m {
                Outgoing::Message(Message::Assign { job_id, .. }) => Some((*job_id, 1)),
                Outgoing::Message(Message::AssignBatch { job_id, tiles }) => {
                    Some((*job_id, tiles.len()))
                }
                _ => None,
            })
            .collect()
    }

    /// Renders `s` to the end on worker 1 (`rx`), every result back before the next fill:
    /// the assignment messages, in order.
    fn batches_to_the_end(
        s: &mut Scheduler,
        rx: &mut UnboundedReceiver<Outgoing>,
    ) -> Vec<(u64, usize)> {
        let mut sent = Vec::new();
        while !s.is_done() && sent.len() < 100 {
            s.fill(Instant::now());
            let msgs = drain(rx);
            sent.extend(batches(&msgs));
            for (job, tile, attempt) in assignments(&msgs) {
                let mut r = result_of(1, job, tile, attempt, 0.5);
                if let Event::Result { seconds, .. } = &mut r {
                    *seconds = 1e-6;
                }
                s.handle(r, Instant::now());
            }
            s.take_complete();
        }
        sent
    }

    /// A frame's tail is filled by the next frame's tiles, so the guided shrink (a quarter of
    /// the queue per thread) counts the frame given next as queued: batches shrink toward the
    /// sequence's end, not toward every frame's, where single tiles would each wake a worker
    /// and the master for nothing.
    #[tokio::test(start_paused = true)]
    async fn batches_shrink_toward_the_sequences_end_not_every_frames() {
        // A mean of 1 µs a tile: batches bound by the queue alone, not by their work.
        let to_the_end = |mut s: Scheduler| {
            s.opts.max_batch = 8;
            s.cost = (8e-6, 8);
            let mut rx = join(&mut s, 1, 1);
            batches_to_the_end(&mut s, &mut rx)
        };
        let (f0, f1) = (
            [4, 3, 1].map(|n| (JOB, n)),
            [2, 1, 1, 1, 1, 1, 1].map(|n| (NEXT, n)),
        );
        assert_eq!(
            to_the_end(two_frames(3, 2)),
            [&f0[..], &f1[..]].concat(),
            "frame 0 in three messages, by a quarter of the 16 tiles left; frame 1, the last, in seven"
        );
        // One frame alone shrinks as frame 1 does.
        let alone = [2, 1, 1, 1, 1, 1, 1].map(|n| (JOB, n));
        assert_eq!(to_the_end(sched(3)), alone);
    }

    #[tokio::test(start_paused = true)]
    async fn with_two_frames_open_the_next_frame_fills_the_tail_of_the_one_before() {
        let mut s = two_frames(3, 2);
        // One thread each: windows of two tiles.
        let mut a = join(&mut s, 1, 1);
        let mut b = join(&mut s, 2, 1);
        s.fill(Instant::now());
        assert_eq!(assignments(&drain(&mut a)), [(JOB, 0, 1), (JOB, 1, 1)]);
        assert_eq!(assignments(&drain(&mut b)), [(JOB, 2, 1), (JOB, 3, 1)]);
        for (w, t) in [(1, 0), (1, 1), (2, 2), (2, 3)] {
            s.handle(result_of(w, JOB, t, 1, 0.5), Instant::now());
        }
        s.fill(Instant::now());
        // Frame 0's last tiles go out, and with its queue empty frame 1 opens: its Job goes
        // to every worker, to build while frame 0's tail renders. (Frame 1 is the last, but
        // frame 0's four tiles out, 0.4 s by its mean, are more work than both threads each
        // running its costliest tile predicted, 0.1 s: it does not open early.)
        let to_a = drain(&mut a);
        assert_eq!(assignments(&to_a), [(JOB, 4, 1), (JOB, 5, 1)]);
        assert_eq!(to_a.last(), Some(&sent_job(1)));
        let to_b = drain(&mut b);
        assert_eq!(assignments(&to_b), [(JOB, 6, 1), (JOB, 7, 1)]);
        assert_eq!(to_b.last(), Some(&sent_job(1)));
        assert_eq!(s.open_frames(), 2);
        // Tiles 5, 6 and 7 of frame 0 in flight: a's free slot takes frame 1's first tile.
        s.handle(result_of(1, JOB, 4, 1, 0.5), Instant::now());
        s.fill(Instant::now());
        assert_eq!(assignments(&drain(&mut a)), [(NEXT, 0, 1)]);
        assert!(drain(&mut b).is_empty(), "b has no room");
        assert_eq!(s.progress(), (5, 16), "frame 0: 5 of 8 in; frame 1: 0 of 8");
        assert!(s.take_complete().is_empty());
        assert_eq!(s.ready_workers(), 2, "no frame boundary to wait at");
    }

    #[tokio::test(start_paused = true)]
    async fn the_last_frame_opens_early_and_its_costliest_tiles_go_before_the_tail() {
        let mut s = two_frames(3, 2);
        let mut w: Vec<_> = (1..=3).map(|id| join(&mut s, id, 1)).collect();
        s.fill(Instant::now());
        // Frame 0's tiles 0–5 take 0.1 s each but tile 5, which takes 1.0 s (a mean of 0.25).
        for t in 0..6 {
            let mut r = result_of(1 + t as WorkerId / 2, JOB, t, 1, 0.5);
            if let Event::Result { seconds, .. } = &mut r {
                *seconds = if t == 5 { 1.0 } else { 0.1 };
            }
            s.handle(r, Instant::now());
        }
        for rx in &mut w {
            drain(rx);
        }
        s.fill(Instant::now());
        // Frame 1 is the last: it opens while frame 0's tiles 6 and 7 are still queued, as
        // those (2 × 0.25 s) are less work than the three threads each running its costliest
        // tile (1.0 s). Its tiles within one of tile 5 (0, 1, 2, 4, 5, 6) are predicted 1.0 s,
        // and all the work not done (0.5 s of frame 0 and frame 1's 1.5 s measured at the same
        // places) is less than the three threads running one of them: each is urgent, and goes
        // before frame 0's last two tiles.
        let sent: Vec<_> = w.iter_mut().map(drain).collect();
        for to in &sent {
            assert_eq!(
                to.first(),
                Some(&sent_job(1)),
                "opened before a tile was dealt"
            );
        }
        let dealt: Vec<_> = sent.iter().flat_map(|to| assignments(to)).collect();
        assert_eq!(
            dealt,
            [0, 1, 2, 4, 5, 6].map(|t| (NEXT, t, 1)),
            "frame 1's urgent tiles, costliest first"
        );
        assert_eq!(s.open_frames(), 2);
        assert_eq!(s.progress(), (6, 16));
    }

    #[tokio::test(start_paused = true)]
    async fn a_worker_lost_with_two_frames_open_loses_no_tile_of_either() {
        let mut s = two_frames(3, 2);
        let mut a = join(&mut s, 1, 1);
        let mut b = join(&mut s, 2, 1);
        s.fill(Instant::now());
        for (w, t) in [(1, 0), (1, 1), (2, 2), (2, 3)] {
            s.handle(result_of(w, JOB, t, 1, 0.5), Instant::now());
        }
        s.fill(Instant::now());
        s.handle(result_of(1, JOB, 4, 1, 0.5), Instant::now());
        s.fill(Instant::now());
        drain(&mut a);
        drain(&mut b);
        // a holds frame 0's tile 5 and frame 1's tile 0, and goes.
        s.handle(
            Event::Gone {
                id: 1,
                reason: "killed".into(),
            },
            Instant::now(),
        );
        assert_eq!(s.faults.requeued, 2, "one tile of each frame");
        // b renders everything else, each frame's tiles valued by frame: first the two it
        // held, then what it is dealt.
        s.handle(result_of(2, JOB, 6, 1, 1.0), Instant::now());
        s.handle(result_of(2, JOB, 7, 1, 1.0), Instant::now());
        let mut rounds = 0;
        let mut frames = Vec::new();
        while !s.is_done() && rounds < 100 {
            rounds += 1;
            s.fill(Instant::now());
            for (job, t, attempt) in assignments(&drain(&mut b)) {
                let value = if job == JOB { 1.0 } else { 2.0 };
                s.handle(result_of(2, job, t, attempt, value), Instant::now());
            }
            frames.extend(s.take_complete());
        }
        assert!(s.is_done());
        let indices: Vec<usize> = frames.iter().map(|(k, _)| *k).collect();
        assert_eq!(indices, [0, 1], "each frame complete, once");
        for (k, f) in &frames {
            let b_value = if *k == 0 { 1.0 } else { 2.0 };
            for t in tiles(16, 8, 4) {
                // Frame 0's first five tiles came at 0.5 before a went.
                let want = if *k == 0 && t.id < 5 { 0.5 } else { b_value };
                assert_eq!(f.film.get(t.x, t.y), [want; 3], "frame {k} tile {}", t.id);
            }
            assert_eq!(f.stats.eye_rays, 128, "frame {k}: every pixel once");
        }
        assert_eq!(s.faults.rejected_results, 0);
    }

    fn ids(rx: &mut UnboundedReceiver<Outgoing>) -> Vec<u32> {
        assigned(rx).iter().map(|(t, _)| t.id).collect()
    }

    #[tokio::test(start_paused = true)]
    async fn an_order_by_cost_is_dealt_in_rounds() {
        let mut s = sched(3);
        s.set_order(&[7, 6, 5, 4, 3, 2, 1, 0]);
        // One thread each: windows of two. Not one worker's window and then the next's.
        let mut a = join(&mut s, 1, 1);
        let mut b = join(&mut s, 2, 1);
        s.fill(Instant::now());
        assert_eq!(ids(&mut a), [7, 5], "the costliest and the third");
        assert_eq!(ids(&mut b), [6, 4]);
    }

    #[tokio::test(start_paused = true)]
    async fn raster_order_fills_each_window_in_turn() {
        let mut s = sched(3);
        let mut a = join(&mut s, 1, 1);
        let mut b = join(&mut s, 2, 1);
        s.fill(Instant::now());
        assert_eq!(ids(&mut a), [0, 1], "neighbours, not a column");
        assert_eq!(ids(&mut b), [2, 3]);
    }

    #[tokio::test(start_paused = true)]
    async fn restored_tiles_are_not_handed_out_and_new_ones_reach_the_sink() {
        let all = tiles(16, 8, 4);
        let mut s = sched(3);
        s.keep_accepted();
        let mut bad = accepted(&all[5], 0.5);
        bad.pixels.bytes.pop();
        let mut nan = accepted(&all[6], 0.5);
        nan.pixels = TilePixels::encode(&[[f32::NAN; 3]; 16], PixelFormat::F32);
        let done = vec![accepted(&all[0], 0.25), accepted(&all[3], 0.75), bad, nan];
        assert_eq!(
            s.restore(done),
            2,
            "the short and the NaN records are refused"
        );
        assert_eq!(s.progress(), (2, 8));
        assert_eq!(s.open[0].stats.eye_rays, 32);
        let mut rx = join(&mut s, 1, 4);
        s.fill(Instant::now());
        let sent = assigned(&mut rx);
        let ids: Vec<u32> = sent.iter().map(|(t, _)| t.id).collect();
        assert_eq!(ids, [1, 2, 4, 5, 6, 7]);
        assert!(s.take_accepted().is_empty());
        for (t, a) in &sent[..2] {
            s.handle(result(1, t, *a, 1.0), Instant::now());
        }
        let got: Vec<u32> = s.take_accepted().iter().map(|t| t.tile_id).collect();
        assert_eq!(got, [1, 2]);
        assert!(
            s.take_accepted().is_empty(),
            "each tile is handed over once"
        );
        for (t, a) in &sent[2..] {
            s.handle(result(1, t, *a, 1.0), Instant::now());
        }
        assert!(s.is_done());
        let f = s.finish();
        assert_eq!(f.stats.eye_rays, 128);
        assert_eq!(f.film.pixels[0], [0.25; 3]);
    }

    #[tokio::test(start_paused = true)]
    async fn window_is_two_per_thread_and_results_refill_it() {
        let mut s = sched(3);
        let mut rx = join(&mut s, 1, 2);
        s.fill(Instant::now());
        let a = assigned(&mut rx);
        assert_eq!(a.len(), 4);
        s.handle(result(1, &a[0].0, a[0].1, 1.0), Instant::now());
        s.fill(Instant::now());
        assert_eq!(assigned(&mut rx).len(), 1);
        assert_eq!(s.progress(), (1, 8));
    }

    #[tokio::test(start_paused = true)]
    async fn an_auto_window_shrinks_to_what_the_round_trip_needs() {
        let mut s = Scheduler::new(
            JOB,
            &RenderSettings::new(64, 64),
            1,
            tiles(64, 64, 4), // 256 tiles
            SchedOptions {
                window: Window::Auto,
                tile_deadline: Duration::from_secs(5),
                max_failures: 3,
                backups: true,
                max_batch: 1,
                batch_seconds: BATCH_SECONDS,
                pixel_format: PixelFormat::F32,
                pack_pixels: true,
                rules: Rules::default(),
            },
        );
        let t0 = Instant::now();
        let mut rx = join(&mut s, 1, 4);
        s.fill(t0);
        // No round trip measured yet: two per thread.
        let a = assigned(&mut rx);
        assert_eq!(a.len(), 8);
        // The first result (0.1 s of render) comes back 2 ms later than its render: four
        // threads finishing 0.1 s tiles free one every 25 ms, so one queued tile covers it.
        let t1 = t0 + Duration::from_millis(102);
        s.handle(result(1, &a[0].0, a[0].1, 1.0), t1);
        s.fill(t1);
        assert_eq!(assigned(&mut rx).len(), 0, "7 held, window now 4 + 1");
        for (tile, attempt) in &a[1..4] {
            s.handle(result(1, tile, *attempt, 1.0), t1);
        }
        s.fill(t1);
        assert_eq!(assigned(&mut rx).len(), 1, "4 held: refilled to 5");
        // A fixed window of two per thread would have refilled to 8.
    }

    #[tokio::test(start_paused = true)]
    async fn first_result_wins_and_duplicates_are_ignored() {
        let mut s = sched(3);
        let mut rx1 = join(&mut s, 1, 4); // takes all 8 tiles
        s.fill(Instant::now());
        let a1 = assigned(&mut rx1);
        assert_eq!(a1.len(), 8);
        // Worker 2 is idle with an empty queue: it gets backups (one per thread).
        let mut rx2 = join(&mut s, 2, 1);
        s.fill(Instant::now());
        let a2 = assigned(&mut rx2);
        assert_eq!(a2.len(), 1);
        let (tile, attempt2) = a2[0];
        assert_eq!(attempt2, 2);
        s.handle(result(2, &tile, attempt2, 2.0), Instant::now());
        let attempt1 = a1.iter().find(|(t, _)| t.id == tile.id).unwrap().1;
        s.handle(result(1, &tile, attempt1, 1.0), Instant::now());
        let f = s.finish();
        assert_eq!(f.faults.duplicate_results, 1);
        assert_eq!(f.film.get(tile.x, tile.y), [2.0; 3]);
        assert_eq!(f.stats.eye_rays, tile.pixel_count() as u64);
    }

    #[tokio::test(start_paused = true)]
    async fn results_for_unheld_tiles_wrong_job_or_size_are_rejected() {
        let mut s = sched(10);
        let mut rx = join(&mut s, 1, 1);
        s.fill(Instant::now());
        let a = assigned(&mut rx);
        let (held, attempt) = a[0];
        let other = tiles(16, 8, 4)[5];
        s.handle(result(1, &other, 1, 1.0), Instant::now());
        s.handle(result(1, &held, attempt + 1, 1.0), Instant::now());
        let mut wrong_job = result(1, &held, attempt, 1.0);
        if let Event::Result { job_id, .. } = &mut wrong_job {
            *job_id = 1;
        }
        s.handle(wrong_job, Instant::now());
        let three = TilePixels::encode(&[[0.0; 3]; 3], PixelFormat::F32);
        s.handle(result_carrying(1, held.id, attempt, three), Instant::now());
        // An id past the tile list is rejected too, without panicking.
        let none = TilePixels::encode(&[], PixelFormat::F32);
        s.handle(result_carrying(1, u32::MAX, 1, none), Instant::now());
        assert_eq!(s.progress().0, 0);
        let f = s.finish();
        assert_eq!(f.faults.rejected_results, 5);
    }

    #[tokio::test(start_paused = true)]
    async fn packed_pixels_that_do_not_unpack_to_the_tile_are_rejected_and_the_tile_requeued() {
        let mut s = sched(10);
        let mut rx = join(&mut s, 1, 1);
        s.fill(Instant::now());
        let (held, attempt) = assigned(&mut rx)[0];
        let junk = TilePixels {
            format: PixelFormat::F32,
            packing: parrt_protocol::Packing::Lz4,
            bytes: vec![0x1f, 1, 2, 3],
        };
        s.handle(result_carrying(1, held.id, attempt, junk), Instant::now());
        assert_eq!(s.progress().0, 0);
        // The tile is handed out again, as a new attempt.
        let mut rx2 = join(&mut s, 2, 1);
        s.fill(Instant::now());
        let again: Vec<_> = [assigned(&mut rx), assigned(&mut rx2)].concat();
        assert!(
            again.iter().any(|&(t, a)| t.id == held.id && a > attempt),
            "{again:?}"
        );
        let f = s.finish();
        assert_eq!(f.faults.rejected_results, 1);
    }

    /// Runs a one-worker job of 64 tiles whose results report `seconds` each, the worker
    /// answering its oldest assignment message at a time; returns the tiles per message.
    fn batch_sizes(seconds: f64) -> Vec<usize> {
        let mut s = Scheduler::new(
            JOB,
            &RenderSettings::new(32, 32),
            1,
            tiles(32, 32, 4), // 64 tiles
            SchedOptions {
                window: Window::PerThread(2),
                tile_deadline: Duration::from_secs(5),
                max_failures: 3,
                backups: false,
                max_batch: 8,
                batch_seconds: BATCH_SECONDS,
                pixel_format: PixelFormat::F32,
                pack_pixels: true,
                rules: Rules::default(),
            },
        );
        let mut rx = join(&mut s, 1, 1);
        let mut sizes = Vec::new();
        let mut messages: VecDeque<Vec<(Tile, u32)>> = VecDeque::new();
        s.fill(Instant::now());
        while !s.is_done() {
            while let Ok(m) = rx.try_recv() {
                let batch = match m {
                    Outgoing::Message(Message::Assign { tile, attempt, .. }) => {
                        vec![(tile, attempt)]
                    }
                    Outgoing::Message(Message::AssignBatch { tiles, .. }) => {
                        assert!(tiles.len() > 1);
                        tiles
                    }
                    other => panic!("unexpected {other:?}"),
                };
                sizes.push(batch.len());
                messages.push_back(batch);
            }
            let Some(batch) = messages.pop_front() else {
                panic!("stalled with {:?} done", s.progress());
            };
            for (t, a) in batch {
                let mut ev = result(1, &t, a, t.id as f32);
                if let Event::Result { seconds: sec, .. } = &mut ev {
                    *sec = seconds;
                }
                s.handle(ev, Instant::now());
            }
            s.fill(Instant::now());
        }
        let f = s.finish();
        for t in tiles(32, 32, 4) {
            assert_eq!(f.film.get(t.x, t.y), [t.id as f32; 3]);
        }
        assert_eq!(f.faults.duplicate_results + f.faults.rejected_results, 0);
        assert_eq!(sizes.iter().sum::<usize>(), 64);
        sizes
    }

    /// Cheap tiles go out in guided batches — single tiles until a cost is known,
    /// then up to 8, shrinking to single tiles at the tail — and every tile lands once; costly
    /// tiles (a batch would hold more than `BATCH_SECONDS`) always go alone.
    #[tokio::test(start_paused = true)]
    async fn batches_are_guided_by_queue_and_cost_and_every_tile_lands_once() {
        let sizes = batch_sizes(BATCH_SECONDS / 20.0);
        assert_eq!(&sizes[..2], &[1, 1], "{sizes:?}");
        let top = sizes.iter().position(|&n| n == 8).expect("reaches 8");
        assert!(
            sizes[top..].windows(2).all(|w| w[1] <= w[0]),
            "then only shrinks: {sizes:?}"
        );
        assert_eq!(*sizes.last().unwrap(), 1, "{sizes:?}");
        let costly = batch_sizes(BATCH_SECONDS);
        assert!(costly.iter().all(|&n| n == 1), "{costly:?}");
        let middling = batch_sizes(BATCH_SECONDS / 3.0);
        assert!(middling.iter().all(|&n| n <= 3), "{middling:?}");
        assert!(middling.contains(&3), "{middling:?}");
    }

    /// A result with a NaN or infinite pixel, or with ray counts no render could produce (a wrapped
    /// `u64::MAX`), is rejected and its tile requeued, so the film stays finite and the totals
    /// honest; an honest result for the tile then wins.
    #[tokio::test(start_paused = true)]
    async fn non_finite_pixels_and_impossible_stats_are_rejected_and_requeued() {
        let mut s = sched(10);
        let mut rx = join(&mut s, 1, 1);
        s.fill(Instant::now());
        let a = assigned(&mut rx);
        let (first, mut attempt) = a[0];
        let (second, att2) = a[1];
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut px = vec![[0.5; 3]; first.pixel_count()];
            px[3][1] = bad;
            let mut ev = result(1, &first, attempt, 0.5);
            if let Event::Result { pixels, .. } = &mut ev {
                *pixels = TilePixels::encode(&px, PixelFormat::F32);
            }
            s.handle(ev, Instant::now());
            // Requeued: the next fill hands the tile out again, as a new attempt.
            s.fill(Instant::now());
            let again = assigned(&mut rx);
            assert_eq!(again.len(), 1, "{bad}: {again:?}");
            assert_eq!(again[0].0.id, first.id, "{bad}");
            assert!(again[0].1 > attempt);
            attempt = again[0].1;
        }
        s.handle(result(1, &first, attempt, 0.25), Instant::now());
        let mut wrapped = result(1, &second, att2, 0.75);
        if let Event::Result { stats, .. } = &mut wrapped {
            stats.eye_rays = u64::MAX;
        }
        s.handle(wrapped, Instant::now());
        let f = s.finish();
        assert!(f.film.pixels.iter().flatten().all(|v| v.is_finite()));
        assert_eq!(f.film.get(first.x, first.y), [0.25; 3]);
        assert_eq!(
            f.film.get(second.x, second.y),
            [0.0; 3],
            "wrapped stats accepted"
        );
        assert_eq!(f.faults.rejected_results, 4);
        assert_eq!(f.faults.requeued, 4);
        assert_eq!(f.stats.eye_rays, first.pixel_count() as u64);
    }

    #[tokio::test(start_paused = true)]
    async fn deadline_moves_tiles_and_late_result_still_counts_if_first() {
        let mut s = sched(3);
        let mut rx1 = join(&mut s, 1, 1);
        s.fill(Instant::now());
        let a1 = assigned(&mut rx1);
        assert_eq!(a1.len(), 2);
        tokio::time::advance(Duration::from_secs(6)).await;
        s.expire(Instant::now());
        // Worker 1 is stalled: its expired tiles still fill its window.
        s.fill(Instant::now());
        assert!(assigned(&mut rx1).is_empty());
        let mut rx2 = join(&mut s, 2, 1);
        s.fill(Instant::now());
        let a2 = assigned(&mut rx2);
        let ids2: Vec<u32> = a2.iter().map(|(t, _)| t.id).collect();
        assert_eq!(
            ids2,
            vec![a1[0].0.id, a1[1].0.id],
            "requeued tiles go first"
        );
        // Worker 1 wakes up: its late result for tile 0 is first, so it counts.
        s.handle(result(1, &a1[0].0, a1[0].1, 1.0), Instant::now());
        s.handle(result(2, &a2[0].0, a2[0].1, 2.0), Instant::now());
        assert_eq!(s.progress().0, 1);
        let f = s.finish();
        assert_eq!(f.faults.duplicate_results, 1);
        assert_eq!(f.film.get(a1[0].0.x, a1[0].0.y), [1.0; 3]);
    }

    #[tokio::test(start_paused = true)]
    async fn leaving_worker_loses_its_tiles_and_failing_worker_is_dropped() {
        let mut s = sched(2);
        let mut rx1 = join(&mut s, 1, 1);
        s.fill(Instant::now());
        let a1 = assigned(&mut rx1);
        s.handle(
            Event::Gone {
                id: 1,
                reason: "killed".into(),
            },
            Instant::now(),
        );
        assert_eq!(s.connected_workers(), 0);
        let mut rx2 = join(&mut s, 2, 1);
        s.fill(Instant::now());
        let a2 = assigned(&mut rx2);
        assert_eq!(a2[0].0.id, a1[0].0.id);
        // Two faults drop worker 2; its outbox gets an Error and closes.
        s.handle(result(2, &tiles(16, 8, 4)[7], 1, 0.0), Instant::now());
        s.handle(result(2, &tiles(16, 8, 4)[7], 1, 0.0), Instant::now());
        assert_eq!(s.connected_workers(), 0);
        assert!(matches!(
            rx2.try_recv(),
            Ok(Outgoing::Message(Message::Error { .. }))
        ));
        let f = s.finish();
        assert_eq!(f.faults.dropped, 1);
        assert_eq!(f.reports.len(), 2);
        assert!(f.reports.iter().all(|r| r.left.is_some()));
    }

    #[tokio::test(start_paused = true)]
    async fn worker_that_cannot_build_is_dropped() {
        let mut s = sched(3);
        let (tx, mut rx) = unbounded_channel();
        s.handle(
            Event::Joined {
                id: 9,
                name: "bad".into(),
                threads: 1,
                isa: parrt_render::isa::Isa::Scalar,
                outbox: tx,
                counters: Arc::default(),
            },
            Instant::now(),
        );
        s.handle(
            Event::WorkerError {
                id: 9,
                reason: "cannot build job".into(),
            },
            Instant::now(),
        );
        assert_eq!(s.connected_workers(), 0);
        assert!(matches!(
            rx.try_recv(),
            Ok(Outgoing::Message(Message::Error { .. }))
        ));
    }

    #[tokio::test(start_paused = true)]
    async fn every_tile_once_with_many_workers_in_any_order() {
        let mut s = sched(3);
        let mut rxs: Vec<_> = (1..=3).map(|id| join(&mut s, id, 1)).collect();
        let mut rounds = 0;
        while !s.is_done() {
            rounds += 1;
            assert!(rounds < 100);
            s.fill(Instant::now());
            for (i, rx) in rxs.iter_mut().enumerate() {
                for (t, a) in assigned(rx).into_iter().rev() {
                    s.handle(result(i as u64 + 1, &t, a, t.id as f32), Instant::now());
                }
            }
        }
        let f = s.finish();
        assert_eq!(f.stats.eye_rays, 16 * 8);
        for t in tiles(16, 8, 4) {
            assert_eq!(f.film.get(t.x, t.y), [t.id as f32; 3]);
        }
    }
}
