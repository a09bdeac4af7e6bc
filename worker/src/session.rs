//! One worker session: dial, open the encrypted channel keyed by the token
//! ([`parrt_protocol::channel`]), handshake inside it (Hello with our nonce → Challenge with
//! the master's proof, checked before we answer → Auth → Welcome), then the message loop. A handshake cut
//! short is retried within the dial budget; a refusal or a master that cannot prove the token
//! ends the session at once. The loop owns the connection; renderer builds and tiles go to an
//! executor ([`crate::exec`]) that reports back as one more branch of the loop, so heartbeats
//! never wait. Every write is bounded by the master timeout. It ends on Shutdown, when the
//! master goes away, or when told to stop (Ctrl-C): then it takes no more tiles and
//! disconnects. [`run`] is the real worker (TCP, a rayon pool); [`run_with`] takes the network
//! and the executor as arguments, so a simulation runs this same code.

use crate::dial::Dialer;
use crate::error::WorkerError;
use crate::exec::{Built, ExecEvent, Execute, RayonExec};
use crate::net::{Dial, TcpDial};
use crate::options::WorkerOptions;
use crate::tiles::JobHandle;
use parrt_protocol::channel::{self, ChannelError, LinkKey, SecureStream};
use parrt_protocol::limits;
use parrt_protocol::message::NONCE_LEN;
use parrt_protocol::{
    Connection, JobSpec, Message, ProtocolError, ViewSpec, HANDSHAKE_MAX_FRAME, PROTOCOL_VERSION,
};
use parrt_render::tile::Tile;
use rand::rngs::StdRng;
use rand::{RngCore, SeedableRng};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::time::{interval, sleep_until, timeout, Instant, MissedTickBehavior};
use tokio_util::sync::CancellationToken;
use tracing::{info, warn};

/// How a session ended without error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SessionEnd {
    /// The master said Shutdown.
    Shutdown,
    /// The master closed the connection.
    MasterClosed,
    /// We were told to stop (Ctrl-C) and disconnected.
    Stopped,
}

/// What a session did.
#[derive(Clone, Copy, Debug)]
pub struct SessionSummary {
    /// How it ended.
    pub end: SessionEnd,
    /// Jobs received.
    pub jobs: u32,
    /// Tile results sent.
    pub tiles_rendered: u64,
}

/// A job received but perhaps not yet built.
struct CurrentJob {
    spec_id: u64,
    width: u32,
    height: u32,
    cancelled: Arc<AtomicBool>,
    pixel_format: parrt_protocol::PixelFormat,
    pack_pixels: bool,
    handle: Option<JobHandle>,
    /// Batches of tiles assigned before the renderer was ready.
    waiting: Vec<Vec<(Tile, u32)>>,
    /// A frame that only moves the camera, waiting for its base job's build
    /// ([`Message::View`]): made from the base's renderer as soon as that is built.
    view_of: Option<Box<ViewSpec>>,
}

/// Where handshake nonces come from: fresh from the thread's cryptographic generator, or (a
/// simulation aid, [`WorkerOptions::nonce_seed`]) a seeded one, the same run after run.
enum Nonces {
    Thread,
    Seeded(Box<StdRng>),
}

impl Nonces {
    fn new(opts: &WorkerOptions) -> Self {
        match opts.nonce_seed {
            Some(seed) => Nonces::Seeded(Box::new(StdRng::seed_from_u64(seed))),
            None => Nonces::Thread,
        }
    }

    /// The ephemeral key of a connection attempt's encrypted handshake: `None` (fresh from the
    /// operating system) unless seeded.
    fn ephemeral(&mut self) -> Option<[u8; 32]> {
        match self {
            Nonces::Thread => None,
            Nonces::Seeded(rng) => Some(channel::seeded_ephemeral(rng.next_u64())),
        }
    }

    /// A fresh nonce (one per connection attempt).
    fn next(&mut self) -> [u8; NONCE_LEN] {
        let mut n = [0u8; NONCE_LEN];
        match self {
            // Asked for each time: a ThreadRng may not be kept across an await of a Send future.
            Nonces::Thread => rand::thread_rng().fill_bytes(&mut n),
            Nonces::Seeded(rng) => rng.fill_bytes(&mut n),
        }
        n
    }
}

/// Dials the master over TCP, authenticates and serves it until the session ends, rendering
/// on a rayon pool of [`WorkerOptions::threads`]: the real worker.
pub async fn run(
    opts: &WorkerOptions,
    stop: CancellationToken,
) -> Result<SessionSummary, WorkerError> {
    run_with(opts, stop, &TcpDial, RayonExec::new()).await
}

