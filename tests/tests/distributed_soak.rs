//! Soak: many distributed jobs back to back, in one process, while workers are killed
//! and replaced at random moments. Every image must equal the SMP render bit for bit, with the
//! same statistics (nothing lost, nothing counted twice), and the master's memory — this
//! process's resident set — must stay flat across the jobs.
//!
//! CI runs 24 jobs; `PARRT_SOAK_JOBS=100 cargo test -p parrt-tests --test distributed_soak` runs
//! more by hand. It stays its own test binary, apart from `distributed/`: the resident set it
//! watches is this process's, which the tests running beside it there would change.

use parrt_tests::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::time::Duration;
use tokio::time::{sleep, timeout};

const EXE: &str = env!("CARGO_BIN_EXE_parrt-cli");

fn jobs() -> usize {
    std::env::var("PARRT_SOAK_JOBS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24)
}

/// Resident set size of this process in KiB, from /proc.
fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
        })
        .unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jobs_back_to_back_with_workers_killed_at_random() {
    let desc = test_scene(48, 40);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
    let mut rng = StdRng::seed_from_u64(0x5eed_2026);
    let n = jobs();
    let warm_up = 4.min(n.saturating_sub(1));
    let mut rss_after_warm_up = 0;
    let (mut kills, mut requeued) = (0u32, 0u64);
    for job in 0..n {
        let mut opts = test_options(8);
        opts.schedule.min_workers = 1;
        opts.schedule.tile_deadline = Duration::from_secs(3);
        opts.net.heartbeat_timeout = Duration::from_secs(3);
        let m = start_master(&desc, &settings, &opts).await;
        let mut workers: Vec<ChildGuard> = (0..2)
            .map(|_| spawn_worker_process(EXE.as_ref(), m.addr, 1, Some(4), TEST_TOKEN))
            .collect();
        if rng.gen_bool(0.75) {
            // Kill one worker at a random moment (it may not even have connected yet) and start
            // a replacement, as a node failing and a scheduler restarting it would.
            sleep(Duration::from_millis(rng.gen_range(0..80))).await;
            let victim = rng.gen_range(0..workers.len());
            let _ = workers[victim].0.kill();
            kills += 1;
            workers.push(spawn_worker_process(
                EXE.as_ref(),
                m.addr,
                1,
                Some(4),
                TEST_TOKEN,
            ));
        }
        let r = timeout(Duration::from_secs(60), m.handle)
            .await
            .unwrap_or_else(|_| panic!("job {job} did not finish within 60 s"))
            .expect("master task")
            .unwrap_or_else(|e| panic!("job {job} failed: {e}"));
        assert_same_bits(&r.film, &reference, &format!("job {job}"));
        assert_eq!(
            r.stats, ref_stats,
            "job {job}: statistics (nothing counted twice)"
        );
        requeued += r.faults.requeued;
        drop(workers);
        if job == warm_up {
            rss_after_warm_up = rss_kib();
        }
    }
    let rss_end = rss_kib();
    eprintln!(
        "soak: {n} jobs, {kills} workers killed, {requeued} tiles requeued; RSS {rss_after_warm_up} KiB \
         after {} jobs, {rss_end} KiB at the end",
        warm_up + 1
    );
    assert!(kills > 0, "the soak killed no worker");
    assert!(
        rss_end <= rss_after_warm_up + 8 * 1024,
        "the master's memory grew from {rss_after_warm_up} KiB to {rss_end} KiB over {n} jobs"
    );
}
