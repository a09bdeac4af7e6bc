//! `parrt bench cluster`: an emulated cluster, real everywhere but the tracing. A
//! one-thread render of the scene is recorded once (per-tile costs and pixels); then, for N = 1,
//! 2, 4, … workers × T threads, N real worker processes replay it against a real master over
//! real TCP on 127.0.0.1, each behind an emulated LAN link ([`crate::studies::cluster::link`]). Reports measured
//! efficiency, the schedule simulator's prediction and the hardware's limit, and checks every
//! assembled image bit for bit against the recorded one.

use crate::cli_args::size::parse_size;
use crate::cli_args::{LimitArgs, SceneSpec};
use crate::exit::input_error;
use crate::machine::machine;
use crate::studies::cluster::link::LinkParams;
use anyhow::Context;
use clap::Args;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_worker::replay::{self, Replay};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

mod measure;
mod report;

use measure::Setup;
use report::{binding_warnings, csv, draw_timelines, plot, report};
pub use report::{BUSY_MACHINE, SHORT_TILE_S};

/// Most worker processes one run may start: the cap every master that starts local workers
/// keeps (`render --workers` too).
pub const MAX_WORKERS: usize = parrt_runtime::options::MAX_SPAWNED_WORKERS;
/// Most threads per worker.
pub const MAX_THREADS: usize = 256;

