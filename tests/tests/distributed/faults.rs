//! Faults in distributed rendering (docs/design.md, *Distributed runtime*): workers killed,
//! stopped, interrupted or joining late, and workers that cannot build the job. In every case the
//! image is complete and equal to SMP (or the job's own error is reported). Worker processes use
//! the `PARRT_WORKER_TILE_DELAY_MS` test hook so "mid-job" is certain. Bad peers are
//! `handshake.rs`.

use crate::EXE;
use parrt_protocol::{Connection, Message};
use parrt_runtime::{DistResult, MasterConfig};
use parrt_tests::*;
use std::sync::Arc;
use std::time::Duration;
use tokio::time::timeout;

/// The master's result within 60 s, the render succeeded.
pub async fn finish(m: RunningMaster) -> DistResult {
    timeout(Duration::from_secs(60), m.handle)
        .await
        .expect("the master finishes")
        .expect("master task")
        .expect("the render succeeds")
}

fn report_of(r: &DistResult, pid: u32) -> &parrt_runtime::WorkerReport {
    let suffix = format!("-{pid}");
    r.per_worker
        .iter()
        .find(|w| w.name.ends_with(&suffix))
        .unwrap_or_else(|| panic!("no report for pid {pid}: {:?}", r.per_worker))
}

/// `opts` for a job both worker processes take part in from the start (neither can finish it
/// alone before the other has joined), watched for the tiles each delivers.
fn two_workers_watched(mut opts: MasterConfig) -> (MasterConfig, Arc<Deliveries>) {
    let seen = Deliveries::new();
    opts.schedule.min_workers = 2;
    opts.observers = seen.observers();
    (opts, seen)
}

/// Waits until `worker` has delivered a tile: it is connected, rendering and holds more (64
/// tiles of 40 ms on two workers leave over a second of work), however long it took to start.
async fn mid_job(seen: &Deliveries, worker: &ChildGuard) {
    let suffix = format!("-{}", worker.pid());
    seen.wait_for(&suffix, 1, Duration::from_secs(30)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_killed_mid_job_loses_its_tiles_to_the_others() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
    let (opts, seen) = two_workers_watched(test_options(8));
    let m = start_master(&desc, &settings, &opts).await;
    let victim = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    let _other = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    mid_job(&seen, &victim).await;
    victim.signal("KILL");
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "after SIGKILL");
    assert_eq!(r.stats, ref_stats, "nothing counted twice");
    let v = report_of(&r, victim.pid());
    assert!(v.left.is_some(), "victim left: {v:?}");
    assert!(
        r.faults.requeued >= 1,
        "its tiles were requeued: {:?}",
        r.faults
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stopped_worker_tiles_move_after_the_deadline() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
    let mut opts = test_options(8);
    opts.schedule.tile_deadline = Duration::from_millis(400);
    opts.net.heartbeat_timeout = Duration::from_secs(60); // so only the deadline can move tiles
    opts.schedule.backups = false;
    let (opts, seen) = two_workers_watched(opts);
    let m = start_master(&desc, &settings, &opts).await;
    let stopped = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    let _other = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    mid_job(&seen, &stopped).await;
    stopped.signal("STOP");
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "after SIGSTOP");
    assert_eq!(r.stats, ref_stats);
    assert!(r.faults.requeued >= 1, "{:?}", r.faults);
    assert!(
        r.trace_s < 30.0,
        "moved by the deadline, not the heartbeat timeout"
    );
    drop(stopped); // SIGCONT, then kill
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stopped_worker_is_dropped_after_missed_heartbeats() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
    let mut opts = test_options(8);
    opts.schedule.tile_deadline = Duration::from_secs(60); // so only the heartbeat timeout can act
                                                           // Three of the workers' 1 s heartbeats: a healthy worker waiting for tiles (before the
                                                           // start, or for the stopped one's) is not dropped for a heartbeat a loaded machine delays.
    opts.net.heartbeat_timeout = Duration::from_secs(3);
    opts.schedule.backups = false;
    let (opts, seen) = two_workers_watched(opts);
    let m = start_master(&desc, &settings, &opts).await;
    let stopped = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    let _other = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    mid_job(&seen, &stopped).await;
    stopped.signal("STOP");
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "after missed heartbeats");
    assert_eq!(r.stats, ref_stats);
    let left = report_of(&r, stopped.pid())
        .left
        .clone()
        .unwrap_or_default();
    assert!(left.contains("no heartbeat"), "{left:?}");
    assert!(r.trace_s < 30.0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_joining_late_gets_tiles() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let seen = Deliveries::new();
    let opts = MasterConfig {
        observers: seen.observers(),
        ..test_options(8)
    };
    let m = start_master(&desc, &settings, &opts).await;
    let mut early = worker_options(m.addr, 1, "early");
    early.tile_delay = Some(Duration::from_millis(25));
    let w1 = start_worker(early);
    // Late for certain: the render is under way, with about 1.5 s of the early one's work left.
    seen.wait_for("early", 1, Duration::from_secs(30)).await;
    let mut late = worker_options(m.addr, 1, "late");
    late.tile_delay = Some(Duration::from_millis(25));
    let w2 = start_worker(late);
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "late joiner");
    let tiles = |n: &str| r.per_worker.iter().find(|w| w.name == n).unwrap().tiles;
    assert!(
        tiles("early") > 0 && tiles("late") > 0,
        "{:?}",
        r.per_worker
    );
    w1.await.unwrap().unwrap();
    w2.await.unwrap().unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_reports_a_job_it_cannot_build() {
    // A fake master, speaking raw protocol.
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let worker = start_worker(worker_options(addr, 1, "w"));
    let (s, _) = listener.accept().await.unwrap();
    let mut c = Connection::new(secure_server(s).await, 1 << 20);
    let Some(Message::Hello { nonce: theirs, .. }) = c.read().await.unwrap() else {
        panic!("no hello")
    };
    let nonce = [3u8; 32];
    let proof = token().master_proof(&theirs, &nonce);
    c.write(&Message::Challenge { nonce, proof }).await.unwrap();
    let Some(Message::Auth { mac }) = c.read().await.unwrap() else {
        panic!("no auth")
    };
    assert!(token().verify_worker_proof(&nonce, &theirs, &mac));
    c.write(&Message::Welcome).await.unwrap();
    let mut desc = test_scene(8, 8);
    desc.view.width = 0;
    c.write(&Message::Job(Box::new(parrt_protocol::JobSpec {
        job_id: 42,
        scene: desc,
        settings: parrt_render::settings::RenderSettings::new(0, 8),
        tile_size: 8,
        pixel_format: Default::default(),
        pack_pixels: true,
    })))
    .await
    .unwrap();
    // Tiles for a job it does not have, and outside any image, are errors too, not panics.
    loop {
        match c.read().await.unwrap() {
            Some(Message::Heartbeat) => continue,
            Some(Message::Error { reason }) => {
                assert!(reason.contains("cannot build job 42"), "{reason}");
                break;
            }
            other => panic!("expected Error, got {other:?}"),
        }
    }
    c.write(&Message::Assign {
        job_id: 42,
        tile: parrt_render::tile::Tile {
            id: 0,
            x: 0,
            y: 0,
            w: 8,
            h: 8,
        },
        attempt: 1,
    })
    .await
    .unwrap();
    loop {
        match c.read().await.unwrap() {
            Some(Message::Heartbeat) => continue,
            Some(Message::Error { reason }) => {
                assert!(reason.contains("unknown job"), "{reason}");
                break;
            }
            other => panic!("expected Error, got {other:?}"),
        }
    }
    c.write(&Message::Shutdown).await.unwrap();
    let s = worker.await.unwrap().unwrap();
    assert_eq!(s.end, parrt_worker::session::SessionEnd::Shutdown);
    assert_eq!(s.tiles_rendered, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn interrupted_worker_disconnects_and_its_tiles_are_requeued() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let (opts, seen) = two_workers_watched(test_options(8));
    let m = start_master(&desc, &settings, &opts).await;
    let mut quitter = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    let _other = spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(40), TEST_TOKEN);
    // Its first tile delivered: it is running (its Ctrl-C handler installed) and holds tiles.
    mid_job(&seen, &quitter).await;
    quitter.signal("INT");
    let status = tokio::task::spawn_blocking(move || {
        let st = quitter.0.wait().unwrap();
        drop(quitter);
        st
    });
    let r = finish(m).await;
    assert_same_bits(&r.film, &reference, "after a worker's Ctrl-C");
    let st = status.await.unwrap();
    assert_eq!(
        st.code(),
        Some(130),
        "a worker stopped by Ctrl-C exits 130 (128 + SIGINT)"
    );
    assert!(r.faults.requeued >= 1, "{:?}", r.faults);
}

