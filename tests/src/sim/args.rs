//! The `sim` binary's command line, parsed with clap as the other binaries' are: an unknown or
//! misspelt flag is refused, every number is checked against its range before anything runs
//! (a seed range must fit in `u64`, sizes in `u32` and within what a recording may be,
//! durations and rates finite and within stated bounds), and a refusal is exit 2 with a
//! message, never a panic or a silently altered value.

use clap::{Args, Parser, Subcommand};

/// Widest image `sim scale` records.
pub const MAX_SIZE: u32 = 8192;
/// Largest tile edge `sim scale` accepts.
pub const MAX_TILE: u32 = 256;
/// Longest one-way latency, milliseconds: ten seconds is far past any network worth modelling,
/// and keeps every derived duration representable.
pub const MAX_LATENCY_MS: f64 = 10_000.0;
/// Slowest and fastest link, Gbit/s: from 1 Mbit/s to 10 Tbit/s (slower links would make a
/// frame outlast the simulation's horizon; faster ones round every transfer to zero).
pub const GBIT_RANGE: (f64, f64) = (0.001, 10_000.0);
/// Most master CPU per tile, microseconds (one second a tile).
pub const MAX_MASTER_US: f64 = 1e6;
/// Longest frame of work, one-core seconds: seven days, as the duration flags elsewhere.
pub const MAX_WORK_SECONDS: f64 = 7.0 * 86_400.0;
/// Most frames of one `sim scale` sequence.
pub const MAX_FRAMES: u64 = 10_000;
/// Most degrees an orbit turns (ten whole turns).
pub const MAX_ORBIT: f64 = 3600.0;
/// Most workers and most threads of one `--configs` entry.
pub const MAX_WORKERS: usize = 4096;
/// See [`MAX_WORKERS`].
pub const MAX_THREADS: usize = 256;

/// The deterministic simulation: explore seeds, replay one, check that planted bugs are
/// caught, or run many workers over a recorded render in virtual time.
#[derive(Debug, Parser)]
#[command(name = "sim", about, long_about = None)]
pub struct Cli {
    /// What to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Runs seeds FIRST..FIRST+SEEDS; prints `seed <s> FAIL <invariant>` for each failure and
    /// last `explored N seeds, F failed` (exit 0 only if none failed).
    Explore(Explore),
    /// Runs one seed; prints its events' summary and last `trace <hex hash>`.
    Replay {
        /// The seed.
        seed: u64,
    },
    /// Plants each known bug in the runtime and says which seed caught it (needs a build with
    /// them: `--features planted`, or exit 2).
    Mutants {
        /// Seeds tried per planted bug.
        #[arg(long, default_value_t = 1_000, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
        seeds: u64,
    },
    /// Many workers over a recorded render, in virtual time.
    Scale(Box<Scale>),
}

/// `sim explore`.
#[derive(Debug, Args)]
pub struct Explore {
    /// How many seeds.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub seeds: u64,
    /// The first seed.
    #[arg(long, default_value_t = 0)]
    pub first: u64,
}

impl Explore {
    /// The seeds to run, or why the range does not fit in a `u64`.
    pub fn range(&self) -> Result<std::ops::Range<u64>, String> {
        match self.first.checked_add(self.seeds) {
            Some(end) => Ok(self.first..end),
            None => Err(format!(
                "--first {} plus --seeds {} passes the last seed ({}): at most {} seeds \
                 start there",
                self.first,
                self.seeds,
                u64::MAX,
                u64::MAX - self.first
            )),
        }
    }
}

/// `sim scale`.
#[derive(Debug, Args)]
pub struct Scale {
    /// Where the rows go (rewritten after each row).
    #[arg(long)]
    pub json: std::path::PathBuf,
    /// The scene to record, NAME or NAME:SIZE.
    #[arg(long, default_value = "mount:8", value_parser = scene)]
    pub scene: SceneArg,
    /// Image width and height, pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIZE as i64))]
    pub size: u32,
    /// Tile edge, pixels.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=MAX_TILE as i64))]
    pub tile: u32,
    /// Configurations, WORKERSxTHREADS, comma-separated.
    #[arg(long, default_value = "8x1,64x8", value_delimiter = ',', value_parser = config)]
    pub configs: Vec<(usize, usize)>,
    /// One-core seconds of the frame, comma-separated.
    #[arg(long, default_value = "0.2,1200", value_delimiter = ',', value_parser = work_seconds)]
    pub work_seconds: Vec<f64>,
    /// Link bandwidths, Gbit/s, comma-separated.
    #[arg(long, default_value = "1", value_delimiter = ',', value_parser = gbit)]
    pub gbit: Vec<f64>,
    /// One-way latency, milliseconds.
    #[arg(long, default_value_t = 0.2, value_parser = latency_ms)]
    pub latency_ms: f64,
    /// The master's CPU per tile received, microseconds.
    #[arg(long, default_value_t = 7.0, value_parser = master_us)]
    pub master_us_per_tile: f64,
    /// Most tiles in one assignment.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..=parrt_protocol::limits::MAX_BATCH as u64))]
    pub max_batch: u64,
    /// Hand the tiles out costliest first.
    #[arg(long)]
    pub costly_first: bool,
    /// Frames rendered as one sequence through the master's window (each the recording
    /// panned by its angle of the orbit; 1: one frame).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=MAX_FRAMES))]
    pub frames: u64,
    /// Degrees the sequence turns over its frames.
    #[arg(long, default_value_t = 360.0, value_parser = orbit_degrees)]
    pub orbit: f64,
    /// Frames the master keeps open at once in a sequence, comma-separated (a row each; 1 to
    /// the most a worker keeps built less one). Ignored for one frame.
    #[arg(long, default_value = "2", value_delimiter = ',', value_parser = frames_window)]
    pub frames_window: Vec<usize>,
    /// Where the recording is kept.
    #[arg(long, default_value = "target/sim-scale")]
    pub replay_dir: std::path::PathBuf,
}

