//! The emulated LAN of `parrt bench cluster`: a user-space relay on 127.0.0.1 between every
//! worker and the master. Each connection gets its own link (the worker's NIC: a bandwidth and
//! a one-way latency), and all of them share the master's link (its NIC, the bottleneck of a
//! master/worker render), one bucket per direction. A chunk read from one side is serialised
//! through the links it crosses (first in, first out, as a switch port would) and written to the
//! other side when it has crossed them plus the latency. One plain thread per connection waits
//! in `ppoll`, whose nanosecond timeout keeps sub-millisecond latencies that a millisecond
//! timer wheel would round up.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Bytes read at a time: about a dozen Ethernet frames, so store-and-forward of a chunk adds
/// little beyond what the link would.
const CHUNK: usize = 16 * 1024;
/// Stack of the relay threads (they hold a chunk and little else).
const STACK: usize = 256 * 1024;
/// Longest the relay waits to reach the master for one worker's connection. A master that
/// stopped accepting (it failed to start its workers, say) leaves connects unanswered for
/// minutes of SYN retries; bounded, the relay stops soon after it is dropped, and the worker, whose
/// connection is closed, dials again if the master is still there.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);

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
                    let Ok(master) = TcpStream::connect_timeout(&target, CONNECT_TIMEOUT) else {
                        continue;
                    };
                    if stop2.load(Ordering::Relaxed) {
                        break;
                    }
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

/// Relays one worker's connection on one thread: both directions, each through its links.
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
    let up = Direction::new(
        worker.try_clone()?,
        master.try_clone()?,
        [w_up, to_master.clone()],
    );
    let down = Direction::new(master, worker, [from_master.clone(), w_down]);
    let latency = p.latency;
    std::thread::Builder::new()
        .name("relay".into())
        .stack_size(STACK)
        .spawn(move || pump([up, down], latency))?;
    Ok(())
}

/// One direction of a relayed connection: `from` → links → latency → `to`.
struct Direction {
    from: TcpStream,
    to: TcpStream,
    links: [Arc<Bucket>; 2],
    /// Chunks read and not yet delivered, with when each is due at the far side.
    queue: VecDeque<(Instant, Vec<u8>)>,
    /// `from` has closed (or failed): once the queue drains, `to` is told so.
    ended: bool,
    /// `to` has been told, or cannot be written to any more.
    done: bool,
}

impl Direction {
    fn new(from: TcpStream, to: TcpStream, links: [Arc<Bucket>; 2]) -> Self {
        Direction {
            from,
            to,
            links,
            queue: VecDeque::new(),
            ended: false,
            done: false,
        }
    }

    /// Writes every chunk that is due; passes the end of stream on once all are written.
    fn deliver(&mut self, now: Instant) {
        while self.queue.front().is_some_and(|(due, _)| *due <= now) {
            if let Some((_, bytes)) = self.queue.pop_front() {
                if self.to.write_all(&bytes).is_err() {
                    self.queue.clear();
                    self.ended = true;
                }
            }
        }
        if self.ended && self.queue.is_empty() && !self.done {
            let _ = self.to.shutdown(Shutdown::Write);
            self.done = true;
        }
    }

    /// Reads what has arrived (the socket polled readable) and queues it through the links.
    fn take(&mut self, buf: &mut [u8], latency: Duration) {
        match self.from.read(buf) {
            Ok(0) | Err(_) => self.ended = true,
            Ok(n) => {
                let now = Instant::now();
                let crossed = self.links.iter().fold(now, |t, l| l.pass(t, n));
                self.queue.push_back((crossed + latency, buf[..n].to_vec()));
            }
        }
    }
}

