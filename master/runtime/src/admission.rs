//! Who may hold a connection before authenticating, and for how long: the master's policy for
//! peers that have not yet proved the token. Every connection holds a slot of the connection
//! table; one still handshaking also holds a [`HandshakeSlot`] — at most [`MAX_HANDSHAKING`]
//! at once and [`MAX_HANDSHAKING_PER_PEER`] from one address. A peer that has taken a slot
//! without the token must not be able to keep an honest worker out, so (after OpenSSH's
//! `LoginGraceTime`, `MaxStartups` and `PerSourcePenalties`, and as the live view treats
//! connections that never sent a request):
//!
//! - **first bytes**: a peer must send its first handshake bytes within
//!   [`FIRST_BYTES_TIMEOUT`] (a worker sends its greeting as soon as it has connected), or it
//!   is dropped, long before the whole handshake's timeout;
//! - **eviction**: when a newcomer finds the budget (its address's or the whole) full, a
//!   pre-auth connection in that budget is closed to make room, rather than the newcomer being
//!   turned away: one that never sent a byte before one that did, and among those the one
//!   silent longest (since its last byte, or since it was accepted), provided it has been
//!   silent at least [`EVICT_AFTER`] (or half its first-bytes deadline, when a penalty made that
//!   shorter); with none that silent, the newcomer is turned away and
//!   dials again, so honest workers arriving together never close each other. A squatter that sends
//!   nothing always goes before a worker mid-handshake;
//! - **penalty**: an address whose pre-auth connections keep ending silent (dropped at the
//!   first-bytes deadline or evicted having sent nothing) gets a shorter first-bytes deadline,
//!   halved per strike down to [`MIN_FIRST_BYTES`]; strikes are forgotten after
//!   [`PENALTY_MEMORY`] without a new one. Connections are never refused for their address
//!   alone: an attacker may share it with honest workers (one NAT, one host).
//!
//! Time is tokio's clock, and every choice is made in a fixed order (by connection id), so a
//! run replays exactly under the deterministic simulation.

use parrt_protocol::limits::{MAX_HANDSHAKING, MAX_HANDSHAKING_PER_PEER};
use std::collections::{BTreeMap, HashMap};
use std::net::IpAddr;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::time::Instant;
use tokio_util::sync::CancellationToken;

/// How long a peer may take to send its first handshake bytes (an honest worker sends its
/// greeting as soon as its connection is made: one network delay).
pub const FIRST_BYTES_TIMEOUT: Duration = Duration::from_secs(2);

/// The shortest first-bytes deadline a penalised address gets (still many network delays).
pub const MIN_FIRST_BYTES: Duration = Duration::from_millis(250);

/// How long a pre-auth connection must have been silent before a newcomer may take its place.
/// Honest workers that arrive together (`render --workers 24`) are all fresh and are never
/// closed for each other: a newcomer that finds only fresh connections is turned away and
/// dials again, as before; a squatter's socket, held open to keep a slot, is silent far longer.
pub const EVICT_AFTER: Duration = Duration::from_millis(500);

/// A penalised address's strikes are forgotten after this long without a new one.
pub const PENALTY_MEMORY: Duration = Duration::from_secs(60);

/// Addresses whose strikes are remembered at once; past it the stalest is forgotten.
pub const MAX_PENALISED: usize = 4096;

/// Why a newcomer found no place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Turned {
    /// Every connection slot is held (by authenticated workers, mostly).
    Connections,
    /// The handshake budget is full of peers that made progress more recently than this one
    /// could be judged on (none to evict).
    Handshakes,
    /// The address's handshake budget is full of peers that made progress recently (none to
    /// evict).
    Address,
}

impl Turned {
    /// For the log.
    pub fn reason(self) -> &'static str {
        match self {
            Turned::Connections => "too many connections",
            Turned::Handshakes => "too many handshakes at once, none silent to close",
            Turned::Address => "too many handshakes from this address, none silent to close",
        }
    }
}

/// One pre-auth connection in the table.
#[derive(Debug)]
struct Pending {
    ip: IpAddr,
    /// Microseconds from the table's epoch to the peer's last byte (or its accept).
    progress: Arc<AtomicU64>,
    /// Whether any byte came.
    heard: Arc<AtomicU64>,
    /// Fired to evict it.
    evict: CancellationToken,
    /// Microseconds of silence after which a newcomer may take its place: [`EVICT_AFTER`], or
    /// half its first-bytes deadline when that is shorter (a penalised address's squatters are
    /// dropped at that deadline, and would otherwise never be evictable).
    grace: u64,
}

#[derive(Debug, Default)]
struct Strikes {
    count: u32,
    last: Option<Instant>,
}

