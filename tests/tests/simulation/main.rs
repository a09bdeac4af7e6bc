//! The deterministic simulation in the test suite: a few hundred seeded fault schedules run
//! against the real master runtime and worker sessions (turmoil, virtual time), every
//! invariant held; a seed replays to the same trace, in this process and in new ones
//! ([`replay_processes`]); the invariants can fail; and the `sim` binary refuses bad flags
//! ([`sim_cli`]).

mod replay_processes;
mod sim_cli;

use parrt_tests::sim::plan::{Fault, Plan};
use parrt_tests::sim::run_seed;
use parrt_tests::sim::scale::{packed_result_bytes, run, Config};
use std::time::Duration;

#[test]
fn three_hundred_seeds_keep_every_invariant() {
    let mut failed = Vec::new();
    let mut faults = 0;
    for seed in 0..300 {
        faults += Plan::draw(seed).faults.len();
        let o = run_seed(seed);
        if !o.failures.is_empty() {
            failed.push(format!("seed {seed}: {:?}", o.failures));
        }
    }
    assert!(faults > 300, "the seeds drew faults: {faults}");
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn a_seed_replays_to_the_same_trace() {
    // Seeds with a master crash, a hostile peer and a held link among them.
    let seeds: Vec<u64> = (0..400)
        .filter(|&s| {
            Plan::draw(s).faults.iter().any(|(_, f)| {
                matches!(
                    f,
                    Fault::MasterCrash { .. } | Fault::Hold { .. } | Fault::Hostile(_)
                )
            })
        })
        .take(5)
        .collect();
    assert_eq!(seeds.len(), 5);
    for seed in seeds {
        let (a, b) = (run_seed(seed), run_seed(seed));
        assert_eq!(a.trace, b.trace, "seed {seed}");
        assert_eq!(a.events, b.events, "seed {seed}");
        assert!(a.events > 20, "seed {seed} traced {} events", a.events);
    }
    assert_ne!(run_seed(1).trace, run_seed(2).trace);
}

/// One seed in four renders a sequence of 2–5 frames; a sequence whose master is killed
/// mid-way and started again (resuming the sequence's checkpoint) still writes every frame
/// exactly once, each its own single-frame image (the seeds' invariant).
#[test]
fn sequences_are_explored_and_survive_the_master_killed() {
    let frames: Vec<usize> = (0..400).map(|s| Plan::draw(s).frames).collect();
    let sequences = frames.iter().filter(|&&f| f > 1).count();
    assert!(
        (60..=140).contains(&sequences),
        "{sequences} of 400 seeds are sequences"
    );
    assert!(frames.iter().all(|&f| (1..=5).contains(&f)));
    let seeds: Vec<u64> = (0..4_000)
        .filter(|&s| {
            let p = Plan::draw(s);
            p.frames >= 3
                && p.faults.len() == 1
                && matches!(p.faults[0], (at, Fault::MasterCrash { .. }) if at.as_millis() > 500)
        })
        .take(3)
        .collect();
    assert_eq!(seeds.len(), 3);
    // And the seed that found the sequence's records synced only after the goodbye: its master
    // dies once every tile is in and the workers have left, the crash tears the unsynced end
    // of the checkpoint, and the master started again must finish without any worker.
    let found = 100_911;
    assert!(Plan::draw(found).frames > 1);
    for seed in seeds.into_iter().chain([found]) {
        let o = run_seed(seed);
        assert!(o.failures.is_empty(), "seed {seed}: {:?}", o.failures);
        assert_eq!(o.ended, "complete", "seed {seed}");
    }
}

#[test]
fn a_master_killed_mid_render_resumes_from_its_checkpoint() {
    let seed = (0..2_000)
        .find(|&s| {
            let p = Plan::draw(s);
            p.faults.len() == 1
                && matches!(p.faults[0], (at, Fault::MasterCrash { .. }) if at.as_millis() < 300)
        })
        .expect("a seed whose only fault kills the master early");
    let o = run_seed(seed);
    assert!(o.failures.is_empty(), "seed {seed}: {:?}", o.failures);
    assert_eq!(o.ended, "complete");
}

#[test]
fn every_planted_bug_is_caught() {
    use parrt_runtime::mutation::Mutation;
    use parrt_tests::sim::run_seed_with;
    for m in Mutation::ALL {
        let caught = (0..400).find(|&seed| !run_seed_with(seed, Some(m)).failures.is_empty());
        assert!(caught.is_some(), "{m:?} was not caught in 400 seeds");
    }
    // And nothing stays planted: the same seeds pass without it.
    assert!(run_seed(0).failures.is_empty());
}

/// A recording of a small scene for the scale tests: 64×64 pixels in 256 tiles of 4×4, the
/// pixels of a real render and costs of a fixed pattern (1 to 5 units, so the runs are the
/// same on every machine; measured costs would make each run of the test another test).
fn small_recording(dir: &std::path::Path) -> std::path::PathBuf {
    let desc = parrt_scenes::generate("mount", Some(3)).expect("the mount scene");
    let settings = parrt_render::settings::RenderSettings::new(64, 64);
    let renderer = parrt_render::render::Renderer::new(&desc, &settings).expect("a renderer");
    let opts = parrt_render::smp::SmpOptions {
        threads: 1,
        tile: 4,
        executor: parrt_render::smp::Executor::Queue,
    };
    let film = parrt_render::smp::render_smp(&renderer, &opts, &|_, _| {}).film;
    let costs: Vec<f64> = (0..256u32).map(|i| 1.0 + f64::from(i * 7 % 5)).collect();
    let path = dir.join("mount-3-64-t4.replay");
    parrt_worker::replay::write(&path, 4, &costs, &film).expect("a recording");
    path
}

fn small_config(work_s: f64, dilation: Option<f64>) -> Config {
    Config {
        workers: 4,
        threads: 2,
        work_s,
        link_bps: 1e9,
        latency: Duration::from_micros(200),
        master_s_per_tile: 7e-6,
        max_batch: 8,
        dilation,
        costly_first: false,
        hosts: None,
        frames: 1,
        orbit_deg: 360.0,
        frames_window: 2,
    }
}

#[test]
fn a_frame_of_microsecond_tiles_runs_dilated_with_its_image() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    // 80 µs a tile: far under tokio's millisecond timers, so the run is dilated.
    let row = run(&path, &small_config(0.02, None)).expect("the run");
    assert!(row.identical, "the assembled image is the recorded one");
    assert!(row.dilation > 100.0, "dilated ×{}", row.dilation);
    assert!(
        row.rounding < 0.02,
        "timers added {:.1} %",
        row.rounding * 100.0
    );
    assert!(
        (0.0..=1.0).contains(&row.efficiency) && (row.efficiency - row.predicted).abs() < 0.1,
        "efficiency {:.3}, model {:.3}",
        row.efficiency,
        row.predicted
    );
}