/// Arguments of `parrt bench cluster`.
#[derive(Debug, Args)]
pub struct ClusterArgs {
    /// Scene: an NFF file or NAME[:SIZE].
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE", default_value = "mount")]
    pub scene: String,
    /// Image size in pixels, WxH or N for NxN.
    #[arg(long, value_name = "WxH", default_value = "512")]
    pub size: String,
    /// Samples per pixel of the recorded render.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub spp: u32,
    /// Tile edge, pixels.
    #[arg(long, value_name = "S", default_value_t = 32)]
    pub tile: u32,
    /// Render threads per worker (one series each).
    #[arg(long, value_delimiter = ',', value_name = "T,...", default_value = "1")]
    pub threads: Vec<usize>,
    /// Largest worker count; runs N = 1, 2, 4, … up to it.
    #[arg(long, value_name = "N", default_value_t = 128)]
    pub max_workers: usize,
    /// Worker counts to run instead of the powers of two.
    #[arg(long, value_delimiter = ',', value_name = "N,...")]
    pub workers: Vec<usize>,
    /// Factor on every recorded tile cost (emulates more samples per pixel).
    #[arg(long, value_name = "F", conflicts_with = "work_seconds")]
    pub cost_scale: Option<f64>,
    /// Scale the tile costs so the frame is this many seconds of one-thread work.
    #[arg(long, value_name = "S")]
    pub work_seconds: Option<f64>,
    /// One-way latency of every link, milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 0.2)]
    pub latency_ms: f64,
    /// Bandwidth of the master's link (shared by all workers), Mbit/s per direction.
    #[arg(long, value_name = "MBIT", default_value_t = 1000.0)]
    pub bandwidth_mbps: f64,
    /// Bandwidth of each worker's link, Mbit/s (default: --bandwidth-mbps).
    #[arg(long, value_name = "MBIT")]
    pub worker_bandwidth_mbps: Option<f64>,
    /// Assignments (batches of tiles) a worker holds: K per thread, or `auto` (its threads
    /// plus what its measured round trip needs), as `parrt master --window` takes.
    #[arg(long, value_name = "K|auto", default_value = "2")]
    pub window: parrt_runtime::window::Window,
    /// Most tiles in one assignment (1: every tile alone, as before batching).
    #[arg(long, value_name = "N", default_value_t = 8)]
    pub max_batch: usize,
    /// Send exact f32 pixels (12 bytes each, what an EXR output needs) instead of the 8-bit
    /// pixels of a PNG output (3 bytes); the identity check then compares f32 bits, not bytes.
    #[arg(long)]
    pub exact_pixels: bool,
    /// Seconds one run may take, start-up included; it is cancelled after that.
    #[arg(long, value_name = "S", default_value_t = 600.0)]
    pub run_timeout: f64,
    /// The recorded render (default: in --out, named after scene, size, spp and tile). Recorded
    /// when missing.
    #[arg(long, value_name = "FILE")]
    pub replay: Option<PathBuf>,
    /// Record again even if the replay file exists.
    #[arg(long)]
    pub record: bool,
    /// One-thread renders recorded; each tile's cost is its least.
    #[arg(long, value_name = "K", default_value_t = 3)]
    pub record_repeat: usize,
    /// Output directory for the table, CSV and plot.
    #[arg(long, value_name = "DIR", default_value = "bench-out/cluster")]
    pub out: PathBuf,
    /// Also write the rows as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Worker executable (default: this one, run as `<exe> worker`).
    #[arg(long, value_name = "EXE")]
    pub worker_exe: Option<PathBuf>,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// One row of the report.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Worker processes.
    pub workers: usize,
    /// Threads per worker.
    pub threads: usize,
    /// Tile edge.
    pub tile: u32,
    /// Measured efficiency t₁·scale / (N·T·t_N).
    pub efficiency: f64,
    /// The simulator's efficiency for this emulated run: the same links, window and tile
    /// costs, the master's measured CPU per tile, and the rest of the emulation's measured CPU
    /// per tile on this machine's cores.
    pub predicted: f64,
    /// The simulator's efficiency for a real cluster with these links: every node its own CPU
    /// (no shared host), the master's measured CPU per tile.
    pub predicted_cluster: f64,
    /// The efficiency the hardware allows: compute / max(compute, link, start-up).
    pub limit: f64,
    /// Which term of the limit binds: "compute", "master link", "start-up" or "emulation CPU".
    pub binding: String,
    /// Assembled image equal, bit for bit, to the recorded one.
    pub identical: bool,
    /// Every tile delivered once (first results summed over workers = tiles).
    pub delivered_once: bool,
    /// Tiles in the image.
    pub tiles: usize,
    /// Valid second results ignored (backups).
    pub duplicates: u64,
    /// Tracing wall time, seconds.
    pub trace_s: f64,
    /// Master CPU per tile during tracing, microseconds (measured, fed to the simulator).
    pub master_us_per_tile: f64,
    /// How much longer the workers took over their tiles than the replayed costs (sleeps
    /// overrun when many processes share few cores): Σ tile seconds / (t₁·scale) − 1.
    pub worker_overrun: f64,
    /// The simulator fed the tile times as the workers measured them (overrun included).
    pub predicted_as_run: f64,
    /// Share of this machine's cores the emulation (master, relay, workers) used while tracing.
    pub emulation_cpu: f64,
    /// Share of this machine's cores busy while tracing (every process, other users' too).
    pub machine_busy: f64,
    /// Of the emulation's CPU while tracing: the master's runtime threads, the rest of this
    /// process (the relay, chiefly), and the worker processes; each a share of the total.
    pub cpu_split: [f64; 3],
    /// Bytes received by the master.
    pub bytes_received: u64,
}

/// The default replay file name for these settings.
fn replay_path(args: &ClusterArgs, label: &str, (width, height): (u32, u32)) -> PathBuf {
    let safe: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    args.out.join(format!(
        "{safe}-{}-spp{}-t{}.replay",
        if width == height {
            width.to_string()
        } else {
            format!("{width}x{height}")
        },
        args.spp,
        args.tile
    ))
}