#[derive(Debug)]
struct Table {
    epoch: Instant,
    next: u64,
    /// By admission order: the lowest id first when two are equally silent.
    pending: BTreeMap<u64, Pending>,
    penalties: HashMap<IpAddr, Strikes>,
    evicted: u64,
}

impl Table {
    fn micros(&self, t: Instant) -> u64 {
        t.saturating_duration_since(self.epoch).as_micros() as u64
    }

    /// How many pending (unauthenticated) connections come from `ip`.
    fn pending_from(&self, ip: IpAddr) -> usize {
        self.pending.values().filter(|p| p.ip == ip).count()
    }

    /// The id of the pending connection to evict (of `ip` only, if given): one that never sent
    /// a byte before one that did, then the longest silent, then the oldest.
    fn most_silent(&self, ip: Option<IpAddr>, now: u64) -> Option<u64> {
        self.pending
            .iter()
            .filter(|(_, p)| ip.is_none_or(|ip| p.ip == ip))
            .filter(|(_, p)| now.saturating_sub(p.progress.load(Ordering::Relaxed)) >= p.grace)
            .min_by_key(|(id, p)| {
                let heard = p.heard.load(Ordering::Relaxed) > 0;
                (heard, p.progress.load(Ordering::Relaxed), **id)
            })
            .map(|(id, _)| *id)
    }

    fn strike(&mut self, ip: IpAddr, now: Instant) {
        if !self.penalties.contains_key(&ip) && self.penalties.len() >= MAX_PENALISED {
            let stalest = self
                .penalties
                .iter()
                .min_by_key(|(a, s)| (s.last, **a))
                .map(|(a, _)| *a);
            if let Some(a) = stalest {
                self.penalties.remove(&a);
            }
        }
        let s = self.penalties.entry(ip).or_default();
        if s.last
            .is_some_and(|l| now.duration_since(l) > PENALTY_MEMORY)
        {
            s.count = 0;
        }
        s.count = s.count.saturating_add(1);
        s.last = Some(now);
    }

    fn first_bytes(&self, ip: IpAddr, now: Instant, base: Duration) -> Duration {
        let strikes = match self.penalties.get(&ip) {
            Some(s)
                if s.last
                    .is_some_and(|l| now.duration_since(l) <= PENALTY_MEMORY) =>
            {
                s.count
            }
            _ => 0,
        };
        (base / 2u32.pow(strikes.min(8))).max(MIN_FIRST_BYTES.min(base))
    }
}

/// The connection budgets of one master.
#[derive(Debug)]
pub struct Admission {
    total: Arc<Semaphore>,
    max_handshaking: usize,
    per_peer: usize,
    first_bytes: Duration,
    table: Arc<Mutex<Table>>,
}