/// [`run`] with the network and the executor given: connects through `dial` (every attempt of
/// the dial budget), and builds renderers and renders tiles with `exec`. A simulation passes
/// its simulated streams and an [`crate::exec::InlineExec`]; everything else (backoff,
/// handshake, limits, the message loop, logs) is the real worker's.
pub async fn run_with<D: Dial, E: Execute>(
    opts: &WorkerOptions,
    stop: CancellationToken,
    dial: &D,
    mut exec: E,
) -> Result<SessionSummary, WorkerError> {
    let stopped = SessionSummary {
        end: SessionEnd::Stopped,
        jobs: 0,
        tiles_rendered: 0,
    };
    let mut nonces = Nonces::new(opts);
    let key = LinkKey::from_token(&opts.token);
    let mut dialer = Dialer::with(opts, dial);
    let mut conn = loop {
        let Some(stream) = dialer.connect(&stop).await? else {
            return Ok(stopped);
        };
        match open(stream, opts, &key, &mut nonces).await {
            Ok(conn) => break conn,
            Err(e) if e.is_cut_handshake() => {
                if !dialer.retry_after(e, &stop).await? {
                    return Ok(stopped);
                }
            }
            Err(e) => return Err(e),
        }
    };
    conn.set_max_frame(opts.max_frame);
    info!(master = %opts.connect, threads = opts.threads, "authenticated");
    let mut summary = SessionSummary {
        end: SessionEnd::Stopped,
        jobs: 0,
        tiles_rendered: 0,
    };
    summary.end = match serve(conn, opts, stop, &mut summary, &mut exec).await {
        Ok(end) => end,
        // The master closing its end while we write is the master going away, not a fault.
        Err(WorkerError::Protocol(ProtocolError::Io(e))) if is_disconnect(&e) => {
            info!(error = %e, "master went away");
            SessionEnd::MasterClosed
        }
        Err(e) => return Err(e),
    };
    Ok(summary)
}

/// Opens the encrypted channel on `stream` and authenticates inside it: a connection ready for
/// the job. Each step is bounded by the handshake timeout.
async fn open<S: AsyncRead + AsyncWrite + Unpin>(
    stream: S,
    opts: &WorkerOptions,
    key: &LinkKey,
    nonces: &mut Nonces,
) -> Result<Connection<SecureStream<S>>, WorkerError> {
    let secure = match timeout(
        opts.handshake_timeout,
        channel::connect(stream, key, nonces.ephemeral()),
    )
    .await
    {
        Err(_) => return Err(WorkerError::MasterSilent(opts.handshake_timeout)),
        Ok(Ok(s)) => s,
        Ok(Err(e)) => return Err(channel_error(e, opts)),
    };
    let mut conn = Connection::new(secure, HANDSHAKE_MAX_FRAME);
    handshake(&mut conn, opts, nonces.next()).await?;
    Ok(conn)
}

/// What a failed channel handshake means for the worker: a master that could not prove the
/// token, a refusal (a wrong token, another version), or a cut handshake worth retrying.
fn channel_error(e: ChannelError, opts: &WorkerOptions) -> WorkerError {
    match e {
        ChannelError::WrongKey => WorkerError::MasterUnproven(opts.connect.clone()),
        ChannelError::Refused(r) => WorkerError::Refused(limits::shown_reason(&r)),
        ChannelError::Closed => WorkerError::ClosedInHandshake,
        ChannelError::Io(e) => WorkerError::Protocol(ProtocolError::Io(e)),
        other => WorkerError::Channel(other),
    }
}

fn is_disconnect(e: &std::io::Error) -> bool {
    use std::io::ErrorKind::*;
    matches!(
        e.kind(),
        BrokenPipe | ConnectionReset | ConnectionAborted | UnexpectedEof
    )
}

/// Writes `msg`, giving up when the master takes nothing for `limit`.
async fn write_within<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    msg: &Message,
    limit: Duration,
) -> Result<(), WorkerError> {
    write_all_within(conn, std::slice::from_ref(msg), limit).await
}

/// Writes several messages with one flush, bounded by `limit` like [`write_within`].
async fn write_all_within<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    msgs: &[Message],
    limit: Duration,
) -> Result<(), WorkerError> {
    match timeout(limit, conn.write_all(msgs)).await {
        Ok(r) => Ok(r?),
        Err(_) => Err(WorkerError::MasterNotReading(limit)),
    }
}