/// What `render --workers` gets wrong with a job: the job's own error, or the distributed one.
#[derive(Debug)]
enum LocalFailure {
    Job(String),
    Dist(parrt_runtime::DistError),
}

impl From<parrt_runtime::DistError> for LocalFailure {
    fn from(e: parrt_runtime::DistError) -> Self {
        LocalFailure::Dist(e)
    }
}

// `render --workers` no longer checks the scene before the workers get it (the check cost a
// scene build on the start-up path of every render): spawned workers that cannot build the job
// end the render at once, and the check then names the job's fault as bad input.
#[test]
fn spawned_workers_that_cannot_build_the_job_end_with_the_jobs_own_error() {
    let mut desc = test_scene(32, 32);
    desc.primitives[0].material = 9;
    let settings = settings_for(&desc);
    let mut opts = test_options(16);
    opts.spawn.count = 2;
    opts.spawn.threads = 1;
    opts.spawn.command.exe = Some(EXE.into());
    opts.net.token = None;
    opts.schedule.min_workers = 2;
    // Their refusal is the point: logged at WARN it would read as a failure in a green run.
    // Errors still show, and PARRT_LOG, when set, wins (`PARRT_LOG=warn cargo test ...`).
    opts.spawn.command.log = "error".into();
    // Far beyond the bound below: a master that waits for the workers that refused the
    // job waits this long, a working one ends as soon as they have refused.
    opts.schedule.wait_workers = Duration::from_secs(60);
    let t0 = std::time::Instant::now();
    let job =
        parrt_runtime::Job::prepared(|| Ok::<_, LocalFailure>((desc, settings))).check(|d, s| {
            parrt_render::render::validate_job(d, s).map_err(|e| LocalFailure::Job(e.to_string()))
        });
    let r = parrt_runtime::run(&opts, job, &mut |_| Ok(None), None);
    match r {
        Err(LocalFailure::Job(msg)) => assert!(msg.contains("uses material 9"), "{msg}"),
        Err(LocalFailure::Dist(e)) => panic!("expected the job's error, got: {e}"),
        Ok(_) => panic!("a job no worker can build rendered"),
    }
    assert!(
        t0.elapsed() < Duration::from_secs(30),
        "took {:?}: the master waited for workers that had all refused the job",
        t0.elapsed()
    );
}
