//! Hostile peers (issue 20): a master facing floods of refused or stalled handshakes, lying or
//! oversized frames and slow senders, and a worker facing a peer without the token, a master
//! that stops reading, trickles its job or cuts the handshake. Every peer here is a raw client
//! (or raw fake master) written with `parrt::protocol`, never a real worker, except the worker
//! under test itself.

use bytes::BytesMut;
use parrt::protocol::codec::MessageCodec;
use parrt::protocol::limits::{self, MAX_THREADS};
use parrt::protocol::{Connection, JobSpec, Message, Token, PROTOCOL_VERSION};
use parrt::tile::Tile;
use parrt_tests::*;
use parrt_worker::WorkerError;
use std::io::{BufRead, BufReader, Read};
use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpSocket, TcpStream};
use tokio::time::{sleep, timeout};
use tokio_util::codec::Decoder;

const EXE: &str = env!("CARGO_BIN_EXE_parrt-cli");

fn hello(name: &str, threads: u32, nonce: [u8; 32]) -> Message {
    Message::Hello {
        version: PROTOCOL_VERSION,
        name: name.into(),
        threads,
        nonce,
    }
}

/// A frame holding a version-1 Hello (no nonce): variant 0, version, name, threads.
fn v1_hello_frame(version: u32, name: &[u8], threads: u32) -> Vec<u8> {
    fn varint(mut v: u64, out: &mut Vec<u8>) {
        loop {
            let b = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                out.push(b);
                return;
            }
            out.push(b | 0x80);
        }
    }
    let mut p = vec![0u8];
    varint(version.into(), &mut p);
    varint(name.len() as u64, &mut p);
    p.extend_from_slice(name);
    varint(threads.into(), &mut p);
    let mut f = (p.len() as u32).to_be_bytes().to_vec();
    f.extend(p);
    f
}

/// A raw client through the whole handshake with the test token: Welcome received.
async fn authenticate(addr: SocketAddr, name: &str, threads: u32) -> Connection {
    let s = TcpStream::connect(addr).await.unwrap();
    let mut c = Connection::new(s, 1 << 28);
    let ours = [0x5a; 32];
    c.write(&hello(name, threads, ours)).await.unwrap();
    let Some(Message::Challenge { nonce, proof }) = c.read().await.unwrap() else {
        panic!("no challenge")
    };
    assert!(token().verify_master_proof(&ours, &nonce, &proof));
    c.write(&Message::Auth {
        mac: token().worker_proof(&nonce, &ours),
    })
    .await
    .unwrap();
    assert_eq!(c.read().await.unwrap(), Some(Message::Welcome));
    c
}

/// A raw fake master with the test token: accepts one worker and welcomes it.
async fn welcome_one(listener: &TcpListener) -> Connection {
    let (s, _) = listener.accept().await.unwrap();
    let mut c = Connection::new(s, 1 << 20);
    let Some(Message::Hello { nonce: theirs, .. }) = c.read().await.unwrap() else {
        panic!("no hello")
    };
    let nonce = [0x33; 32];
    let proof = token().master_proof(&theirs, &nonce);
    c.write(&Message::Challenge { nonce, proof }).await.unwrap();
    let Some(Message::Auth { mac }) = c.read().await.unwrap() else {
        panic!("no auth")
    };
    assert!(token().verify_worker_proof(&nonce, &theirs, &mac));
    c.write(&Message::Welcome).await.unwrap();
    c
}

fn job(width: u32, height: u32, tile: u32) -> Message {
    let desc = test_scene(width, height);
    let settings = settings_for(&desc);
    Message::Job(Box::new(JobSpec {
        job_id: 7,
        scene: desc,
        settings,
        tile_size: tile,
        pixel_format: Default::default(),
    }))
}

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
                    let mut c = Connection::new(s, 1 << 20);
                    let f = &frames[(lane + i) % frames.len()];
                    c.get_mut().write_all(f).await.unwrap();
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
    let mut s = TcpStream::connect(m.addr).await.unwrap();
    s.write_all(&frame(&hello(&name, 0, [0; 32])))
        .await
        .unwrap();
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

