//! One connection task per peer: the handshake (version check, challenge, HMAC check), then the
//! relay between the socket and the scheduler. It owns the [`Connection`]; the scheduler talks
//! to it through an outbox channel and hears from it through [`Event`]s. A peer that fails the
//! handshake, breaks the protocol, falls silent or sends garbage ends only its own task.

use super::scheduler::{Event, WorkerId};
use parrt::protocol::{
    Connection, Message, ProtocolError, Token, HANDSHAKE_MAX_FRAME, PROTOCOL_VERSION,
};
use rand::RngCore;
use std::sync::Arc;
use std::time::Duration;
use tokio::net::TcpStream;
use tokio::sync::mpsc::{self, UnboundedSender};
use tokio::time::{interval, sleep_until, timeout, Instant, MissedTickBehavior};
use tokio_util::sync::CancellationToken;
use tracing::{debug, info};

/// What every connection task shares.
#[derive(Debug)]
pub struct ConnContext {
    /// The job message, encoded once per worker as it is sent.
    pub job: Message,
    /// The shared secret.
    pub token: Token,
    /// Largest frame accepted once authenticated.
    pub max_frame: usize,
    /// Time allowed for the whole handshake.
    pub handshake_timeout: Duration,
    /// How often to send heartbeats.
    pub heartbeat: Duration,
    /// A worker silent this long is gone.
    pub heartbeat_timeout: Duration,
}

/// Why a handshake did not produce a worker.
enum Handshake {
    /// The peer is accepted: name and threads.
    Accepted(String, u32),
    /// Refused, with the reason (already sent to the peer when possible).
    Refused(String),
}

/// Serves one peer from accept to close. `stop` ends it (telling the worker Shutdown).
pub async fn serve(
    stream: TcpStream,
    id: WorkerId,
    ctx: Arc<ConnContext>,
    events: UnboundedSender<Event>,
    stop: CancellationToken,
) {
    let peer = stream
        .peer_addr()
        .map_or_else(|_| "?".to_string(), |a| a.to_string());
    let _ = stream.set_nodelay(true);
    let mut conn = Connection::new(stream, HANDSHAKE_MAX_FRAME);
    let hs = tokio::select! {
        _ = stop.cancelled() => return,
        r = timeout(ctx.handshake_timeout, handshake(&mut conn, &ctx)) => match r {
            Ok(h) => h,
            Err(_) => Handshake::Refused(format!("handshake not finished within {:?}", ctx.handshake_timeout)),
        },
    };
    let (name, threads) = match hs {
        Handshake::Accepted(n, t) => (n, t),
        Handshake::Refused(reason) => {
            let _ = events.send(Event::Refused { peer, reason });
            return;
        }
    };
    conn.set_max_frame(ctx.max_frame);
    let (outbox, mut inbox) = mpsc::unbounded_channel();
    let _ = events.send(Event::Joined {
        id,
        name: name.clone(),
        threads,
        outbox,
        counters: conn.counters(),
    });
    let reason = relay(&mut conn, id, &ctx, &events, &mut inbox, &stop).await;
    debug!(worker = id, %name, %peer, %reason, "connection closed");
    let _ = events.send(Event::Gone { id, reason });
}

async fn handshake(conn: &mut Connection, ctx: &ConnContext) -> Handshake {
    let refuse = |r: String| Handshake::Refused(r);
    let (name, threads) = match conn.read().await {
        Ok(Some(Message::Hello {
            version,
            name,
            threads,
        })) => {
            if version != PROTOCOL_VERSION {
                let reason = format!(
                    "protocol version {version} from {name:?}; this master speaks {PROTOCOL_VERSION}"
                );
                let _ = conn
                    .write(&Message::Refused {
                        reason: reason.clone(),
                    })
                    .await;
                return refuse(reason);
            }
            (name, threads)
        }
        Ok(Some(other)) => {
            let reason = format!("expected Hello, got {}", other.kind());
            let _ = conn
                .write(&Message::Refused {
                    reason: reason.clone(),
                })
                .await;
            return refuse(reason);
        }
        Ok(None) => return refuse("closed before Hello".into()),
        Err(e) => return refuse(bad_bytes(e)),
    };
    let mut nonce = [0u8; parrt::protocol::message::NONCE_LEN];
    rand::thread_rng().fill_bytes(&mut nonce);
    if let Err(e) = conn.write(&Message::Challenge { nonce }).await {
        return refuse(format!("cannot send challenge: {e}"));
    }
    match conn.read().await {
        Ok(Some(Message::Auth { mac })) if ctx.token.verify(&nonce, &mac) => {}
        Ok(Some(Message::Auth { .. })) => {
            let reason = format!("wrong token from {name:?}");
            let _ = conn
                .write(&Message::Refused {
                    reason: reason.clone(),
                })
                .await;
            return refuse(reason);
        }
        Ok(Some(other)) => {
            let reason = format!("expected Auth from {name:?}, got {}", other.kind());
            let _ = conn
                .write(&Message::Refused {
                    reason: reason.clone(),
                })
                .await;
            return refuse(reason);
        }
        Ok(None) => return refuse(format!("{name:?} closed before Auth")),
        Err(e) => return refuse(bad_bytes(e)),
    }
    if threads == 0 {
        let reason = format!("{name:?} offers 0 threads");
        let _ = conn
            .write(&Message::Refused {
                reason: reason.clone(),
            })
            .await;
        return refuse(reason);
    }
    if let Err(e) = conn.write(&Message::Welcome).await {
        return refuse(format!("cannot send Welcome: {e}"));
    }
    Handshake::Accepted(name, threads)
}