async fn read_in_handshake<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    opts: &WorkerOptions,
) -> Result<Message, WorkerError> {
    match timeout(opts.handshake_timeout, conn.read()).await {
        Err(_) => Err(WorkerError::MasterSilent(opts.handshake_timeout)),
        Ok(r) => r?.ok_or(WorkerError::ClosedInHandshake),
    }
}

async fn handshake<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    opts: &WorkerOptions,
    ours: [u8; NONCE_LEN],
) -> Result<(), WorkerError> {
    let hello = Message::Hello {
        version: PROTOCOL_VERSION,
        name: opts.name.clone(),
        threads: opts.render_threads() as u32,
        nonce: ours,
        isa: parrt_render::isa::current(),
    };
    write_within(conn, &hello, opts.handshake_timeout).await?;
    let theirs = match read_in_handshake(conn, opts).await? {
        Message::Challenge { nonce, proof } => {
            // Answer only a peer that proved it knows the token over our nonce: anyone else
            // gets nothing it could relay or test guesses of the token against.
            if !opts.token.verify_master_proof(&ours, &nonce, &proof) {
                return Err(WorkerError::MasterUnproven(opts.connect.clone()));
            }
            nonce
        }
        Message::Refused { reason } => {
            return Err(WorkerError::Refused(limits::shown_reason(&reason)))
        }
        other => {
            return Err(WorkerError::Unexpected {
                got: other.kind(),
                during: "waiting for the challenge",
            })
        }
    };
    let auth = Message::Auth {
        mac: opts.token.worker_proof(&theirs, &ours),
    };
    write_within(conn, &auth, opts.handshake_timeout).await?;
    match read_in_handshake(conn, opts).await? {
        Message::Welcome => Ok(()),
        Message::Refused { reason } => Err(WorkerError::Refused(limits::shown_reason(&reason))),
        other => Err(WorkerError::Unexpected {
            got: other.kind(),
            during: "waiting for Welcome",
        }),
    }
}

