//! A discrete-event model of the master/worker schedule (docs/design-measures.md, *Schedule
//! model*): measured per-tile costs, workers × threads, a window of assignments in flight
//! per worker, each a batch of tiles sized by the master's own rule ([`parrt_runtime::batch::batch_size`])
//! and answered in one message when its last tile is done, one-way latency, link bandwidth (the
//! master's link shared by the workers in turns, `shared_link`), the master's per-result work and
//! the scene transfer; and, as the master does once its queue is empty, backup copies of tiles in
//! flight for idle workers (the first result counts). It predicts the makespan and efficiency of
//! configurations larger than this machine, and says where the time goes.

mod shared_link;

use shared_link::SharedLink;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};
use std::ops::Range;

/// The model's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct SimParams {
    /// Worker processes (nodes).
    pub workers: usize,
    /// Render threads per worker.
    pub threads: usize,
    /// Assignments in flight per worker (sent but not yet answered).
    pub window: usize,
    /// Most tiles in one assignment (1: every tile alone); the size of each is
    /// [`parrt_runtime::batch::batch_size`] of the queue, the threads and the mean cost seen so far.
    pub max_batch: usize,
    /// The most work, in seconds at the mean cost seen, one batch may hold
    /// ([`parrt_runtime::batch::BATCH_SECONDS`] unless a schedule sets another).
    pub batch_seconds: f64,
    /// One-way network latency, seconds.
    pub latency_s: f64,
    /// Bandwidth of each worker's link, bytes per second (infinity: no limit).
    pub bandwidth_bps: f64,
    /// Bandwidth of the master's link, shared by every worker's results, bytes per second
    /// (infinity: no limit). Results cross the worker's link, then queue for this one.
    pub master_link_bps: f64,
    /// Master CPU time per result (decode, copy into the film, assign the next tile), seconds.
    pub master_per_tile_s: f64,
    /// CPU each tile needs on a host that every node shares (an emulated cluster on one
    /// machine: the workers' and the relay's share of carrying its assignment and its result),
    /// seconds; half is spent as the assignment crosses, half as the result does. 0 for a real
    /// cluster, where each node has its own CPU.
    pub host_per_tile_s: f64,
    /// Cores of that shared host; a result waits for a free one.
    pub host_cores: usize,
    /// Bytes of the job message (scene and settings) sent to each worker.
    pub scene_bytes: f64,
    /// Seconds each worker spends building its accelerator after receiving the scene.
    pub build_s: f64,
    /// Bytes of a result per pixel (12 for three f32) plus a fixed header per tile.
    pub result_bytes_per_pixel: f64,
    /// Fixed bytes per message (frame header, ids, statistics).
    pub message_bytes: f64,
    /// Once the queue is empty, a worker with no tiles of its own left takes copies of tiles
    /// in flight elsewhere, up to one per thread, the longest held first (the master's
    /// backups): the first result of a tile counts, the other is ignored.
    pub backups: bool,
    /// The tiles come costliest first and the first windows are dealt in rounds, one batch to
    /// each worker a round, as the master deals an order given by cost; otherwise (raster
    /// order) each worker's window is filled in turn, as the master does.
    pub rounds: bool,
    /// The tiles are a sequence's frames one after another, dealt through the master's window
    /// of frames ([`FrameWindow`]); `None`: the tiles are one frame.
    pub frames: Option<FrameWindow>,
}

/// A sequence as the master renders it: the frames' tiles one after another in the queue,
/// each frame `tiles` long, at most `window` frames open at once. A frame's tiles are dealt
/// only once every frame `window` before it is whole, so the costliest tile of one frame holds
/// up the frame `window` after it (what a window too narrow for a cluster's tail costs).
///
/// A frame opens once the frames open have no tile left to deal or, the last frame, with each
/// tile's cost predicted ([`simulate_sequence`]), once what they have left is less work than
/// every thread running its costliest tile; tiles are dealt from the oldest frame open with
/// tiles left, except that a later frame's next tile predicted to take as long as all the work
/// left spread over the threads goes first, as the master's scheduler deals them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameWindow {
    /// Tiles of each frame (the last may have fewer).
    pub tiles: usize,
    /// Frames open at once (at least 1).
    pub window: usize,
}

impl SimParams {
    /// Ideal conditions: no latency, infinite bandwidth, free master, window = threads.
    pub fn ideal(workers: usize, threads: usize) -> Self {
        SimParams {
            workers,
            threads,
            window: threads,
            max_batch: 1,
            batch_seconds: parrt_runtime::batch::BATCH_SECONDS,
            latency_s: 0.0,
            bandwidth_bps: f64::INFINITY,
            master_link_bps: f64::INFINITY,
            master_per_tile_s: 0.0,
            host_per_tile_s: 0.0,
            host_cores: 1,
            scene_bytes: 0.0,
            build_s: 0.0,
            result_bytes_per_pixel: 12.0,
            message_bytes: 0.0,
            backups: false,
            rounds: false,
            frames: None,
        }
    }
}