/// Records a one-thread render of the scene into `path`: the image, and each tile's cost as
/// the least of `repeat` renders. On a shared machine a tile is sometimes preempted mid-way;
/// scaled up (×100 to emulate 100 samples), one such hiccup would become a tile seconds long
/// that no real render has, so the minimum, not the first or the mean, is the tile's cost.
fn record(renderer: &Renderer, tile: u32, repeat: usize, path: &Path) -> anyhow::Result<()> {
    crate::errln!(
        "recording a one-thread render ({repeat} times) into {} ...",
        path.display()
    );
    let opts = SmpOptions {
        threads: 1,
        tile,
        executor: Executor::Queue,
    };
    let first = render_smp(renderer, &opts, &|_, _| {});
    let mut costs = first.tile_seconds.clone();
    for _ in 1..repeat {
        let again = render_smp(renderer, &opts, &|_, _| {});
        for (c, a) in costs.iter_mut().zip(&again.tile_seconds) {
            *c = c.min(*a);
        }
    }
    replay::write(path, tile, &costs, &first.film)?;
    crate::errln!(
        "recorded: t₁ = {:.3} s (first run {:.3} s)",
        costs.iter().sum::<f64>(),
        first.trace_s
    );
    Ok(())
}

/// The worker counts to run.
fn worker_counts(args: &ClusterArgs) -> Vec<usize> {
    if !args.workers.is_empty() {
        return args.workers.clone();
    }
    let mut v = Vec::new();
    let mut n = 1;
    while n <= args.max_workers {
        v.push(n);
        n *= 2;
    }
    if v.last() != Some(&args.max_workers) {
        v.push(args.max_workers);
    }
    v
}

fn bad(msg: String) -> anyhow::Error {
    input_error(anyhow::anyhow!(msg))
}