fn bad_bytes(e: ProtocolError) -> String {
    format!("bad bytes in handshake: {e}")
}

/// After Shutdown: reads and discards until the worker closes (at most [`DRAIN_TIMEOUT`]), so
/// it reads our Shutdown before we close rather than meeting a reset mid-write.
async fn drain(conn: &mut Connection) {
    let _ = timeout(DRAIN_TIMEOUT, async {
        while let Ok(Some(_)) = conn.read().await {}
    })
    .await;
}

/// How long to wait for a worker to close after Shutdown.
pub const DRAIN_TIMEOUT: Duration = Duration::from_secs(2);

/// Relays between socket and scheduler until either side ends; returns why.
async fn relay(
    conn: &mut Connection,
    id: WorkerId,
    ctx: &ConnContext,
    events: &UnboundedSender<Event>,
    inbox: &mut mpsc::UnboundedReceiver<Message>,
    stop: &CancellationToken,
) -> String {
    let job_sent = Instant::now();
    if let Err(e) = conn.write(&ctx.job).await {
        return format!("cannot send the job: {e}");
    }
    let mut beat = interval(ctx.heartbeat);
    beat.set_missed_tick_behavior(MissedTickBehavior::Delay);
    // Any message from the worker counts as a heartbeat.
    let mut last_heard = Instant::now();
    loop {
        tokio::select! {
            _ = stop.cancelled() => {
                let _ = conn.write(&Message::Shutdown).await;
                drain(conn).await;
                return "master finished".into();
            }
            out = inbox.recv() => match out {
                Some(msg) => {
                    let last = matches!(msg, Message::Shutdown);
                    if let Err(e) = conn.write(&msg).await {
                        return format!("write failed: {e}");
                    }
                    if last {
                        drain(conn).await;
                        return "shut down".into();
                    }
                }
                None => {
                    // The scheduler dropped this worker.
                    let _ = conn.write(&Message::Shutdown).await;
                    drain(conn).await;
                    return "dropped by the scheduler".into();
                }
            },
            _ = beat.tick() => {
                if let Err(e) = conn.write(&Message::Heartbeat).await {
                    return format!("write failed: {e}");
                }
            }
            _ = sleep_until(last_heard + ctx.heartbeat_timeout) => {
                return format!("no heartbeat for {:?}", ctx.heartbeat_timeout);
            }
            read = conn.read() => {
                let msg = match read {
                    Err(e) => return format!("connection error: {e}"),
                    Ok(None) => return "disconnected".into(),
                    Ok(Some(m)) => m,
                };
                last_heard = Instant::now();
                let ev = match msg {
                    Message::Heartbeat => continue,
                    Message::Ready { job_id, build_s } => Event::Ready {
                        id,
                        job_id,
                        build_s,
                        job_to_ready_s: job_sent.elapsed().as_secs_f64(),
                    },
                    Message::TileResult { job_id, tile_id, attempt, pixels, stats, seconds } => {
                        Event::Result { id, job_id, tile_id, attempt, pixels, stats, seconds }
                    }
                    Message::Error { reason } => Event::WorkerError { id, reason },
                    other => {
                        let reason = format!("protocol violation: unexpected {}", other.kind());
                        info!(worker = id, %reason, "closing connection");
                        let _ = conn.write(&Message::Error { reason: reason.clone() }).await;
                        return reason;
                    }
                };
                if events.send(ev).is_err() {
                    return "scheduler finished".into();
                }
            }
        }
    }
}