/// What the model predicts.
#[derive(Clone, Debug, PartialEq)]
pub struct SimResult {
    /// Time from the start of the job to the last result processed by the master.
    pub makespan: f64,
    /// Sum of tile costs (the one-thread trace time t₁).
    pub work: f64,
    /// Total render threads n = workers × threads.
    pub n: usize,
    /// Efficiency t₁ / (n · makespan).
    pub efficiency: f64,
    /// Fraction of the master's time spent busy (near 1: the master is the bottleneck).
    pub master_utilisation: f64,
    /// Time until every worker could start rendering (scene transfer + build + latency).
    pub startup_s: f64,
    /// Thread-seconds idle after the first thread ran out of work (tail imbalance).
    pub tail_idle_s: f64,
    /// Bytes sent over all links.
    pub bytes: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// An assignment (a batch) reaches a worker.
    Assign { worker: usize, batch: usize },
    /// A thread of a worker finishes a tile of a batch.
    Done { worker: usize, batch: usize },
    /// A batch's results have crossed the worker's link and wait for the master's.
    AtMaster { worker: usize, batch: usize },
    /// The master's link has received a batch's results.
    Received { worker: usize, batch: usize },
    /// A batch's results reach the master.
    Result { worker: usize, batch: usize },
}

#[derive(Clone, Copy, Debug)]
struct Event {
    time: f64,
    seq: u64,
    kind: Kind,
}

impl PartialEq for Event {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Event {}
impl PartialOrd for Event {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Event {
    fn cmp(&self, o: &Self) -> Ordering {
        // Earliest first on a max-heap; ties in insertion order, so runs are deterministic.
        o.time.total_cmp(&self.time).then(o.seq.cmp(&self.seq))
    }
}

/// One assignment handed out.
struct Batch {
    /// Its tiles, consecutive in the queue.
    tiles: Range<usize>,
    /// How many are not done yet.
    left: usize,
    /// A backup copy (else the worker's own tiles).
    backup: bool,
    /// The worker it went to.
    worker: usize,
    /// Still out; once not, it holds no place in the worker's window.
    state: BatchState,
}

#[derive(Clone, Copy, PartialEq)]
enum BatchState {
    Out,
    /// The master took its results.
    Answered,
    /// Its frame was whole first: a sequence closes a frame and forgets every copy still out;
    /// the worker skips its tiles not started and sends nothing.
    Dropped,
}

struct Sim<'a> {
    p: &'a SimParams,
    costs: &'a [f64],
    pixels: &'a [u64],
    heap: BinaryHeap<Event>,
    seq: u64,
    /// Every batch handed out.
    batches: Vec<Batch>,
    /// Per tile (queue index): live copies out, and whether its first result is in.
    holders: Vec<u32>,
    accepted: Vec<bool>,
    /// Per worker: tiles of its own (not backups) out, and backups out; together, what its
    /// window holds.
    primaries: Vec<usize>,
    backups_out: Vec<usize>,
    /// Tiles out with one copy, by when and to whom they went (earliest first, ties by
    /// worker then tile, as the master picks them); stale entries are skipped when popped.
    candidates: BinaryHeap<std::cmp::Reverse<(u64, usize, usize)>>,
    /// Each tile's cost as the master predicts it (a sequence's frames after the first): as
    /// long as it may take, and as expected.
    predicted: Option<Predicted<'a>>,
    /// Per frame (one when the tiles are not a sequence): the next tile not yet handed out,
    /// the expected cost of those without a result yet and the costliest tile predicted.
    cursor: Vec<usize>,
    left_cost: Vec<f64>,
    costliest: Vec<f64>,
    /// Frames opened (the first `opened`), tiles in them, and tiles handed out.
    opened: usize,
    opened_tiles: usize,
    dealt: usize,
    /// The costs seen by the master.
    seen: (f64, usize),
    queue: Vec<VecDeque<(usize, usize)>>,
    idle: Vec<usize>,
    link_free: Vec<f64>,
    master_link: SharedLink,
    host_free: Vec<f64>,
    bytes: f64,
    first_idle: f64,
    tail_idle: f64,
    /// When the master is next free, and how long it has been busy, in seconds.
    master_free: f64,
    master_busy: f64,
    /// Tiles with a first result, and when the last of them was accepted.
    done: usize,
    makespan: f64,
    /// In a sequence, each frame's tiles without a first result yet.
    frame_left: Vec<usize>,
}

impl Sim<'_> {
    fn push(&mut self, time: f64, kind: Kind) {
        self.seq += 1;
        self.heap.push(Event {
            time,
            seq: self.seq,
            kind,
        });
    }

    fn transfer(&self, bytes: f64) -> f64 {
        if self.p.bandwidth_bps.is_finite() && self.p.bandwidth_bps > 0.0 {
            bytes / self.p.bandwidth_bps
        } else {
            0.0
        }
    }

    /// Starts queued tiles on idle threads of `worker`.
    fn start(&mut self, worker: usize, now: f64) {
        while self.idle[worker] > 0 {
            let Some((tile, batch)) = self.queue[worker].pop_front() else {
                break;
            };
            self.idle[worker] -= 1;
            self.push(now + self.costs[tile], Kind::Done { worker, batch });
        }
    }