#[test]
fn a_sequence_of_three_frames_gives_each_frame_once_as_recorded_and_panned() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    let row = run(
        &path,
        &Config {
            frames: 3,
            orbit_deg: 360.0,
            ..small_config(15.36, None)
        },
    )
    .expect("the sequence");
    assert_eq!(row.frames, 3);
    let mut frames: Vec<usize> = row.seen.iter().map(|f| f.index).collect();
    frames.sort_unstable();
    assert_eq!(frames, [0, 1, 2], "each frame finished once");
    for f in &row.seen {
        assert!(f.identical, "frame {} is the recording panned", f.index);
        assert!(f.latency_s > 0.0, "frame {} has its span", f.index);
    }
    assert!(row.identical);
    assert!(
        row.latency_mean_s > 0.0
            && row.latency_mean_s <= row.latency_max_s
            && row.latency_max_s <= row.trace_s,
        "latency mean {} max {} trace {}",
        row.latency_mean_s,
        row.latency_max_s,
        row.trace_s
    );
    // Three frames' work over eight threads: the frames fill each other's tails.
    assert!(
        (row.efficiency - row.predicted).abs() < 0.05 && row.efficiency > 0.8,
        "efficiency {:.3}, model {:.3}",
        row.efficiency,
        row.predicted
    );
}

#[test]
fn a_wider_window_of_frames_fills_the_tails_and_the_model_follows_it() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    // Sixteen threads over 256 tiles a frame: with one frame open, every frame ends in a tail
    // of idle threads; with four open, the next frames fill it.
    let rows: Vec<_> = [1, 4]
        .into_iter()
        .map(|frames_window| {
            run(
                &path,
                &Config {
                    workers: 8,
                    frames: 4,
                    frames_window,
                    ..small_config(15.36, None)
                },
            )
            .expect("the sequence")
        })
        .collect();
    for r in &rows {
        assert!(
            r.identical,
            "window {}: every frame as recorded",
            r.frames_window
        );
        assert!(
            (r.efficiency - r.predicted).abs() < 0.03,
            "window {}: efficiency {:.3}, model {:.3}",
            r.frames_window,
            r.efficiency,
            r.predicted
        );
    }
    assert!(
        rows[1].efficiency > rows[0].efficiency + 0.02,
        "window 1: {:.3}, window 4: {:.3}",
        rows[0].efficiency,
        rows[1].efficiency
    );
    assert!(
        rows[1].predicted > rows[0].predicted + 0.02,
        "the model: window 1 {:.3}, window 4 {:.3}",
        rows[0].predicted,
        rows[1].predicted
    );
}