/// Item 2: a worker whose handshake is cut (the master's table full) dials again within its
/// budget; a refusal ends it at once, without another attempt.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cut_handshake_is_retried_but_a_refusal_is_not() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let mut w = worker_options(addr, 1, "w");
    w.dial_timeout = Duration::from_secs(10);
    let worker = start_worker(w);
    let serve = async {
        for _ in 0..2 {
            // Accepted and closed at once, as a full table does.
            drop(listener.accept().await.unwrap());
        }
        let mut c = welcome_one(&listener).await;
        c.write(&Message::Shutdown).await.unwrap();
        c
    };
    // Without retries the worker never comes back: give up rather than hang.
    let c = timeout(Duration::from_secs(10), serve).await;
    let s = worker
        .await
        .unwrap()
        .expect("retried after the cut handshakes");
    assert_eq!(s.end, parrt_worker::session::SessionEnd::Shutdown);
    drop(c);

    let worker = start_worker(worker_options(addr, 1, "w"));
    let (s, _) = listener.accept().await.unwrap();
    let mut c = Connection::new(s, 1 << 20);
    assert!(matches!(
        c.read().await.unwrap(),
        Some(Message::Hello { .. })
    ));
    c.write(&Message::Refused {
        reason: "go away".into(),
    })
    .await
    .unwrap();
    drop(c);
    match worker.await.unwrap() {
        Err(WorkerError::Refused(r)) => assert_eq!(r, "go away"),
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert!(
        timeout(Duration::from_millis(500), listener.accept())
            .await
            .is_err(),
        "a refused worker dialled again"
    );
}

/// Item 3: a peer without the token that a worker dials gets no MAC: the worker checks the
/// master's proof over its own nonce first, and stops with a clear error.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_answers_no_peer_that_cannot_prove_the_token() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let worker = start_worker(worker_options(addr, 1, "w"));
    let (s, _) = listener.accept().await.unwrap();
    let mut c = Connection::new(s, 1 << 20);
    let Some(Message::Hello { nonce: theirs, .. }) = c.read().await.unwrap() else {
        panic!("no hello")
    };
    // A squatter relaying some master's nonce, with a proof it cannot make.
    let nonce = [9u8; 32];
    let proof = Token::new("a guess").unwrap().master_proof(&theirs, &nonce);
    c.write(&Message::Challenge { nonce, proof }).await.unwrap();
    let mut after = Vec::new();
    while let Ok(Some(m)) = c.read().await {
        after.push(m.kind());
    }
    assert!(after.is_empty(), "the worker sent {after:?}");
    let err = worker.await.unwrap().unwrap_err();
    assert!(matches!(err, WorkerError::MasterUnproven(_)), "{err}");
    assert!(err.to_string().contains("did not prove"), "{err}");
}

/// Item 3: the master proves the token over the worker's nonce and its own; the proof is
/// bound to both, and the worker's MAC is not the master's.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn master_proves_the_token_bound_to_both_nonces() {
    let desc = test_scene(16, 16);
    let m = start_master(&desc, &settings_for(&desc), &test_options(8)).await;
    let mut proofs = Vec::new();
    for ours in [[1u8; 32], [2u8; 32]] {
        let s = TcpStream::connect(m.addr).await.unwrap();
        let mut c = Connection::new(s, 1 << 20);
        c.write(&hello("prober", 1, ours)).await.unwrap();
        let Some(Message::Challenge { nonce, proof }) = c.read().await.unwrap() else {
            panic!("no challenge")
        };
        assert!(token().verify_master_proof(&ours, &nonce, &proof));
        assert!(!token().verify_master_proof(&[3u8; 32], &nonce, &proof));
        // Echoing the master's proof as our MAC is refused.
        c.write(&Message::Auth {
            mac: proof.to_vec(),
        })
        .await
        .unwrap();
        match c.read().await.unwrap() {
            Some(Message::Refused { reason }) => assert!(reason.contains("wrong token")),
            other => panic!("expected Refused, got {other:?}"),
        }
        proofs.push((nonce, proof));
    }
    assert_ne!(proofs[0].0, proofs[1].0, "fresh master nonces");
    // A Hello of version 1 (no nonce) is refused with its version.
    let mut s = TcpStream::connect(m.addr).await.unwrap();
    s.write_all(&v1_hello_frame(1, b"old", 1)).await.unwrap();
    let mut c = Connection::new(s, 1 << 20);
    match c.read().await.unwrap() {
        Some(Message::Refused { reason }) => {
            assert!(reason.contains("protocol version 1"), "{reason}")
        }
        other => panic!("expected Refused, got {other:?}"),
    }
    m.cancel.cancel();
    let _ = m.handle.await;
}

