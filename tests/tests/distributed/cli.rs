//! `parrt master` and `parrt worker` as processes, their command lines: a master without
//! workers gives up with a clear message (exit 1), a master or worker without a token and a
//! worker with an address that does not resolve or an absurd --dial-timeout are usage errors
//! (exit 2), and Ctrl-C on the master tells its workers to shut down and exits 130.

use crate::EXE;
use parrt_tests::*;
use std::io::BufRead;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn scene_file(dir: &std::path::Path, w: u32, h: u32) -> std::path::PathBuf {
    let p = dir.join("scene.json");
    std::fs::write(&p, serde_json::to_string(&test_scene(w, h)).unwrap()).unwrap();
    p
}

#[test]
fn master_without_workers_exits_1_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = Instant::now();
    let out = Command::new(EXE)
        .args([
            "master",
            "--listen",
            "127.0.0.1:0",
            "--wait-workers",
            "0.5",
            "--scene-json",
        ])
        .arg(scene_file(dir.path(), 16, 16))
        .arg("-o")
        .arg(dir.path().join("x.png"))
        .env("PARRT_TOKEN", TEST_TOKEN)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no worker arrived within"), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(20));
    assert!(!dir.path().join("x.png").exists());
}

#[test]
fn master_without_a_token_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(EXE)
        .args(["master", "--scene-json"])
        .arg(scene_file(dir.path(), 16, 16))
        .env_remove("PARRT_TOKEN")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--token-file"), "{err}");
}

#[test]
fn ctrl_c_on_the_master_shuts_workers_down_and_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    let mut master = Command::new(EXE)
        .args([
            "master",
            "--listen",
            "127.0.0.1:0",
            "--tile",
            "8",
            "--scene-json",
        ])
        .arg(scene_file(dir.path(), 64, 64))
        .arg("-o")
        .arg(dir.path().join("x.png"))
        .env("PARRT_TOKEN", TEST_TOKEN)
        .env("PARRT_LOG", "info")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = std::io::BufReader::new(master.stderr.take().unwrap());
    let mut line = String::new();
    let addr = loop {
        line.clear();
        assert!(
            stderr.read_line(&mut line).unwrap() > 0,
            "master ended early"
        );
        if let Some(rest) = line.split("listening on ").nth(1) {
            break rest.split(';').next().unwrap().trim().parse().unwrap();
        }
    };
    let master = ChildGuard(master);
    let mut worker = spawn_worker_process(EXE.as_ref(), addr, 1, Some(100), TEST_TOKEN);
    // Interrupt once the worker has joined and tiles go out (its 64 tiles of 100 ms leave
    // seconds of work), however long it took to start: a worker still dialling would not be
    // told to shut down.
    loop {
        line.clear();
        assert!(
            stderr.read_line(&mut line).unwrap() > 0,
            "master ended before starting"
        );
        if line.contains("starting") {
            break;
        }
    }
    master.signal("INT");
    let mut master = master;
    let status = master.0.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut rest).unwrap();
    // 128 + SIGINT, as an SMP render Ctrl-C kills.
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(rest.contains("interrupted"), "{rest}");
    // The worker was told Shutdown: it exits 0 on its own, promptly.
    let t0 = Instant::now();
    let st = loop {
        if let Some(st) = worker.0.try_wait().unwrap() {
            break st;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "worker still running"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(st.success(), "worker exit {st:?}");
    assert!(!dir.path().join("x.png").exists());
}

#[test]
fn worker_binary_and_subcommand_refuse_to_start_without_a_token() {
    let out = Command::new(EXE)
        .args(["worker", "--connect", "127.0.0.1:9"])
        .env_remove("PARRT_TOKEN")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("token"));
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
