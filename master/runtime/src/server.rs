//! The master's server: takes peers from a [`Listener`] (each served by a task from
//! [`super::connection`], at most `max_connections` at once, those not yet authenticated
//! under the budgets and deadlines of [`super::admission`], so peers that stall or squat a
//! handshake never hold an authenticated worker's slot nor keep a newcomer out),
//! and runs the loop that moves events into the scheduler and accepted tiles into the sink
//! until the scheduler says stop; then it tells every worker to shut down and waits for the
//! tasks to end (a `CancellationToken` broadcast and a `TaskTracker`, as in mini-redis's
//! shutdown). Every decision is the scheduler's ([`Scheduler::step`]); this loop only moves
//! events, bytes and time.

use super::admission::Admission;
use super::checkpoint::Opened;
use super::clock::SharedClock;
use super::connection::{self, ConnContext};
pub use super::frames::FrameSource;
use super::frames::{drive_frames, NoFrames, SequenceSums};
use super::net::{Listener, TcpListener};
use super::options::MasterConfig;
use super::scheduler::{AcceptedTile, Event, SchedOptions, Scheduler, Step, Verdict, WorkerId};
use super::shared_regions::SharedRegions;
use super::sink::{BackgroundWriter, TileSink, WRITER_QUEUE};
use super::{DistError, DistResult};
use parrt_protocol::limits::{frame_allowance, worker_frame_limit};
use parrt_protocol::{Encoded, JobSpec, Message, Token};
use parrt_render::description::SceneDescription;
use parrt_render::settings::RenderSettings;
use parrt_render::tile::tiles;
use rand::{Rng, SeedableRng};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::mpsc;
use tokio::time::{interval, timeout, Instant, MissedTickBehavior};
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;
use tracing::{debug, info, warn};

/// How often the loop looks at deadlines when no event comes.
pub const TICK: Duration = Duration::from_millis(100);

/// How long shutdown waits for connection tasks to end.
pub const SHUTDOWN_WAIT: Duration = Duration::from_secs(5);

/// How a checkpoint is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Writer {
    /// On a thread of its own behind a bounded queue (real runs: a slow disk never stalls
    /// the loop).
    Background,
    /// On the loop's own thread (the deterministic simulation: what a crash leaves is the
    /// same on every replay).
    Inline,
}

/// Where accepted tiles go, with what an earlier run left.
struct SinkState {
    sink: Box<dyn TileSink>,
    /// Whether closing may block (a background writer's join), so runs off the loop.
    blocking_close: bool,
    restored: Vec<AcceptedTile>,
    bad_records: usize,
}

/// A bound master, ready to render one job.
pub struct Master<L: Listener = TcpListener> {
    listener: L,
    addr: SocketAddr,
    token: Token,
    config: MasterConfig,
    clock: SharedClock,
    sink: Option<SinkState>,
    shared: Arc<SharedRegions>,
}

impl Master<TcpListener> {
    /// Binds `config.net.listen` over TCP.
    pub async fn bind(config: &MasterConfig, token: Token) -> Result<Self, DistError> {
        let listener = TcpListener::bind(&config.net.listen)
            .await
            .map_err(|source| DistError::Bind {
                addr: config.net.listen.clone(),
                source,
            })?;
        Master::with_listener(listener, config, token)
    }
}

impl<L: Listener> Master<L> {
    /// A master taking peers from `listener` (the network seam: TCP, or simulated TCP).
    pub fn with_listener(
        listener: L,
        config: &MasterConfig,
        token: Token,
    ) -> Result<Self, DistError> {
        let addr = listener.local_addr().map_err(|source| DistError::Bind {
            addr: config.net.listen.clone(),
            source,
        })?;
        Ok(Master {
            listener,
            addr,
            token,
            config: config.clone(),
            clock: super::clock::system(),
            sink: None,
            shared: Arc::default(),
        })
    }

    /// The regions of memory this master shares with the workers it starts, for their pixels
    /// ([`crate::spawn`] makes one per worker when asked to).
    pub fn shared_regions(&self) -> Arc<SharedRegions> {
        self.shared.clone()
    }

