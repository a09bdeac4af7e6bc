//! Who keeps a connection and an event stream when there are too many: the live view's
//! admission, so that nobody, token or not, can shut the real pages (or, by taking every
//! descriptor, the render's workers) out. It never refuses a newcomer and never blocks:
//! - at most [`MAX_CONNECTIONS`](super::limits::MAX_CONNECTIONS) connections are open. A new
//!   one past the cap closes the oldest connection that never had a request allowed (one still
//!   sending its head, or one that was only told 401); only when every open connection has
//!   been served does it close the oldest served one that carries no event stream. Slots are
//!   so kept for the connections that proved they may see the view.
//! - at most [`MAX_STREAMS`](super::limits::MAX_STREAMS) event streams are open. A new one past
//!   the cap closes the connection of the stream that took an event least recently (a stuck
//!   page's first; the oldest among equals), so a page is never refused a stream.
//!
//! The connection's task holds its [`Ticket`] (dropped when it ends) and waits on
//! [`Ticket::closed`]; the requests on it carry a [`Conn`] (in their extensions) through which
//! the handlers tell the gate what the connection is used for.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tokio_util::sync::CancellationToken;

/// The open connections and what they are used for.
pub struct Gate {
    max_connections: usize,
    max_streams: usize,
    inner: Mutex<Inner>,
}

struct Inner {
    /// The next connection's number (so the map's order is the order they opened in).
    next: u64,
    open: BTreeMap<u64, Entry>,
    streams: usize,
}

struct Entry {
    /// A request on it was allowed (it is no longer the first to go).
    served: bool,
    /// It carries an event stream that last took an event at this moment.
    stream: Option<Instant>,
    close: CancellationToken,
}

/// A connection's place in the [`Gate`], held by the connection's task: dropping it frees the
/// place.
pub struct Ticket {
    conn: Conn,
    close: CancellationToken,
}

/// A handle on one connection's place, for its requests' handlers.
#[derive(Clone)]
pub struct Conn {
    gate: Arc<Gate>,
    id: u64,
}

/// An event stream's place in the [`Gate`]; dropping it frees the place.
pub struct StreamSlot {
    conn: Conn,
}

