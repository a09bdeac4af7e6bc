//! One connection task per peer: the encrypted channel keyed by the token
//! ([`parrt_protocol::channel`]: a wrong token or another version refused at its first
//! message), the handshake inside it (version and thread checks, the master's proof, the
//! worker's MAC check), then the relay between the socket and the scheduler. It owns the
//! [`Connection`]; the scheduler talks to it through an outbox channel and hears from it
//! through [`Event`]s. A peer that fails the
//! handshake, breaks the protocol, falls silent or sends garbage ends only its own task. A peer's
//! name is only ever logged or kept through [`limits::shown`] (escaped, cut), its reasons
//! through [`limits::capped_reason`]; every write is bounded by the heartbeat timeout.

use super::admission::HandshakeSlot;
use super::scheduler::{Event, WorkerId};
use super::shared_regions::{ConnRegion, SharedRegions};
use crate::outgoing::Outgoing;
use parrt_protocol::channel::{self, ChannelError, LinkKey, SecureStream};
use parrt_protocol::limits::{self, MAX_THREADS};
use parrt_protocol::message::NONCE_LEN;
use parrt_protocol::seconds::seconds;
use parrt_protocol::{
    Connection, Encoded, Message, ProtocolError, Token, HANDSHAKE_MAX_FRAME, PROTOCOL_VERSION,
};
use parrt_render::isa::Isa;
use rand::{RngCore, SeedableRng};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::sync::mpsc::{self, UnboundedSender};
use tokio::time::{interval, sleep_until, timeout, Instant, MissedTickBehavior};
use tokio_util::sync::CancellationToken;
use tracing::{debug, info};

/// What every connection task shares.
#[derive(Debug)]
pub struct ConnContext {
    /// The job message, encoded once for every worker.
    pub job: Encoded,
    /// The shared secret.
    pub token: Token,
    /// Largest frame sent (the job) once authenticated.
    pub max_frame: usize,
    /// Largest frame accepted once authenticated ([`limits::worker_frame_limit`] of the tile).
    pub max_receive: usize,
    /// Time allowed for writing the job: the heartbeat timeout plus its size at the floor rate.
    pub job_write_timeout: Duration,
    /// Time allowed for the whole handshake.
    pub handshake_timeout: Duration,
    /// How often to send heartbeats.
    pub heartbeat: Duration,
    /// A worker silent this long is gone.
    pub heartbeat_timeout: Duration,
    /// Seeds each connection's nonce with this and its id (`None`: the operating system's
    /// randomness). Only the deterministic simulation sets it.
    pub seed: Option<u64>,
    /// The most messages that ever waited in one outbox ([`crate::QueuePeaks::outbox`]).
    pub outbox_peak: std::sync::atomic::AtomicUsize,
    /// The memory shared with the workers this master started, for their pixels (none made
    /// when it started none, or was not asked to share).
    pub shared: Arc<SharedRegions>,
}

/// Why a handshake did not produce a worker.
enum Handshake {
    /// The peer is accepted: name, threads and instruction-set tier.
    Accepted(String, u32, Isa),
    /// Refused, with the reason (already sent to the peer when possible).
    Refused(String),
}