    /// Reads the master's CPU time from `clock` (the clock seam).
    pub fn set_clock(&mut self, clock: SharedClock) {
        self.clock = clock;
    }

    /// Records accepted tiles in the checkpoint `c`, written as `writer` says, and starts
    /// from the tiles it already holds.
    pub fn set_checkpoint(&mut self, c: Opened, writer: Writer) {
        let inner: Box<dyn TileSink> = Box::new(c.checkpoint);
        let sink: Box<dyn TileSink> = match writer {
            Writer::Inline => inner,
            Writer::Background => match BackgroundWriter::start(inner, WRITER_QUEUE) {
                Ok(w) => Box::new(w),
                Err((inner, e)) => {
                    warn!(error = %e, "no thread for the checkpoint writer; writing inline");
                    inner
                }
            },
        };
        self.set_sink(sink, c.scan.tiles, c.scan.bad_records);
        if let Some(s) = &mut self.sink {
            s.blocking_close = writer == Writer::Background;
        }
    }

    /// Sends accepted tiles to `sink`, starting from `restored` (tiles an earlier run
    /// accepted; `bad_records` of its records were not trusted).
    pub fn set_sink(
        &mut self,
        sink: Box<dyn TileSink>,
        restored: Vec<AcceptedTile>,
        bad_records: usize,
    ) {
        self.sink = Some(SinkState {
            sink,
            blocking_close: false,
            restored,
            bad_records,
        });
    }

    /// The address actually bound (the port chosen when asked for `:0`).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Renders `desc` with `settings` on whatever workers connect. `cancel` aborts (Ctrl-C):
    /// workers are told Shutdown and the error is [`DistError::Interrupted`].
    pub async fn render(
        self,
        desc: &SceneDescription,
        settings: &RenderSettings,
        cancel: CancellationToken,
    ) -> Result<DistResult, DistError> {
        self.render_frames::<NoFrames>(desc, settings, None, cancel)
            .await
    }

    /// Renders a sequence on whatever workers connect, every frame on the same workers with up
    /// to [`crate::options::Schedule::frames_window`] frames open at once: `desc` and
    /// `settings` are frame 0's, `frames` gives the later ones and takes every finished frame
    /// but the last, which is the result's film (its statistics, tiles and tile count are
    /// summed over the whole sequence). A frame opens when no tile of those open is left to
    /// hand out (the last frame earlier, so that its costliest tiles start in time): its Job
    /// goes to every worker and its tiles go out costliest first as the frames before predict
    /// them ([`Scheduler::push_frame`], [`crate::prediction`]). A checkpoint holds one frame
    /// only: it is refused with a sequence of more than one.
    pub async fn render_sequence(
        self,
        desc: &SceneDescription,
        settings: &RenderSettings,
        frames: &mut dyn FrameSource,
        cancel: CancellationToken,
    ) -> Result<DistResult, DistError> {
        self.render_frames(desc, settings, Some(frames), cancel)
            .await
    }

