//! The live view's defences, attacked as a client would: half-sent requests by the hundred, unread
//! `/frame` responses, stuck event streams, a foreign `Host`, and the workers' token offered as the
//! view's key.

use crate::live_view::{
    events_start, get, get_as, key_of, start_command, start_render, status_when_done,
};
use crate::EXE;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::Command;
use std::time::{Duration, Instant};

/// Opens `n` connections to `dial`, each sending `head` and nothing more.
fn open_stuck(dial: &str, n: usize, head: &str) -> Vec<TcpStream> {
    (0..n)
        .map(|_| {
            let mut s = TcpStream::connect(dial).expect("connects");
            s.write_all(head.as_bytes()).expect("sends");
            s
        })
        .collect()
}

/// Whether the server closed `s` within `wait` (reading and dropping whatever it sent first).
fn closed_within(s: &mut TcpStream, wait: Duration) -> bool {
    let deadline = Instant::now() + wait;
    let mut buf = [0u8; 65536];
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return false;
        }
        s.set_read_timeout(Some(left)).expect("a timeout");
        match s.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => return true,
            Err(_) => return false,
        }
    }
}

/// The resident memory of process `pid`, in bytes (from `/proc`).
fn rss(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("/proc status");
    let kib: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("VmRSS");
    kib * 1024
}

#[test]
fn half_sent_requests_shut_out_neither_the_page_nor_the_workers() {
    // Under 256 descriptors, 300 connections that never finish their request's head: before
    // the gate they took every descriptor, the page got no answer and the render could not
    // write its image.
    let dir = tempfile::tempdir().unwrap();
    let mut cmd = Command::new("sh");
    cmd.args(["-c", "ulimit -n 256 && exec \"$0\" \"$@\"", EXE, "render"])
        .args([
            "--scene", "balls:2", "--width", "128", "--height", "128", "--tile", "16",
        ])
        .args(["--workers", "2", "--threads", "2", "--http", "0.0.0.0:0"])
        .args(["--http-linger", "60", "-o"])
        .arg(dir.path().join("out.png"));
    let r = start_command(cmd, Some(100));
    let key = key_of(&r.url);
    let mut stuck = open_stuck(
        &r.dial,
        300,
        "GET /status HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer wr",
    );
    let asked = Instant::now();
    let (code, _, body) = get(&r.dial, "/status", Some(&format!("Bearer {key}")));
    let waited = asked.elapsed();
    assert_eq!(code, 200);
    assert!(String::from_utf8_lossy(&body).contains("tiles_total"));
    assert!(
        waited < Duration::from_secs(2),
        "the page waited {waited:?}"
    );
    // The oldest were closed for newer ones; the newest, by the head timeout (5 s).
    assert!(closed_within(&mut stuck[0], Duration::from_secs(1)));
    let last = stuck.len() - 1;
    assert!(closed_within(&mut stuck[last], Duration::from_secs(10)));
    // The workers were not shut out: the image is written, every tile in it.
    r.written();
    let v = status_when_done(&r.dial, Some(&format!("Bearer {key}")));
    assert_eq!(v["state"], "done");
    assert_eq!(v["tiles_done"], 64);
}

#[test]
fn unread_frames_keep_the_memory_bounded() {
    // A 2048 × 1024 frame is 6 MiB: 24 unread `GET /frame` pinned a copy each (144 MiB) before
    // they shared one snapshot and were capped at 4 at once.
    let dir = tempfile::tempdir().unwrap();
    let r = start_render(
        dir.path(),
        &[
            "--scene",
            "balls:1",
            "--width",
            "2048",
            "--height",
            "1024",
            "--tile",
            "64",
            "--max-depth",
            "1",
        ],
        &["--http", "127.0.0.1:0"],
        None,
    );
    r.written();
    let frame = 2048 * 1024 * 3;
    let before = rss(r.child.id());
    let head = format!("GET /frame HTTP/1.1\r\nHost: {}\r\n\r\n", r.dial);
    let _unread = open_stuck(&r.dial, 24, &head);
    // Let the server answer them all (as far as the unread sockets let it).
    std::thread::sleep(Duration::from_millis(1500));
    let after = rss(r.child.id());
    let grew = after.saturating_sub(before);
    eprintln!(
        "24 unread frames: RSS {} -> {} MiB",
        before >> 20,
        after >> 20
    );
    assert!(
        grew < 4 * frame,
        "24 unread frames grew the process by {} MiB (a frame is {} MiB)",
        grew >> 20,
        frame >> 20
    );
    // Past the cap, a frame asked for is refused for now (503), not queued.
    let (code, _, _) = get(&r.dial, "/frame", None);
    assert_eq!(code, 503);
}