/// Serves one peer from accept to close. `stop` ends it (telling the worker Shutdown). `slot`
/// is the peer's place in the handshake budget, given back as soon as the handshake ends.
#[allow(clippy::too_many_arguments)]
pub async fn serve<S: AsyncRead + AsyncWrite + Unpin + Send>(
    stream: S,
    peer: SocketAddr,
    id: WorkerId,
    ctx: Arc<ConnContext>,
    events: UnboundedSender<Event>,
    stop: CancellationToken,
    slot: HandshakeSlot,
) {
    let peer = peer.to_string();
    let stream = slot.watch(stream);
    let first_bytes = slot.first_bytes();
    // A peer that has sent nothing by its first-bytes deadline goes (an honest worker sends
    // its greeting at once); one that has keeps the whole handshake timeout.
    let silent = async {
        tokio::time::sleep(first_bytes).await;
        if slot.heard() {
            std::future::pending::<()>().await;
        }
    };
    let hs = tokio::select! {
        biased;
        _ = stop.cancelled() => return,
        _ = slot.evicted().cancelled() => Err(format!(
            "closed to make room for a newcomer: silent longest of the {}",
            if slot.heard() { "handshakes" } else { "handshakes, having sent nothing" }
        )),
        _ = silent => {
            slot.silent_timeout();
            Err(format!("sent nothing within {}", seconds(first_bytes)))
        }
        r = timeout(ctx.handshake_timeout, open(stream, &ctx, id)) => match r {
            Ok(h) => h,
            Err(_) => Err(format!("handshake not finished within {}", seconds(ctx.handshake_timeout))),
        },
    };
    drop(slot);
    let (mut conn, name, threads, isa) = match hs {
        Ok(accepted) => accepted,
        Err(reason) => {
            let _ = events.send(Event::Refused { peer, reason });
            return;
        }
    };
    conn.set_max_frame(ctx.max_frame);
    conn.set_max_receive(ctx.max_receive);
    let (outbox, mut inbox) = mpsc::unbounded_channel();
    let _ = events.send(Event::Joined {
        id,
        name: name.clone(),
        threads,
        isa,
        outbox,
        counters: conn.counters(),
    });
    let reason = relay(&mut conn, id, &ctx, &events, &mut inbox, &stop).await;
    debug!(worker = id, %name, %peer, %reason, "connection closed");
    let _ = events.send(Event::Gone { id, reason });
}

/// Opens the encrypted channel keyed by the token, then runs the handshake inside it: the
/// connection with the worker's name, threads and tier, or the reason for refusing it.
async fn open<S: AsyncRead + AsyncWrite + Unpin>(
    stream: S,
    ctx: &ConnContext,
    id: WorkerId,
) -> Result<(Connection<SecureStream<S>>, String, u32, Isa), String> {
    let ephemeral = ctx
        .seed
        .map(|seed| channel::seeded_ephemeral(seed ^ id.wrapping_mul(0xD1B5_4A32_D192_ED03)));
    let secure = match channel::accept(stream, &LinkKey::from_token(&ctx.token), ephemeral).await {
        Ok(s) => s,
        Err(ChannelError::WrongKey) => {
            return Err("wrong token (the encrypted handshake failed)".into())
        }
        Err(ChannelError::OtherVersion(v)) => {
            return Err(format!(
                "protocol version {v}; this master speaks {PROTOCOL_VERSION}"
            ))
        }
        Err(ChannelError::Closed) => return Err("closed before the encrypted handshake".into()),
        Err(e) => return Err(format!("bad bytes in handshake: {e}")),
    };
    let mut conn = Connection::new(secure, HANDSHAKE_MAX_FRAME);
    match handshake(&mut conn, ctx, id).await {
        Handshake::Accepted(name, threads, isa) => Ok((conn, name, threads, isa)),
        Handshake::Refused(reason) => Err(reason),
    }
}

/// Sends Refused (best effort, briefly) and returns the refusal.
async fn refuse<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    reason: String,
) -> Handshake {
    let reason = limits::capped_reason(reason);
    let _ = conn
        .write(&Message::Refused {
            reason: reason.clone(),
        })
        .await;
    Handshake::Refused(reason)
}