    /// The one render loop: one frame, or a sequence whose later frames `frames` gives (generic
    /// so that a render of one frame stays a `Send` future).
    async fn render_frames<F: FrameSource + ?Sized>(
        self,
        desc: &SceneDescription,
        settings: &RenderSettings,
        frames: Option<&mut F>,
        cancel: CancellationToken,
    ) -> Result<DistResult, DistError> {
        let Master {
            listener,
            token,
            config,
            clock,
            sink,
            shared,
            ..
        } = self;
        let (sched_opts, net) = (&config.schedule, &config.net);
        if worker_frame_limit(sched_opts.tile) > net.max_frame {
            return Err(DistError::TileTooLarge {
                tile: sched_opts.tile,
                max_frame: net.max_frame,
            });
        }
        let mut rng = match config.seed {
            Some(s) => rand::rngs::StdRng::seed_from_u64(s),
            None => rand::rngs::StdRng::from_entropy(),
        };
        let job_id = rng.gen::<u64>();
        let list = tiles(settings.width, settings.height, sched_opts.tile);
        let n_tiles = list.len();
        let observers = config.observers.clone();
        let mut sched = new_scheduler(job_id, desc, settings, list, &config);
        let (mut sink, blocking_close, restored_tiles, checkpoint_bad_records) = match sink {
            Some(s) => {
                sched.keep_accepted();
                let restored = sched.restore(s.restored);
                (Some(s.sink), s.blocking_close, restored, s.bad_records)
            }
            None => (None, false, 0, 0),
        };
        let job = encode_job(job_id, desc, settings, &config)?;
        let ctx = conn_context(job, token, &config, shared, &mut rng);
        let conn_ctx = ctx.clone();
        let (events_tx, mut events) = mpsc::unbounded_channel::<Event>();
        let stop = CancellationToken::new();
        let tracker = TaskTracker::new();
        tracker.spawn(accept_loop(
            listener,
            ctx,
            events_tx,
            stop.clone(),
            tracker.clone(),
            net.max_connections,
        ));

        let mut seq = SequenceSums {
            tiles: n_tiles,
            ..SequenceSums::default()
        };
        let mut loop_of = Loop {
            sched: &mut sched,
            events: &mut events,
            sink: &mut sink,
            cancel: &cancel,
            clock: &clock,
            observers: &observers,
        };
        let first = (job_id, settings);
        let outcome = drive_frames(&mut loop_of, first, frames, &mut rng, &config, &mut seq).await;
        let (cpu_at_start, events_peak) = (seq.cpu_at_start, seq.events_peak);
        let started = sched.started();
        let trace_s = started.map_or(0.0, |s| s.elapsed().as_secs_f64());
        let master_cpu_s = if started.is_some() {
            clock.cpu_s() - cpu_at_start
        } else {
            0.0
        };
        let complete = sched.is_done();
        let most_open_frames = sched.most_open_frames();
        observers.each(|o| o.finished(complete, Instant::now()));

        // A complete render is on the disk before any worker is told to go: a machine that
        // crashes after this point leaves a checkpoint that needs no worker to finish (with
        // the goodbye first, a power loss while a slow disk synced the last records took them
        // back after every worker had left). The runtime's thread keeps serving heartbeats
        // meanwhile.
        let closed_early = if complete {
            Some(close_sink(sink.take(), blocking_close).await)
        } else {
            None
        };

        // Shutdown: the scheduler closes every outbox after a Shutdown; the stop signal ends
        // the accept loop and any handshake still running; then wait for the tasks.
        let finished = sched.finish();
        shut_down(stop, tracker, closed_early, sink, blocking_close).await;
        // Late events (Gone of the last workers) are of no interest now.
        drop(events);
        outcome?;
        let mut finished = finished;
        let last_frame_span = seq.last.as_ref().map(|l| (l.first_out, l.done_at));
        if let Some(last) = seq.last.take() {
            finished.film = last.film;
            finished.tile_seconds = last.tile_seconds;
            finished.stats = last.stats;
        }
        finished.stats += seq.stats;
        let mut result = dist_result(
            finished,
            Counts {
                tiles: seq.tiles,
                restored_tiles,
                checkpoint_bad_records,
                events_peak,
                most_open_frames,
            },
            trace_s,
            master_cpu_s,
            &conn_ctx,
        );
        result.last_frame_span = last_frame_span;
        Ok(result)
    }
}

/// What every connection task shares: the job's bytes, the token, the limits and timeouts.
fn conn_context(
    job: Encoded,
    token: Token,
    config: &MasterConfig,
    shared: Arc<SharedRegions>,
    rng: &mut rand::rngs::StdRng,
) -> Arc<ConnContext> {
    let (sched_opts, net) = (&config.schedule, &config.net);
    let job_bytes = job.len();
    Arc::new(ConnContext {
        job,
        token,
        max_frame: net.max_frame,
        max_receive: worker_frame_limit(sched_opts.tile).min(net.max_frame),
        job_write_timeout: net.heartbeat_timeout + frame_allowance(job_bytes),
        handshake_timeout: net.handshake_timeout,
        heartbeat: net.heartbeat,
        heartbeat_timeout: net.heartbeat_timeout,
        seed: config.seed.map(|_| rng.gen()),
        outbox_peak: Default::default(),
        shared,
    })
}