#[test]
fn workers_sharing_a_simulated_host_measure_what_workers_apart_do() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    // Four workers on four hosts, then all four sessions on one: each keeps its connection
    // and its link, so the frame takes the same virtual time.
    let apart = run(&path, &small_config(15.36, None)).expect("the run on four hosts");
    let shared = run(
        &path,
        &Config {
            hosts: Some(1),
            ..small_config(15.36, None)
        },
    )
    .expect("the run on one host");
    assert!(apart.identical && shared.identical);
    assert!(
        (apart.efficiency - shared.efficiency).abs() <= 0.005,
        "efficiency {:.4} on four hosts, {:.4} on one",
        apart.efficiency,
        shared.efficiency
    );
}

#[test]
fn dilating_a_frame_leaves_its_efficiency_as_it_was() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    // 60 ms a tile: no dilation needed; the same frame stretched 8 times must measure the same.
    let plain = run(&path, &small_config(15.36, None)).expect("the plain run");
    let stretched = run(&path, &small_config(15.36, Some(8.0))).expect("the dilated run");
    assert_eq!(plain.dilation, 1.0);
    assert_eq!(stretched.dilation, 8.0);
    assert!(plain.identical && stretched.identical);
    // The plain run's timers end each tile at a whole millisecond (its `rounding`); the
    // dilated run's at an eighth of that in frame time. They may differ by that much.
    let bound = 2.0 * plain.rounding + 0.005;
    assert!(
        (plain.efficiency - stretched.efficiency).abs() <= bound,
        "efficiency {:.4} plain (timers +{:.2} %), {:.4} dilated ×8: more than {bound:.4} apart",
        plain.efficiency,
        plain.rounding * 100.0,
        stretched.efficiency
    );
}

#[test]
fn the_masters_link_and_cpu_work_side_by_side() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    // A slow link: a tile's result (about 150 bytes) takes some 5 ms to cross it, while the
    // eight threads finish a tile every 1.25 ms, so the master's link binds the frame.
    let link_bps = 240e3;
    let link_only = Config {
        link_bps,
        master_s_per_tile: 0.0,
        ..small_config(2.56, None)
    };
    // The master's CPU then takes as long per byte as its link (the CPU is charged per
    // result, spread over a packed result's mean bytes): the card receives the next message
    // while the CPU handles the last, so the link still binds, not their sum.
    let replay = parrt_worker::replay::Replay::open(&path, 1.0).expect("the recording");
    let result_bytes = packed_result_bytes(&replay).expect("the recording's pixels");
    let both = Config {
        master_s_per_tile: result_bytes * 8.0 / link_bps,
        ..link_only.clone()
    };
    let a = run(&path, &link_only).expect("the run with a free master");
    let b = run(&path, &both).expect("the run with a busy master");
    assert!(a.identical && b.identical);
    assert!(
        a.efficiency < 0.5,
        "the link should bind: efficiency {:.3}",
        a.efficiency
    );
    assert!(
        b.efficiency >= 0.85 * a.efficiency,
        "efficiency {:.3} with the master's CPU as slow as its link, {:.3} without: the two \
         worked one after the other",
        b.efficiency,
        a.efficiency
    );
}

#[test]
fn a_dilated_frame_stretches_the_workers_heartbeats_too() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = small_recording(dir.path());
    // The link test's frame: the master's link binds, and the run is dilated ×5 for its
    // 10 ms tiles. Dilated ×64 with the workers' heartbeats left at one a second, they would
    // send 13 times as many and take the link from the results.
    let slow = Config {
        link_bps: 240e3,
        master_s_per_tile: 0.0,
        ..small_config(2.56, None)
    };
    let plain = run(&path, &slow).expect("the plain run");
    let stretched = run(
        &path,
        &Config {
            dilation: Some(64.0),
            ..slow.clone()
        },
    )
    .expect("the dilated run");
    assert!(plain.identical && stretched.identical);
    let bound = 2.0 * plain.rounding + 0.01;
    assert!(
        (plain.efficiency - stretched.efficiency).abs() <= bound,
        "efficiency {:.4} plain, {:.4} dilated ×64: more than {bound:.4} apart",
        plain.efficiency,
        stretched.efficiency
    );
}