    /// Starts the next waiting message across the master's link, if it is free.
    fn serve_master_link(&mut self, now: f64) {
        if let Some((worker, batch, bytes)) = self.master_link.start() {
            let done = now + bytes / self.p.master_link_bps;
            self.push(done, Kind::Received { worker, batch });
        }
    }

    /// The bytes of `batch`'s results message.
    fn result_bytes(&self, batch: usize) -> f64 {
        let px: u64 = self.pixels[self.batches[batch].tiles.clone()].iter().sum();
        self.p.message_bytes + self.p.result_bytes_per_pixel * px as f64
    }

    /// When a message that reaches the shared host at `at` and needs `cpu` seconds of it is
    /// through: the earliest free core takes it (no host, or no CPU: at once).
    fn host(&mut self, at: f64, cpu: f64) -> f64 {
        if cpu <= 0.0 {
            return at;
        }
        let (core, free) = self
            .host_free
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, 0.0));
        let done = free.max(at) + cpu;
        if let Some(c) = self.host_free.get_mut(core) {
            *c = done;
        }
        done
    }

    /// Hands `worker` batches while its window has room, as the master's `fill` does: a
    /// batch goes whole or, when the worker holds nothing, as much of it as fits. Each
    /// reaches the worker at `at`.
    fn fill(&mut self, worker: usize, at: f64) {
        while self.deal(worker, at) {}
        self.take_backups(worker, at);
    }

    /// Hands `worker` one batch if the queue has tiles and its window room for them; says
    /// whether it did.
    fn deal(&mut self, worker: usize, at: f64) -> bool {
        let p = self.p;
        let Some(frame) = self.dealable() else {
            return false;
        };
        let (next, end) = (self.cursor[frame], self.frame_span(frame).end);
        let mean = self.mean();
        // As the master sizes a batch: by the tiles queued in the frames open.
        let size = parrt_runtime::batch::batch_size(
            p.max_batch,
            self.opened_tiles - self.dealt,
            p.workers.max(1) * p.threads.max(1),
            mean,
            p.batch_seconds,
        );
        let held = self.primaries[worker] + self.backups_out[worker];
        let free = (p.window.max(1) * size).saturating_sub(held);
        if free == 0 || (free < size && held > 0) {
            return false;
        }
        // A batch is of one frame.
        let take = size.min(free).min(end - next);
        for t in next..next + take {
            self.holders[t] = 1;
            if p.backups {
                self.candidates
                    .push(std::cmp::Reverse((at.max(0.0).to_bits(), worker, t)));
            }
        }
        self.assign(worker, next..next + take, false, at);
        self.cursor[frame] += take;
        self.dealt += take;
        self.primaries[worker] += take;
        true
    }

    /// The mean cost of the tiles the master has seen (`None` before the first).
    fn mean(&self) -> Option<f64> {
        (self.seen.1 > 0).then(|| self.seen.0 / self.seen.1 as f64)
    }

    /// Tile `t`'s predicted cost, as long as it may take (0 where nothing predicts it).
    fn predicted_cost(&self, t: usize) -> f64 {
        self.predicted
            .and_then(|c| c.longest.get(t))
            .copied()
            .unwrap_or(0.0)
    }

    /// Tile `t`'s expected cost (0 where nothing predicts it).
    fn expected_cost(&self, t: usize) -> f64 {
        self.predicted
            .and_then(|c| c.expected.get(t))
            .copied()
            .unwrap_or(0.0)
    }

    /// Whether frame `frame`'s costs are predicted (a sequence's frames after the first).
    fn is_predicted(&self, frame: usize) -> bool {
        frame > 0 && self.predicted.is_some()
    }

    /// Frame `frame`'s tiles in the queue.
    fn frame_span(&self, frame: usize) -> Range<usize> {
        match self.p.frames {
            Some(f) => {
                let tiles = f.tiles.max(1);
                (frame * tiles).min(self.costs.len())..((frame + 1) * tiles).min(self.costs.len())
            }
            None => 0..self.costs.len(),
        }
    }

    /// The frame to deal a tile from now, opening frames first as the master does: the oldest
    /// frame open with tiles left, unless a later one's next tile is urgent (predicted to take
    /// at least as long as all the work left spread over every thread; the costliest such);
    /// `None` when no frame open has a tile left.
    fn dealable(&mut self) -> Option<usize> {
        self.open_frames();
        let threads = (self.p.workers.max(1) * self.p.threads.max(1)) as f64;
        let left = self.work_left();
        let mut oldest = None;
        let mut urgent: Option<(f64, usize)> = None;
        for frame in 0..self.opened {
            let next = self.cursor[frame];
            if next >= self.frame_span(frame).end {
                continue;
            }
            oldest.get_or_insert(frame);
            if !self.is_predicted(frame) {
                continue;
            }
            let cost = self.predicted_cost(next);
            if left.is_some_and(|w| cost * threads >= w) && urgent.is_none_or(|(c, _)| cost > c) {
                urgent = Some((cost, frame));
            }
        }
        urgent.map(|(_, frame)| frame).or(oldest)
    }

    /// The expected work of the tiles of the frames open without a result yet (queued or
    /// out, as the master counts it): each tile's expected cost, or for a frame nothing
    /// predicts, the mean cost seen for each (`None` before one is seen).
    fn work_left(&self) -> Option<f64> {
        let mean = self.mean();
        let mut left = 0.0;
        for f in 0..self.opened {
            let n = match self.p.frames {
                Some(_) => self.frame_left.get(f).copied().unwrap_or(0),
                None => self.costs.len() - self.done,
            };
            left += if n == 0 {
                0.0
            } else if self.is_predicted(f) {
                self.left_cost[f].max(0.0)
            } else {
                mean? * n as f64
            };
        }
        Some(left)
    }

    /// Opens the next frames while the window allows: once every frame the window before is
    /// whole, and either the frames open have no tile left to deal or, the next frame the
    /// last and predicted, what they have not done is less work than every thread running its
    /// costliest tile.
    fn open_frames(&mut self) {
        let frames = self.cursor.len();
        let window = self.p.frames.map_or(1, |f| f.window.max(1));
        let threads = (self.p.workers.max(1) * self.p.threads.max(1)) as f64;
        while self.opened < frames {
            let frame = self.opened;
            if frame >= window && self.frame_left[frame - window] > 0 {
                return;
            }
            if self.dealt < self.opened_tiles {
                let early = self.is_predicted(frame)
                    && frame + 1 == frames
                    && self
                        .work_left()
                        .is_some_and(|w| w < threads * self.costliest[frame]);
                if !early {
                    return;
                }
            }
            self.opened += 1;
            self.opened_tiles += self.frame_span(frame).len();
        }
    }

    /// Once no tile may be dealt (the queue is empty, or the next frame waits for the window),
    /// a worker with nothing of its own takes backups.
    fn take_backups(&mut self, worker: usize, at: f64) {
        let p = self.p;
        if !p.backups || self.dealable().is_some() || self.primaries[worker] > 0 {
            return;
        }
        while self.backups_out[worker] < p.threads.max(1) {
            let Some(t) = self.backup_candidate() else {
                break;
            };
            self.holders[t] += 1;
            self.backups_out[worker] += 1;
            self.assign(worker, t..t + 1, true, at);
        }
    }

    /// Sends `tiles` to `worker` as one message leaving the master at `at`.
    fn assign(&mut self, worker: usize, tiles: Range<usize>, backup: bool, at: f64) {
        let take = tiles.len();
        self.batches.push(Batch {
            tiles,
            left: take,
            backup,
            worker,
            state: BatchState::Out,
        });
        self.bytes += self.p.message_bytes;
        let batch = self.batches.len() - 1;
        let arrive = self.host(at, 0.5 * self.p.host_per_tile_s * take as f64);
        self.push(arrive, Kind::Assign { worker, batch });
    }

    /// The tile out the longest with a single copy and no result yet. A worker asking has
    /// none of its own out, so the copy is always another's.
    fn backup_candidate(&mut self) -> Option<usize> {
        while let Some(std::cmp::Reverse((_, _, t))) = self.candidates.pop() {
            if !self.accepted[t] && self.holders[t] == 1 {
                return Some(t);
            }
        }
        None
    }
}