/// What the master's loop works on: the scheduler, the connections' events, the checkpoint's
/// sink, Ctrl-C, the CPU clock and the observers.
pub(crate) struct Loop<'a> {
    pub(crate) sched: &'a mut Scheduler,
    pub(crate) events: &'a mut mpsc::UnboundedReceiver<Event>,
    pub(crate) sink: &'a mut Option<Box<dyn TileSink>>,
    pub(crate) cancel: &'a CancellationToken,
    pub(crate) clock: &'a SharedClock,
    pub(crate) observers: &'a crate::observer::Observers,
}

/// What driving a job to its end gave: how it ended, the master's CPU seconds when the first
/// tile went out, and the most events that waited at once.
pub(crate) struct Driven {
    pub(crate) outcome: Result<(), DistError>,
    pub(crate) cpu_at_start: f64,
    pub(crate) events_peak: usize,
}

/// The master's loop: steps the scheduler, reports progress, and waits for Ctrl-C, the
/// deadline tick or the connections' events, in that order, until the job is done, fails or is
/// cancelled; each round's accepted tiles go to the checkpoint's sink.
/// `after` runs after each round of events, before the next step (a sequence's frames: take
/// those complete, give the next).
pub(crate) async fn drive<H: FnMut(&mut Scheduler) -> Result<(), DistError>>(
    l: &mut Loop<'_>,
    n_tiles: usize,
    after: &mut H,
) -> Driven {
    let Loop {
        sched,
        events,
        sink,
        cancel,
        clock,
        observers,
    } = l;
    let (cancel, clock, observers) = (*cancel, *clock, *observers);
    let mut tick = interval(TICK);
    tick.set_missed_tick_behavior(MissedTickBehavior::Delay);
    let mut cpu_at_start = 0.0;
    let mut events_peak = 0;
    let outcome: Result<(), DistError> = loop {
        let now = Instant::now();
        match sched.step(now) {
            Step::Done => break Ok(()),
            Step::Fail(v) => break Err(failure(v, sched, n_tiles)),
            Step::Run { started } => {
                if started {
                    cpu_at_start = clock.cpu_s();
                }
                sched.fill(now);
            }
            Step::Wait => {}
        }
        if !observers.is_empty() {
            let (done, total) = sched.progress();
            let rates = sched.throughput(now);
            observers.each(|o| o.progress(done, total, &rates));
        }
        // Polled in this order (not at random), so a run replays exactly under the
        // simulation; deadlines come before events, so a busy master still checks them.
        tokio::select! {
            biased;
            _ = cancel.cancelled() => break Err(DistError::Interrupted),
            _ = tick.tick() => sched.expire(Instant::now()),
            ev = events.recv() => match ev {
                Some(ev) => {
                    events_peak = events_peak.max(events.len() + 1);
                    // Take every event already waiting before handing out tiles again:
                    // a batch's results arrive together and are answered together.
                    let now = Instant::now();
                    sched.handle(ev, now);
                    while let Ok(ev) = events.try_recv() {
                        sched.handle(ev, now);
                    }
                }
                None => break Err(DistError::AcceptFailed),
            },
        }
        if let Some(s) = sink {
            if let Err(e) = s.take(sched.take_accepted()) {
                break Err(e.into());
            }
        }
        if let Err(e) = after(sched) {
            break Err(e);
        }
    };
    Driven {
        outcome,
        cpu_at_start,
        events_peak,
    }
}

/// A finished job's counts that the scheduler does not hold.
struct Counts {
    tiles: usize,
    restored_tiles: usize,
    checkpoint_bad_records: usize,
    events_peak: usize,
    most_open_frames: usize,
}