/// A scene name with its optional size.
#[derive(Clone, Debug)]
pub struct SceneArg {
    /// As given (names the recording).
    pub text: String,
    /// The generator's name.
    pub name: String,
    /// Its size level, if given.
    pub level: Option<u32>,
}

fn scene(s: &str) -> Result<SceneArg, String> {
    let (name, level) = match s.split_once(':') {
        Some((n, l)) => (
            n,
            Some(
                l.parse::<u32>()
                    .map_err(|_| format!("{l:?} is not a size (a whole number)"))?,
            ),
        ),
        None => (s, None),
    };
    Ok(SceneArg {
        text: s.to_string(),
        name: name.to_string(),
        level,
    })
}

fn config(s: &str) -> Result<(usize, usize), String> {
    s.split_once('x')
        .and_then(|(w, t)| Some((w.trim().parse().ok()?, t.trim().parse().ok()?)))
        .filter(|&(w, t)| (1..=MAX_WORKERS).contains(&w) && (1..=MAX_THREADS).contains(&t))
        .ok_or_else(|| {
            format!("{s:?} is not WORKERSxTHREADS (1 to {MAX_WORKERS} × 1 to {MAX_THREADS})")
        })
}

/// A finite number within `lo..=hi` (`lo` excluded when `open`).
fn bounded(s: &str, lo: f64, open: bool, hi: f64, unit: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    let above = if open { x > lo } else { x >= lo };
    if x.is_finite() && above && x <= hi {
        Ok(x)
    } else {
        let from = if open { "above" } else { "from" };
        Err(format!("{s} is out of range: {from} {lo} to {hi} {unit}"))
    }
}

fn work_seconds(s: &str) -> Result<f64, String> {
    bounded(s, 0.0, true, MAX_WORK_SECONDS, "seconds")
}

fn gbit(s: &str) -> Result<f64, String> {
    bounded(s, GBIT_RANGE.0, false, GBIT_RANGE.1, "Gbit/s")
}

fn latency_ms(s: &str) -> Result<f64, String> {
    bounded(s, 0.0, true, MAX_LATENCY_MS, "ms")
}

fn frames_window(s: &str) -> Result<usize, String> {
    let most = parrt_runtime::scheduler::MAX_FRAMES_WINDOW;
    s.trim()
        .parse::<usize>()
        .ok()
        .filter(|w| (1..=most).contains(w))
        .ok_or_else(|| format!("{s:?} is not a window of frames (1 to {most})"))
}

fn orbit_degrees(s: &str) -> Result<f64, String> {
    bounded(s, -MAX_ORBIT, false, MAX_ORBIT, "degrees")
}

fn master_us(s: &str) -> Result<f64, String> {
    bounded(s, 0.0, true, MAX_MASTER_US, "µs")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<Cli, String> {
        Cli::try_parse_from(std::iter::once("sim").chain(args.iter().copied()))
            .map_err(|e| e.to_string())
    }

    #[test]
    fn a_seed_range_past_the_last_seed_is_refused() {
        let Command::Explore(e) =
            parse(&["explore", "--seeds", "3", "--first", "18446744073709551615"])
                .unwrap()
                .command
        else {
            panic!("explore")
        };
        assert_eq!(
            e.range().unwrap_err(),
            "--first 18446744073709551615 plus --seeds 3 passes the last seed \
             (18446744073709551615): at most 0 seeds start there"
        );
        let Command::Explore(e) = parse(&["explore", "--seeds", "3", "--first", "7"])
            .unwrap()
            .command
        else {
            panic!("explore")
        };
        assert_eq!(e.range().unwrap(), 7..10);
        assert!(parse(&["explore", "--seeds", "0"]).is_err());
    }

    #[test]
    fn sizes_rates_and_durations_out_of_range_are_refused() {
        let base = ["scale", "--json", "x.json"];
        for (flag, value, why) in [
            ("--size", "4294967312", "4294967312"),
            ("--tile", "4294967312", "4294967312"),
            ("--size", "8193", "8193"),
            ("--latency-ms", "1e300", "out of range"),
            ("--latency-ms", "NaN", "out of range"),
            ("--gbit", "1e-300", "out of range"),
            ("--gbit", "1,inf", "out of range"),
            ("--master-us-per-tile", "1e300", "out of range"),
            ("--work-seconds", "0", "out of range"),
            ("--max-batch", "0", "0"),
            ("--configs", "8x0", "not WORKERSxTHREADS"),
            ("--frames", "0", "0"),
            ("--orbit", "NaN", "out of range"),
            ("--frames-window", "0", "not a window of frames (1 to 15)"),
            (
                "--frames-window",
                "4,16",
                "not a window of frames (1 to 15)",
            ),
        ] {
            let mut args = base.to_vec();
            args.extend([flag, value]);
            let e = parse(&args).unwrap_err();
            assert!(e.contains(flag) && e.contains(why), "{flag} {value}: {e}");
        }
        assert!(parse(&base).is_ok());
    }

    #[test]
    fn unknown_flags_are_refused() {
        for args in [
            &["scale", "--json", "x.json", "--bogus-flag", "7"][..],
            &["scale", "--json", "x.json", "--frame", "24"],
            &["explore", "--seeds", "1", "--seed", "4"],
            &["replay", "4", "--fast"],
        ] {
            let e = parse(args).unwrap_err();
            assert!(e.contains("unexpected argument"), "{args:?}: {e}");
        }
    }
}