impl Admission {
    /// Budgets for a table of `max_connections`, the first-bytes deadline no longer than the
    /// whole handshake's (`handshake_timeout`).
    pub fn new(max_connections: usize, handshake_timeout: Duration) -> Self {
        let max = max_connections.max(1);
        Admission {
            total: Arc::new(Semaphore::new(max)),
            max_handshaking: MAX_HANDSHAKING.min(max.div_ceil(2)),
            per_peer: MAX_HANDSHAKING_PER_PEER,
            first_bytes: FIRST_BYTES_TIMEOUT.min(handshake_timeout),
            table: Arc::new(Mutex::new(Table {
                epoch: Instant::now(),
                next: 0,
                pending: BTreeMap::new(),
                penalties: HashMap::new(),
                evicted: 0,
            })),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Table> {
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Pre-auth connections closed so far to make room for newcomers.
    pub fn evicted(&self) -> u64 {
        self.lock().evicted
    }

    /// Slots for a newcomer from `ip`: a connection slot and a handshake slot, making room by
    /// evicting the longest-silent pre-auth connection of the full budget; or why not.
    pub fn admit(&self, ip: IpAddr) -> Result<(OwnedSemaphorePermit, HandshakeSlot), Turned> {
        let now = Instant::now();
        let mut t = self.lock();
        let mut victims = Vec::new();
        let now_us = t.micros(now);
        let address_full = t.pending_from(ip) >= self.per_peer;
        if address_full || t.pending.len() >= self.max_handshaking {
            match t.most_silent(address_full.then_some(ip), now_us) {
                Some(v) => victims.push(v),
                None if address_full => return Err(Turned::Address),
                None => return Err(Turned::Handshakes),
            }
        }
        let Ok(total) = self.total.clone().try_acquire_owned() else {
            return Err(Turned::Connections);
        };
        for v in victims {
            if let Some(p) = t.pending.remove(&v) {
                if p.heard.load(Ordering::Relaxed) == 0 {
                    t.strike(p.ip, now);
                }
                t.evicted += 1;
                p.evict.cancel();
            }
        }
        let id = t.next;
        t.next += 1;
        let progress = Arc::new(AtomicU64::new(t.micros(now)));
        let heard = Arc::new(AtomicU64::new(0));
        let evict = CancellationToken::new();
        let first_bytes = t.first_bytes(ip, now, self.first_bytes);
        t.pending.insert(
            id,
            Pending {
                ip,
                progress: progress.clone(),
                heard: heard.clone(),
                evict: evict.clone(),
                grace: EVICT_AFTER.min(first_bytes / 2).as_micros() as u64,
            },
        );
        Ok((
            total,
            HandshakeSlot {
                id,
                ip,
                table: self.table.clone(),
                progress,
                heard,
                evict,
                first_bytes,
                epoch: t.epoch,
            },
        ))
    }
}

/// A peer's place in the handshake budget; given back on drop (or taken by eviction).
#[derive(Debug)]
pub struct HandshakeSlot {
    id: u64,
    ip: IpAddr,
    table: Arc<Mutex<Table>>,
    progress: Arc<AtomicU64>,
    heard: Arc<AtomicU64>,
    evict: CancellationToken,
    first_bytes: Duration,
    epoch: Instant,
}

impl HandshakeSlot {
    /// How long this peer has to send its first bytes (shorter for a penalised address).
    pub fn first_bytes(&self) -> Duration {
        self.first_bytes
    }

    /// Fired when the slot was taken for a newcomer.
    pub fn evicted(&self) -> &CancellationToken {
        &self.evict
    }

    /// Whether the peer has sent any byte.
    pub fn heard(&self) -> bool {
        self.heard.load(Ordering::Relaxed) > 0
    }

    /// `stream`, noting in this slot each time bytes arrive on it.
    pub fn watch<S>(&self, stream: S) -> Watched<S> {
        Watched {
            inner: stream,
            progress: self.progress.clone(),
            heard: self.heard.clone(),
            epoch: self.epoch,
        }
    }

    /// The peer sent nothing before its first-bytes deadline: a strike against its address.
    pub fn silent_timeout(&self) {
        let mut t = self.table.lock().unwrap_or_else(|e| e.into_inner());
        t.strike(self.ip, Instant::now());
    }
}

impl Drop for HandshakeSlot {
    fn drop(&mut self) {
        let mut t = self.table.lock().unwrap_or_else(|e| e.into_inner());
        t.pending.remove(&self.id);
    }
}

/// A stream that notes in its [`HandshakeSlot`] when bytes arrive (a relaxed atomic store a
/// read: nothing locked, nothing allocated).
#[derive(Debug)]
pub struct Watched<S> {
    inner: S,
    progress: Arc<AtomicU64>,
    heard: Arc<AtomicU64>,
    epoch: Instant,
}

impl<S: AsyncRead + Unpin> AsyncRead for Watched<S> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        let before = buf.filled().len();
        let r = Pin::new(&mut self.inner).poll_read(cx, buf);
        let got = buf.filled().len() - before;
        if got > 0 {
            let at = Instant::now()
                .saturating_duration_since(self.epoch)
                .as_micros() as u64;
            self.progress.store(at, Ordering::Relaxed);
            self.heard.fetch_add(got as u64, Ordering::Relaxed);
        }
        r
    }
}

impl<S: AsyncWrite + Unpin> AsyncWrite for Watched<S> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.inner).poll_write(cx, buf)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.inner).poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(last: u8) -> IpAddr {
        IpAddr::from([127, 0, 0, last])
    }

    #[tokio::test(start_paused = true)]
    async fn a_full_address_evicts_its_longest_silent_connection_not_the_newcomer() {
        let a = Admission::new(1024, Duration::from_secs(10));
        let mut squatters = Vec::new();
        for _ in 0..MAX_HANDSHAKING_PER_PEER {
            squatters.push(a.admit(ip(1)).expect("room"));
            tokio::time::advance(Duration::from_millis(10)).await;
        }
        // While every squatter is fresh, a newcomer is turned away (workers arriving together
        // never close each other) ...
        assert_eq!(a.admit(ip(1)).unwrap_err(), Turned::Address);
        assert!(squatters.iter().all(|(_, s)| !s.evicted().is_cancelled()));
        tokio::time::advance(EVICT_AFTER).await;
        // ... once they have been silent long enough, the worker gets in and the first
        // (longest silent) squatter is told to go.
        let (_p, worker) = a.admit(ip(1)).expect("the newcomer is admitted");
        assert!(squatters[0].1.evicted().is_cancelled());
        assert!(squatters[1..]
            .iter()
            .all(|(_, s)| !s.evicted().is_cancelled()));
        assert!(!worker.evicted().is_cancelled());
        assert_eq!(a.evicted(), 1);
        // A squatter evicted having sent nothing is a strike: the address's next peers get
        // half the first-bytes deadline.
        assert_eq!(worker.first_bytes(), FIRST_BYTES_TIMEOUT / 2);
        // Another address is not penalised.
        let (_q, other) = a.admit(ip(2)).unwrap();
        assert_eq!(other.first_bytes(), FIRST_BYTES_TIMEOUT);
    }

    #[tokio::test(start_paused = true)]
    async fn a_peer_that_sent_bytes_lately_is_evicted_after_the_silent_ones() {
        let a = Admission::new(1024, Duration::from_secs(10));
        let mut slots = Vec::new();
        for _ in 0..MAX_HANDSHAKING_PER_PEER {
            slots.push(a.admit(ip(1)).unwrap());
            tokio::time::advance(Duration::from_millis(10)).await;
        }
        // The oldest connection sends a byte now: it is no longer the most silent.
        let (mut near, mut far) = tokio::io::duplex(64);
        let mut watched = slots[0].1.watch(&mut far);
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        near.write_all(b"x").await.unwrap();
        let mut b = [0u8; 1];
        watched.read_exact(&mut b).await.unwrap();
        assert!(slots[0].1.heard());
        tokio::time::advance(EVICT_AFTER).await;
        let _n = a.admit(ip(1)).unwrap();
        assert!(!slots[0].1.evicted().is_cancelled());
        assert!(slots[1].1.evicted().is_cancelled());
    }

    #[tokio::test(start_paused = true)]
    async fn the_global_budget_evicts_across_addresses_and_penalties_fade() {
        let a = Admission::new(1024, Duration::from_secs(10));
        let mut slots = Vec::new();
        for k in 0..MAX_HANDSHAKING {
            slots.push(
                a.admit(ip(2 + (k / MAX_HANDSHAKING_PER_PEER) as u8))
                    .unwrap(),
            );
        }
        assert_eq!(a.admit(ip(1)).unwrap_err(), Turned::Handshakes);
        tokio::time::advance(EVICT_AFTER).await;
        let (_p, w) = a.admit(ip(1)).expect("room made for an address of its own");
        assert!(slots[0].1.evicted().is_cancelled());
        assert_eq!(w.first_bytes(), FIRST_BYTES_TIMEOUT);
        // Strikes shorten the deadline down to the floor, and are forgotten.
        for _ in 0..10 {
            slots[5].1.silent_timeout();
        }
        let (_q, s) = a.admit(ip(2)).unwrap();
        assert_eq!(s.first_bytes(), MIN_FIRST_BYTES);
        tokio::time::advance(PENALTY_MEMORY + Duration::from_secs(1)).await;
        drop(slots);
        let (_r, s) = a.admit(ip(2)).unwrap();
        assert_eq!(s.first_bytes(), FIRST_BYTES_TIMEOUT);
    }

    #[tokio::test(start_paused = true)]
    async fn a_penalised_address_squatters_are_evictable_before_their_deadline() {
        let a = Admission::new(1024, Duration::from_secs(10));
        let (_p, first) = a.admit(ip(1)).unwrap();
        for _ in 0..10 {
            first.silent_timeout();
        }
        drop(first);
        // Squatters from an address at the floor deadline are dropped after MIN_FIRST_BYTES,
        // sooner than EVICT_AFTER: were EVICT_AFTER their grace, they would reconnect fresh
        // and keep an honest newcomer from that address out for good.
        let mut squatters = Vec::new();
        for _ in 0..MAX_HANDSHAKING_PER_PEER {
            let (p, s) = a.admit(ip(1)).expect("room");
            assert_eq!(s.first_bytes(), MIN_FIRST_BYTES);
            squatters.push((p, s));
        }
        assert_eq!(a.admit(ip(1)).unwrap_err(), Turned::Address);
        tokio::time::advance(MIN_FIRST_BYTES / 2).await;
        let (_w, worker) = a.admit(ip(1)).expect("half the deadline is grace enough");
        assert!(squatters[0].1.evicted().is_cancelled());
        assert!(!worker.evicted().is_cancelled());
    }

    #[tokio::test(start_paused = true)]
    async fn a_full_connection_table_turns_the_newcomer_away() {
        // A table of 2: one may handshake at a time.
        let a = Admission::new(2, Duration::from_secs(10));
        let (_px, x) = a.admit(ip(1)).unwrap();
        tokio::time::advance(EVICT_AFTER).await;
        let (_py, y) = a.admit(ip(2)).expect("x is evicted for y");
        assert!(x.evicted().is_cancelled());
        // x's task has not ended yet (it holds its connection slot): no slot for z, and y
        // keeps its place, silent long enough to be evicted or not.
        assert_eq!(a.admit(ip(3)).unwrap_err(), Turned::Handshakes);
        tokio::time::advance(EVICT_AFTER).await;
        assert_eq!(a.admit(ip(3)).unwrap_err(), Turned::Connections);
        assert!(!y.evicted().is_cancelled());
    }
}