/// What a finished render returns: the scheduler's film and reports, the traffic summed over
/// the workers and the mean scene transfer of those that built the scene.
fn dist_result(
    finished: crate::scheduler::Finished,
    counts: Counts,
    trace_s: f64,
    master_cpu_s: f64,
    conn_ctx: &ConnContext,
) -> DistResult {
    let bytes_sent = finished.reports.iter().map(|r| r.bytes_sent).sum();
    let bytes_received = finished.reports.iter().map(|r| r.bytes_received).sum();
    let transfers: Vec<f64> = finished
        .reports
        .iter()
        .filter(|r| r.build_s > 0.0 || r.scene_transfer_s > 0.0)
        .map(|r| r.scene_transfer_s)
        .collect();
    let scene_transfer_s = if transfers.is_empty() {
        0.0
    } else {
        transfers.iter().sum::<f64>() / transfers.len() as f64
    };
    DistResult {
        film: finished.film,
        stats: finished.stats,
        tile_seconds: finished.tile_seconds,
        trace_s,
        master_cpu_s,
        per_worker: finished.reports,
        bytes_sent,
        bytes_received,
        scene_transfer_s,
        faults: finished.faults,
        tiles: counts.tiles,
        restored_tiles: counts.restored_tiles,
        checkpoint_bad_records: counts.checkpoint_bad_records,
        queue_peaks: crate::QueuePeaks {
            events: counts.events_peak,
            outbox: conn_ctx
                .outbox_peak
                .load(std::sync::atomic::Ordering::Relaxed),
        },
        most_open_frames: counts.most_open_frames,
        last_frame_span: None,
        tiles_shared: conn_ctx.shared.tiles(),
    }
}

/// The scheduler of one job: `list`'s tiles under the configuration's schedule, its order and
/// its observers.
fn new_scheduler(
    job_id: u64,
    desc: &SceneDescription,
    settings: &RenderSettings,
    list: Vec<parrt_render::tile::Tile>,
    config: &MasterConfig,
) -> Scheduler {
    let sched_opts = &config.schedule;
    // With a token of its own making only the workers it started can join.
    let closed_to =
        (config.net.token.is_none() && config.spawn.count > 0).then_some(config.spawn.count);
    let mut sched = Scheduler::new(
        job_id,
        settings,
        desc.lights.len(),
        list,
        SchedOptions {
            window: sched_opts.window,
            tile_deadline: sched_opts.tile_deadline,
            max_failures: sched_opts.max_failures,
            backups: sched_opts.backups,
            max_batch: sched_opts
                .max_batch
                .clamp(1, parrt_protocol::limits::MAX_BATCH),
            batch_seconds: sched_opts.batch_seconds,
            pixel_format: sched_opts.pixel_format,
            pack_pixels: sched_opts.pack_pixels,
            rules: super::lifecycle::Rules {
                min_workers: sched_opts.min_workers,
                wait_workers: sched_opts.wait_workers,
                await_all_workers: sched_opts.await_all_workers,
                closed_to,
            },
        },
    );
    if let Some(order) = &sched_opts.order {
        sched.set_order(order);
    }
    sched.set_observers(config.observers.clone());
    sched
}

/// What every Job message of a render says beside its scene and settings: the tile edge and
/// how pixels travel. Small and `Copy`, so that a Job made later (a deferred frame's) needs no
/// borrow of the configuration.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JobForm {
    tile_size: u32,
    pixel_format: parrt_protocol::PixelFormat,
    pack_pixels: bool,
}

impl JobForm {
    /// The form `config` gives its Jobs.
    pub(crate) fn of(config: &MasterConfig) -> Self {
        JobForm {
            tile_size: config.schedule.tile,
            pixel_format: config.schedule.pixel_format,
            pack_pixels: config.schedule.pack_pixels,
        }
    }

    /// The Job message of `desc` and `settings` as job `job_id`.
    pub(crate) fn message(
        self,
        job_id: u64,
        desc: &SceneDescription,
        settings: &RenderSettings,
    ) -> Message {
        Message::Job(Box::new(JobSpec {
            job_id,
            scene: desc.clone(),
            settings: settings.clone(),
            tile_size: self.tile_size,
            pixel_format: self.pixel_format,
            pack_pixels: self.pack_pixels,
        }))
    }
}

/// The job message, encoded once for every worker, refused if it would not fit a frame.
pub(crate) fn encode_job(
    job_id: u64,
    desc: &SceneDescription,
    settings: &RenderSettings,
    config: &MasterConfig,
) -> Result<Encoded, DistError> {
    let net = &config.net;
    let job = JobForm::of(config).message(job_id, desc, settings);
    // Encoded once, for every worker (and to size the time allowed for sending it).
    let job = Encoded::new(&job).map_err(DistError::EncodeJob)?;
    let job_bytes = job.len();
    if job_bytes > net.max_frame {
        return Err(DistError::JobTooLarge {
            bytes: job_bytes,
            max_frame: net.max_frame,
        });
    }
    Ok(job)
}