/// Item 10: a Hello claiming more than MAX_THREADS threads is refused (it would take every
/// tile); the worker CLI refuses such a --threads with exit 2.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn too_many_threads_are_refused() {
    let desc = test_scene(16, 16);
    let m = start_master(&desc, &settings_for(&desc), &test_options(8)).await;
    for threads in [MAX_THREADS + 1, u32::MAX] {
        let s = TcpStream::connect(m.addr).await.unwrap();
        let mut c = Connection::new(s, 1 << 20);
        c.write(&hello("greedy", threads, [1; 32])).await.unwrap();
        match c.read().await.unwrap() {
            Some(Message::Refused { reason }) => assert!(reason.contains("threads"), "{reason}"),
            other => panic!("expected Refused, got {other:?}"),
        }
    }
    drop(authenticate(m.addr, "ok", MAX_THREADS).await);
    m.cancel.cancel();
    let _ = m.handle.await;

    let out = Command::new(EXE)
        .args(["worker", "--connect", "127.0.0.1:9", "--threads", "100000"])
        .env("PARRT_TOKEN", "t")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--threads"));
}

/// "Also": an address that does not parse or resolve, or an absurd --dial-timeout, fails at
/// once with exit 2 (no retries, no panic).
#[test]
fn worker_flags_fail_at_once_with_exit_2() {
    for args in [
        vec!["--connect", "nothing"],
        vec!["--connect", "127.0.0.1:1", "--dial-timeout", "1e30"],
    ] {
        let out = Command::new(EXE)
            .arg("worker")
            .args(&args)
            .env("PARRT_TOKEN", "t")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(err.contains(args[args.len() - 2]), "{args:?}: {err}");
    }
}

/// Item 11: a master that stops reading cannot hang a worker: its writes give up after the
/// master timeout and it ends with a clear error, even while the master still sends heartbeats.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_gives_up_on_a_master_that_stops_reading() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let mut w = worker_options(addr, 2, "w");
    w.master_timeout = Duration::from_secs(2);
    let worker = start_worker(w);
    let mut c = welcome_one(&listener).await;
    c.write(&job(128, 128, 128)).await.unwrap();
    // 200 results of 196 KB: far more than the socket buffers hold.
    for attempt in 1..=200 {
        c.write(&Message::Assign {
            job_id: 7,
            tile: Tile {
                id: 0,
                x: 0,
                y: 0,
                w: 128,
                h: 128,
            },
            attempt,
        })
        .await
        .unwrap();
    }
    // Now never read, but keep beating: the worker cannot take the master for silent (as it
    // would if filling the socket buffers took longer than the timeout on a loaded machine),
    // so only its stalled writes can end it.
    let (_unread, mut w) = c.into_inner().into_split();
    let beats = tokio::spawn(async move {
        while w.write_all(&frame(&Message::Heartbeat)).await.is_ok() {
            sleep(Duration::from_millis(100)).await;
        }
    });
    let ended = timeout(Duration::from_secs(60), worker).await;
    beats.abort();
    let err = ended
        .expect("the worker hung on a master that stopped reading")
        .unwrap()
        .unwrap_err();
    assert!(matches!(err, WorkerError::MasterNotReading(_)), "{err}");
}

