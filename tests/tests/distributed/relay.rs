//! A relay between a real worker and a real master: every byte of the conversation passes through a
//! test that can read and change it. Without the token it sees no plaintext (not the worker's name,
//! the Welcome, nor the scene), and one byte it flips ends that connection while the render
//! finishes on another worker, to the same bits.

use crate::faults::finish;
use parrt_protocol::codec::encode_payload;
use parrt_protocol::Message;
use parrt_tests::*;
use parrt_worker::session::SessionEnd;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// What one relayed connection carried, each direction.
#[derive(Default)]
struct Seen {
    to_master: Vec<u8>,
    to_worker: Vec<u8>,
}

/// Accepts one connection on `listener`, dials `master` and forwards bytes both ways until
/// either side closes, keeping a copy. With `flip_over = Some(n)`, the last byte of the first
/// encrypted chunk from the worker longer than `n` bytes is flipped on the way; returns
/// whether a byte was flipped.
async fn relay_one(
    listener: TcpListener,
    master: SocketAddr,
    flip_over: Option<usize>,
    seen: Arc<Mutex<Seen>>,
) -> bool {
    let (w, _) = listener.accept().await.unwrap();
    let m = TcpStream::connect(master).await.unwrap();
    let (mut wr, mut ww) = w.into_split();
    let (mut mr, mut mw) = m.into_split();
    let seen_up = seen.clone();
    let up = async move {
        // The greeting frame: a 4-byte length and its payload.
        let mut flipped = false;
        let mut len = [0u8; 4];
        if wr.read_exact(&mut len).await.is_err() {
            return flipped;
        }
        let mut greeting = vec![0u8; u32::from_be_bytes(len) as usize];
        if wr.read_exact(&mut greeting).await.is_err() {
            return flipped;
        }
        let mut out = len.to_vec();
        out.extend_from_slice(&greeting);
        // Then encrypted chunks: a 2-byte length and the ciphertext.
        loop {
            seen_up.lock().unwrap().to_master.extend_from_slice(&out);
            if mw.write_all(&out).await.is_err() {
                return flipped;
            }
            let mut len = [0u8; 2];
            if wr.read_exact(&mut len).await.is_err() {
                return flipped;
            }
            let mut body = vec![0u8; u16::from_be_bytes(len) as usize];
            if wr.read_exact(&mut body).await.is_err() {
                return flipped;
            }
            if !flipped && flip_over.is_some_and(|n| body.len() > n) {
                if let Some(last) = body.last_mut() {
                    *last ^= 0x01;
                    flipped = true;
                }
            }
            out = len.to_vec();
            out.extend_from_slice(&body);
        }
    };
    let down = async move {
        let mut buf = vec![0u8; 1 << 16];
        loop {
            match mr.read(&mut buf).await {
                Ok(0) | Err(_) => break,
                Ok(n) => {
                    seen.lock().unwrap().to_worker.extend_from_slice(&buf[..n]);
                    if ww.write_all(&buf[..n]).await.is_err() {
                        break;
                    }
                }
            }
        }
        let _ = ww.shutdown().await;
    };
    tokio::join!(up, down).0
}

fn contains(hay: &[u8], needle: &[u8]) -> bool {
    hay.windows(needle.len()).any(|w| w == needle)
}

/// A relay sees no plaintext of the handshake, the Welcome or the scene.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_relay_sees_no_plaintext() {
    let desc = test_scene(32, 32);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let m = start_master(&desc, &settings, &test_options(8)).await;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let relay_addr = listener.local_addr().unwrap();
    let seen = Arc::new(Mutex::new(Seen::default()));
    let relay = tokio::spawn(relay_one(listener, m.addr, None, seen.clone()));
    let name = "relayed-worker-with-a-findable-name";
    let worker = start_worker(worker_options(relay_addr, 2, name));
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "through a relay");
    assert_eq!(worker.await.unwrap().unwrap().end, SessionEnd::Shutdown);
    assert!(!relay.await.unwrap());

    let seen = seen.lock().unwrap();
    assert!(
        seen.to_worker.len() > 1000 && seen.to_master.len() > 1000,
        "the relay carried the render"
    );
    // What a plain-text link would show: the scene as the Job encodes it, the name in Hello,
    // the Welcome frame. Each is found in the plaintext it comes from (the search works)…
    let job = encode_payload(&Message::Job(Box::new(parrt_protocol::JobSpec {
        job_id: 1,
        scene: desc.clone(),
        settings: settings.clone(),
        tile_size: 8,
        pixel_format: Default::default(),
        pack_pixels: true,
    })))
    .unwrap();
    // The middle of the Job's payload: scene bytes (the job id, which differs, is at its head).
    let scene_part = &job[job.len() / 2..job.len() / 2 + 48];
    let welcome = frame(&Message::Welcome);
    // …and never in what the relay saw.
    for (what, needle) in [
        ("the scene", scene_part),
        ("the worker's name", name.as_bytes()),
        ("Welcome", &welcome[..]),
    ] {
        assert!(
            !contains(&seen.to_worker, needle),
            "{what} crossed to the worker in clear"
        );
        assert!(
            !contains(&seen.to_master, needle),
            "{what} crossed to the master in clear"
        );
    }
    // Nor the token.
    assert!(!contains(&seen.to_master, TEST_TOKEN.as_bytes()));
}

/// A relay that flips one byte of one worker's traffic ends that connection;
/// the render finishes on the other worker, to the same bits.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flipped_byte_ends_that_connection_and_the_render_finishes() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
    let mut opts = test_options(8);
    // Both take part from the start, so the tampered one holds tiles when its link breaks.
    opts.schedule.min_workers = 2;
    let m = start_master(&desc, &settings, &opts).await;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let relay_addr = listener.local_addr().unwrap();
    let seen = Arc::new(Mutex::new(Seen::default()));
    // Hello, Auth, Ready and heartbeats are under 100 bytes; tile results are longer.
    let relay = tokio::spawn(relay_one(listener, m.addr, Some(150), seen));
    let mut tampered = worker_options(relay_addr, 1, "tampered");
    tampered.tile_delay = Some(std::time::Duration::from_millis(20));
    let tampered = start_worker(tampered);
    let mut good = worker_options(m.addr, 1, "good");
    good.tile_delay = Some(std::time::Duration::from_millis(5));
    let good = start_worker(good);
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "with one link tampered with");
    assert_eq!(r.stats, ref_stats);
    assert_eq!(good.await.unwrap().unwrap().end, SessionEnd::Shutdown);
    // The tampered link was cut by the master, not ended by a Shutdown.
    match tampered.await.unwrap() {
        Ok(s) => assert_ne!(s.end, SessionEnd::Shutdown, "the tampered link lasted"),
        Err(e) => eprintln!("tampered worker: {e}"),
    }
    assert!(relay.await.unwrap(), "the relay flipped no byte");
}