/// The relay loop of one connection: deliver what is due, then wait (with `ppoll`'s
/// nanosecond timeout, so a 0.2 ms latency is kept) until a socket has bytes or the next chunk
/// is due. One thread and two wake-ups per chunk, where a reader and a writer thread per
/// direction cost four and a hand-over.
fn pump(mut dirs: [Direction; 2], latency: Duration) {
    // SAFETY: prctl with PR_SET_TIMERSLACK only sets this thread's timer slack (1 µs instead of
    // 50 µs), so a due chunk is delivered on time.
    unsafe {
        libc::prctl(libc::PR_SET_TIMERSLACK, 1000 as libc::c_ulong);
    }
    let mut buf = vec![0u8; CHUNK];
    loop {
        let now = Instant::now();
        for d in &mut dirs {
            d.deliver(now);
        }
        if dirs.iter().all(|d| d.done) {
            return;
        }
        let mut fds: Vec<libc::pollfd> = dirs
            .iter()
            .map(|d| libc::pollfd {
                fd: if d.ended { -1 } else { d.from.as_raw_fd() },
                events: libc::POLLIN,
                revents: 0,
            })
            .collect();
        let next_due = dirs
            .iter()
            .filter_map(|d| d.queue.front().map(|c| c.0))
            .min();
        let wait = next_due.map(|due| {
            let left = due.saturating_duration_since(Instant::now());
            libc::timespec {
                tv_sec: left.as_secs() as libc::time_t,
                tv_nsec: left.subsec_nanos() as libc::c_long,
            }
        });
        if next_due.is_none() && fds.iter().all(|f| f.fd < 0) {
            return; // Nothing to read and nothing to deliver.
        }
        let timeout = wait.as_ref().map_or(std::ptr::null(), |t| t as *const _);
        // SAFETY: `fds` is a live array of `fds.len()` pollfds and `timeout` is null or points
        // at a timespec that outlives the call; no signal mask is passed.
        let rc = unsafe {
            libc::ppoll(
                fds.as_mut_ptr(),
                fds.len() as libc::nfds_t,
                timeout,
                std::ptr::null(),
            )
        };
        if rc < 0 {
            if std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
                continue;
            }
            return;
        }
        for (d, f) in dirs.iter_mut().zip(&fds) {
            if f.fd >= 0 && f.revents != 0 {
                d.take(&mut buf, latency);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A master that stopped accepting (its listen queue full, so a connect
    /// waits through minutes of SYN retries) does not keep the dropped relay alive.
    #[test]
    fn dropping_the_relay_does_not_wait_on_a_master_that_never_answers() {
        use std::os::fd::FromRawFd;
        // A listener with the shortest queue, filled, that never accepts.
        // SAFETY: plain socket calls on a descriptor owned here, then by the TcpListener.
        let (listener, target) = unsafe {
            let fd = libc::socket(libc::AF_INET, libc::SOCK_STREAM, 0);
            assert!(fd >= 0);
            let mut a: libc::sockaddr_in = std::mem::zeroed();
            a.sin_family = libc::AF_INET as libc::sa_family_t;
            a.sin_addr.s_addr = u32::from_ne_bytes([127, 0, 0, 1]);
            let len = std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t;
            assert_eq!(
                libc::bind(fd, &a as *const _ as *const libc::sockaddr, len),
                0
            );
            assert_eq!(libc::listen(fd, 0), 0);
            let l = TcpListener::from_raw_fd(fd);
            let addr = l.local_addr().unwrap();
            (l, addr)
        };
        let mut fillers = Vec::new();
        while let Ok(c) = TcpStream::connect_timeout(&target, Duration::from_millis(300)) {
            fillers.push(c);
            assert!(fillers.len() < 64, "the queue never filled");
        }
        let relay = Relay::start(
            target,
            LinkParams {
                latency: Duration::ZERO,
                worker_bps: f64::INFINITY,
                master_bps: f64::INFINITY,
            },
        )
        .unwrap();
        let _worker = TcpStream::connect(relay.addr()).unwrap();
        std::thread::sleep(Duration::from_millis(100));
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            drop(relay);
            let _ = tx.send(());
        });
        // A hang guard, not a timing: unbounded, the relay's connect waited ~130 s.
        rx.recv_timeout(Duration::from_secs(30))
            .expect("dropping the relay waited on the master's connect");
        drop((listener, fillers));
    }

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