/// Reads frames from a raw read half until `want` arrives; false on close or error.
async fn read_until(
    r: &mut tokio::net::tcp::OwnedReadHalf,
    want: fn(&Message) -> bool,
) -> Option<Message> {
    let mut codec = MessageCodec::new(1 << 28);
    let mut buf = BytesMut::new();
    loop {
        while let Ok(Some(m)) = codec.decode(&mut buf) {
            if want(&m) {
                return Some(m);
            }
        }
        let mut chunk = [0u8; 8192];
        match r.read(&mut chunk).await {
            Ok(0) | Err(_) => return None,
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
        }
    }
}

/// A job of about `bytes` bytes: the test scene with extra small spheres.
fn big_job(bytes: usize) -> Message {
    let mut desc = test_scene(16, 16);
    let extra = desc.primitives[1].clone();
    while frame(&Message::Job(Box::new(JobSpec {
        job_id: 7,
        scene: desc.clone(),
        settings: settings_for(&desc),
        tile_size: 8,
        pixel_format: Default::default(),
    })))
    .len()
        < bytes
    {
        for _ in 0..100 {
            desc.primitives.push(extra.clone());
        }
    }
    let settings = settings_for(&desc);
    Message::Job(Box::new(JobSpec {
        job_id: 7,
        scene: desc,
        settings,
        tile_size: 8,
        pixel_format: Default::default(),
    }))
}

/// Item 12: a job trickling in at 320 KB/s, slower than the 1 s master timeout allows for a
/// whole message but above the floor rate, is received; one below the floor is dropped.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_takes_a_slow_job_but_not_a_stalled_one() {
    // Taken: 600 KB in 32 KB chunks every 100 ms, at least 1.9 s (past the timeout) against
    // the 1 s + 9.4 s the floor rate allows: over 5 times as slow still passes. Dropped: 300 KB
    // at 10 KB/s, allowed 1 s + 4.7 s, which it would take 30 s to send.
    for (size, chunk, pause_ms, accepted) in [
        (600 * 1024, 32 * 1024, 100, true),
        (300 * 1024, 1024, 100, false),
    ] {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let mut w = worker_options(addr, 1, "w");
        w.master_timeout = Duration::from_secs(1);
        let worker = start_worker(w);
        let c = welcome_one(&listener).await;
        let (mut r, mut wr) = c.into_inner().into_split();
        let bytes = frame(&big_job(size));
        let began = std::time::Instant::now();
        let trickle = tokio::spawn(async move {
            for part in bytes.chunks(chunk) {
                if wr.write_all(part).await.is_err() {
                    return false;
                }
                sleep(Duration::from_millis(pause_ms)).await;
            }
            // Keep the line alive (heartbeats) until the test is done.
            for _ in 0..50 {
                if wr.write_all(&frame(&Message::Heartbeat)).await.is_err() {
                    return true;
                }
                sleep(Duration::from_millis(100)).await;
            }
            true
        });
        let ready = read_until(&mut r, |m| matches!(m, Message::Ready { .. })).await;
        if accepted {
            let took = began.elapsed();
            if ready.is_none() {
                let why = match timeout(Duration::from_secs(5), worker).await {
                    Ok(Ok(Err(e))) => format!("the worker failed: {e}"),
                    other => format!("the worker: {other:?}"),
                };
                panic!("the slow job was dropped after {took:?}; {why}");
            }
            assert!(
                took > Duration::from_secs(1),
                "the job took {took:?}, not longer than the timeout: nothing was tested"
            );
            drop(r);
            trickle.abort();
            let _ = worker.await;
        } else {
            assert!(ready.is_none(), "a stalled frame was waited for");
            let err = worker.await.unwrap().unwrap_err();
            assert!(matches!(err, WorkerError::MasterSilent(_)), "{err}");
            trickle.abort();
        }
    }
}

