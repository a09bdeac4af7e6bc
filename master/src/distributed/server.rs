//! The master's server: binds the listener, accepts peers (each served by a task from
//! [`super::connection`], at most `max_connections` at once, of which at most
//! [`MAX_HANDSHAKING`] still handshaking and [`MAX_HANDSHAKING_PER_PEER`] of those from one
//! address, so peers that stall their handshake never hold an authenticated worker's slot),
//! and runs the scheduler loop until
//! the image is complete, then tells every worker to shut down and waits for the tasks to end
//! (a `CancellationToken` broadcast and a `TaskTracker`, as in mini-redis's shutdown).

use super::checkpoint::{Checkpoint, Opened};
use super::connection::{self, ConnContext};
use super::progress::Progress;
use super::scheduler::{Event, SchedOptions, Scheduler, WorkerId};
use super::{DistError, DistOptions, DistResult};
use parrt::description::SceneDescription;
use parrt::protocol::limits::{
    frame_allowance, worker_frame_limit, MAX_HANDSHAKING, MAX_HANDSHAKING_PER_PEER,
};
use parrt::protocol::{Encoded, JobSpec, Message, Token};
use parrt::settings::RenderSettings;
use parrt::tile::tiles;
use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::net::TcpListener;
use tokio::sync::{mpsc, OwnedSemaphorePermit, Semaphore};
use tokio::time::{interval, timeout, Instant, MissedTickBehavior};
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;
use tracing::{debug, info, warn};

/// A bound master, ready to render one job.
pub struct Master {
    listener: TcpListener,
    addr: SocketAddr,
    token: Token,
    opts: DistOptions,
    checkpoint: Option<Opened>,
}

impl Master {
    /// Binds `opts.listen`.
    pub async fn bind(opts: &DistOptions, token: Token) -> Result<Master, DistError> {
        let listener = TcpListener::bind(&opts.listen)
            .await
            .map_err(|source| DistError::Bind {
                addr: opts.listen.clone(),
                source,
            })?;
        let addr = listener.local_addr().map_err(|source| DistError::Bind {
            addr: opts.listen.clone(),
            source,
        })?;
        Ok(Master {
            listener,
            addr,
            token,
            opts: opts.clone(),
            checkpoint: None,
        })
    }

