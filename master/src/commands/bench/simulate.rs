//! `parrt bench simulate`: feeds measured per-tile costs (from `parrt render --tile-costs`) to the
//! discrete-event model of the master/worker schedule and predicts efficiency for 1 to 1024
//! workers and each tile size, with what limits it (tail imbalance, the master, the network).

use crate::exit::input_error;
use crate::plot::{save_chart, Chart, Reference, Series};
use crate::studies::efficiency::aggregate_costs;
use crate::studies::simulate::{simulate, SimParams};
use clap::Args;
use parrt_render::tile::Tile;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `parrt bench simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Per-tile costs measured at one thread (`parrt render --threads 1 --tile 8 --tile-costs F`).
    #[arg(long, value_name = "FILE")]
    pub tile_costs: PathBuf,
    /// Tile sizes to model; each must be a multiple of the measured tile size.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "S,...",
        default_value = "8,16,32,64"
    )]
    pub tiles: Vec<u32>,
    /// Worker counts.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "W,...",
        default_value = "1,2,4,8,16,32,64,128,256,512,1024"
    )]
    pub workers: Vec<usize>,
    /// Render threads per worker.
    #[arg(long, value_name = "T", default_value_t = 1)]
    pub threads: usize,
    /// Tiles in flight per worker (default: 2 × threads).
    #[arg(long, value_name = "K")]
    pub window: Option<usize>,
    /// One-way network latency in milliseconds.
    #[arg(long, value_name = "MS", default_value_t = 0.1)]
    pub latency_ms: f64,
    /// Link bandwidth in megabits per second.
    #[arg(long, value_name = "MBIT", default_value_t = 1000.0)]
    pub bandwidth_mbps: f64,
    /// Master CPU time per tile result in microseconds.
    #[arg(long, value_name = "US", default_value_t = 20.0)]
    pub master_us: f64,
    /// Bytes of the job message (scene) per worker.
    #[arg(long, value_name = "BYTES", default_value_t = 700_000.0)]
    pub scene_bytes: f64,
    /// Seconds each worker needs to build its accelerator.
    #[arg(long, value_name = "S", default_value_t = 0.006)]
    pub build_s: f64,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "bench-out/simulate")]
    pub out: PathBuf,
}

/// What limits a simulated run, in words: the master, the start-up, per-tile round trips the
/// window cannot hide, too few or too uneven tiles for the threads, or nothing much.
fn limit_note(
    p: &SimParams,
    r: &crate::studies::simulate::SimResult,
    costs: &[f64],
    tile: u32,
) -> String {
    let n = r.n;
    let mean = r.work / costs.len().max(1) as f64;
    let round_trip = 2.0 * p.latency_s + p.master_per_tile_s;
    let per_thread_window = p.window as f64 / p.threads.max(1) as f64;
    let ideal = r.work / n as f64;
    let max_tile = costs.iter().cloned().fold(0.0, f64::max);
    let head = format!("at tile {tile}: ");
    let loss = 1.0 - r.efficiency;
    let startup = r.startup_s / r.makespan.max(1e-12);
    head + &if r.efficiency >= 0.97 {
        "balanced".into()
    } else if r.master_utilisation > 0.8 {
        format!("master busy {:.0}%", 100.0 * r.master_utilisation)
    } else if per_thread_window * mean < mean + round_trip {
        format!(
            "round trips: a tile takes {:.0} µs, a round trip {:.0} µs, a window of {} per thread cannot hide it",
            mean * 1e6,
            round_trip * 1e6,
            per_thread_window
        )
    } else if startup >= 0.5 * loss {
        format!(
            "start-up {:.0}% of the time (scene transfer + build)",
            100.0 * startup
        )
    } else if costs.len() < 2 * n || max_tile > 0.5 * ideal {
        format!(
            "tail: {} tiles for {n} threads, largest tile {:.1}× the ideal share",
            costs.len(),
            max_tile / ideal.max(1e-12)
        )
    } else {
        format!(
            "latency: start-up {:.0}% plus the last results' trip back",
            100.0 * startup
        )
    }
}

/// The measured tiles' size and the image's width and height, after checking that every
/// simulated tile size is a whole number of measured tiles and the counts are at least 1.
fn measured_grid(args: &SimulateArgs, fine: &[(Tile, f64)]) -> anyhow::Result<(u32, u32, u32)> {
    let Some(first) = fine.first() else {
        return Err(input_error(anyhow::anyhow!(
            "{}: no tiles",
            args.tile_costs.display()
        )));
    };
    let base = first.0.w.max(first.0.h);
    let width = fine.iter().map(|(t, _)| t.x + t.w).max().unwrap_or(0);
    let height = fine.iter().map(|(t, _)| t.y + t.h).max().unwrap_or(0);
    if args.threads == 0 || args.workers.contains(&0) {
        return Err(input_error(anyhow::anyhow!(
            "--threads and --workers must be at least 1"
        )));
    }
    for &t in &args.tiles {
        if t == 0 || t % base != 0 {
            return Err(input_error(anyhow::anyhow!(
                "tile size {t} is not a multiple of the measured tile size {base}"
            )));
        }
    }
    Ok((base, width, height))
}

/// The model's parameters for `workers` workers: every tile alone (no batches), raster order,
/// no backup copies, so the table shows tile size and window alone.
fn sim_params(args: &SimulateArgs, workers: usize) -> SimParams {
    SimParams {
        workers,
        threads: args.threads,
        window: args.window.unwrap_or(2 * args.threads),
        // Every tile alone: the model of tile size and window, without batches.
        max_batch: 1,
        batch_seconds: parrt_runtime::batch::BATCH_SECONDS,
        latency_s: args.latency_ms / 1e3,
        bandwidth_bps: args.bandwidth_mbps * 1e6 / 8.0,
        master_link_bps: f64::INFINITY,
        host_per_tile_s: 0.0,
        host_cores: 1,
        master_per_tile_s: args.master_us / 1e6,
        // Raster order: the master fills each window in turn.
        rounds: false,
        scene_bytes: args.scene_bytes,
        build_s: args.build_s,
        result_bytes_per_pixel: 12.0,
        // The model of tile size and window alone: no backup copies.
        backups: false,
        message_bytes: 64.0,
        // One frame.
        frames: None,
    }
}

/// The plot of predicted efficiency against render threads, one series per tile size.
fn chart(args: &SimulateArgs, width: u32, height: u32, series: Vec<Series>) -> Chart {
    Chart {
        title: format!(
            "Predicted efficiency: {} ({width}×{height}), {} thread(s)/worker, {} ms, {} Mbit/s \
             (simulated; machine: {})",
            args.tile_costs.file_name().map_or_else(
                || args.tile_costs.display().to_string(),
                |f| f.to_string_lossy().into_owned()
            ),
            args.threads,
            args.latency_ms,
            args.bandwidth_mbps,
            crate::machine::machine()
        ),
        x_label: "render threads n (workers × threads)".into(),
        y_label: "efficiency t₁/(n·tₙ) (1 = ideal)".into(),
        series,
        log_x: true,
        y_range: Some((0.0, 1.05)),
        reference: Some(Reference::ideal_efficiency()),
    }
}

/// Runs `parrt bench simulate`.
pub fn run(args: SimulateArgs) -> anyhow::Result<ExitCode> {
    let fine = crate::cli_args::tile_order::read_costs(&args.tile_costs)?;
    let (base, width, height) = measured_grid(&args, &fine)?;
    crate::cli_args::output::prepare_out_dir(&args.out)?;
    let mut md = String::new();
    let work: f64 = fine.iter().map(|(_, c)| c).sum();
    let _ = writeln!(
        md,
        "# Simulated efficiency\n\nCosts: {} ({width}×{height}, {} tiles of {base} px, t₁ = {work:.4}s). \
         {} thread(s) per worker, window {}, latency {} ms, {} Mbit/s, master {} µs/tile, scene {} bytes, \
         build {} s. Cells: efficiency (makespan s); notes name the limiting factor.\n",
        args.tile_costs.display(),
        fine.len(),
        args.threads,
        args.window.unwrap_or(2 * args.threads),
        args.latency_ms,
        args.bandwidth_mbps,
        args.master_us,
        args.scene_bytes,
        args.build_s
    );
    md.push_str("| workers | n |");
    for t in &args.tiles {
        let _ = write!(md, " tile {t} |");
    }
    md.push_str(" limit (at the best tile size) |\n|---:|---:|");
    for _ in &args.tiles {
        md.push_str("---:|");
    }
    md.push_str("---|\n");
    let mut series: Vec<Series> = args
        .tiles
        .iter()
        .map(|t| Series {
            label: format!("tile {t} px"),
            points: Vec::new(),
            line: true,
        })
        .collect();
    let mut csv = csv::Writer::from_writer(Vec::new());
    csv.write_record([
        "workers",
        "threads",
        "n",
        "tile",
        "makespan_s",
        "efficiency",
        "master_utilisation",
        "startup_s",
        "bytes",
    ])?;
    for &w in &args.workers {
        let n = w * args.threads;
        let _ = write!(md, "| {w} | {n} |");
        // The row's note explains its best tile size: what keeps even that from 1.
        let mut best: Option<(f64, String)> = None;
        for (i, &tile) in args.tiles.iter().enumerate() {
            let list = parrt_render::tile::tiles(width, height, tile);
            let costs = aggregate_costs(&fine, &list, tile);
            let px: Vec<u64> = list.iter().map(|t| t.pixel_count() as u64).collect();
            let p = sim_params(&args, w);
            let r = simulate(&costs, &px, &p);
            let _ = write!(md, " {:.3} ({:.4}s) |", r.efficiency, r.makespan);
            csv.write_record([
                w.to_string(),
                args.threads.to_string(),
                n.to_string(),
                tile.to_string(),
                format!("{:.6}", r.makespan),
                format!("{:.6}", r.efficiency),
                format!("{:.4}", r.master_utilisation),
                format!("{:.6}", r.startup_s),
                format!("{:.0}", r.bytes),
            ])?;
            series[i].points.push((n as f64, r.efficiency));
            if best.as_ref().is_none_or(|(e, _)| r.efficiency > *e) {
                let note = limit_note(&p, &r, &costs, tile);
                best = Some((r.efficiency, note));
            }
        }
        let note = best.map(|(_, n)| n).unwrap_or_default();
        let _ = writeln!(md, " {note} |");
    }
    let chart = chart(&args, width, height, series);
    save_chart(
        &chart,
        &args.out.join("simulate.svg"),
        &args.out.join("simulate.png"),
    )?;
    let _ = writeln!(md, "\n![simulate](simulate.png)");
    std::fs::write(args.out.join("simulate.md"), &md)?;
    std::fs::write(args.out.join("simulate.csv"), csv.into_inner()?)?;
    crate::outln!("{md}");
    Ok(ExitCode::SUCCESS)
}
