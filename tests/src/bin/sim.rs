//! The simulation's command line: `explore --seeds N [--first S]` runs seeds S..S+N and prints
//! `seed <s> FAIL <invariant>` for each failure and last `explored N seeds, F failed` (exit 0
//! only if none failed); `replay <seed>` runs one seed, prints its events' summary and last
//! `trace <hex hash>`.

use parrt_tests::sim::{run_seed, run_seed_with};
use std::process::ExitCode;
use std::time::Instant;

const USAGE: &str = "usage: sim explore --seeds N [--first S] | sim replay <seed> | \
     sim mutants [--seeds N] | sim scale --json FILE [--scene NAME:SIZE] [--size PX] [--tile S] \
     [--configs WxT,...] [--work-seconds S,...] [--gbit G,...] [--latency-ms MS] \
     [--master-us-per-tile US] [--max-batch N] [--costly-first]";

/// The value after `flag`, or `default`.
fn text<'a>(args: &'a [String], flag: &str, default: &'a str) -> &'a str {
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1))
        .map_or(default, String::as_str)
}

/// A comma-separated list of numbers after `flag`.
fn list(args: &[String], flag: &str, default: &str) -> Result<Vec<f64>, String> {
    text(args, flag, default)
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x > 0.0)
                .ok_or_else(|| format!("{flag}: {v:?} is not a positive number"))
        })
        .collect()
}

fn scale(args: &[String]) -> Result<ExitCode, String> {
    use parrt_tests::sim::scale::{record, run, Config};
    let json = text(args, "--json", "");
    if json.is_empty() {
        return Err(format!("scale needs --json FILE\n{USAGE}"));
    }
    let scene = text(args, "--scene", "mount:8");
    let (name, level) = match scene.split_once(':') {
        Some((n, l)) => (
            n,
            Some(
                l.parse::<u32>()
                    .map_err(|_| format!("--scene {scene}: bad size"))?,
            ),
        ),
        None => (scene, None),
    };
    let size = number(args, "--size")?.unwrap_or(512) as u32;
    let tile = number(args, "--tile")?.unwrap_or(32) as u32;
    if size == 0 || size > 8192 || tile == 0 || tile > 256 {
        return Err("--size must be 1..=8192 and --tile 1..=256".into());
    }
    let desc = parrt_scenes::generate(name, level).map_err(|e| format!("--scene {scene}: {e}"))?;
    let settings = parrt::settings::RenderSettings::new(size, size);
    let dir = std::path::Path::new(text(args, "--replay-dir", "target/sim-scale"));
    let path = dir.join(format!("{}-{size}-t{tile}.replay", scene.replace(':', "-")));
    eprintln!(
        "recording {scene} at {size}² (once) into {}",
        path.display()
    );
    record(&desc, &settings, tile, &path).map_err(|e| format!("{e:#}"))?;
    let latency = list(args, "--latency-ms", "0.2")?[0] / 1e3;
    let us = list(args, "--master-us-per-tile", "7")?[0];
    let max_batch = number(args, "--max-batch")?.unwrap_or(8).clamp(1, 256) as usize;
    let mut rows = Vec::new();
    for c in text(args, "--configs", "8x1,64x8").split(',') {
        let (w, t) = c
            .split_once('x')
            .and_then(|(w, t)| Some((w.parse::<usize>().ok()?, t.parse::<usize>().ok()?)))
            .filter(|&(w, t)| (1..=4096).contains(&w) && (1..=256).contains(&t))
            .ok_or_else(|| format!("--configs: {c:?} is not WORKERSxTHREADS"))?;
        for &work_s in &list(args, "--work-seconds", "0.2,1200")? {
            for &gbit in &list(args, "--gbit", "1")? {
                let cfg = Config {
                    workers: w,
                    threads: t,
                    work_s,
                    link_bps: gbit * 1e9,
                    latency: std::time::Duration::from_secs_f64(latency),
                    master_s_per_byte: us * 1e-6 / (3.0 * (tile * tile) as f64),
                    max_batch,
                    dilation: None,
                    costly_first: args.iter().any(|a| a == "--costly-first"),
                    hosts: None,
                };
                let row = run(&path, &cfg).map_err(|e| format!("{c}: {e:#}"))?;
                println!(
                    "{w:>5} × {t:<3} work {work_s:>8.1} s  {gbit:>4} Gbit/s  efficiency {:.3}  predicted {:.3} (tail {:.3}, master busy {:.2})  identical {}  (+{:.1} % rounding, dilated ×{}, {:.3} virtual s, {:.1} s wall); trace: queue empty at {:.0} %, then {:.1} % of thread time idle, last 1 % handed out {:.1}× the mean tile, last 1 % in {:.1}×, costliest still out {:.1}×",
                    row.efficiency, row.predicted, row.model_tail, row.model_master, row.identical, row.rounding * 100.0, row.dilation, row.trace_s, row.wall_s,
                    row.trace.handout_share * 100.0, row.trace.idle_after_queue * 100.0, row.trace.last_tiles_cost, row.trace.last_results_cost, row.trace.costliest_out
                );
                rows.push(row);
                // Written after every row: a long sweep keeps what it has measured.
                let text = serde_json::to_string_pretty(&rows).map_err(|e| e.to_string())?;
                std::fs::write(json, text).map_err(|e| format!("cannot write {json}: {e}"))?;
            }
        }
    }
    Ok(if rows.iter().all(|r| r.identical) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn number(args: &[String], flag: &str) -> Result<Option<u64>, String> {
    match args.iter().position(|a| a == flag) {
        None => Ok(None),
        Some(i) => args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .map(Some)
            .ok_or_else(|| format!("{flag} needs a whole number\n{USAGE}")),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    // Expected refusals and departures are the simulation's daily bread: keep logs quiet.
    let run = || -> Result<ExitCode, String> {
        match args.first().map(String::as_str) {
            Some("explore") => {
                let n = number(&args, "--seeds")?.ok_or(USAGE)?;
                let first = number(&args, "--first")?.unwrap_or(0);
                let t0 = Instant::now();
                let mut failed = 0u64;
                let mut virtual_s = 0.0;
                for seed in first..first.saturating_add(n) {
                    let o = run_seed(seed);
                    virtual_s += o.virtual_s;
                    if !o.failures.is_empty() {
                        failed += 1;
                        for f in &o.failures {
                            println!("seed {seed} FAIL {f}");
                        }
                        println!(
                            "  replay: cargo run --release -p parrt-tests --bin sim -- replay {seed}"
                        );
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
            Some("scale") => scale(&args),
            Some("mutants") => {
                // Each planted bug must be caught within N seeds.
                let n = number(&args, "--seeds")?.unwrap_or(1_000);
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
            Some("replay") => {
                let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).ok_or(USAGE)?;
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
                Ok(if o.failures.is_empty() {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::FAILURE
                })
            }
            _ => Err(USAGE.into()),
        }
    };
    match run() {
        Ok(code) => code,
        Err(msg) => {
            eprintln!("sim: {msg}");
            ExitCode::from(2)
        }
    }
}