async fn handshake<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    ctx: &ConnContext,
    id: WorkerId,
) -> Handshake {
    let (name, threads, isa, worker_nonce) = match conn.read().await {
        Ok(Some(Message::Hello {
            version,
            name,
            threads,
            nonce,
            isa,
        })) => {
            let name = limits::shown(&name);
            if version != PROTOCOL_VERSION {
                let reason = format!(
                    "protocol version {version} from {name}; this master speaks {PROTOCOL_VERSION}"
                );
                return refuse(conn, reason).await;
            }
            if threads == 0 || threads > MAX_THREADS {
                let reason = format!(
                    "{name} offers {threads} threads; from 1 to {MAX_THREADS} are accepted"
                );
                return refuse(conn, reason).await;
            }
            (name, threads, isa, nonce)
        }
        Err(ProtocolError::OtherVersion(version)) => {
            let reason =
                format!("protocol version {version}; this master speaks {PROTOCOL_VERSION}");
            return refuse(conn, reason).await;
        }
        Ok(Some(other)) => {
            let reason = format!("expected Hello, got {}", other.kind());
            return refuse(conn, reason).await;
        }
        Ok(None) => return Handshake::Refused("closed before Hello".into()),
        Err(e) => return Handshake::Refused(bad_bytes(e)),
    };
    let mut nonce = [0u8; NONCE_LEN];
    match ctx.seed {
        Some(seed) => {
            rand::rngs::StdRng::seed_from_u64(seed ^ id.wrapping_mul(0x9E37_79B9_7F4A_7C15))
                .fill_bytes(&mut nonce)
        }
        None => rand::thread_rng().fill_bytes(&mut nonce),
    }
    let proof = ctx.token.master_proof(&worker_nonce, &nonce);
    if let Err(e) = conn.write(&Message::Challenge { nonce, proof }).await {
        return Handshake::Refused(format!("cannot send challenge: {e}"));
    }
    match conn.read().await {
        Ok(Some(Message::Auth { mac }))
            if ctx.token.verify_worker_proof(&nonce, &worker_nonce, &mac) => {}
        Ok(Some(Message::Auth { .. })) => {
            return refuse(conn, format!("wrong token from {name}")).await;
        }
        Ok(Some(other)) => {
            let reason = format!("expected Auth from {name}, got {}", other.kind());
            return refuse(conn, reason).await;
        }
        Ok(None) => return Handshake::Refused(format!("{name} closed before Auth")),
        Err(e) => return Handshake::Refused(bad_bytes(e)),
    }
    if let Err(e) = conn.write(&Message::Welcome).await {
        return Handshake::Refused(format!("cannot send Welcome: {e}"));
    }
    Handshake::Accepted(name, threads, isa)
}

fn bad_bytes(e: ProtocolError) -> String {
    format!("bad bytes in handshake: {e}")
}

/// Writes `msg`, giving up (with the reason) when the worker does not take it within `limit`.
async fn write_within<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    msg: &Message,
    limit: Duration,
) -> Result<(), String> {
    match timeout(limit, conn.write(msg)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(format!("write failed: {e}")),
        Err(_) => Err(format!("the worker took nothing for {}", seconds(limit))),
    }
}

/// Writes `msg`, encoded once for every worker, giving up after `limit` as [`write_within`].
async fn write_encoded_within<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    msg: &Encoded,
    limit: Duration,
) -> Result<(), String> {
    match timeout(limit, conn.write_encoded(msg)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(format!("write failed: {e}")),
        Err(_) => Err(format!("the worker took nothing for {}", seconds(limit))),
    }
}

/// After Shutdown: reads and discards until the worker closes (at most [`DRAIN_TIMEOUT`]), so
/// it reads our Shutdown before we close rather than meeting a reset mid-write.
async fn drain<S: AsyncRead + AsyncWrite + Unpin>(conn: &mut Connection<S>) {
    let _ = timeout(DRAIN_TIMEOUT, async {
        while let Ok(Some(_)) = conn.read().await {}
    })
    .await;
}

/// Tells the worker what it broke (`what`) before the connection closes; returns the reason
/// to close it with.
async fn violation<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    id: WorkerId,
    what: String,
    limit: Duration,
) -> String {
    let reason = format!("protocol violation: {what}");
    info!(worker = id, %reason, "closing connection");
    let _ = timeout(
        limit,
        conn.write(&Message::Error {
            reason: reason.clone(),
        }),
    )
    .await;
    reason
}

/// How long to wait for a worker to close after Shutdown.
pub const DRAIN_TIMEOUT: Duration = Duration::from_secs(2);

