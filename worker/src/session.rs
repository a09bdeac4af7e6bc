//! One worker session: dial, handshake (Hello → Challenge → Auth → Welcome), then the message
//! loop. The loop owns the connection; renderer builds run on a blocking thread and tiles on the
//! rayon pool, both reporting back through channels. It ends on Shutdown, when the master goes
//! away, or when told to stop (Ctrl-C): then it takes no more tiles and disconnects.

use crate::dial::dial;
use crate::error::WorkerError;
use crate::options::WorkerOptions;
use crate::tiles::{JobHandle, TileRenderer};
use parrt::protocol::{
    Connection, JobSpec, Message, ProtocolError, HANDSHAKE_MAX_FRAME, PROTOCOL_VERSION,
};
use parrt::render::Renderer;
use parrt::tile::Tile;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use tokio::net::TcpStream;
use tokio::sync::mpsc;
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
    pixel_format: parrt::protocol::PixelFormat,
    handle: Option<JobHandle>,
    /// Batches of tiles assigned before the renderer was ready.
    waiting: Vec<Vec<(Tile, u32)>>,
}

/// A finished renderer build.
struct Built {
    job_id: u64,
    result: Result<Renderer, String>,
    seconds: f64,
}

/// Dials the master, authenticates and serves it until the session ends.
pub async fn run(
    opts: &WorkerOptions,
    stop: CancellationToken,
) -> Result<SessionSummary, WorkerError> {
    let Some(stream) = dial(opts, &stop).await? else {
        return Ok(SessionSummary {
            end: SessionEnd::Stopped,
            jobs: 0,
            tiles_rendered: 0,
        });
    };
    let mut conn = Connection::new(stream, HANDSHAKE_MAX_FRAME);
    handshake(&mut conn, opts).await?;
    conn.set_max_frame(opts.max_frame);
    info!(master = %opts.connect, threads = opts.threads, "authenticated");
    let mut summary = SessionSummary {
        end: SessionEnd::Stopped,
        jobs: 0,
        tiles_rendered: 0,
    };
    summary.end = match serve(conn, opts, stop, &mut summary).await {
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

fn is_disconnect(e: &std::io::Error) -> bool {
    use std::io::ErrorKind::*;
    matches!(
        e.kind(),
        BrokenPipe | ConnectionReset | ConnectionAborted | UnexpectedEof
    )
}

async fn read_in_handshake(
    conn: &mut Connection<TcpStream>,
    opts: &WorkerOptions,
) -> Result<Message, WorkerError> {
    match timeout(opts.handshake_timeout, conn.read()).await {
        Err(_) => Err(WorkerError::MasterSilent(opts.handshake_timeout)),
        Ok(r) => r?.ok_or(WorkerError::ClosedInHandshake),
    }
}

async fn handshake(
    conn: &mut Connection<TcpStream>,
    opts: &WorkerOptions,
) -> Result<(), WorkerError> {
    conn.write(&Message::Hello {
        version: PROTOCOL_VERSION,
        name: opts.name.clone(),
        threads: opts.threads as u32,
    })
    .await?;
    let nonce = match read_in_handshake(conn, opts).await? {
        Message::Challenge { nonce } => nonce,
        Message::Refused { reason } => return Err(WorkerError::Refused(reason)),
        other => {
            return Err(WorkerError::Unexpected {
                got: other.kind(),
                during: "waiting for the challenge",
            })
        }
    };
    conn.write(&Message::Auth {
        mac: opts.token.sign(&nonce),
    })
    .await?;
    match read_in_handshake(conn, opts).await? {
        Message::Welcome => Ok(()),
        Message::Refused { reason } => Err(WorkerError::Refused(reason)),
        other => Err(WorkerError::Unexpected {
            got: other.kind(),
            during: "waiting for Welcome",
        }),
    }
}

/// The message loop of an authenticated session.
async fn serve(
    mut conn: Connection<TcpStream>,
    opts: &WorkerOptions,
    stop: CancellationToken,
    summary: &mut SessionSummary,
) -> Result<SessionEnd, WorkerError> {
    let threads = opts.threads.max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("parrt-render-{i}"))
        .build()
        .map_err(|source| WorkerError::Pool { threads, source })?;
    let (out_tx, mut out_rx) = mpsc::unbounded_channel::<Vec<Message>>();
    let (built_tx, mut built_rx) = mpsc::unbounded_channel::<Built>();
    let renderer = TileRenderer::new(pool, out_tx, opts.tile_delay);
    let mut job: Option<CurrentJob> = None;
    let mut beat = interval(opts.heartbeat);
    beat.set_missed_tick_behavior(MissedTickBehavior::Delay);
    // Any message from the master (heartbeats included) proves it is alive.
    let mut last_heard = Instant::now();
    let finish = |job: &Option<CurrentJob>| {
        if let Some(j) = job {
            j.cancelled.store(true, Ordering::Relaxed);
        }
    };
    loop {
        tokio::select! {
            _ = stop.cancelled() => {
                // Stop taking tiles; dropping the connection tells the master to requeue ours.
                finish(&job);
                info!("stopping: disconnecting from the master");
                return Ok(SessionEnd::Stopped);
            }
            _ = sleep_until(last_heard + opts.master_timeout) => {
                finish(&job);
                return Err(WorkerError::MasterSilent(opts.master_timeout));
            }
            read = conn.read() => {
                let msg = match read {
                    Err(e) => {
                        finish(&job);
                        return Err(e.into());
                    }
                    Ok(None) => {
                        finish(&job);
                        info!("master closed the connection");
                        return Ok(SessionEnd::MasterClosed);
                    }
                    Ok(Some(m)) => m,
                };
                last_heard = Instant::now();
                match msg {
                    Message::Job(spec) => {
                        finish(&job);
                        summary.jobs += 1;
                        job = Some(start_build(*spec, built_tx.clone()));
                    }
                    Message::Assign { job_id, tile, attempt } => {
                        take_tiles(&mut conn, opts, &renderer, job.as_mut(), job_id, vec![(tile, attempt)]).await?;
                    }
                    Message::AssignBatch { job_id, tiles } => {
                        take_tiles(&mut conn, opts, &renderer, job.as_mut(), job_id, tiles).await?;
                    }
                    Message::Cancel { job_id } => {
                        if job.as_ref().is_some_and(|j| j.spec_id == job_id) {
                            finish(&job);
                            job = None;
                        }
                    }
                    Message::Shutdown => {
                        finish(&job);
                        info!("master said shutdown");
                        return Ok(SessionEnd::Shutdown);
                    }
                    Message::Heartbeat => {}
                    Message::Error { reason } => warn!(%reason, "master reported an error"),
                    other => {
                        finish(&job);
                        return Err(WorkerError::Unexpected { got: other.kind(), during: "serving" });
                    }
                }
            }
            Some(b) = built_rx.recv() => {
                let Some(j) = job.as_mut().filter(|j| j.spec_id == b.job_id) else { continue };
                match b.result {
                    Ok(r) => {
                        info!(job = b.job_id, build_s = b.seconds, "renderer built");
                        let handle = JobHandle {
                            job_id: b.job_id,
                            renderer: Arc::new(r),
                            cancelled: j.cancelled.clone(),
                            pixel_format: j.pixel_format,
                        };
                        conn.write(&Message::Ready { job_id: b.job_id, build_s: b.seconds }).await?;
                        for batch in j.waiting.drain(..) {
                            renderer.submit(&handle, batch);
                        }
                        j.handle = Some(handle);
                    }
                    Err(reason) => {
                        warn!(job = b.job_id, %reason, "cannot build the job");
                        conn.write(&Message::Error { reason: format!("cannot build job {}: {reason}", b.job_id) }).await?;
                        job = None;
                    }
                }
            }
            Some(msgs) = out_rx.recv() => {
                summary.tiles_rendered += msgs
                    .iter()
                    .filter(|m| matches!(m, Message::TileResult { .. }))
                    .count() as u64;
                conn.write_all(&msgs).await?;
            }
            _ = beat.tick() => conn.write(&Message::Heartbeat).await?,
        }
    }
}

/// Checks an assignment of `tiles` for job `job_id` and queues the valid ones as one batch
/// (their results go back together); each invalid tile is answered with an Error.
async fn take_tiles(
    conn: &mut Connection<TcpStream>,
    opts: &WorkerOptions,
    renderer: &TileRenderer,
    job: Option<&mut CurrentJob>,
    job_id: u64,
    tiles: Vec<(Tile, u32)>,
) -> Result<(), WorkerError> {
    let Some(j) = job.filter(|j| j.spec_id == job_id) else {
        let ids: Vec<u32> = tiles.iter().map(|(t, _)| t.id).collect();
        conn.write(&Message::Error {
            reason: format!("tile(s) {ids:?} assigned for unknown job {job_id}"),
        })
        .await?;
        return Ok(());
    };
    let mut batch = Vec::with_capacity(tiles.len());
    for (tile, attempt) in tiles {
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
        } else {
            None
        };
        match problem {
            Some(reason) => conn.write(&Message::Error { reason }).await?,
            None => batch.push((tile, attempt)),
        }
    }
    if !batch.is_empty() {
        match &j.handle {
            Some(h) => renderer.submit(h, batch),
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

/// Builds the job's renderer on a blocking thread (never on the runtime's workers).
fn start_build(spec: JobSpec, done: mpsc::UnboundedSender<Built>) -> CurrentJob {
    let job = CurrentJob {
        spec_id: spec.job_id,
        width: spec.settings.width,
        height: spec.settings.height,
        cancelled: Arc::new(AtomicBool::new(false)),
        pixel_format: spec.pixel_format,
        handle: None,
        waiting: Vec::new(),
    };
    tokio::task::spawn_blocking(move || {
        let t0 = std::time::Instant::now();
        let result = std::panic::catch_unwind(|| Renderer::new(&spec.scene, &spec.settings))
            .map_err(|_| "building the renderer panicked".to_string())
            .and_then(|r| r.map_err(|e| e.to_string()));
        let _ = done.send(Built {
            job_id: spec.job_id,
            result,
            seconds: t0.elapsed().as_secs_f64(),
        });
    });
    job
}