/// Simulates rendering tiles with the given one-thread `costs` (seconds) and pixel counts.
pub fn simulate(costs: &[f64], pixels: &[u64], p: &SimParams) -> SimResult {
    run(costs, None, pixels, p)
}

/// A sequence's tile costs as the master predicts them, one per tile (the first frame's are
/// not used: nothing predicts it), from the costs measured in the frames before.
#[derive(Clone, Copy, Debug)]
pub struct Predicted<'a> {
    /// As long as each may take ([`parrt_runtime::prediction::predict`]): the order of a
    /// frame's tiles and which are urgent.
    pub longest: &'a [f64],
    /// As expected (the latest measured at its place): the work left.
    pub expected: &'a [f64],
}

/// Simulates a sequence ([`SimParams::frames`]) whose tiles' costs the master predicts as
/// `predicted`.
pub fn simulate_sequence(
    costs: &[f64],
    predicted: Predicted<'_>,
    pixels: &[u64],
    p: &SimParams,
) -> SimResult {
    run(costs, Some(predicted), pixels, p)
}

fn run(
    costs: &[f64],
    predicted: Option<Predicted<'_>>,
    pixels: &[u64],
    p: &SimParams,
) -> SimResult {
    let mut sim = Sim::new(costs, predicted, pixels, p);
    let startup = sim.send_job();
    while let Some(ev) = sim.heap.pop() {
        if sim.handle(ev) {
            // The image is whole: copies still out are never waited for.
            break;
        }
    }
    debug_assert_eq!(sim.done, costs.len());
    sim.finish(startup)
}