/// The message loop of an authenticated session.
async fn serve<S: AsyncRead + AsyncWrite + Unpin, E: Execute>(
    mut conn: Connection<S>,
    opts: &WorkerOptions,
    stop: CancellationToken,
    summary: &mut SessionSummary,
    exec: &mut E,
) -> Result<SessionEnd, WorkerError> {
    exec.start(opts);
    // The jobs held, oldest first: one, or the frames of a sequence the master has open.
    let mut jobs: Vec<CurrentJob> = Vec::new();
    let mut beat = interval(opts.heartbeat);
    beat.set_missed_tick_behavior(MissedTickBehavior::Delay);
    let limit = opts.master_timeout;
    let finish = |jobs: &[CurrentJob]| {
        for j in jobs {
            j.cancelled.store(true, Ordering::Relaxed);
        }
    };
    loop {
        // Any bytes from the master (heartbeats included) prove it is alive; a frame must
        // still arrive at the floor rate.
        let alive_until = conn.alive_until(limit);
        // In this order (not at random), so a session replays exactly under the simulation;
        // silence is judged last, after any bytes waiting have been read.
        tokio::select! {
            biased;
            _ = stop.cancelled() => {
                // Stop taking tiles; dropping the connection tells the master to requeue ours.
                finish(&jobs);
                info!("stopping: disconnecting from the master");
                return Ok(SessionEnd::Stopped);
            }
            read = conn.read() => {
                let msg = match read {
                    Err(e) => {
                        finish(&jobs);
                        return Err(e.into());
                    }
                    Ok(None) => {
                        finish(&jobs);
                        info!("master closed the connection");
                        return Ok(SessionEnd::MasterClosed);
                    }
                    Ok(Some(m)) => m,
                };
                match msg {
                    // A job already held, sent again: nothing changes, its tiles keep
                    // rendering.
                    Message::Job(spec) if jobs.iter().any(|j| j.spec_id == spec.job_id) => {}
                    Message::Job(spec) => {
                        // A sequence sends a Job for each frame and keeps a window of them
                        // open: each is held beside the others until the master cancels it
                        // (the limit stays the job's); past the most held, the oldest goes.
                        if jobs.len() >= limits::MAX_JOBS_HELD {
                            let oldest = jobs.remove(0);
                            finish(std::slice::from_ref(&oldest));
                        }
                        summary.jobs += 1;
                        jobs.push(start_build(*spec, exec));
                    }
                    Message::View(spec) if jobs.iter().any(|j| j.spec_id == spec.job_id) => {}
                    Message::View(spec) => {
                        // Held as a Job is, beside its base (which a master keeps until it
                        // sends a frame of another scene): past the most held, the oldest job
                        // that is not this frame's base goes.
                        if jobs.len() >= limits::MAX_JOBS_HELD {
                            if let Some(i) = jobs.iter().position(|j| j.spec_id != spec.base_job_id) {
                                let oldest = jobs.remove(i);
                                finish(std::slice::from_ref(&oldest));
                            }
                        }
                        summary.jobs += 1;
                        exec.viewed(&spec);
                        view_job(&mut conn, &mut jobs, spec, limit).await?;
                    }
                    Message::Assign { job_id, tile, attempt } => {
                        let job = jobs.iter_mut().find(|j| j.spec_id == job_id);
                        take_tiles(&mut conn, opts, exec, job, job_id, vec![(tile, attempt)]).await?;
                    }
                    Message::AssignBatch { job_id, tiles } => {
                        let job = jobs.iter_mut().find(|j| j.spec_id == job_id);
                        take_tiles(&mut conn, opts, exec, job, job_id, tiles).await?;
                    }
                    Message::Cancel { job_id } => {
                        if let Some(i) = jobs.iter().position(|j| j.spec_id == job_id) {
                            // A base still building that frames of its scene wait for stays
                            // until they are made (its own tiles are dropped at once).
                            let waited_on = views_of(&jobs, job_id).next().is_some();
                            if waited_on {
                                finish(&jobs[i..=i]);
                            } else {
                                let gone = jobs.remove(i);
                                finish(std::slice::from_ref(&gone));
                            }
                        }
                    }
                    Message::Shutdown => {
                        finish(&jobs);
                        info!("master said shutdown");
                        return Ok(SessionEnd::Shutdown);
                    }
                    Message::Heartbeat => {}
                    Message::Error { reason } => {
                        let reason = limits::shown_reason(&reason);
                        warn!(%reason, "master reported an error");
                    }
                    other => {
                        finish(&jobs);
                        return Err(WorkerError::Unexpected { got: other.kind(), during: "serving" });
                    }
                }
            }
            event = exec.next() => match event? {
                ExecEvent::Built(b) => built(&mut conn, exec, &mut jobs, *b, limit).await?,
                ExecEvent::Results(msgs) => {
                    summary.tiles_rendered += msgs
                        .iter()
                        .filter(|m| matches!(m, Message::TileResult { .. }))
                        .count() as u64;
                    if let Err(e) = write_all_within(&mut conn, &msgs, limit).await {
                        finish(&jobs);
                        return Err(e);
                    }
                }
            },
            _ = beat.tick() => write_within(&mut conn, &Message::Heartbeat, limit).await?,
            _ = sleep_until(alive_until) => {
                if Instant::now() < conn.alive_until(limit) {
                    continue;
                }
                finish(&jobs);
                return Err(WorkerError::MasterSilent(limit));
            }
        }
    }
}

/// A renderer build ended: for a job held, Ready and the tiles that waited for it go to the
/// executor, or the build's error goes to the master and the job is dropped; a build of a job
/// since cancelled or dropped is ignored.
async fn built<S: AsyncRead + AsyncWrite + Unpin, E: Execute>(
    conn: &mut Connection<S>,
    exec: &mut E,
    jobs: &mut Vec<CurrentJob>,
    b: Built,
    limit: Duration,
) -> Result<(), WorkerError> {
    let Some(i) = jobs.iter().position(|j| j.spec_id == b.job_id) else {
        return Ok(());
    };
    let j = &mut jobs[i];
    match b.result {
        Ok(r) => {
            info!(job = b.job_id, build_s = b.seconds, "renderer built");
            let handle = JobHandle {
                job_id: b.job_id,
                renderer: Arc::new(r),
                cancelled: j.cancelled.clone(),
                pixel_format: j.pixel_format,
                pack_pixels: j.pack_pixels,
            };
            let ready = Message::Ready {
                job_id: b.job_id,
                build_s: b.seconds,
            };
            write_within(conn, &ready, limit).await?;
            for batch in j.waiting.drain(..) {
                exec.submit(&handle, batch);
            }
            j.handle = Some(handle);
            // The frames that only move this job's camera, which waited for its build.
            let waiting: Vec<u64> = views_of(jobs, b.job_id)
                .filter(|d| d.handle.is_none())
                .map(|d| d.spec_id)
                .collect();
            for id in waiting {
                view_built(conn, exec, jobs, b.job_id, id, limit).await?;
            }
            // A base cancelled while it was building goes once its frames are made.
            jobs.retain(|j| j.spec_id != b.job_id || !j.cancelled.load(Ordering::Relaxed));
        }
        Err(reason) => {
            warn!(job = b.job_id, %reason, "cannot build the job");
            let reason = limits::capped_reason(format!("cannot build job {}: {reason}", b.job_id));
            write_within(conn, &Message::Error { reason }, limit).await?;
            jobs.remove(i);
            // Frames of its scene cannot be made either.
            let derived: Vec<u64> = views_of(jobs, b.job_id).map(|d| d.spec_id).collect();
            for id in derived {
                let reason = format!("cannot build job {id}: its base job {} failed", b.job_id);
                write_within(conn, &Message::Error { reason }, limit).await?;
                jobs.retain(|d| d.spec_id != id);
            }
        }
    }
    Ok(())
}