/// Item 12, master side: a result trickling in slower than the heartbeat timeout allows for a
/// whole message, but above the floor rate, is taken.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn master_takes_a_slow_result() {
    // One 256 x 256 tile: a 786 KB result, so the floor rate allows it 3 s + 12 s, and the
    // trickle below (at least 4.8 s, 160 KB/s, a chunk every 100 ms) stays far inside that
    // even when the tests beside it slow this one several times over.
    let desc = test_scene(256, 256);
    let settings = settings_for(&desc);
    let mut opts = test_options(256);
    // Short enough that the trickle outlasts it; long enough that a stall of this test, run
    // beside others that load the machine, does not read as a silent worker.
    opts.net.heartbeat_timeout = Duration::from_secs(3);
    opts.schedule.wait_workers = Duration::from_secs(8);
    opts.schedule.backups = false;
    let m = start_master(&desc, &settings, &opts).await;
    let mut c = authenticate(m.addr, "slow", 1).await;
    let Some(Message::Job(j)) = c.read().await.unwrap() else {
        panic!("no job")
    };
    c.write(&Message::Ready {
        job_id: j.job_id,
        build_s: 0.0,
    })
    .await
    .unwrap();
    let tile = loop {
        match c.read().await.unwrap() {
            Some(Message::Assign { tile, attempt, .. }) => break (tile, attempt),
            Some(_) => continue,
            None => panic!("closed"),
        }
    };
    let result = frame(&Message::TileResult {
        job_id: j.job_id,
        tile_id: tile.0.id,
        attempt: tile.1,
        pixels: parrt::protocol::TilePixels::encode(
            &vec![[0.25, 0.5, 0.75]; tile.0.pixel_count()],
            Default::default(),
        ),
        stats: parrt::stats::RayStats {
            eye_rays: tile.0.pixel_count() as u64,
            ..Default::default()
        },
        seconds: 0.0,
    });
    assert!(result.len() > 700_000, "a {}-byte result", result.len());
    let (_r, mut w) = c.into_inner().into_split();
    let began = std::time::Instant::now();
    for part in result.chunks(16 * 1024) {
        if let Err(e) = w.write_all(part).await {
            let why = match timeout(Duration::from_secs(5), m.handle).await {
                Ok(Ok(Err(e))) => format!("the master failed: {e:#}"),
                Ok(Ok(Ok(_))) => "the master finished without the result".into(),
                other => format!("the master: {other:?}"),
            };
            panic!("the master closed after {:?} ({e}); {why}", began.elapsed());
        }
        sleep(Duration::from_millis(100)).await;
    }
    let trickled = began.elapsed();
    assert!(
        trickled > opts.net.heartbeat_timeout,
        "the result took {trickled:?}, not longer than the timeout: nothing was tested"
    );
    let r = m.handle.await.unwrap().expect("the slow result was taken");
    assert_eq!(r.film.pixels[0], [0.25, 0.5, 0.75]);
}

/// Item 14: after Welcome the master accepts no frame larger than the job's biggest result,
/// and the worker none larger than a small message after the job.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_frames_after_welcome_are_refused_at_once() {
    let desc = test_scene(16, 16);
    let m = start_master(&desc, &settings_for(&desc), &test_options(8)).await;
    let c = authenticate(m.addr, "bloater", 1).await;
    let mut s = c.into_inner();
    let announced = limits::worker_frame_limit(8) as u32 + 1;
    s.write_all(&announced.to_be_bytes()).await.unwrap();
    s.write_all(&[0u8; 1024]).await.unwrap();
    assert!(
        closed_within_5s(&mut s).await,
        "the master waited for an oversized frame"
    );
    m.cancel.cancel();
    let _ = m.handle.await;

    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let worker = start_worker(worker_options(listener.local_addr().unwrap(), 1, "w"));
    let mut c = welcome_one(&listener).await;
    c.write(&job(16, 16, 8)).await.unwrap();
    let mut s = c.into_inner();
    s.write_all(&(10u32 << 20).to_be_bytes()).await.unwrap();
    let ended = timeout(Duration::from_secs(5), worker)
        .await
        .expect("the worker waited for a 10 MiB frame after the job");
    let err = ended.unwrap().unwrap_err();
    assert!(err.to_string().contains("larger than the limit"), "{err}");
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