impl<'a> Sim<'a> {
    fn new(
        costs: &'a [f64],
        predicted: Option<Predicted<'a>>,
        pixels: &'a [u64],
        p: &'a SimParams,
    ) -> Self {
        let workers = p.workers.max(1);
        let threads = p.threads.max(1);
        let predicted = predicted.filter(|c| {
            c.longest.len() == costs.len() && c.expected.len() == costs.len() && p.frames.is_some()
        });
        let spans: Vec<Range<usize>> = match p.frames {
            Some(f) => (0..costs.len())
                .step_by(f.tiles.max(1))
                .map(|s| s..(s + f.tiles.max(1)).min(costs.len()))
                .collect(),
            None => std::iter::once(0..costs.len()).collect(),
        };
        let sum = |r: &Range<usize>| predicted.map_or(0.0, |c| c.expected[r.clone()].iter().sum());
        let max = |r: &Range<usize>| {
            predicted.map_or(0.0, |c| {
                c.longest[r.clone()].iter().copied().fold(0.0, f64::max)
            })
        };
        Sim {
            p,
            costs,
            pixels,
            heap: BinaryHeap::new(),
            seq: 0,
            batches: Vec::new(),
            holders: vec![0; costs.len()],
            accepted: vec![false; costs.len()],
            primaries: vec![0; workers],
            backups_out: vec![0; workers],
            candidates: BinaryHeap::new(),
            predicted,
            cursor: spans.iter().map(|r| r.start).collect(),
            left_cost: spans.iter().map(sum).collect(),
            costliest: spans.iter().map(max).collect(),
            opened: 0,
            opened_tiles: 0,
            dealt: 0,
            seen: (0.0, 0),
            queue: vec![VecDeque::new(); workers],
            idle: vec![threads; workers],
            link_free: vec![0.0; workers],
            master_link: SharedLink::new(workers),
            host_free: vec![0.0; p.host_cores.max(1)],
            bytes: 0.0,
            first_idle: f64::INFINITY,
            tail_idle: 0.0,
            master_free: 0.0,
            master_busy: 0.0,
            done: 0,
            makespan: 0.0,
            frame_left: match p.frames {
                Some(f) => (0..costs.len())
                    .step_by(f.tiles.max(1))
                    .map(|s| f.tiles.max(1).min(costs.len() - s))
                    .collect(),
                None => Vec::new(),
            },
        }
    }

    /// Sends the job at time 0 and fills the first windows; every worker is ready after the
    /// same time (returned), and the first windows are filled in turn or, for an order by
    /// cost, dealt in rounds ([`SimParams::rounds`]).
    fn send_job(&mut self) -> f64 {
        let p = self.p;
        let workers = p.workers.max(1);
        let job = p.scene_bytes + p.message_bytes;
        self.bytes += job * workers as f64;
        let startup = p.latency_s + self.transfer(job) + p.build_s;
        self.deal_all(startup);
        startup
    }

    /// Fills every worker's window, arriving at `at`: in turn or, for an order by cost, dealt
    /// in rounds ([`SimParams::rounds`]).
    fn deal_all(&mut self, at: f64) {
        let workers = self.p.workers.max(1);
        if self.p.rounds {
            let mut open: Vec<usize> = (0..workers).collect();
            while !open.is_empty() {
                open.retain(|&w| self.deal(w, at));
            }
            for w in 0..workers {
                self.take_backups(w, at);
            }
        } else {
            for w in 0..workers {
                self.fill(w, at);
            }
        }
    }

    /// Runs one event; says whether the image is whole.
    fn handle(&mut self, ev: Event) -> bool {
        let p = self.p;
        let now = ev.time;
        match ev.kind {
            Kind::Assign { worker, batch } if self.batches[batch].state == BatchState::Out => {
                let tiles = self.batches[batch].tiles.clone();
                self.queue[worker].extend(tiles.map(|tile| (tile, batch)));
                self.start(worker, now);
            }
            Kind::Assign { .. } => {}
            Kind::Done { worker, batch } => self.tile_done(worker, batch, now),
            Kind::AtMaster { worker, batch } => {
                let bytes = self.result_bytes(batch);
                self.master_link.arrive(worker, batch, bytes);
                self.serve_master_link(now);
            }
            Kind::Received { worker, batch } => {
                let count = self.batches[batch].tiles.len() as f64;
                let sent = self.host(now, 0.5 * p.host_per_tile_s * count);
                self.push(sent + p.latency_s, Kind::Result { worker, batch });
                if p.master_link_bps.is_finite() && p.master_link_bps > 0.0 {
                    self.master_link.done();
                    self.serve_master_link(now);
                }
            }
            Kind::Result { worker, batch } => return self.result(worker, batch, now),
        }
        false
    }

    /// A worker's thread finished a tile of `batch`: the thread takes the next queued tile, and
    /// the batch's last tile sends its results back in one message, across the worker's link
    /// and then the master's.
    fn tile_done(&mut self, worker: usize, batch: usize, now: f64) {
        let p = self.p;
        self.idle[worker] += 1;
        self.start(worker, now);
        let b = &mut self.batches[batch];
        b.left -= 1;
        if b.left == 0 && b.state != BatchState::Dropped {
            let bytes = self.result_bytes(batch);
            self.bytes += bytes;
            let sent = self.link_free[worker].max(now) + self.transfer(bytes);
            self.link_free[worker] = sent;
            if p.master_link_bps.is_finite() && p.master_link_bps > 0.0 {
                self.push(sent, Kind::AtMaster { worker, batch });
            } else {
                self.push(sent, Kind::Received { worker, batch });
            }
        }
        if self.idle[worker] > 0 && self.dealt >= self.costs.len() {
            self.first_idle = self.first_idle.min(now);
        }
    }