/// Relays between socket and scheduler until either side ends; returns why.
async fn relay<S: AsyncRead + AsyncWrite + Unpin>(
    conn: &mut Connection<S>,
    id: WorkerId,
    ctx: &ConnContext,
    events: &UnboundedSender<Event>,
    inbox: &mut mpsc::UnboundedReceiver<Outgoing>,
    stop: &CancellationToken,
) -> String {
    let job_sent = Instant::now();
    match timeout(ctx.job_write_timeout, conn.write_encoded(&ctx.job)).await {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return format!("cannot send the job: {e}"),
        Err(_) => {
            return format!(
                "the job not taken within {}",
                seconds(ctx.job_write_timeout)
            )
        }
    }
    let limit = ctx.heartbeat_timeout;
    let mut region = ConnRegion::new(ctx.shared.clone());
    let mut beat = interval(ctx.heartbeat);
    beat.set_missed_tick_behavior(MissedTickBehavior::Delay);
    loop {
        // Any bytes from the worker count as life (a big result may take a while), but each
        // frame must still arrive at the floor rate.
        let alive_until = if crate::mutation::is(crate::mutation::Mutation::NoHeartbeatCheck) {
            Instant::now() + Duration::from_secs(86_400)
        } else {
            conn.alive_until(limit)
        };
        // In this order (not at random), so a run replays exactly under the simulation.
        tokio::select! {
            biased;
            _ = stop.cancelled() => {
                let _ = timeout(limit, conn.write(&Message::Shutdown)).await;
                drain(conn).await;
                return "master finished".into();
            }
            _ = beat.tick() => {
                if let Err(e) = write_within(conn, &Message::Heartbeat, limit).await {
                    return e;
                }
            }
            out = inbox.recv() => match out {
                Some(msg) => {
                    ctx.outbox_peak
                        .fetch_max(inbox.len() + 1, std::sync::atomic::Ordering::Relaxed);
                    let last = matches!(msg, Outgoing::Message(Message::Shutdown));
                    let written = match &msg {
                        Outgoing::Message(m) => write_within(conn, m, limit).await,
                        // A sequence's next frame is a Job: as much time as the first one had.
                        Outgoing::Encoded(e) => write_encoded_within(conn, e, ctx.job_write_timeout).await,
                    };
                    if let Err(e) = written {
                        return e;
                    }
                    if last {
                        drain(conn).await;
                        return "shut down".into();
                    }
                }
                None => {
                    // The scheduler dropped this worker.
                    let _ = timeout(limit, conn.write(&Message::Shutdown)).await;
                    drain(conn).await;
                    return "dropped by the scheduler".into();
                }
            },
            read = conn.read() => {
                let msg = match read {
                    Err(e) => return format!("connection error: {e}"),
                    Ok(None) => return "disconnected".into(),
                    Ok(Some(m)) => m,
                };
                let ev = match msg {
                    Message::Heartbeat => continue,
                    Message::Ready { job_id, build_s } => Event::Ready {
                        id,
                        job_id,
                        build_s,
                        job_to_ready_s: job_sent.elapsed().as_secs_f64(),
                    },
                    Message::TileResult { job_id, tile_id, attempt, pixels, stats, seconds } => {
                        match region.resolve(pixels) {
                            Ok(pixels) => Event::Result { id, job_id, tile_id, attempt, pixels, stats, seconds },
                            Err(what) => return violation(conn, id, what, limit).await,
                        }
                    }
                    Message::Error { reason } => Event::WorkerError { id, reason: limits::capped_reason(reason) },
                    other => {
                        let what = format!("unexpected {}", other.kind());
                        return violation(conn, id, what, limit).await;
                    }
                };
                if events.send(ev).is_err() {
                    return "scheduler finished".into();
                }
            }
            _ = sleep_until(alive_until) => {
                let now = Instant::now();
                if now < conn.alive_until(limit) {
                    continue;
                }
                return match conn.pending_frame() {
                    Some((_, len)) => format!(
                        "a {len}-byte frame arriving slower than {} bytes/s", limits::MIN_FRAME_RATE
                    ),
                    None => format!("no heartbeat for {}", seconds(limit)),
                };
            }
        }
    }
}
