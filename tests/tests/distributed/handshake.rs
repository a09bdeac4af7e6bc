//! The handshake: authentication is mutual, inside the encrypted channel keyed by the token
//! (docs/design.md, *Protocol*). A worker with another token is refused as a wrong token at its
//! first message; one that dialled a peer without the token stops at once having sent nothing more;
//! inside the channel the master proves the token over the worker's nonce and its own before the
//! worker answers with its own MAC (labels per role); a peer with a wrong MAC, another protocol
//! version, garbage, a 4 GiB length prefix or too many threads is refused with a reason while a
//! good worker finishes the render; a cut handshake is dialled again, a refusal is not.

use crate::faults::finish;
use crate::peers::{authenticate, hello, v1_hello_frame, welcome_one};
use crate::token::SECRET;
use crate::EXE;
use parrt_protocol::limits::MAX_THREADS;
use parrt_protocol::{Connection, Message, PROTOCOL_VERSION};
use parrt_tests::*;
use parrt_worker::WorkerError;
use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::time::timeout;

/// The channel's first message tells the master the token is wrong; it says so,
/// and the worker stops at once with that reason.
#[test]
fn a_worker_with_another_token_is_refused_as_a_wrong_token() {
    let dir = tempfile::tempdir().unwrap();
    let mut master = Command::new(EXE)
        .args([
            "master", "--scene", "mount:4", "--width", "16", "--height", "16", "--tile", "8",
        ])
        .args(["--listen", "127.0.0.1:0", "--wait-workers", "3", "-o"])
        .arg(dir.path().join("m.png"))
        .env("PARRT_TOKEN", SECRET)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start master");
    let mut err = BufReader::new(master.stderr.take().unwrap());
    let addr = loop {
        let mut line = String::new();
        assert!(err.read_line(&mut line).unwrap() > 0, "master ended early");
        if let Some(rest) = line.split("listening on ").nth(1) {
            break rest
                .split(|c: char| c == ';' || c.is_whitespace())
                .next()
                .unwrap()
                .to_string();
        }
    };
    let out = Command::new(EXE)
        .args(["worker", "--connect", &addr, "--threads", "1"])
        .env("PARRT_TOKEN", "another token")
        .output()
        .expect("run worker");
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(log.contains("refused the connection: wrong token"), "{log}");
    let mut master_log = String::new();
    err.read_to_string(&mut master_log).unwrap();
    // No worker came: the master gives up (exit 1), having refused a wrong token.
    assert_eq!(master.wait().unwrap().code(), Some(1));
    assert!(master_log.contains("wrong token"), "{master_log}");
}

/// Item 3: a peer without the token that a worker dials gets nothing past the channel's first
/// message: the worker checks the master's answer first, and stops with a clear error.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_answers_no_peer_that_cannot_prove_the_token() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let worker = start_worker(worker_options(addr, 1, "w"));
    let (mut s, _) = listener.accept().await.unwrap();
    let mut len = [0u8; 4];
    s.read_exact(&mut len).await.unwrap();
    let mut greeting = vec![0u8; u32::from_be_bytes(len) as usize];
    s.read_exact(&mut greeting).await.unwrap();
    assert_eq!(
        &greeting[..2],
        &[0, PROTOCOL_VERSION as u8],
        "variant 0, then the version"
    );
    // A squatter answering with a handshake message it could not make without the token.
    let mut answer = 49u32.to_be_bytes().to_vec();
    answer.push(0xFF);
    answer.extend_from_slice(&[9u8; 48]);
    s.write_all(&answer).await.unwrap();
    let mut after = Vec::new();
    let _ = s.read_to_end(&mut after).await;
    assert!(
        after.is_empty(),
        "the worker sent {} more bytes",
        after.len()
    );
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
        let mut c = Connection::new(secure_client(s).await, 1 << 20);
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
    let mut c = Connection::new(secure_server(s).await, 1 << 20);
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