    /// Records accepted tiles in `c` and starts from the tiles it already holds.
    pub fn set_checkpoint(&mut self, c: Opened) {
        self.checkpoint = Some(c);
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
        let opts = self.opts;
        let tile_bytes = (opts.tile as usize)
            .saturating_mul(opts.tile as usize)
            .saturating_mul(12);
        if tile_bytes.saturating_add(1024) > opts.max_frame {
            return Err(DistError::TileTooLarge {
                tile: opts.tile,
                max_frame: opts.max_frame,
            });
        }
        let job_id = rand::random::<u64>();
        let list = tiles(settings.width, settings.height, opts.tile);
        let n_tiles = list.len();
        let mut sched = Scheduler::new(
            job_id,
            settings,
            desc.lights.len(),
            list,
            SchedOptions {
                window: opts.window,
                tile_deadline: opts.tile_deadline,
                max_failures: opts.max_failures,
                backups: opts.backups,
                max_batch: opts.max_batch.clamp(1, parrt::protocol::limits::MAX_BATCH),
                pixel_format: opts.pixel_format,
            },
        );
        sched.set_observers(opts.observers.clone());
        let (mut checkpoint, restored_tiles, checkpoint_bad_records): (Option<Checkpoint>, _, _) =
            match self.checkpoint {
                Some(o) => {
                    sched.keep_accepted();
                    let restored = sched.restore(o.scan.tiles);
                    (Some(o.checkpoint), restored, o.scan.bad_records)
                }
                None => (None, 0, 0),
            };
        let job = Message::Job(Box::new(JobSpec {
            job_id,
            scene: desc.clone(),
            settings: settings.clone(),
            tile_size: opts.tile,
            pixel_format: opts.pixel_format,
        }));
        // Encoded once, for every worker (and to size the time allowed for sending it).
        let job = Encoded::new(&job).map_err(DistError::EncodeJob)?;
        let job_bytes = job.len();
        if job_bytes > opts.max_frame {
            return Err(DistError::JobTooLarge {
                bytes: job_bytes,
                max_frame: opts.max_frame,
            });
        }
        let ctx = Arc::new(ConnContext {
            job,
            token: self.token,
            max_frame: opts.max_frame,
            max_receive: worker_frame_limit(opts.tile).min(opts.max_frame),
            job_write_timeout: opts.heartbeat_timeout + frame_allowance(job_bytes),
            handshake_timeout: opts.handshake_timeout,
            heartbeat: opts.heartbeat,
            heartbeat_timeout: opts.heartbeat_timeout,
        });
        let (events_tx, mut events) = mpsc::unbounded_channel::<Event>();
        let stop = CancellationToken::new();
        let tracker = TaskTracker::new();
        tracker.spawn(accept_loop(
            self.listener,
            ctx,
            events_tx,
            stop.clone(),
            tracker.clone(),
            opts.max_connections,
        ));

        let progress = Progress::new(n_tiles, opts.progress);
        let mut tick = interval(Duration::from_millis(100));
        tick.set_missed_tick_behavior(MissedTickBehavior::Delay);
        let mut started: Option<Instant> = None;
        let mut cpu_at_start = 0.0;
        let mut waiting_since = Some(Instant::now());
        let min_workers = opts.min_workers.max(1);
        let outcome: Result<(), DistError> = loop {
            if sched.is_done() && (started.is_some() || !opts.await_all_workers) {
                break Ok(());
            }
            tokio::select! {
                _ = cancel.cancelled() => break Err(DistError::Interrupted),
                ev = events.recv() => match ev {
                    Some(ev) => {
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
                _ = tick.tick() => sched.expire(Instant::now()),
            }
            if let Some(c) = &mut checkpoint {
                if let Err(e) = c.append(&sched.take_accepted()) {
                    break Err(e.into());
                }
            }
            let now = Instant::now();
            let ready = sched.ready_workers();
            let needed = if started.is_some() { 1 } else { min_workers };
            if ready >= needed {
                waiting_since = None;
                if started.is_none() {
                    info!(workers = ready, tiles = n_tiles, "starting");
                    started = Some(now);
                    cpu_at_start = crate::cpu_time::process_cpu_s();
                    opts.observers.each(|o| o.started(now));
                }
                sched.fill(now);
            } else {
                let since = *waiting_since.get_or_insert(now);
                // With a token of its own making only the workers it started can join: once
                // they have all left, waiting longer waits for no one.
                let nobody_else = opts.token.is_none()
                    && opts.workers_to_spawn > 0
                    && sched.departures_count() >= opts.workers_to_spawn;
                if nobody_else || now.duration_since(since) > opts.wait_workers {
                    break Err(if started.is_none() {
                        DistError::NoWorkers {
                            waited: now.duration_since(since),
                            wanted: min_workers,
                            ready,
                            failed: sched.departures(),
                        }
                    } else {
                        DistError::AllWorkersLost {
                            waited: now.duration_since(since),
                            done: sched.progress().0,
                            total: n_tiles,
                        }
                    });
                }
            }
            progress.update(sched.progress().0, &sched.throughput(now));
        };
        let trace_s = started.map_or(0.0, |s| s.elapsed().as_secs_f64());
        let master_cpu_s = if started.is_some() {
            crate::cpu_time::process_cpu_s() - cpu_at_start
        } else {
            0.0
        };
        progress.finish();
        let complete = sched.is_done();
        opts.observers
            .each(|o| o.finished(complete, Instant::now()));
        if let Some(c) = &mut checkpoint {
            if let Err(e) = c.sync() {
                warn!(error = %e, "cannot sync the checkpoint");
            }
        }

        // Shutdown: the scheduler closes every outbox after a Shutdown; the stop signal ends
        // the accept loop and any handshake still running; then wait for the tasks.
        let finished = sched.finish();
        stop.cancel();
        tracker.close();
        if timeout(Duration::from_secs(5), tracker.wait())
            .await
            .is_err()
        {
            warn!("some connections did not close within 5 s");
        }
        // Late events (Gone of the last workers) are of no interest now.
        drop(events);
        outcome?;
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
        Ok(DistResult {
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
            tiles: n_tiles,
            restored_tiles,
            checkpoint_bad_records,
        })
    }
}

/// A peer's place in the handshake budget (overall and per address); given back on drop.
#[derive(Debug)]
pub struct HandshakeSlot {
    _permit: OwnedSemaphorePermit,
    ip: IpAddr,
    per_peer: Arc<Mutex<HashMap<IpAddr, usize>>>,
}

impl Drop for HandshakeSlot {
    fn drop(&mut self) {
        let mut map = self.per_peer.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = map.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                map.remove(&self.ip);
            }
        }
    }
}

/// The connection budgets: every connection holds a slot of `total`; one still handshaking
/// also holds a [`HandshakeSlot`].
struct Admission {
    total: Arc<Semaphore>,
    handshaking: Arc<Semaphore>,
    per_peer: Arc<Mutex<HashMap<IpAddr, usize>>>,
}

impl Admission {
    fn new(max_connections: usize) -> Self {
        let max = max_connections.max(1);
        Admission {
            total: Arc::new(Semaphore::new(max)),
            handshaking: Arc::new(Semaphore::new(MAX_HANDSHAKING.min(max.div_ceil(2)))),
            per_peer: Arc::default(),
        }
    }

    /// Slots for a new peer from `ip`, or why there is none.
    fn admit(&self, ip: IpAddr) -> Result<(OwnedSemaphorePermit, HandshakeSlot), &'static str> {
        let mut map = self.per_peer.lock().unwrap_or_else(|e| e.into_inner());
        let n = map.entry(ip).or_insert(0);
        if *n >= MAX_HANDSHAKING_PER_PEER {
            return Err("too many handshakes from this address");
        }
        let Ok(permit) = self.handshaking.clone().try_acquire_owned() else {
            return Err("too many handshakes at once");
        };
        let Ok(total) = self.total.clone().try_acquire_owned() else {
            return Err("too many connections");
        };
        *n += 1;
        let slot = HandshakeSlot {
            _permit: permit,
            ip,
            per_peer: self.per_peer.clone(),
        };
        Ok((total, slot))
    }
}

async fn accept_loop(
    listener: TcpListener,
    ctx: Arc<ConnContext>,
    events: mpsc::UnboundedSender<Event>,
    stop: CancellationToken,
    tracker: TaskTracker,
    max_connections: usize,
) {
    let admission = Admission::new(max_connections);
    let mut next_id: WorkerId = 1;
    // Turned-away peers are logged at WARN at most once a second.
    let mut last_warn: Option<Instant> = None;
    let mut turned_away = 0u64;
    loop {
        let accepted = tokio::select! {
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
            Err(why) => {
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
            connection::serve(stream, id, ctx, events, stop, slot).await;
            drop(permit);
        });
    }
}