#[test]
fn stuck_event_streams_never_shut_out_a_page() {
    // 40 streams that are never read, past the cap of 32: before, every page after the 32nd
    // got 503.
    let dir = tempfile::tempdir().unwrap();
    let r = start_render(
        dir.path(),
        &["--scene", "balls:1", "--width", "64", "--height", "64"],
        &["--http", "127.0.0.1:0"],
        None,
    );
    r.written();
    let head = format!("GET /events HTTP/1.1\r\nHost: {}\r\n\r\n", r.dial);
    let mut stuck = open_stuck(&r.dial, 40, &head);
    std::thread::sleep(Duration::from_millis(300));
    let ev = events_start(&r.dial, "");
    assert!(ev.starts_with("HTTP/1.1 200"), "{ev}");
    assert!(
        ev.contains("event: reload") && ev.contains("event: done"),
        "{ev}"
    );
    let (code, _, _) = get(&r.dial, "/", None);
    assert_eq!(code, 200);
    // The stalest streams (the first opened: none took an event since) were closed for newer.
    assert!(closed_within(&mut stuck[0], Duration::from_secs(3)));
}

#[test]
fn a_loopback_view_answers_only_to_its_own_host() {
    let dir = tempfile::tempdir().unwrap();
    let r = start_render(
        dir.path(),
        &["--scene", "balls:1", "--width", "64", "--height", "64"],
        &["--http", "127.0.0.1:0"],
        None,
    );
    let port = r.dial.rsplit(':').next().expect("a port").to_string();
    for path in ["/status", "/", "/frame", "/image.png", "/events"] {
        for host in [
            "evil.example".to_string(),
            format!("evil.example:{port}"),
            "localhost".to_string(),
            "127.0.0.1:1".to_string(),
        ] {
            let (code, _, body) = get_as(&r.dial, &host, path, None);
            assert_eq!(code, 421, "{path} as {host}");
            assert!(!String::from_utf8_lossy(&body).contains("tiles_total"));
        }
    }
    for host in [format!("localhost:{port}"), format!("127.0.0.1:{port}")] {
        let (code, _, _) = get_as(&r.dial, &host, "/status", None);
        assert_eq!(code, 200, "{host}");
    }
}

#[test]
fn the_workers_token_does_not_open_the_view_and_is_never_printed() {
    let dir = tempfile::tempdir().unwrap();
    let token = "workers-secret-3f9a7c1e5b2d4086";
    let mut cmd = Command::new(EXE);
    cmd.args([
        "master", "--scene", "balls:1", "--width", "64", "--height", "64",
    ])
    .args(["--token", token, "--listen", "127.0.0.1:0"])
    .args(["--http", "0.0.0.0:0", "--http-linger", "60", "-o"])
    .arg(dir.path().join("out.png"));
    let r = start_command(cmd, None);
    let key = key_of(&r.url);
    assert_ne!(key, token);
    let (code, _, _) = get(&r.dial, "/status", Some(&format!("Bearer {token}")));
    assert_eq!(code, 401, "the token as the bearer");
    let (code, _, _) = get(&r.dial, &format!("/status?key={token}"), None);
    assert_eq!(code, 401, "the token as the key");
    let (code, _, _) = get(&r.dial, &format!("/status?token={token}"), None);
    assert_eq!(code, 401, "the token as the old parameter");
    let (code, _, _) = get(&r.dial, &format!("/status?key={key}"), None);
    assert_eq!(code, 200);
    // A worker joins: the render completes, and nothing it printed holds the token.
    let mut printed = r.printed.clone();
    let listening = loop {
        let line = r
            .lines
            .recv_timeout(Duration::from_secs(30))
            .expect("the master says where it listens");
        printed.push(line.clone());
        if let Some(rest) = line.strip_prefix("parrt master: listening on ") {
            break rest.split(';').next().expect("an address").to_string();
        }
    };
    let worker = Command::new(EXE)
        .args(["worker", "--connect", &listening, "--token", token])
        .args(["--threads", "1"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("the worker runs");
    assert!(worker.status.success(), "{worker:?}");
    loop {
        let line = r
            .lines
            .recv_timeout(Duration::from_secs(30))
            .expect("the master writes the image");
        let wrote = line.starts_with("parrt master: wrote ");
        printed.push(line);
        if wrote {
            break;
        }
    }
    let all = printed.join("\n");
    assert!(!all.contains(token), "{all}");
    assert!(!all.contains(&key), "not to a log either: {all}");
    let worker_said = String::from_utf8_lossy(&worker.stderr);
    assert!(!worker_said.contains(token), "{worker_said}");
}