    /// The master takes `batch`'s results: first results are accepted, the worker's window is
    /// filled again. Says whether the image is whole.
    fn result(&mut self, worker: usize, batch: usize, now: f64) -> bool {
        let p = self.p;
        if self.batches[batch].state == BatchState::Dropped {
            // Of a frame already whole: ignored, as the master ignores it.
            return false;
        }
        self.batches[batch].state = BatchState::Answered;
        let tiles = self.batches[batch].tiles.clone();
        let per = p.master_per_tile_s * tiles.len() as f64;
        self.master_free = self.master_free.max(now) + per;
        self.master_busy += per;
        let mut first = 0;
        let waiting = self.dealt < self.costs.len() && self.dealable().is_none();
        for t in tiles.clone() {
            self.holders[t] -= 1;
            if !std::mem::replace(&mut self.accepted[t], true) {
                first += 1;
                self.seen.0 += self.costs[t];
                let expected = self.expected_cost(t);
                let frame = p.frames.map_or(0, |f| t / f.tiles.max(1));
                if let Some(c) = self.left_cost.get_mut(frame) {
                    *c -= expected;
                }
                if let Some(f) = p.frames {
                    let frame = t / f.tiles.max(1);
                    if let Some(left) = self.frame_left.get_mut(frame) {
                        *left -= 1;
                        if *left == 0 {
                            self.close_frame(frame, f.tiles.max(1));
                        }
                    }
                }
            }
        }
        self.done += first;
        self.seen.1 += first;
        self.release(batch);
        if first > 0 {
            self.makespan = self.makespan.max(self.master_free);
        }
        if self.done == self.costs.len() {
            return true;
        }
        let arrive = self.master_free + p.latency_s + self.transfer(p.message_bytes);
        if waiting && self.dealable().is_some() {
            // A frame is whole and the next opens: every worker with room is dealt its tiles
            // (in rounds when the order is by cost), not only the one that answered.
            self.deal_all(arrive);
        } else {
            self.fill(worker, arrive);
        }
        false
    }

    /// Frame `frame` is whole: the master forgets every copy of its tiles still out (they no
    /// longer hold a place in any window), and each worker skips those it has not started.
    fn close_frame(&mut self, frame: usize, tiles: usize) {
        let span = frame * tiles..((frame + 1) * tiles).min(self.costs.len());
        for b in 0..self.batches.len() {
            let batch = &mut self.batches[b];
            if batch.state != BatchState::Out || !span.contains(&batch.tiles.start) {
                continue;
            }
            batch.state = BatchState::Dropped;
            let queue = &mut self.queue[batch.worker];
            let before = queue.len();
            queue.retain(|&(_, x)| x != b);
            batch.left -= before - queue.len();
            self.release(b);
        }
    }

    /// Batch `b` holds no place in its worker's window any more (a backup copy, or so many of
    /// the worker's own tiles).
    fn release(&mut self, b: usize) {
        let batch = &self.batches[b];
        if batch.backup {
            self.backups_out[batch.worker] -= 1;
        } else {
            self.primaries[batch.worker] -= batch.tiles.len();
        }
    }

