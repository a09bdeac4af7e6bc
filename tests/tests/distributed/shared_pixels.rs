//! Pixels through memory a master shares with the workers it starts
//! (docs/protocol.md, *Pixels in shared memory*): a worker killed mid-job with tiles in its
//! region loses them to the other worker, and the image is SMP's bit for bit; a worker told of
//! a region that is none sends its pixels over its connection, and nothing else changes.

use crate::EXE;
use parrt_tests::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The processes `pid` started, from every one of its threads' child lists.
fn children(pid: u32) -> Vec<u32> {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return Vec::new();
    };
    let mut found = Vec::new();
    for t in tasks.flatten() {
        let list = std::fs::read_to_string(t.path().join("children")).unwrap_or_default();
        found.extend(
            list.split_whitespace()
                .filter_map(|p| p.parse::<u32>().ok()),
        );
    }
    found
}

fn render_args<'a>(scene: &'a str, out: &'a Path) -> Vec<&'a str> {
    let out = out.to_str().unwrap();
    vec![
        "render", scene, "--width", "64", "--height", "64", "--tile", "8", "-o", out,
    ]
}

#[test]
fn a_worker_killed_with_tiles_in_shared_memory_loses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = crate::support::spd_dir().join("mount-4.nff");
    let scene = scene.to_str().unwrap();
    let (smp, dist, ckpt) = (
        dir.path().join("smp.png"),
        dir.path().join("dist.png"),
        dir.path().join("dist.ckpt"),
    );
    let done = Command::new(EXE)
        .args(render_args(scene, &smp))
        .args(["--threads", "2"])
        .output()
        .unwrap();
    assert!(done.status.success(), "{done:?}");
    // 64 tiles of 40 ms each: over a second of work for each of the two workers.
    let mut master = Command::new(EXE)
        .args(render_args(scene, &dist))
        .args(["--workers", "2", "--threads", "1", "--checkpoint"])
        .arg(&ckpt)
        .env(parrt_worker::options::TILE_DELAY_ENV, "40")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let guard = scopeguard(master.id());
    // Mid-job: the checkpoint holds tiles, so the workers have sent results through their
    // regions and hold more.
    let t0 = Instant::now();
    let workers = loop {
        let kids = children(master.id());
        let len = std::fs::metadata(&ckpt).map_or(0, |m| m.len());
        if kids.len() == 2 && len > 4096 {
            break kids;
        }
        assert!(master.try_wait().unwrap().is_none(), "ended before mid-job");
        assert!(t0.elapsed() < Duration::from_secs(30), "no progress");
        std::thread::sleep(Duration::from_millis(5));
    };
    sigkill(workers[0]);
    let out = master.wait_with_output().unwrap();
    drop(guard);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        std::fs::read(&smp).unwrap() == std::fs::read(&dist).unwrap(),
        "the image differs from SMP's after a worker was killed"
    );
}

/// Sends SIGKILL to `pid`.
fn sigkill(pid: u32) {
    let _ = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status();
}

/// Kills the master (and so its workers) if the test fails before it has ended.
fn scopeguard(pid: u32) -> impl Drop {
    struct Kill(u32);
    impl Drop for Kill {
        fn drop(&mut self) {
            if std::thread::panicking() {
                sigkill(self.0);
            }
        }
    }
    Kill(pid)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_told_of_no_region_sends_its_pixels_over_its_connection() {
    let desc = test_scene(32, 32);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let m = start_master(&desc, &settings, &test_options(8)).await;
    // Stdin is no region, and nor is a descriptor that is not open.
    let _w: Vec<ChildGuard> = ["0", "987"]
        .into_iter()
        .map(|fd| {
            let child = Command::new(EXE)
                .args(["worker", "--connect", &m.addr.to_string(), "--threads", "1"])
                .env("PARRT_TOKEN", TEST_TOKEN)
                .env(parrt_protocol::SHARED_PIXELS_ENV, fd)
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("spawn worker process");
            ChildGuard(child)
        })
        .collect();
    let r = tokio::time::timeout(Duration::from_secs(60), m.handle)
        .await
        .expect("render finishes")
        .unwrap()
        .unwrap();
    assert_same_bits(&r.film, &reference, "workers with no region");
    assert_eq!(r.tiles_shared, 0);
    assert!(
        r.bytes_received >= 32 * 32 * 12,
        "{} bytes",
        r.bytes_received
    );
}
