//! `parrt bench cluster`: an emulated cluster, real everywhere but the tracing (issue 15). A
//! one-thread render of the scene is recorded once (per-tile costs and pixels); then, for N = 1,
//! 2, 4, … workers × T threads, N real worker processes replay it against a real master over
//! real TCP on 127.0.0.1, each behind an emulated LAN link ([`crate::studies::cluster::link`]). Reports measured
//! efficiency, the schedule simulator's prediction and the hardware's limit, and checks every
//! assembled image bit for bit against the recorded one.

use crate::cli_args::{LimitArgs, SceneSpec};
use crate::exit::input_error;
use crate::machine::machine;
use crate::plot::{save_chart, Chart, Reference, Series};
use crate::studies::cluster::emulate::{self, EmulatedRun};
use crate::studies::cluster::link::LinkParams;
use anyhow::Context;
use clap::Args;
use parrt::render::Renderer;
use parrt::settings::RenderSettings;
use parrt::simulate::{simulate, SimParams};
use parrt::smp::{render_smp, Executor, SmpOptions};
use parrt_worker::replay::{self, Replay};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// Most worker processes one run may start: the cap every master that starts local workers
/// keeps (`render --workers` too).
pub const MAX_WORKERS: usize = parrt_runtime::options::MAX_SPAWNED_WORKERS;
/// Most threads per worker.
pub const MAX_THREADS: usize = 256;