    /// The run's figures, once the image is whole.
    fn finish(mut self, startup: f64) -> SimResult {
        let p = self.p;
        let n = p.workers.max(1) * p.threads.max(1);
        let work: f64 = self.costs.iter().sum();
        let makespan = self.makespan;
        // Idle thread-time after the first thread ran dry: n·makespan − work − idle before that.
        if self.first_idle.is_finite() {
            let busy_after: f64 = n as f64 * makespan - work - n as f64 * startup;
            self.tail_idle = busy_after.max(0.0);
        }
        SimResult {
            makespan,
            work,
            n,
            efficiency: if makespan > 0.0 {
                work / (n as f64 * makespan)
            } else {
                1.0
            },
            master_utilisation: if makespan > 0.0 {
                self.master_busy / makespan
            } else {
                0.0
            },
            startup_s: startup,
            tail_idle_s: self.tail_idle,
            bytes: self.bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn idle_workers_copy_a_tile_queued_behind_another() {
        // Worker 0 holds two 3 s tiles, one after the other; workers 1 and 2 are done with
        // theirs at 1 s. As the master does, each takes a copy of the oldest tile out with a
        // single copy: worker 2 gets the second 3 s tile, and it is in at 4 s, not 6.
        let costs = [3.0, 3.0, 0.5, 0.5, 0.5, 0.5];
        let px = [1; 6];
        let p = SimParams {
            window: 2,
            ..SimParams::ideal(3, 1)
        };
        let plain = simulate(&costs, &px, &p);
        let copied = simulate(
            &costs,
            &px,
            &SimParams {
                backups: true,
                ..p.clone()
            },
        );
        assert_eq!(plain.makespan, 6.0);
        assert_eq!(copied.makespan, 4.0);
        assert_eq!(copied.work, plain.work, "a copy's work is not the frame's");
    }

    #[test]
    fn a_frame_waits_for_the_frame_the_window_before_it() {
        // Two frames of two tiles on two one-thread workers, one tile each at a time. Frame
        // 0's 4 s tile is still out at 1 s, when worker 1 is free. With one frame open, frame
        // 1 waits for it (and worker 1 idles 3 s): 4 + 1 = 5 s. With two open, worker 1
        // renders frame 1 meanwhile: 4 s, as one stream of tiles would take.
        let costs = [4.0, 1.0, 1.0, 1.0];
        let px = [1; 4];
        let p = |window| SimParams {
            window: 1,
            frames: Some(FrameWindow { tiles: 2, window }),
            ..SimParams::ideal(2, 1)
        };
        let stream = simulate(
            &costs,
            &px,
            &SimParams {
                window: 1,
                ..SimParams::ideal(2, 1)
            },
        );
        assert_eq!(simulate(&costs, &px, &p(1)).makespan, 5.0);
        assert_eq!(simulate(&costs, &px, &p(2)).makespan, 4.0);
        assert_eq!(stream.makespan, 4.0);
        // With backups, worker 1 copies the 4 s tile at 1 s. The frame is whole at 4 s and the
        // copy forgotten, so worker 1's window takes frame 1's second tile at once, but its
        // thread is still in the copy (a tile is not stopped mid-trace) until 5 s: 6 s.
        let copies = SimParams {
            backups: true,
            ..p(1)
        };
        assert_eq!(simulate(&costs, &px, &copies).makespan, 6.0);
    }

    #[test]
    fn the_last_frame_starts_its_costliest_tile_while_the_frame_before_has_work_left() {
        // Two one-thread workers, one tile each at a time. Frame 0: twelve 0.5 s tiles;
        // frame 1, the last: a 3 s tile and two of 0.5 s (10 s in all: 5 s ideal). Opened when
        // frame 0's queue runs dry, frame 1's 3 s tile starts at 3 s and ends at 6 s while
        // the other thread idles from 4 s. Predicted, frame 1 opens once frame 0 has less
        // than 2 × 3 s queued, and its 3 s tile goes before frame 0's last tiles as soon as
        // all the work left, over both threads, is no longer than it: at 2 s, ending at 5 s.
        let mut costs = vec![0.5; 12];
        costs.extend([3.0, 0.5, 0.5]);
        let px = vec![1; 15];
        let p = SimParams {
            window: 1,
            frames: Some(FrameWindow {
                tiles: 12,
                window: 2,
            }),
            ..SimParams::ideal(2, 1)
        };
        assert_eq!(simulate(&costs, &px, &p).makespan, 6.0);
        let predicted = Predicted {
            longest: &costs,
            expected: &costs,
        };
        assert_eq!(simulate_sequence(&costs, predicted, &px, &p).makespan, 5.0);
        // A frame before the last is not opened early: with a third frame after it, the
        // same two frames take what they took unpredicted.
        let mut three = costs.clone();
        three.extend([0.5; 12]);
        let px = vec![1; three.len()];
        let both = Predicted {
            longest: &three,
            expected: &three,
        };
        assert_eq!(
            simulate_sequence(&three, both, &px, &p).makespan,
            simulate(&three, &px, &p).makespan
        );
    }

    #[test]
    fn a_window_as_wide_as_the_sequence_is_one_stream() {
        let costs: Vec<f64> = (0..60).map(|i| 0.1 + (i * 37 % 11) as f64).collect();
        let px = vec![1024; 60];
        let stream = SimParams {
            latency_s: 0.001,
            backups: true,
            ..SimParams::ideal(3, 2)
        };
        let seq = SimParams {
            frames: Some(FrameWindow {
                tiles: 12,
                window: 5,
            }),
            ..stream.clone()
        };
        assert_eq!(simulate(&costs, &px, &seq), simulate(&costs, &px, &stream));
        let narrow = SimParams {
            frames: Some(FrameWindow {
                tiles: 12,
                window: 1,
            }),
            ..stream.clone()
        };
        assert!(simulate(&costs, &px, &narrow).makespan > simulate(&costs, &px, &stream).makespan);
    }

    #[test]
    fn an_order_by_cost_is_dealt_in_rounds() {
        // Two one-thread workers with windows of two. Filled in turn (raster order), both 4 s
        // tiles go into the first window (8 s); dealt in rounds, as the master deals an order
        // by cost, one to each (5 s).
        let p = SimParams {
            window: 2,
            ..SimParams::ideal(2, 1)
        };
        let costs = [4.0, 4.0, 1.0, 1.0];
        assert_eq!(simulate(&costs, &[1; 4], &p).makespan, 8.0);
        let rounds = SimParams { rounds: true, ..p };
        assert_eq!(simulate(&costs, &[1; 4], &rounds).makespan, 5.0);
    }

    #[test]
    fn equal_costs_zero_latency_is_ceil_n_over_p() {
        for (tiles, workers, threads) in [(10, 2, 2), (64, 4, 1), (7, 1, 3), (100, 3, 2), (5, 8, 1)]
        {
            let costs = vec![0.25; tiles];
            let px = vec![64; tiles];
            let r = simulate(&costs, &px, &SimParams::ideal(workers, threads));
            let p = workers * threads;
            let expect = tiles.div_ceil(p) as f64 * 0.25;
            assert_eq!(r.makespan, expect, "{tiles} tiles on {workers}x{threads}");
            assert_eq!(r.efficiency, tiles as f64 * 0.25 / (p as f64 * expect));
        }
    }

    #[test]
    fn one_worker_one_thread_with_latency_pays_a_round_trip_per_tile() {
        let (c, l, tiles) = (0.5, 0.01, 20);
        let mut p = SimParams::ideal(1, 1);
        p.latency_s = l;
        let r = simulate(&vec![c; tiles], &vec![1; tiles], &p);
        let expect = tiles as f64 * (c + 2.0 * l);
        assert!(
            (r.makespan - expect).abs() < 1e-9,
            "{} vs {expect}",
            r.makespan
        );
    }

    #[test]
    fn a_window_hides_latency() {
        let mut p = SimParams::ideal(1, 1);
        p.latency_s = 0.01;
        let costs = vec![0.5; 20];
        let px = vec![1; 20];
        let w1 = simulate(&costs, &px, &p).makespan;
        p.window = 2;
        let w2 = simulate(&costs, &px, &p).makespan;
        assert!((w2 - (0.01 + 20.0 * 0.5 + 0.01)).abs() < 1e-9);
        assert!(w2 < w1);
    }

    #[test]
    fn a_slow_master_bounds_throughput() {
        let mut p = SimParams::ideal(64, 1);
        p.master_per_tile_s = 0.01;
        let r = simulate(&vec![0.001; 1000], &vec![1; 1000], &p);
        assert!(r.makespan >= 1000.0 * 0.01);
        assert!(r.master_utilisation > 0.99);
    }

    #[test]
    fn the_shared_master_link_bounds_throughput() {
        // 100 results of 1000 bytes through a 1 MB/s master link take at least 0.1 s, however
        // many workers send them and however fast their own links are.
        let mut p = SimParams::ideal(50, 1);
        p.result_bytes_per_pixel = 1000.0;
        let free = simulate(&vec![0.001; 100], &vec![1; 100], &p).makespan;
        p.master_link_bps = 1e6;
        let shared = simulate(&vec![0.001; 100], &vec![1; 100], &p).makespan;
        assert!(free < 0.01, "{free}");
        assert!(shared >= 0.1, "{shared}");
    }

    #[test]
    fn a_shared_host_bounds_throughput_by_its_cores() {
        // 400 tiles each needing 10 ms of a 2-core host (half for the assignment, half for
        // the result): at least 2 s, however many workers.
        let mut p = SimParams::ideal(100, 1);
        p.host_per_tile_s = 0.01;
        p.host_cores = 2;
        let r = simulate(&vec![0.001; 400], &vec![1; 400], &p);
        assert!(r.makespan >= 2.0 - 1e-9, "{}", r.makespan);
        assert!(r.makespan < 2.1, "{}", r.makespan);
    }

    /// Batches follow the master's rule: single tiles until a cost is seen, then cheap tiles
    /// go in batches (fewer messages), and a batch's results come back together.
    #[test]
    fn cheap_tiles_go_in_batches_and_come_back_together() {
        let costs = vec![1e-5; 512];
        let px = vec![16u64; 512];
        let mut p = SimParams::ideal(2, 1);
        p.window = 2;
        p.message_bytes = 10.0;
        p.result_bytes_per_pixel = 0.0;
        let single = simulate(&costs, &px, &p);
        p.max_batch = 8;
        let batched = simulate(&costs, &px, &p);
        // Messages: an assignment and a result per batch, plus the job per worker.
        assert_eq!(single.bytes, 10.0 * (2.0 + 2.0 * 512.0));
        assert!(batched.bytes < single.bytes / 4.0, "{}", batched.bytes);
        assert!((batched.work - single.work).abs() < 1e-12);
        // One worker, one thread, one assignment at a time, 1 s latency each way: 41 tiles go
        // as batches of 1 (no cost seen yet), 8, 8, 6, 4, 3, 2, 2 and seven of 1 (a quarter of
        // the queue, at most 8): 15 round trips, each a batch's tiles back in one message.
        let mut p = SimParams::ideal(1, 1);
        p.window = 1;
        p.max_batch = 8;
        p.latency_s = 1.0;
        p.message_bytes = 10.0;
        p.result_bytes_per_pixel = 0.0;
        let r = simulate(&[1e-5; 41], &[1; 41], &p);
        assert_eq!(r.bytes, 10.0 * (1.0 + 2.0 * 15.0));
        assert!((r.makespan - (30.0 + 41e-5)).abs() < 1e-9, "{}", r.makespan);
    }
}
