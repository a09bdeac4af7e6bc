//! The shared token never appears in logs or on a command line (where `ps` would show it),
//! whether given by file or environment or generated for local workers. How a token
//! is proved in the handshake is `handshake.rs`.

use crate::EXE;
use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A token no other test uses, to look for in logs and command lines.
pub const SECRET: &str = "s3cret-token-that-must-never-leak-4711";

/// Command lines of this user's processes that run our executable as a worker.
fn worker_cmdlines() -> Vec<String> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        let Ok(raw) = std::fs::read(entry.path().join("cmdline")) else {
            continue;
        };
        let line = String::from_utf8_lossy(&raw).replace('\0', " ");
        if line.contains("parrt-cli") && line.contains(" worker ") {
            out.push(line);
        }
    }
    out
}

#[test]
fn token_stays_out_of_logs_and_command_lines() {
    let dir = tempfile::tempdir().unwrap();
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, format!("{SECRET}\n")).unwrap();
    let out = dir.path().join("m.png");
    let mut master = Command::new(EXE)
        .args([
            "master", "--scene", "mount:4", "--width", "48", "--height", "48", "--tile", "8",
        ])
        .args([
            "--listen",
            "127.0.0.1:0",
            "--min-workers",
            "2",
            "--wait-workers",
            "30",
            "-o",
        ])
        .arg(&out)
        .arg("--token-file")
        .arg(&token_file)
        .env("PARRT_LOG", "trace")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start master");
    // The master says where it listens on stderr; read until then, keep the rest.
    let mut err = BufReader::new(master.stderr.take().unwrap());
    let mut master_log = String::new();
    let addr = loop {
        let mut line = String::new();
        assert!(
            err.read_line(&mut line).unwrap() > 0,
            "master ended early: {master_log}"
        );
        master_log.push_str(&line);
        if let Some(rest) = line.split("listening on ").nth(1) {
            break rest
                .split(|c: char| c == ';' || c.is_whitespace())
                .next()
                .unwrap()
                .to_string();
        }
    };
    let workers: Vec<_> = (0..2)
        .map(|_| {
            Command::new(EXE)
                .args(["worker", "--connect", &addr, "--threads", "1"])
                .env("PARRT_TOKEN", SECRET)
                .env("PARRT_LOG", "trace")
                .env("PARRT_WORKER_TILE_DELAY_MS", "20")
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .expect("start worker")
        })
        .collect();
    // While they work, nothing's command line holds the secret.
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(300) {
        for line in worker_cmdlines() {
            assert!(!line.contains(SECRET), "token on a command line: {line}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    err.read_to_string(&mut master_log).unwrap();
    assert!(
        master.wait().unwrap().success(),
        "master failed: {master_log}"
    );
    for w in workers {
        let o = w.wait_with_output().unwrap();
        let log =
            String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
        assert!(!log.contains(SECRET), "token in a worker's log: {log}");
        assert!(
            log.len() > 50,
            "trace logging produced almost nothing: {log}"
        );
    }
    assert!(
        !master_log.contains(SECRET),
        "token in the master's log: {master_log}"
    );
    assert!(out.is_file());
}

#[test]
fn local_workers_get_their_token_through_the_environment() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("w.png");
    let mut render = Command::new(EXE)
        .args([
            "render",
            "--scene",
            "mount:4",
            "--width",
            "64",
            "--height",
            "64",
            "--workers",
            "2",
            "-o",
        ])
        .arg(&out)
        .env("PARRT_WORKER_TILE_DELAY_MS", "15")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start render");
    let mut seen = 0;
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(20) {
        if render.try_wait().unwrap().is_some() {
            break;
        }
        for line in worker_cmdlines() {
            seen += 1;
            assert!(
                !line.contains("--token"),
                "a spawned worker got its token on argv: {line}"
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(render.wait().unwrap().success());
    assert!(seen > 0, "never saw a spawned worker to check");
    assert!(out.is_file());
}