/// The jobs that are Views of job `base`: frames made, or to be made, from its build.
fn views_of(jobs: &[CurrentJob], base: u64) -> impl Iterator<Item = &CurrentJob> {
    jobs.iter()
        .filter(move |d| d.view_of.as_ref().is_some_and(|v| v.base_job_id == base))
}

/// A frame that only moves the camera of a job held ([`Message::View`]): made at once from
/// the base's renderer when that is built (Ready, or Error for a bad view or settings), else
/// held until it is; a base this worker does not hold is answered with an Error (the frame is
/// not held, its tiles are refused as a job unknown).
async fn view_job<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    jobs: &mut Vec<CurrentJob>,
    spec: Box<ViewSpec>,
    limit: Duration,
) -> Result<(), WorkerError> {
    let Some(base) = jobs.iter().find(|j| j.spec_id == spec.base_job_id) else {
        let reason = format!(
            "cannot build job {}: it is a view of job {}, which this worker does not hold",
            spec.job_id, spec.base_job_id
        );
        warn!(%reason, "unknown base job");
        write_within(conn, &Message::Error { reason }, limit).await?;
        return Ok(());
    };
    let base_handle = base.handle.clone();
    let mut job = CurrentJob {
        spec_id: spec.job_id,
        width: spec.settings.width,
        height: spec.settings.height,
        cancelled: Arc::new(AtomicBool::new(false)),
        pixel_format: spec.pixel_format,
        pack_pixels: spec.pack_pixels,
        handle: None,
        waiting: Vec::new(),
        view_of: None,
    };
    match base_handle {
        Some(h) => match derive(&h, &spec, &job) {
            Ok((handle, build_s)) => {
                job.handle = Some(handle);
                jobs.push(job);
                let ready = Message::Ready {
                    job_id: spec.job_id,
                    build_s,
                };
                write_within(conn, &ready, limit).await?;
            }
            Err(reason) => write_within(conn, &Message::Error { reason }, limit).await?,
        },
        None => {
            job.view_of = Some(spec);
            jobs.push(job);
        }
    }
    Ok(())
}

/// Job `id`, a view of job `base` whose build just ended, made from it: Ready and its waiting
/// tiles to the executor, or an Error and the job dropped.
async fn view_built<S: AsyncRead + AsyncWrite + Unpin, E: Execute>(
    conn: &mut Connection<S>,
    exec: &mut E,
    jobs: &mut Vec<CurrentJob>,
    base: u64,
    id: u64,
    limit: Duration,
) -> Result<(), WorkerError> {
    let Some(h) = jobs
        .iter()
        .find(|j| j.spec_id == base)
        .and_then(|j| j.handle.clone())
    else {
        return Ok(());
    };
    let Some(i) = jobs.iter().position(|j| j.spec_id == id) else {
        return Ok(());
    };
    let Some(spec) = jobs[i].view_of.take() else {
        return Ok(());
    };
    match derive(&h, &spec, &jobs[i]) {
        Ok((handle, build_s)) => {
            let j = &mut jobs[i];
            for batch in j.waiting.drain(..) {
                exec.submit(&handle, batch);
            }
            j.handle = Some(handle);
            write_within(
                conn,
                &Message::Ready {
                    job_id: id,
                    build_s,
                },
                limit,
            )
            .await?;
        }
        Err(reason) => {
            jobs.remove(i);
            write_within(conn, &Message::Error { reason }, limit).await?;
        }
    }
    Ok(())
}