/// Checks the flags a user gives (once, here).
fn check(args: &ClusterArgs) -> anyhow::Result<()> {
    let counts = worker_counts(args);
    if counts.is_empty() || counts.iter().any(|&n| n == 0 || n > MAX_WORKERS) {
        return Err(bad(format!("worker counts must be in 1..={MAX_WORKERS}")));
    }
    if args.threads.is_empty() || args.threads.iter().any(|&t| t == 0 || t > MAX_THREADS) {
        return Err(bad(format!("--threads must be in 1..={MAX_THREADS}")));
    }
    if args.tile == 0 || args.spp == 0 || args.record_repeat == 0 {
        return Err(bad(
            "--tile, --spp and --record-repeat must be at least 1".into()
        ));
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !(args.latency_ms.is_finite() && args.latency_ms >= 0.0 && args.latency_ms <= 10_000.0) {
        return Err(bad("--latency-ms must be in 0..=10000".into()));
    }
    if !positive(args.bandwidth_mbps) || !args.worker_bandwidth_mbps.is_none_or(positive) {
        return Err(bad("bandwidths must be positive numbers".into()));
    }
    if !(positive(args.run_timeout) && args.run_timeout <= 86_400.0) {
        return Err(bad("--run-timeout must be in (0, 86400] seconds".into()));
    }
    if let Some(s) = args.cost_scale {
        if !(positive(s) && s <= replay::MAX_COST_SCALE) {
            return Err(bad(format!(
                "--cost-scale must be in (0, {}]",
                replay::MAX_COST_SCALE
            )));
        }
    }
    if args.work_seconds.is_some_and(|s| !positive(s)) {
        return Err(bad("--work-seconds must be a positive number".into()));
    }
    Ok(())
}

/// The hardware's lower bound on the tracing time and the term that sets it: the emulated
/// cluster's compute, master link and start-up, and this machine's CPU, which had to run the
/// emulation itself (`emulation_cpu_s` spread over all its cores).
fn limit(
    work: f64,
    cores: usize,
    bytes: f64,
    master_bps: f64,
    latency: f64,
    emulation_cpu_s: f64,
) -> (f64, String) {
    let machine_cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    let terms = [
        (work / cores as f64, "compute"),
        (bytes / master_bps, "master link"),
        (2.0 * latency, "start-up"),
        (emulation_cpu_s / machine_cores, "emulation CPU"),
    ];
    let (t, name) = terms.iter().fold(
        (0.0, "compute"),
        |a, &(t, n)| if t > a.0 { (t, n) } else { a },
    );
    (t, name.to_string())
}

/// Runs `parrt bench cluster`.
pub fn run(args: ClusterArgs) -> anyhow::Result<ExitCode> {
    check(&args)?;
    let (width, height) = parse_size(&args.size)?;
    // Before the recording allocates its film: an unchecked 65536² image aborted on 51.5 GB.
    args.limits.check_image(width, height, args.tile)?;
    let spec = SceneSpec::parse(&args.scene)?;
    let (desc, _) = spec.load(&args.limits.limits())?;
    let mut settings = RenderSettings::new(width, height);
    settings.spp = args.spp;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let path = args
        .replay
        .clone()
        .unwrap_or_else(|| replay_path(&args, &spec.label(), (width, height)));
    if args.record || !path.exists() {
        let renderer = Renderer::new(&desc, &settings).map_err(input_error)?;
        record(&renderer, args.tile, args.record_repeat, &path)?;
    }
    let rec = Replay::open(&path, 1.0).map_err(|e| input_error(anyhow::Error::new(e)))?;
    if (rec.width, rec.height, rec.tile) != (width, height, args.tile) {
        return Err(bad(format!(
            "{} was recorded at {}x{} tile {}, not {}x{} tile {}: use --record",
            path.display(),
            rec.width,
            rec.height,
            rec.tile,
            width,
            height,
            args.tile
        )));
    }
    let reference = rec.film()?;
    let t1: f64 = rec.costs.iter().sum();
    let scale = match (args.cost_scale, args.work_seconds) {
        (Some(s), _) => s,
        (None, Some(w)) => w / t1.max(1e-9),
        (None, None) => 1.0,
    };
    if !(scale > 0.0 && scale <= replay::MAX_COST_SCALE) {
        return Err(bad(format!("the cost scale {scale} is out of range")));
    }
    let work = t1 * scale;
    let master_bps = args.bandwidth_mbps * 1e6 / 8.0;
    let worker_bps = args.worker_bandwidth_mbps.unwrap_or(args.bandwidth_mbps) * 1e6 / 8.0;
    let link = LinkParams {
        latency: Duration::from_secs_f64(args.latency_ms / 1e3),
        worker_bps,
        master_bps,
    };
    let (worker_exe, prefix) = match &args.worker_exe {
        Some(e) => (e.clone(), vec![]),
        None => (
            std::env::current_exe().context("cannot find this executable")?,
            vec!["worker".to_string()],
        ),
    };
    let costs: Vec<f64> = rec.costs.iter().map(|c| c * scale).collect();
    let px: Vec<u64> = rec.tiles.iter().map(|t| t.pixel_count() as u64).collect();
    let setup = Setup {
        args: &args,
        desc,
        settings,
        path,
        reference,
        scale,
        work,
        pixels: px.iter().sum(),
        costs,
        px,
        link,
        worker_exe,
        prefix,
    };
    let mut rows = Vec::new();
    let mut timelines = Vec::new();
    for &threads in &args.threads {
        for &workers in &worker_counts(&args) {
            let (row, timeline) = setup.measure(workers, threads)?;
            rows.push(row);
            timelines.push(timeline);
        }
    }
    let title = format!(
        "Emulated cluster: {} {}×{}, {} spp, tile {} — {}",
        spec.label(),
        width,
        height,
        args.spp,
        args.tile,
        machine()
    );
    let mut md = report(&args, &title, &setup.path, &rec.costs, scale, &rows);
    md += &draw_timelines(&args, &spec.label(), (width, height), &timelines)?;
    std::fs::write(args.out.join("cluster.csv"), csv(&rows)?)?;
    plot(&args, &title, &rows)?;
    if let Some(j) = &args.json {
        std::fs::write(j, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("cannot write {}", j.display()))?;
    }
    let warnings = binding_warnings(work / setup.costs.len().max(1) as f64, &rows);
    md += &warnings
        .iter()
        .map(|w| format!("\n**Warning:** {w}\n"))
        .collect::<String>();
    std::fs::write(args.out.join("cluster.md"), &md)?;
    crate::outln!("{md}");
    for w in &warnings {
        crate::errln!("warning: {w}");
    }
    let all_good = rows.iter().all(|r| r.identical && r.delivered_once);
    if !all_good {
        crate::errln!("some runs did not assemble the recorded image exactly once per tile");
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}
