//! What a peer can cost the master and a worker: a flood of refused handshakes leaves
//! the master's memory and log bounded, the reasons it keeps are cut; stalled handshakes cannot
//! keep an authenticated worker out; a worker with thousands of threads heartbeats before its
//! pool is built. Every peer is a raw client written with `parrt_protocol`, except the worker
//! under test itself.

use crate::peers::{hello, v1_hello_frame, welcome_one};
use crate::EXE;
use parrt_protocol::{Connection, Message, PROTOCOL_VERSION};
use parrt_tests::*;
use std::io::{BufRead, BufReader, Read};
use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::time::Duration;
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpSocket, TcpStream};
use tokio::time::timeout;
use tokio_util::either::Either;

fn vm_kib(pid: u32, field: &str) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix(field))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or_else(|| panic!("no {field} in /proc/{pid}/status"))
}

/// Item 1: 1 000 refused handshakes with 64 KiB names leave the master under 50 MB (peak
/// resident, from /proc) and write a bounded log; the record keeps a count and a small sample.
#[test]
fn refusal_flood_keeps_master_memory_and_log_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let mut master = ChildGuard(
        Command::new(EXE)
            .args([
                "master", "--scene", "mount:4", "--width", "32", "--height", "32", "--tile", "8",
            ])
            .args(["--listen", "127.0.0.1:0", "--wait-workers", "120", "-o"])
            .arg(dir.path().join("m.png"))
            .env("PARRT_TOKEN", TEST_TOKEN)
            .env("PARRT_LOG", "info")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start master"),
    );
    let mut err = BufReader::new(master.0.stderr.take().unwrap());
    let addr: SocketAddr = loop {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "master ended early");
        if let Some(rest) = line.split("listening on ").nth(1) {
            break rest
                .split(|c: char| c == ';' || c.is_whitespace())
                .next()
                .unwrap()
                .parse()
                .unwrap();
        }
    };
    // Keep reading the log (a full pipe would stall the master), counting its bytes.
    let log = std::thread::spawn(move || {
        let mut rest = Vec::new();
        let _ = err.read_to_end(&mut rest);
        rest
    });
    // As large as fits the 64 KiB handshake frame with the rest of a Hello.
    let name = vec![1u8; 65_400];
    let name_str = String::from_utf8(name.clone()).unwrap();
    let frames: Vec<Vec<u8>> = vec![
        // Version 1's Hello (no nonce): refused for its version.
        v1_hello_frame(1, &name, 1),
        // Our Hello of another version.
        frame(&Message::Hello {
            version: PROTOCOL_VERSION + 7,
            name: name_str.clone(),
            threads: 1,
            nonce: [0; 32],
            isa: parrt_render::isa::Isa::Scalar,
        })
        .to_vec(),
        // Our version, offering no threads.
        frame(&hello(&name_str, 0, [0; 32])).to_vec(),
    ];
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let mut tasks = Vec::new();
        for lane in 0..8usize {
            let frames = frames.clone();
            tasks.push(tokio::spawn(async move {
                for i in 0..125 {
                    let s = TcpStream::connect(addr).await.unwrap();
                    let k = (lane + i) % frames.len();
                    let f = &frames[k];
                    // Other versions are refused in clear, before the channel; our own
                    // version's Hello travels inside it.
                    let mut c = if k == 2 {
                        let mut c = Connection::new(Either::Right(secure_client(s).await), 1 << 20);
                        c.get_mut().write_all(f).await.unwrap();
                        c.get_mut().flush().await.unwrap();
                        c
                    } else {
                        let mut c = Connection::new(Either::Left(s), 1 << 20);
                        c.get_mut().write_all(f).await.unwrap();
                        c
                    };
                    // Refused with a reason (not merely turned away), then closed.
                    let got = timeout(Duration::from_secs(5), c.read()).await;
                    match got {
                        Ok(Ok(Some(Message::Refused { reason }))) => {
                            assert!(reason.len() < 400, "a {}-byte reason", reason.len())
                        }
                        other => panic!("expected Refused, got {other:?}"),
                    }
                    assert!(closed_within_5s(c.get_mut()).await, "refused peer closed");
                }
            }));
        }
        for t in tasks {
            t.await.unwrap();
        }
    });
    let pid = master.pid();
    let peak = vm_kib(pid, "VmHWM:");
    assert!(
        master.0.try_wait().unwrap().is_none(),
        "master still waits for workers"
    );
    master.signal("KILL");
    let _ = master.0.wait();
    let log = log.join().unwrap();
    eprintln!("master peak RSS {peak} KiB, log {} bytes", log.len());
    assert!(peak < 50 * 1024, "master peak RSS {peak} KiB");
    assert!(log.len() < 256 * 1024, "master log of {} bytes", log.len());
}