/// The renderer of `spec` from its base's: the same built scene seen from the frame's view
/// ([`parrt_render::render::Renderer::with_view`]), or why not (a bad view or settings).
fn derive(base: &JobHandle, spec: &ViewSpec, job: &CurrentJob) -> Result<(JobHandle, f64), String> {
    let t = std::time::Instant::now();
    match base.renderer.with_view(&spec.view, &spec.settings) {
        Ok(r) => Ok((
            JobHandle {
                job_id: spec.job_id,
                renderer: Arc::new(r),
                cancelled: job.cancelled.clone(),
                pixel_format: spec.pixel_format,
                pack_pixels: spec.pack_pixels,
            },
            t.elapsed().as_secs_f64(),
        )),
        Err(e) => {
            warn!(job = spec.job_id, error = %e, "cannot view the base job's scene");
            Err(limits::capped_reason(format!(
                "cannot build job {}: {e}",
                spec.job_id
            )))
        }
    }
}

/// Checks an assignment of `tiles` for job `job_id` and queues the valid ones as one batch
/// (their results go back together); each invalid tile is answered with an Error.
async fn take_tiles<S: AsyncRead + AsyncWrite + Unpin, E: Execute>(
    conn: &mut Connection<S>,
    opts: &WorkerOptions,
    exec: &mut E,
    job: Option<&mut CurrentJob>,
    job_id: u64,
    tiles: Vec<(Tile, u32)>,
) -> Result<(), WorkerError> {
    let Some(j) = job.filter(|j| j.spec_id == job_id) else {
        let ids: Vec<u32> = tiles.iter().map(|(t, _)| t.id).collect();
        let reason = format!("tile(s) {ids:?} assigned for unknown job {job_id}");
        write_within(conn, &Message::Error { reason }, opts.master_timeout).await?;
        return Ok(());
    };
    let mut batch = Vec::with_capacity(tiles.len());
    // What the batch's results will hold: bounded, so no assignment can make the worker
    // allocate past its budget (the tiles past it are refused, each with an Error).
    let mut held = 0usize;
    for (tile, attempt) in tiles {
        let bytes = tile
            .pixel_count()
            .saturating_mul(j.pixel_format.bytes_per_pixel());
        let problem = if !tile_fits(&tile, j.width, j.height) {
            Some(format!(
                "tile {} ({}x{} at {},{}) lies outside the {}x{} image",
                tile.id, tile.w, tile.h, tile.x, tile.y, j.width, j.height
            ))
        } else if tile
            .pixel_count()
            .saturating_mul(j.pixel_format.bytes_per_pixel())
            .saturating_add(1024)
            > opts.max_frame
        {
            Some(format!(
                "tile {} of {}x{} pixels does not fit one {}-byte frame",
                tile.id, tile.w, tile.h, opts.max_frame
            ))
        } else if held.saturating_add(bytes) > opts.batch_budget {
            Some(format!(
                "tile {} would make this batch's results hold more than {} bytes; assign it \
                 again in another batch",
                tile.id, opts.batch_budget
            ))
        } else {
            held += bytes;
            None
        };
        match problem {
            Some(reason) => {
                write_within(conn, &Message::Error { reason }, opts.master_timeout).await?
            }
            None => batch.push((tile, attempt)),
        }
    }
    if !batch.is_empty() {
        match &j.handle {
            Some(h) => exec.submit(h, batch),
            None => j.waiting.push(batch),
        }
    }
    Ok(())
}

fn tile_fits(t: &Tile, width: u32, height: u32) -> bool {
    t.w > 0
        && t.h > 0
        && t.x.checked_add(t.w).is_some_and(|r| r <= width)
        && t.y.checked_add(t.h).is_some_and(|b| b <= height)
}

/// Has `exec` build the job's renderer (the rayon executor: on a blocking thread, never on the
/// runtime's workers).
fn start_build<E: Execute>(spec: JobSpec, exec: &mut E) -> CurrentJob {
    let job = CurrentJob {
        spec_id: spec.job_id,
        width: spec.settings.width,
        height: spec.settings.height,
        cancelled: Arc::new(AtomicBool::new(false)),
        pixel_format: spec.pixel_format,
        pack_pixels: spec.pack_pixels,
        handle: None,
        waiting: Vec::new(),
        view_of: None,
    };
    exec.build(spec);
    job
}