/// Item 10: a Hello claiming more than MAX_THREADS threads is refused (it would take every
/// tile); the worker CLI refuses such a --threads with exit 2.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn too_many_threads_are_refused() {
    let desc = test_scene(16, 16);
    let m = start_master(&desc, &settings_for(&desc), &test_options(8)).await;
    for threads in [MAX_THREADS + 1, u32::MAX] {
        let s = TcpStream::connect(m.addr).await.unwrap();
        let mut c = Connection::new(secure_client(s).await, 1 << 20);
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_peers_are_refused_while_a_good_worker_finishes() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
    let mut opts = test_options(8);
    opts.schedule.max_failures = 1;
    opts.net.handshake_timeout = Duration::from_millis(500);
    // The good worker and the liar below: the render cannot start, let alone end, before the
    // liar has its job, however slowly the bad peers before it are handled.
    opts.schedule.min_workers = 2;
    let m = start_master(&desc, &settings, &opts).await;
    // A peer that connects and says nothing holds no slot for long.
    let mut mute = TcpStream::connect(m.addr).await.unwrap();
    let mut good = worker_options(m.addr, 2, "good");
    good.tile_delay = Some(Duration::from_millis(20));
    let good = start_worker(good);

    // Wrong token: refused at the channel's first message, with that reason.
    let mut wrong = worker_options(m.addr, 1, "wrong-token");
    wrong.token = parrt_protocol::Token::new("not the token").unwrap();
    let err = start_worker(wrong).await.unwrap().unwrap_err();
    assert!(matches!(err, WorkerError::Refused(_)), "{err}");
    assert!(err.to_string().contains("wrong token"), "{err}");

    // A peer inside the channel that answers with a wrong MAC is refused with the master's
    // reason.
    let s = TcpStream::connect(m.addr).await.unwrap();
    let mut c = Connection::new(secure_client(s).await, 1 << 20);
    c.write(&Message::Hello {
        version: PROTOCOL_VERSION,
        name: "guesser".into(),
        threads: 1,
        nonce: [6; 32],
        isa: parrt_render::isa::Isa::Scalar,
    })
    .await
    .unwrap();
    let Some(Message::Challenge { nonce, .. }) = c.read().await.unwrap() else {
        panic!("no challenge")
    };
    let guess = parrt_protocol::Token::new("not the token").unwrap();
    c.write(&Message::Auth {
        mac: guess.worker_proof(&nonce, &[6; 32]),
    })
    .await
    .unwrap();
    match c.read().await.unwrap() {
        Some(Message::Refused { reason }) => assert!(reason.contains("wrong token"), "{reason}"),
        other => panic!("expected Refused, got {other:?}"),
    }

    // Wrong protocol version, spoken in raw frames.
    let mut s = TcpStream::connect(m.addr).await.unwrap();
    s.write_all(&frame(&Message::Hello {
        version: PROTOCOL_VERSION + 98,
        name: "future".into(),
        threads: 1,
        nonce: [1; 32],
        isa: parrt_render::isa::Isa::Scalar,
    }))
    .await
    .unwrap();
    let mut c = Connection::new(s, 1 << 20);
    match c.read().await.unwrap() {
        Some(Message::Refused { reason }) => {
            assert!(reason.contains("protocol version"), "{reason}")
        }
        other => panic!("expected Refused, got {other:?}"),
    }

    // Random garbage.
    let mut s = TcpStream::connect(m.addr).await.unwrap();
    let junk: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    let _ = s.write_all(&junk).await;
    assert!(closed_within_5s(&mut s).await, "garbage peer closed");

    // A length prefix of 4 GiB: refused before anything is buffered.
    let mut s = TcpStream::connect(m.addr).await.unwrap();
    s.write_all(&[0xff, 0xff, 0xff, 0xff, 0, 1, 2, 3])
        .await
        .unwrap();
    assert!(
        closed_within_5s(&mut s).await,
        "oversized frame peer closed"
    );

    // An authenticated peer sending a result for a tile it was never given.
    let s = TcpStream::connect(m.addr).await.unwrap();
    let mut c = Connection::new(secure_client(s).await, 1 << 28);
    let ours = [2u8; 32];
    c.write(&Message::Hello {
        version: PROTOCOL_VERSION,
        name: "liar".into(),
        threads: 1,
        nonce: ours,
        isa: parrt_render::isa::Isa::Scalar,
    })
    .await
    .unwrap();
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
    let Some(Message::Job(job)) = c.read().await.unwrap() else {
        panic!("no job")
    };
    c.write(&Message::Ready {
        job_id: job.job_id,
        build_s: 0.0,
    })
    .await
    .unwrap();
    // Once the render is under way (tiles from the front of the queue come to it), the result
    // of the last tile, which it does not hold.
    loop {
        match timeout(Duration::from_secs(30), c.read()).await {
            Ok(Ok(Some(Message::Assign { .. } | Message::AssignBatch { .. }))) => break,
            Ok(Ok(Some(_))) => {}
            other => panic!("the liar was given no tile: {other:?}"),
        }
    }
    let last = parrt_render::tile::tiles(64, 64, 8).len() as u32 - 1;
    c.write(&Message::TileResult {
        job_id: job.job_id,
        tile_id: last,
        attempt: 1,
        pixels: parrt_protocol::TilePixels::encode(&[[9.0; 3]; 64], Default::default()),
        stats: parrt_render::stats::RayStats::default(),
        seconds: 0.0,
    })
    .await
    .unwrap();
    // It is dropped (max_failures = 1): told why, then Shutdown.
    let mut told = false;
    while let Ok(Ok(Some(msg))) = timeout(Duration::from_secs(5), c.read()).await {
        match msg {
            Message::Error { reason } => told |= reason.contains("does not hold"),
            Message::Shutdown => break,
            _ => {}
        }
    }
    assert!(told, "the liar is told why it was dropped");

    assert!(closed_within_5s(&mut mute).await, "silent peer closed");

    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "with bad peers around");
    assert_eq!(r.stats, ref_stats);
    let refused = r.faults.refused.reasons.join(" | ");
    for want in [
        "wrong token",
        "protocol version",
        "bad bytes",
        "larger than the limit",
    ] {
        assert!(refused.contains(want), "refusals {refused:?} lack {want:?}");
    }
    assert_eq!(r.faults.rejected_results, 1);
    assert_eq!(r.faults.dropped, 1);
    good.await.unwrap().unwrap();
}