/// Arguments of `parrt bench cluster`.
#[derive(Debug, Args)]
pub struct ClusterArgs {
    /// Scene: an NFF file or NAME[:SIZE].
    #[arg(value_name = "SCENE", default_value = "mount")]
    pub scene: String,
    /// Image size in pixels, N for NxN (this study renders square images).
    #[arg(long, value_name = "PX", default_value_t = 512)]
    pub size: u32,
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
    pub window: parrt::window::Window,
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
fn replay_path(args: &ClusterArgs, label: &str) -> PathBuf {
    let safe: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    args.out.join(format!(
        "{safe}-{}-spp{}-t{}.replay",
        args.size, args.spp, args.tile
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
    if args.size == 0 || args.tile == 0 || args.spp == 0 || args.record_repeat == 0 {
        return Err(bad(
            "--size, --tile, --spp and --record-repeat must be at least 1".into(),
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

/// A mean tile cost below this (seconds) measures wake-ups, timer slack and the emulation's own
/// CPU per message more than a cluster's schedule.
pub const SHORT_TILE_S: f64 = 0.002;
/// Machine busy above this share during a run: the emulation competes with itself.
pub const BUSY_MACHINE: f64 = 0.8;

/// What makes the table measure this machine rather than a cluster, in words (empty: nothing).
fn binding_warnings(mean_tile_s: f64, rows: &[Row]) -> Vec<String> {
    let mut w = Vec::new();
    if mean_tile_s < SHORT_TILE_S {
        w.push(format!(
            "tiles average {:.2} ms of work: at this size the per-message costs of the \
             emulation (process wake-ups, timer slack, the relay) weigh as much as the work, and \
             the efficiencies say more about this machine than about a cluster; give the frame \
             a cluster's work with --work-seconds (e.g. --work-seconds 60)",
            mean_tile_s * 1e3
        ));
    }
    let busy: Vec<String> = rows
        .iter()
        .filter(|r| r.machine_busy > BUSY_MACHINE)
        .map(|r| {
            format!(
                "{}×{} ({:.0}%)",
                r.workers,
                r.threads,
                100.0 * r.machine_busy
            )
        })
        .collect();
    if !busy.is_empty() {
        w.push(format!(
            "this machine was busy above {:.0}% during {}: the emulation competes with itself \
             for its cores, so those rows bound this host, not the schedule",
            100.0 * BUSY_MACHINE,
            busy.join(", ")
        ));
    }
    w
}

/// Runs `parrt bench cluster`.
pub fn run(args: ClusterArgs) -> anyhow::Result<ExitCode> {
    check(&args)?;
    // Before the recording allocates its film (issue 31 item 11: 65536² aborted on 51.5 GB).
    args.limits.check_image(args.size, args.size, args.tile)?;
    let spec = SceneSpec::parse(&args.scene)?;
    let (desc, _) = spec.load(&args.limits.limits())?;
    let mut settings = RenderSettings::new(args.size, args.size);
    settings.spp = args.spp;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let path = args
        .replay
        .clone()
        .unwrap_or_else(|| replay_path(&args, &spec.label()));
    if args.record || !path.exists() {
        let renderer = Renderer::new(&desc, &settings).map_err(input_error)?;
        record(&renderer, args.tile, args.record_repeat, &path)?;
    }
    let rec = Replay::open(&path, 1.0).map_err(|e| input_error(anyhow::Error::new(e)))?;
    if (rec.width, rec.height, rec.tile) != (args.size, args.size, args.tile) {
        return Err(bad(format!(
            "{} was recorded at {}x{} tile {}, not {}x{} tile {}: use --record",
            path.display(),
            rec.width,
            rec.height,
            rec.tile,
            args.size,
            args.size,
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
    let pixels: u64 = px.iter().sum();
    let mut rows = Vec::new();
    let mut timelines = Vec::new();
    for &threads in &args.threads {
        for &workers in &worker_counts(&args) {
            crate::errln!("{workers} workers × {threads} threads ...");
            let recorder = std::sync::Arc::new(crate::timeline::Recorder::new());
            let m = emulate::run(
                &desc,
                &settings,
                &EmulatedRun {
                    workers,
                    threads,
                    tile: args.tile,
                    window: args.window,
                    max_batch: args.max_batch,
                    pixel_format: if args.exact_pixels {
                        parrt::protocol::PixelFormat::F32
                    } else {
                        parrt::protocol::PixelFormat::Rgb8
                    },
                    link,
                    replay: path.clone(),
                    cost_scale: scale,
                    worker_exe: worker_exe.clone(),
                    worker_prefix: prefix.clone(),
                    timeout: Duration::from_secs_f64(args.run_timeout),
                    observers: parrt_runtime::observer::Observers(vec![recorder.clone()]),
                },
            )
            .with_context(|| format!("{workers} workers × {threads} threads"))?;
            timelines.push((workers, threads, recorder, m.trace_s));
            let cores = workers * threads;
            let machine_cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            let master_per_tile = m.master_cpu_s / m.tiles.max(1) as f64;
            let p = SimParams {
                workers,
                threads,
                // The master's rule, fed the round trip this link and master give a result.
                window: args.window.assignments(
                    threads,
                    Some(
                        2.0 * args.latency_ms / 1e3
                            + master_per_tile
                            + (m.own_cpu_s - m.master_cpu_s).max(0.0) / m.tiles.max(1) as f64,
                    ),
                    work / costs.len().max(1) as f64,
                ),
                max_batch: args.max_batch,
                batch_seconds: parrt::batch::BATCH_SECONDS,
                latency_s: args.latency_ms / 1e3,
                bandwidth_bps: worker_bps,
                master_link_bps: master_bps,
                master_per_tile_s: master_per_tile,
                // Everything else the emulation spent per result, on this machine's cores.
                host_per_tile_s: (m.own_cpu_s - m.master_cpu_s).max(0.0) / m.tiles.max(1) as f64,
                host_cores: machine_cores,
                // Every worker is ready before the first tile: the trace has no start-up.
                // Raster order: the master fills each window in turn.
                rounds: false,
                scene_bytes: 0.0,
                build_s: 0.0,
                result_bytes_per_pixel: m.bytes_received as f64 / pixels.max(1) as f64,
                message_bytes: 0.0,
                // The master's default: idle workers take copies of tiles out once the queue is empty.
                backups: true,
            };
            let sim = simulate(&costs, &px, &p);
            let as_run = simulate(&m.tile_seconds, &px, &p);
            let cluster = simulate(
                &costs,
                &px,
                &SimParams {
                    host_per_tile_s: 0.0,
                    ..p.clone()
                },
            );
            let ran: f64 = m.tile_seconds.iter().sum();
            let (bound, binding) = limit(
                work,
                cores,
                m.bytes_received as f64,
                master_bps,
                args.latency_ms / 1e3,
                m.own_cpu_s,
            );
            let busy = |cpu: f64| cpu / (machine_cores as f64 * m.trace_s.max(1e-12));
            let row = Row {
                workers,
                threads,
                tile: args.tile,
                efficiency: work / (cores as f64 * m.trace_s.max(1e-12)),
                predicted: sim.efficiency,
                predicted_cluster: cluster.efficiency,
                limit: (work / cores as f64) / bound.max(1e-12),
                binding,
                identical: if args.exact_pixels {
                    m.film == reference
                } else {
                    m.film.to_rgb8() == reference.to_rgb8()
                },
                delivered_once: m.delivered == m.tiles as u64,
                tiles: m.tiles,
                duplicates: m.duplicates,
                trace_s: m.trace_s,
                master_us_per_tile: master_per_tile * 1e6,
                worker_overrun: ran / work - 1.0,
                emulation_cpu: busy(m.own_cpu_s),
                machine_busy: busy(m.machine_busy_s),
                cpu_split: {
                    let total = m.own_cpu_s.max(1e-12);
                    let relay = (m.bench_process_cpu_s - m.master_cpu_s).max(0.0);
                    let workers = (m.own_cpu_s - m.bench_process_cpu_s).max(0.0);
                    [m.master_cpu_s / total, relay / total, workers / total]
                },
                predicted_as_run: as_run.efficiency * work / ran.max(1e-12),
                bytes_received: m.bytes_received,
            };
            crate::errln!(
                "  e = {:.3}, predicted {:.3} ({:.3} from the tile times as run, workers overran {:.1}%), limit {:.3} ({}), emulation CPU {:.0}% (master {:.0}%, relay {:.0}%, workers {:.0}% of it), machine busy {:.0}%, identical {}",
                row.efficiency,
                row.predicted,
                row.predicted_as_run,
                100.0 * row.worker_overrun,
                row.limit,
                row.binding,
                100.0 * row.emulation_cpu,
                100.0 * row.cpu_split[0],
                100.0 * row.cpu_split[1],
                100.0 * row.cpu_split[2],
                100.0 * row.machine_busy,
                row.identical
            );
            rows.push(row);
        }
    }
    let title = format!(
        "Emulated cluster: {} {}×{}, {} spp, tile {} — {}",
        spec.label(),
        args.size,
        args.size,
        args.spp,
        args.tile,
        machine()
    );
    let mut md = report(&args, &title, &path, &rec.costs, scale, &rows);
    md += &draw_timelines(&args, &spec.label(), &timelines)?;
    std::fs::write(args.out.join("cluster.csv"), csv(&rows)?)?;
    plot(&args, &title, &rows)?;
    if let Some(j) = &args.json {
        std::fs::write(j, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("cannot write {}", j.display()))?;
    }
    let warnings = binding_warnings(work / costs.len().max(1) as f64, &rows);
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

fn report(
    args: &ClusterArgs,
    title: &str,
    replay: &Path,
    costs: &[f64],
    scale: f64,
    rows: &[Row],
) -> String {
    let t1: f64 = costs.iter().sum();
    let largest = costs.iter().cloned().fold(0.0, f64::max);
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# {title}\n\nCommand: `parrt {}`. Replay {} (t₁ = {t1:.3} s recorded at one thread, × {scale:.3} \
         = {:.1} s of work; {} tiles, the largest {:.1}× the mean). Link: {} ms one way, master {} Mbit/s shared, workers {} Mbit/s each; \
         window {} (assignments per thread, or auto: one per thread plus the round trip's prefetch). e = t₁·scale/(N·T·t_N), t_N from the first tile handed out (every \
         worker ready) to the last result in. Predicted: `parrt::simulate` with the measured master \
         CPU per tile and bytes per pixel, and the rest of the emulation's measured CPU per tile \
         queued on this machine's cores; cluster predicted: the same without that shared host (every \
         node its own CPU, as in a real cluster). Limit: compute/cores ÷ max(compute/cores, bytes/master \
         link, 2 × latency, this machine's CPU used by the emulation / its cores). Emulation CPU: \
         share of this machine's cores the master, relay and workers used while tracing; machine busy: \
         every process's (others' too). Near 100%, the run measures this machine, not the cluster.\n",
        std::env::args().skip(1).collect::<Vec<_>>().join(" "),
        replay.display(),
        t1 * scale,
        costs.len(),
        largest * costs.len() as f64 / t1.max(1e-12),
        args.latency_ms,
        args.bandwidth_mbps,
        args.worker_bandwidth_mbps.unwrap_or(args.bandwidth_mbps),
        args.window
    );
    md.push_str(
        "| workers | threads | cores | t_N s | efficiency | predicted | Δ points | cluster predicted | limit | binds | \
         master µs/tile | emulation CPU | machine busy | MB in | identical | once | dup |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---|---|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:+.1} | {:.3} | {:.3} | {} | {:.0} | {:.0}% | {:.0}% | {:.1} | {} | {} | {} |",
            r.workers,
            r.threads,
            r.workers * r.threads,
            r.trace_s,
            r.efficiency,
            r.predicted,
            100.0 * (r.predicted - r.efficiency),
            r.predicted_cluster,
            r.limit,
            r.binding,
            r.master_us_per_tile,
            100.0 * r.emulation_cpu,
            100.0 * r.machine_busy,
            r.bytes_received as f64 / 1e6,
            if r.identical { "yes" } else { "**no**" },
            if r.delivered_once { "yes" } else { "**no**" },
            r.duplicates
        );
    }
    let _ = writeln!(md, "\n![cluster](cluster.png)");
    md
}

/// `cluster.csv`: a record per run.
fn csv(rows: &[Row]) -> anyhow::Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "workers",
        "threads",
        "tile",
        "trace_s",
        "efficiency",
        "predicted",
        "predicted_cluster",
        "limit",
        "binding",
        "master_us_per_tile",
        "emulation_cpu",
        "machine_busy",
        "bytes_received",
        "identical",
        "delivered_once",
        "duplicates",
    ])?;
    for r in rows {
        w.write_record([
            r.workers.to_string(),
            r.threads.to_string(),
            r.tile.to_string(),
            format!("{:.6}", r.trace_s),
            format!("{:.6}", r.efficiency),
            format!("{:.6}", r.predicted),
            format!("{:.6}", r.predicted_cluster),
            format!("{:.6}", r.limit),
            r.binding.clone(),
            format!("{:.2}", r.master_us_per_tile),
            format!("{:.3}", r.emulation_cpu),
            format!("{:.3}", r.machine_busy),
            r.bytes_received.to_string(),
            r.identical.to_string(),
            r.delivered_once.to_string(),
            r.duplicates.to_string(),
        ])?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// Draws the timeline of the run with the most workers at each thread count (and of one
/// worker, for contrast, when it differs); returns the Markdown that shows them.
fn draw_timelines(
    args: &ClusterArgs,
    scene: &str,
    runs: &[(usize, usize, std::sync::Arc<crate::timeline::Recorder>, f64)],
) -> anyhow::Result<String> {
    let mut md = String::new();
    for &threads in &args.threads {
        let of: Vec<_> = runs.iter().filter(|r| r.1 == threads).collect();
        let (Some(most), Some(fewest)) =
            (of.iter().max_by_key(|r| r.0), of.iter().min_by_key(|r| r.0))
        else {
            continue;
        };
        // A timeline has a row per worker thread: draw it while it stays readable.
        let mut pick = vec![most];
        if fewest.0 != most.0 {
            pick.insert(0, fewest);
        }
        for (workers, threads, rec, trace_s) in pick.into_iter().map(|r| (r.0, r.1, &r.2, r.3)) {
            if workers * threads > 128 {
                continue;
            }
            let job = crate::timeline::Job {
                scene,
                width: args.size,
                height: args.size,
                tile_size: args.tile,
            };
            let tl = rec.timeline(&job, trace_s);
            let stem = format!("timeline-{workers}x{threads}");
            // The data behind the plot, for whoever wants to look closer.
            tl.write(&args.out.join(format!("{stem}.json")))?;
            md += &crate::timeline::plot::save_figure(
                &tl,
                &args.out,
                &stem,
                &format!("{workers} emulated workers × {threads} threads, replayed"),
            )?;
        }
    }
    Ok(md)
}

fn plot(args: &ClusterArgs, title: &str, rows: &[Row]) -> anyhow::Result<()> {
    let mut series = Vec::new();
    for &t in &args.threads {
        let pick = |f: &dyn Fn(&Row) -> f64| -> Vec<(f64, f64)> {
            rows.iter()
                .filter(|r| r.threads == t)
                .map(|r| ((r.workers * r.threads) as f64, f(r)))
                .collect()
        };
        series.push(Series {
            label: format!("measured, {t} thread(s)/worker"),
            points: pick(&|r| r.efficiency),
            line: true,
        });
        series.push(Series {
            label: format!("simulated emulation, {t} thread(s)/worker"),
            points: pick(&|r| r.predicted),
            line: true,
        });
        series.push(Series {
            label: format!("simulated real cluster, {t} thread(s)/worker"),
            points: pick(&|r| r.predicted_cluster),
            line: true,
        });
        series.push(Series {
            label: format!("hardware limit, {t} thread(s)/worker"),
            points: pick(&|r| r.limit),
            line: true,
        });
    }
    let chart = Chart {
        title: title.to_string(),
        x_label: "render threads n (workers × threads per worker)".into(),
        y_label: "efficiency t₁/(n·tₙ) (1 = ideal)".into(),
        series,
        log_x: true,
        y_range: Some((0.0, 1.05)),
        reference: Some(Reference::ideal_efficiency()),
    };
    save_chart(
        &chart,
        &args.out.join("cluster.svg"),
        &args.out.join("cluster.png"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_tiles_and_a_busy_machine_are_said() {
        assert!(binding_warnings(0.05, &[]).is_empty());
        let w = binding_warnings(0.0007, &[]);
        assert_eq!(w.len(), 1);
        assert!(
            w[0].contains("0.70 ms") && w[0].contains("--work-seconds"),
            "{}",
            w[0]
        );
    }

    #[test]
    fn csv_keeps_its_columns_and_number_formats() {
        let row = Row {
            workers: 1,
            threads: 1,
            tile: 16,
            efficiency: 0.998003,
            predicted: 0.999993,
            predicted_cluster: 0.999996,
            limit: 1.0,
            binding: "compute".into(),
            identical: true,
            delivered_once: true,
            tiles: 256,
            duplicates: 0,
            trace_s: 128.256123,
            master_us_per_tile: 116.28,
            worker_overrun: 0.0,
            predicted_as_run: 0.99,
            emulation_cpu: 0.008,
            machine_busy: 0.306,
            cpu_split: [0.2, 0.3, 0.5],
            bytes_received: 3314291,
        };
        assert_eq!(
            csv(&[row]).expect("writes"),
            "workers,threads,tile,trace_s,efficiency,predicted,predicted_cluster,limit,binding,\
             master_us_per_tile,emulation_cpu,machine_busy,bytes_received,identical,\
             delivered_once,duplicates\n\
             1,1,16,128.256123,0.998003,0.999993,0.999996,1.000000,compute,116.28,0.008,0.306,\
             3314291,true,true,0\n"
        );
    }
}