/// Ends the accept loop and every connection task (waiting at most [`SHUTDOWN_WAIT`]) while
/// the checkpoint's sink finishes, if it was not closed early.
async fn shut_down(
    stop: CancellationToken,
    tracker: TaskTracker,
    closed_early: Option<Result<(), super::checkpoint::CheckpointError>>,
    sink: Option<Box<dyn TileSink>>,
    blocking_close: bool,
) {
    stop.cancel();
    tracker.close();
    let closing = async {
        if timeout(SHUTDOWN_WAIT, tracker.wait()).await.is_err() {
            warn!("some connections did not close within {SHUTDOWN_WAIT:?}");
        }
    };
    // An incomplete render's sink finishes while the workers are told goodbye.
    let sink_closed = async {
        match closed_early {
            Some(r) => r,
            None => close_sink(sink, blocking_close).await,
        }
    };
    let ((), closed) = tokio::join!(closing, sink_closed);
    if let Err(e) = closed {
        warn!(error = %e, "cannot finish the checkpoint");
    }
}

/// Writes what `sink` has left and makes it durable: on a blocking thread when it may wait
/// for a disk (`blocking`), so the runtime's thread stays free for the connections.
async fn close_sink(
    sink: Option<Box<dyn TileSink>>,
    blocking: bool,
) -> Result<(), super::checkpoint::CheckpointError> {
    match sink {
        Some(s) if blocking => match tokio::task::spawn_blocking(move || s.close()).await {
            Ok(r) => r,
            Err(_) => Err(super::checkpoint::CheckpointError::WriterGone),
        },
        Some(s) => s.close(),
        None => Ok(()),
    }
}

/// The error for the scheduler's verdict.
fn failure(v: Verdict, sched: &Scheduler, total: usize) -> DistError {
    match v {
        Verdict::NoWorkers {
            waited,
            wanted,
            ready,
        } => DistError::NoWorkers {
            waited,
            wanted,
            ready,
            failed: sched.departures(),
        },
        Verdict::AllWorkersLost { waited } => DistError::AllWorkersLost {
            waited,
            done: sched.progress().0,
            total,
        },
    }
}

async fn accept_loop<L: Listener>(
    mut listener: L,
    ctx: Arc<ConnContext>,
    events: mpsc::UnboundedSender<Event>,
    stop: CancellationToken,
    tracker: TaskTracker,
    max_connections: usize,
) {
    let admission = Admission::new(max_connections, ctx.handshake_timeout);
    let mut next_id: WorkerId = 1;
    // Turned-away peers are logged at WARN at most once a second.
    let mut last_warn: Option<Instant> = None;
    let mut turned_away = 0u64;
    loop {
        let accepted = tokio::select! {
            biased;
            _ = stop.cancelled() => return,
            a = listener.accept() => a,
        };
        let (stream, peer) = match accepted {
            Ok(a) => a,
            Err(e) => {
                // Usually a transient resource shortage (EMFILE): back off briefly.
                warn!(error = %e, "accept failed");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let (permit, slot) = match admission.admit(peer.ip()) {
            Ok(a) => a,
            Err(turned) => {
                let why = turned.reason();
                turned_away += 1;
                let now = Instant::now();
                // INFO, not WARN: many honest workers arriving at once (`render --workers 40`)
                // meet these budgets too, and simply retry.
                if last_warn.is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1)) {
                    info!(%peer, max_connections, turned_away, "{why}; closing this one");
                    last_warn = Some(now);
                } else {
                    debug!(%peer, "{why}; closing this one");
                }
                continue;
            }
        };
        let id = next_id;
        next_id += 1;
        let (ctx, events, stop) = (ctx.clone(), events.clone(), stop.clone());
        tracker.spawn(async move {
            connection::serve(stream, peer, id, ctx, events, stop, slot).await;
            drop(permit);
        });
    }
}