/// A peer without the token that the worker dialled controls the text of its clear refusal:
/// the worker shows it escaped (no escape sequence, link or forged log line reaches the
/// terminal) and bounded.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_refusal_from_a_peer_is_shown_escaped_and_bounded() {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let worker = start_worker(worker_options(addr, 1, "w"));
    let (mut s, _) = listener.accept().await.unwrap();
    let mut len = [0u8; 4];
    s.read_exact(&mut len).await.unwrap();
    let mut greeting = vec![0u8; u32::from_be_bytes(len) as usize];
    s.read_exact(&mut greeting).await.unwrap();
    let hostile = format!(
        "\x1b[2J\x1b]8;;https://evil.example\x07click\x1b]8;;\x07\n\
         2026-11-28T01:00:00Z  INFO parrt: render complete{}",
        "x".repeat(5000)
    );
    let bytes = hostile.len();
    s.write_all(&frame(&Message::Refused { reason: hostile }))
        .await
        .unwrap();
    drop(s);
    let err = worker.await.unwrap().unwrap_err().to_string();
    assert!(!err.chars().any(char::is_control), "{err:?}");
    assert!(
        err.contains(r"\u{1b}[2J\u{1b}]8;;https://evil.example\u{7}click"),
        "{err}"
    );
    assert!(err.contains(r"\n2026-11-28T01:00:00Z"), "{err}");
    assert!(err.ends_with(&format!("… ({bytes} bytes)")), "{err}");
    assert!(err.len() < 400, "{} bytes shown", err.len());
}
