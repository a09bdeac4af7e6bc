//! The simulation's command line (flags in [`parrt_tests::sim::args`]): `explore --seeds N
//! [--first S]` runs seeds S..S+N and prints `seed <s> FAIL <invariant>` for each failure and
//! last `explored N seeds, F failed` (exit 0 only if none failed); `replay <seed>` runs one
//! seed, prints its events' summary and last `trace <hex hash>`; `mutants` and `scale` as
//! `sim --help` says. Bad flags or values are exit 2.

use clap::Parser;
use parrt_tests::sim::args::{Cli, Command, Explore, Scale};
use parrt_tests::sim::{run_seed, run_seed_with};
use std::process::ExitCode;
use std::time::Instant;

fn scale(a: &Scale) -> Result<ExitCode, String> {
    use parrt_tests::sim::scale::{record, run, Config};
    let (size, tile) = (a.size, a.tile);
    let scene = &a.scene.text;
    let desc = parrt_scenes::generate(&a.scene.name, a.scene.level)
        .map_err(|e| format!("--scene {scene}: {e}"))?;
    let settings = parrt_render::settings::RenderSettings::new(size, size);
    let path = a
        .replay_dir
        .join(format!("{}-{size}-t{tile}.replay", scene.replace(':', "-")));
    eprintln!(
        "recording {scene} at {size}² (once) into {}",
        path.display()
    );
    record(&desc, &settings, tile, &path).map_err(|e| format!("{e:#}"))?;
    let latency = a.latency_ms / 1e3;
    let us = a.master_us_per_tile;
    let max_batch = a.max_batch as usize;
    let json = &a.json;
    // A window of frames matters only to a sequence: one frame runs the first alone.
    let windows = if a.frames > 1 {
        &a.frames_window[..]
    } else {
        &a.frames_window[..1]
    };
    let mut configs = Vec::new();
    for &(workers, threads) in &a.configs {
        for &work_s in &a.work_seconds {
            for &gbit in &a.gbit {
                for &frames_window in windows {
                    configs.push(Config {
                        workers,
                        threads,
                        work_s,
                        link_bps: gbit * 1e9,
                        latency: std::time::Duration::from_secs_f64(latency),
                        master_s_per_tile: us * 1e-6,
                        max_batch,
                        dilation: None,
                        costly_first: a.costly_first,
                        hosts: None,
                        frames: a.frames as usize,
                        orbit_deg: a.orbit,
                        frames_window,
                    });
                }
            }
        }
    }
    let mut rows = Vec::new();
    for cfg in &configs {
        let row = run(&path, cfg).map_err(|e| format!("{}x{}: {e:#}", cfg.workers, cfg.threads))?;
        print_row(&row);
        rows.push(row);
        // Written after every row: a long sweep keeps what it has measured.
        let text = serde_json::to_string_pretty(&rows).map_err(|e| e.to_string())?;
        std::fs::write(json, text).map_err(|e| format!("cannot write {}: {e}", json.display()))?;
    }
    Ok(if rows.iter().all(|r| r.identical) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// One row of `sim scale`, as a line (and a second for a sequence's frames).
fn print_row(row: &parrt_tests::sim::scale::Row) {
    let (w, t, work_s, gbit) = (row.workers, row.threads, row.work_s, row.link_gbit);
    println!(
        "{w:>5} × {t:<3} work {work_s:>8.1} s  {gbit:>4} Gbit/s  efficiency {:.3}  predicted {:.3} (tail {:.3}, master busy {:.2})  identical {}  (+{:.1} % rounding, dilated ×{}, {:.3} virtual s, {:.1} s wall); trace: queue empty at {:.0} %, then {:.1} % of thread time idle, last 1 % handed out {:.1}× the mean tile, last 1 % in {:.1}×, costliest still out {:.1}×",
        row.efficiency, row.predicted, row.model_tail, row.model_master, row.identical, row.rounding * 100.0, row.dilation, row.trace_s, row.wall_s,
        row.trace.handout_share * 100.0, row.trace.idle_after_queue * 100.0, row.trace.last_tiles_cost, row.trace.last_results_cost, row.trace.costliest_out
    );
    if row.frames > 1 {
        println!(
            "        {} frames, window {}: frame latency mean {:.3} s, worst {:.3} s (one frame alone, model: {:.3} s)",
            row.frames, row.frames_window, row.latency_mean_s, row.latency_max_s, row.single_frame_predicted_s
        );
    }
}

fn explore(e: &Explore) -> Result<ExitCode, String> {
    let seeds = e.range()?;
    let n = e.seeds;
    let t0 = Instant::now();
    let mut failed = 0u64;
    let mut virtual_s = 0.0;
    for seed in seeds {
        let o = run_seed(seed);
        virtual_s += o.virtual_s;
        if !o.failures.is_empty() {
            failed += 1;
            for f in &o.failures {
                println!("seed {seed} FAIL {f}");
            }
            println!("  replay: cargo run --release -p parrt-tests --bin sim -- replay {seed}");
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    eprintln!(
        "{:.1} seeds/s, {wall:.1} s wall, {virtual_s:.0} virtual s",
        n as f64 / wall.max(1e-9)
    );
    println!("explored {n} seeds, {failed} failed");
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Each planted bug must be caught within `n` seeds. A build without them is refused (exit 2):
/// it would report every bug missed.
fn mutants(n: u64) -> Result<ExitCode, String> {
    if !parrt_runtime::mutation::COMPILED_IN {
        return Err(
            "built without planted bugs; run `cargo run -p parrt-tests --features \
             planted --bin sim -- mutants`"
                .into(),
        );
    }
    let mut missed = 0;
    println!("| planted bug | caught by seed | seeds run | invariant |");
    println!("|---|---:|---:|---|");
    for m in parrt_runtime::mutation::Mutation::ALL {
        let caught = (0..n).find_map(|seed| {
            let o = run_seed_with(seed, Some(m));
            o.failures.first().map(|f| (seed, f.clone()))
        });
        match caught {
            Some((seed, f)) => {
                let what = f.split(':').next().unwrap_or("").to_string();
                println!("| {m:?} | {seed} | {} | {what} |", seed + 1)
            }
            None => {
                missed += 1;
                println!("| {m:?} | not caught | {n} | |")
            }
        }
    }
    Ok(if missed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn replay(seed: u64) -> ExitCode {
    let o = run_seed(seed);
    println!("plan {:?}", parrt_tests::sim::plan::Plan::draw(seed));
    println!(
        "ended: {}; {} events in {:.2} virtual s",
        o.ended, o.events, o.virtual_s
    );
    for f in &o.failures {
        println!("FAIL {f}");
    }
    println!("trace {}", o.trace);
    if o.failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn main() -> ExitCode {
    // clap refuses unknown flags and values out of range with exit 2 (and prints help with 0).
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    let r = match &cli.command {
        Command::Explore(e) => explore(e),
        Command::Replay { seed } => Ok(replay(*seed)),
        Command::Mutants { seeds } => mutants(*seeds),
        Command::Scale(s) => scale(s),
    };
    match r {
        Ok(code) => code,
        Err(msg) => {
            eprintln!("sim: {msg}");
            ExitCode::from(2)
        }
    }
}
