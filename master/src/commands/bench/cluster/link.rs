//! The emulated LAN of `parrt bench cluster`: a user-space relay on 127.0.0.1 between every
//! worker and the master. Each connection gets its own link (the worker's NIC: a bandwidth and
//! a one-way latency), and all of them share the master's link (its NIC, the bottleneck of a
//! master/worker render), one bucket per direction. A chunk read from one side is serialised
//! through the links it crosses (first in, first out, as a switch port would) and written to the
//! other side when it has crossed them plus the latency. Plain threads with blocking sockets:
//! `std::thread::sleep` keeps sub-millisecond latencies that a millisecond timer wheel would
//! round up.

use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Bytes read at a time: about a dozen Ethernet frames, so store-and-forward of a chunk adds
/// little beyond what the link would.
const CHUNK: usize = 16 * 1024;
/// Stack of the relay threads (they hold a chunk and little else).
const STACK: usize = 256 * 1024;

/// The emulated network.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkParams {
    /// One-way latency added to every byte.
    pub latency: Duration,
    /// Each worker's link, bytes per second (infinity: unlimited).
    pub worker_bps: f64,
    /// The master's link, shared by all workers, bytes per second per direction.
    pub master_bps: f64,
}

/// A link's queue: when it will have sent everything handed to it so far.
#[derive(Debug)]
struct Bucket {
    bps: f64,
    free_at: Mutex<Option<Instant>>,
}

impl Bucket {
    fn new(bps: f64) -> Arc<Bucket> {
        Arc::new(Bucket {
            bps,
            free_at: Mutex::new(None),
        })
    }

    /// Queues `bytes` arriving at `at`; returns when their last byte has left.
    fn pass(&self, at: Instant, bytes: usize) -> Instant {
        if !(self.bps.is_finite() && self.bps > 0.0) {
            return at;
        }
        let mut free = self.free_at.lock().unwrap_or_else(|e| e.into_inner());
        let start = free.map_or(at, |f| f.max(at));
        let done = start + Duration::from_secs_f64(bytes as f64 / self.bps);
        *free = Some(done);
        done
    }
}

/// A running relay; dropping it closes every relayed connection and stops accepting.
pub struct Relay {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    sockets: Arc<Mutex<Vec<TcpStream>>>,
    accept: Option<JoinHandle<()>>,
}

impl Relay {
    /// Listens on 127.0.0.1 (a free port) and relays every connection to `target` through
    /// the emulated links.
    pub fn start(target: SocketAddr, p: LinkParams) -> std::io::Result<Relay> {
        let listener = TcpListener::bind("127.0.0.1:0")?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let sockets = Arc::new(Mutex::new(Vec::new()));
        let (up, down) = (Bucket::new(p.master_bps), Bucket::new(p.master_bps));
        let (stop2, sockets2) = (stop.clone(), sockets.clone());
        let accept = std::thread::Builder::new()
            .name("relay-accept".into())
            .stack_size(STACK)
            .spawn(move || {
                for conn in listener.incoming() {
                    if stop2.load(Ordering::Relaxed) {
                        break;
                    }
                    let Ok(worker) = conn else { continue };
                    let Ok(master) = TcpStream::connect(target) else {
                        continue;
                    };
                    if let Err(e) = connect(worker, master, &p, &up, &down, &sockets2) {
                        tracing::warn!(error = %e, "relay: cannot relay a connection");
                    }
                }
            })?;
        Ok(Relay {
            addr,
            stop,
            sockets,
            accept: Some(accept),
        })
    }

    /// Where workers should dial.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // Wake the accept loop so it sees the flag.
        let _ = TcpStream::connect(self.addr);
        if let Some(h) = self.accept.take() {
            let _ = h.join();
        }
        for s in self
            .sockets
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
        {
            let _ = s.shutdown(Shutdown::Both);
        }
    }
}

/// Relays one worker's connection: two directions, each a reader and a writer thread.
fn connect(
    worker: TcpStream,
    master: TcpStream,
    p: &LinkParams,
    to_master: &Arc<Bucket>,
    from_master: &Arc<Bucket>,
    sockets: &Mutex<Vec<TcpStream>>,
) -> std::io::Result<()> {
    worker.set_nodelay(true)?;
    master.set_nodelay(true)?;
    {
        let mut all = sockets.lock().unwrap_or_else(|e| e.into_inner());
        all.push(worker.try_clone()?);
        all.push(master.try_clone()?);
    }
    // The worker's own link, one bucket per direction (full duplex).
    let (w_up, w_down) = (Bucket::new(p.worker_bps), Bucket::new(p.worker_bps));
    direction(
        worker.try_clone()?,
        master.try_clone()?,
        [w_up, to_master.clone()],
        p.latency,
    )?;
    direction(master, worker, [from_master.clone(), w_down], p.latency)
}

/// One direction: `from` → links → latency → `to`.
fn direction(
    mut from: TcpStream,
    mut to: TcpStream,
    links: [Arc<Bucket>; 2],
    latency: Duration,
) -> std::io::Result<()> {
    let (tx, rx) = mpsc::channel::<(Instant, Vec<u8>)>();
    std::thread::Builder::new()
        .name("relay-read".into())
        .stack_size(STACK)
        .spawn(move || {
            let mut buf = vec![0u8; CHUNK];
            loop {
                let n = match from.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => n,
                };
                let now = Instant::now();
                let crossed = links.iter().fold(now, |t, l| l.pass(t, n));
                if tx.send((crossed + latency, buf[..n].to_vec())).is_err() {
                    break;
                }
            }
            // Dropping `tx` lets the writer drain and pass the end of stream on.
        })?;
    std::thread::Builder::new()
        .name("relay-write".into())
        .stack_size(STACK)
        .spawn(move || {
            for (due, bytes) in rx {
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                }
                if to.write_all(&bytes).is_err() {
                    break;
                }
            }
            let _ = to.shutdown(Shutdown::Write);
        })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relays_both_ways_with_latency_and_bandwidth() {
        let server = TcpListener::bind("127.0.0.1:0").unwrap();
        let target = server.local_addr().unwrap();
        let echo = std::thread::spawn(move || {
            let (mut s, _) = server.accept().unwrap();
            let mut buf = vec![0u8; 100_000];
            s.read_exact(&mut buf).unwrap();
            s.write_all(&buf).unwrap();
        });
        let relay = Relay::start(
            target,
            LinkParams {
                latency: Duration::from_millis(20),
                worker_bps: f64::INFINITY,
                master_bps: 1e6,
            },
        )
        .unwrap();
        let mut c = TcpStream::connect(relay.addr()).unwrap();
        let data: Vec<u8> = (0..100_000u32).map(|i| (i % 251) as u8).collect();
        let t0 = Instant::now();
        c.write_all(&data).unwrap();
        let mut back = vec![0u8; data.len()];
        c.read_exact(&mut back).unwrap();
        // 100 kB each way at 1 MB/s plus two latencies: at least 0.24 s.
        assert!(
            t0.elapsed() >= Duration::from_millis(240),
            "{:?}",
            t0.elapsed()
        );
        assert_eq!(back, data);
        echo.join().unwrap();
        drop(relay);
    }
}
