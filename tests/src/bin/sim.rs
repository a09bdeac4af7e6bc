//! The simulation's command line: `explore --seeds N [--first S]` runs seeds S..S+N and prints
//! `seed <s> FAIL <invariant>` for each failure and last `explored N seeds, F failed` (exit 0
//! only if none failed); `replay <seed>` runs one seed, prints its events' summary and last
//! `trace <hex hash>`.

use parrt_tests::sim::{run_seed, run_seed_with};
use std::process::ExitCode;
use std::time::Instant;

const USAGE: &str =
    "usage: sim explore --seeds N [--first S] | sim replay <seed> | sim mutants [--seeds N]";

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