/// Item 1, in-process: the reasons kept show names escaped and cut.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn refused_names_are_shown_cut() {
    let desc = test_scene(16, 16);
    let m = start_master(&desc, &settings_for(&desc), &test_options(8)).await;
    let name = "\u{1}".repeat(60_000);
    let s = TcpStream::connect(m.addr).await.unwrap();
    let mut s = secure_client(s).await;
    s.write_all(&frame(&hello(&name, 0, [0; 32])))
        .await
        .unwrap();
    s.flush().await.unwrap();
    let mut c = Connection::new(s, 1 << 20);
    let Some(Message::Refused { reason }) = c.read().await.unwrap() else {
        panic!("not refused")
    };
    assert!(reason.len() < 400, "a {}-byte reason", reason.len());
    assert!(reason.contains("(60000 bytes)"), "{reason}");
    m.cancel.cancel();
    let _ = m.handle.await;
}

/// Item 2: 1 030 peers that send one byte and stall cannot keep an authenticated worker out:
/// handshakes have their own budget (and one address only part of it).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stalled_handshakes_do_not_turn_a_worker_away() {
    let desc = test_scene(32, 32);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let mut opts = test_options(8);
    opts.net.handshake_timeout = Duration::from_secs(60);
    let m = start_master(&desc, &settings, &opts).await;
    let mut stalled = Vec::new();
    for _ in 0..1030 {
        // From another loopback address than the worker's.
        let sock = TcpSocket::new_v4().unwrap();
        sock.bind("127.0.0.2:0".parse().unwrap()).unwrap();
        let mut s = sock.connect(m.addr).await.unwrap();
        let _ = s.write_all(&[0]).await;
        stalled.push(s);
    }
    let mut w = worker_options(m.addr, 1, "real");
    w.dial_timeout = Duration::from_secs(20);
    let summary = start_worker(w).await.unwrap().expect("the worker got in");
    assert!(summary.tiles_rendered > 0);
    let r = m.handle.await.unwrap().unwrap();
    assert_same_bits(&r.film, &reference, "despite stalled peers");
    drop(stalled);
}

/// Render threads of this process that exist now (rayon names them `parrt-render-N`).
fn render_threads() -> usize {
    std::fs::read_dir("/proc/self/task")
        .unwrap()
        .flatten()
        .filter(|t| {
            std::fs::read_to_string(t.path().join("comm"))
                .is_ok_and(|c| c.starts_with("parrt-render"))
        })
        .count()
}

/// Item 10: a worker with thousands of threads builds its pool off the runtime's thread: its
/// first heartbeat goes out while the pool is still being built (before, the loop started only
/// once every thread existed).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heartbeats_do_not_wait_for_a_big_pool() {
    const THREADS: usize = 2048;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let mut w = worker_options(listener.local_addr().unwrap(), THREADS, "wide");
    w.heartbeat = Duration::from_millis(20);
    let worker = start_worker(w);
    let mut c = welcome_one(&listener).await;
    let first = timeout(Duration::from_secs(60), c.read()).await.unwrap();
    let threads_then = render_threads();
    eprintln!("first heartbeat with {threads_then} of {THREADS} render threads started");
    assert_eq!(first.unwrap(), Some(Message::Heartbeat));
    assert!(
        threads_then < THREADS,
        "the first heartbeat waited for all {threads_then} threads"
    );
    c.write(&Message::Shutdown).await.unwrap();
    let s = worker.await.unwrap().unwrap();
    assert_eq!(s.end, parrt_worker::session::SessionEnd::Shutdown);
}