impl Gate {
    /// A gate of at most `max_connections` connections, of which at most `max_streams` carry
    /// an event stream (`max_streams` < `max_connections`).
    pub fn new(max_connections: usize, max_streams: usize) -> Arc<Self> {
        Arc::new(Gate {
            max_connections: max_connections.max(1),
            max_streams: max_streams.clamp(1, max_connections.max(2) - 1),
            inner: Mutex::new(Inner {
                next: 0,
                open: BTreeMap::new(),
                streams: 0,
            }),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A place for a connection just accepted, made by closing another when all are taken (see
    /// the module's doc); `None` only if none can be closed for it.
    pub fn admit(self: &Arc<Self>) -> Option<Ticket> {
        let mut i = self.lock();
        if i.open.len() >= self.max_connections {
            let victim = i
                .open
                .iter()
                .find(|(_, e)| !e.served)
                .or_else(|| i.open.iter().find(|(_, e)| e.stream.is_none()))
                .map(|(id, _)| *id)?;
            if let Some(e) = i.open.remove(&victim) {
                e.close.cancel();
            }
        }
        let id = i.next;
        i.next += 1;
        let close = CancellationToken::new();
        i.open.insert(
            id,
            Entry {
                served: false,
                stream: None,
                close: close.clone(),
            },
        );
        Some(Ticket {
            conn: Conn {
                gate: self.clone(),
                id,
            },
            close,
        })
    }

    /// Connections open, and how many of them carry an event stream.
    pub fn counts(&self) -> (usize, usize) {
        let i = self.lock();
        (i.open.len(), i.streams)
    }
}

impl Ticket {
    /// The handle its requests carry.
    pub fn conn(&self) -> Conn {
        self.conn.clone()
    }

    /// Completes when the gate closed this connection for another.
    pub async fn closed(&self) {
        self.close.cancelled().await
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        let mut i = self.conn.gate.lock();
        if let Some(e) = i.open.remove(&self.conn.id) {
            if e.stream.is_some() {
                i.streams -= 1;
            }
        }
    }
}

impl Conn {
    /// A request on this connection was allowed: it is no longer among the first to go.
    pub fn served(&self) {
        if let Some(e) = self.gate.lock().open.get_mut(&self.id) {
            e.served = true;
        }
    }

    /// This connection now carries an event stream; past the cap, the connection of the stream
    /// that took an event least recently is closed for it. `None` if this connection is
    /// already closed.
    pub fn open_stream(&self) -> Option<StreamSlot> {
        let mut i = self.gate.lock();
        let now = Instant::now();
        let e = i.open.get(&self.id)?;
        if e.stream.is_some() {
            return None;
        }
        if i.streams >= self.gate.max_streams {
            let victim = i
                .open
                .iter()
                .filter_map(|(id, e)| e.stream.map(|t| (t, *id)))
                .min()
                .map(|(_, id)| id);
            if let Some(e) = victim.and_then(|v| i.open.get_mut(&v)) {
                e.stream = None;
                e.close.cancel();
                i.streams -= 1;
            }
        }
        i.streams += 1;
        if let Some(e) = i.open.get_mut(&self.id) {
            e.stream = Some(now);
        }
        Some(StreamSlot { conn: self.clone() })
    }
}

impl StreamSlot {
    /// The stream took an event (its client is reading, or its socket still has room).
    pub fn took(&self) {
        if let Some(e) = self.conn.gate.lock().open.get_mut(&self.conn.id) {
            if e.stream.is_some() {
                e.stream = Some(Instant::now());
            }
        }
    }
}

impl Drop for StreamSlot {
    fn drop(&mut self) {
        let mut i = self.conn.gate.lock();
        let was = i
            .open
            .get_mut(&self.conn.id)
            .and_then(|e| e.stream.take())
            .is_some();
        if was {
            i.streams -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_closed(t: &Ticket) -> bool {
        t.close.is_cancelled()
    }

    #[test]
    fn a_newcomer_past_the_cap_closes_the_oldest_unserved_connection() {
        let gate = Gate::new(3, 1);
        let a = gate.admit().expect("a");
        let b = gate.admit().expect("b");
        let c = gate.admit().expect("c");
        a.conn().served();
        let d = gate.admit().expect("d");
        assert!(!is_closed(&a), "served: kept");
        assert!(is_closed(&b), "the oldest never served goes first");
        assert!(!is_closed(&c) && !is_closed(&d));
        assert_eq!(gate.counts(), (3, 0));
        drop(b);
        assert_eq!(
            gate.counts(),
            (3, 0),
            "a closed ticket's place was already freed"
        );
        drop(c);
        assert_eq!(gate.counts(), (2, 0));
    }

    #[test]
    fn when_all_were_served_the_oldest_without_a_stream_goes() {
        let gate = Gate::new(3, 2);
        let a = gate.admit().expect("a");
        let b = gate.admit().expect("b");
        let c = gate.admit().expect("c");
        for t in [&a, &b, &c] {
            t.conn().served();
        }
        let _s = a.conn().open_stream().expect("a stream");
        let _d = gate.admit().expect("d");
        assert!(!is_closed(&a), "streams are not closed for connections");
        assert!(is_closed(&b));
        assert!(!is_closed(&c));
    }

    #[test]
    fn a_stream_past_the_cap_closes_the_one_that_took_an_event_least_recently() {
        let gate = Gate::new(10, 2);
        let t: Vec<Ticket> = (0..3).map(|_| gate.admit().expect("admitted")).collect();
        let s0 = t[0].conn().open_stream().expect("0");
        let s1 = t[1].conn().open_stream().expect("1");
        std::thread::sleep(std::time::Duration::from_millis(2));
        s0.took();
        // 1 is stuck: it has taken nothing since it opened, 0 took an event since.
        let s2 = t[2].conn().open_stream().expect("2 is never refused");
        assert!(is_closed(&t[1]) && !is_closed(&t[0]) && !is_closed(&t[2]));
        assert_eq!(gate.counts(), (3, 2));
        drop(s1);
        assert_eq!(
            gate.counts(),
            (3, 2),
            "the closed stream was counted out once"
        );
        drop((s0, s2));
        assert_eq!(gate.counts(), (3, 0));
        assert!(t[0].conn().open_stream().is_some(), "a slot again");
    }
}
