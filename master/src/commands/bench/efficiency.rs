//! `parrt bench efficiency`: the paper's experiment in one command. Measures t₁ and tₙ (median
//! of K runs, same build and settings) for every accelerator, executor, tile size and thread
//! count, and writes the paper-shaped tables (rows threads, columns tile sizes; efficiency of the
//! tracing phase and of the whole render) as Markdown and CSV, plots like its Figures 2 and 3,
//! and a check of the schedule simulator against the measured runs. With `--frames N` every
//! run renders an orbit of N frames as one job instead (its `sequence` module).

mod sequence;

use crate::cli_args::{AccelArg, ExecutorArg, LimitArgs, SceneSpec};
use crate::exit::input_error;
use crate::machine::machine;
use crate::plot::{range_from_zero, save_chart, Chart, Reference, Series};
use crate::studies::efficiency::{median, EfficiencyTable};
use crate::studies::simulate::{simulate, SimParams};
use crate::timeline::plot::save_figure;
use anyhow::Context;
use clap::{Args, ValueEnum};
use parrt_render::description::SceneDescription;
use parrt_render::render::Renderer;
use parrt_render::settings::{AccelKind, RenderSettings};
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Execution modes compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    /// One process, N threads.
    Smp,
    /// A master and N local worker processes of one thread each, over TCP on loopback.
    Distributed,
}

/// Arguments of `parrt bench efficiency`.
#[derive(Debug, Args)]
pub struct EfficiencyArgs {
    /// Scene: an NFF file or NAME[:SIZE] (default: mount, the paper's test scene).
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE", default_value = "mount")]
    pub scene: String,
    /// Thread counts (rows). Counts above the core count are marked oversubscribed.
    #[arg(long, value_delimiter = ',', value_name = "N,...")]
    pub threads: Vec<usize>,
    /// Tile sizes (columns).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "S,...",
        default_value = "8,16,32,64"
    )]
    pub tiles: Vec<u32>,
    /// Accelerators.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "A,...",
        value_enum,
        default_value = "bvh,grid"
    )]
    pub accel: Vec<AccelArg>,
    /// Modes.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "M,...",
        default_value = "smp"
    )]
    pub mode: Vec<Mode>,
    /// SMP executors (queue is the paper's; guided removes its tile-size trade-off).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "E,...",
        value_enum,
        default_value = "queue,rayon,guided"
    )]
    pub executors: Vec<ExecutorArg>,
    /// Image sizes (square): the paper's 512, and a larger one where runs are short.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "PX,...",
        default_value = "512,1024"
    )]
    pub sizes: Vec<u32>,
    /// Frames of each run: above 1, every run renders an orbit of the scene in this many frames
    /// as one job (a sequence: tiles of the next frame fill a frame's tail), and the times are
    /// the whole sequence's; the CSV's `frames` column says so.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub frames: usize,
    /// The orbit's degrees over the frames (with `--frames` above 1).
    #[arg(
        long,
        value_name = "DEGREES",
        default_value_t = 360.0,
        allow_negative_numbers = true
    )]
    pub orbit: f64,
    /// Runs per measurement; the median is used.
    #[arg(long, value_name = "K", default_value_t = 3)]
    pub repeat: usize,
    /// Output directory for tables and plots.
    #[arg(long, value_name = "DIR", default_value = "bench-out/efficiency")]
    pub out: PathBuf,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// Median tracing time of `repeat` distributed renders through `n` local one-thread workers,
/// with the mean bytes on the wire and scene transfer time.
fn time_distributed(
    desc: &parrt_render::description::SceneDescription,
    settings: &RenderSettings,
    n: usize,
    tile: u32,
    repeat: usize,
) -> anyhow::Result<(f64, f64, f64)> {
    let mut ts = Vec::new();
    let (mut bytes, mut transfer) = (0.0, 0.0);
    for _ in 0..repeat {
        let r = run_distributed(desc, settings, n, tile, None)?;
        ts.push(r.trace_s);
        bytes = (r.bytes_sent + r.bytes_received) as f64;
        transfer = r.scene_transfer_s;
    }
    Ok((median(&ts), bytes, transfer))
}

/// One distributed render through `n` local one-thread workers, recorded by `recorder`.
fn run_distributed(
    desc: &parrt_render::description::SceneDescription,
    settings: &RenderSettings,
    n: usize,
    tile: u32,
    recorder: Option<std::sync::Arc<crate::timeline::Recorder>>,
) -> anyhow::Result<parrt_runtime::DistResult> {
    use parrt_runtime::{Job, MasterConfig};
    let mut config = MasterConfig {
        observers: parrt_runtime::observer::Observers(
            recorder
                .into_iter()
                .map(|r| r as std::sync::Arc<dyn parrt_runtime::observer::Observer>)
                .collect(),
        ),
        ..MasterConfig::default()
    };
    crate::commands::distributed::local_workers(&mut config, n, 1);
    config.schedule.tile = tile;
    config.schedule.min_workers = n;
    // As `parrt render --workers N -o out.png` runs: 8-bit pixels on the wire.
    config.schedule.pixel_format = parrt_protocol::PixelFormat::Rgb8;
    let job = Job::<parrt_runtime::DistError>::ready(desc.clone(), settings.clone());
    parrt_runtime::run(&config, job, &mut |_| Ok(None), None)
        .map(|done| done.result)
        .context("distributed run failed")
}

/// The run drawn as a timeline: the most threads, at a 32-pixel tile if measured (the
/// default), else the smallest tile measured.
fn timeline_case(threads: &[usize], tiles: &[u32]) -> (usize, u32) {
    let n = threads.iter().copied().max().unwrap_or(1);
    let tile = if tiles.contains(&32) {
        32
    } else {
        tiles.iter().copied().min().unwrap_or(32)
    };
    (n, tile)
}

/// What the run will do, said before it starts: how many renders, and the files it writes.
fn plan(args: &EfficiencyArgs, threads: &[usize]) -> String {
    let (tiles, reps) = (args.tiles.len(), args.repeat);
    let multi = threads.iter().filter(|&&n| n > 1).count();
    let smp = if args.mode.contains(&Mode::Smp) {
        args.executors.len() * (tiles * (1 + multi) * reps + 1)
    } else {
        0
    };
    let dist = if args.mode.contains(&Mode::Distributed) {
        tiles * threads.len() * reps + 1
    } else {
        0
    };
    let cases = args.sizes.len() * args.accel.len();
    let renders = cases * (smp + dist);
    // Per case: the chart and a timeline per executor and mode (SVG and PNG each).
    let timelines = if args.mode.contains(&Mode::Smp) {
        args.executors.len()
    } else {
        0
    } + usize::from(args.mode.contains(&Mode::Distributed));
    let files = 2 + cases * 2 * (1 + timelines);
    format!(
        "bench efficiency: {renders} renders ({} sizes × {} accelerators, {} tile sizes, {reps} \
         runs each); at 512² and up this takes minutes. Writes {files} files (tables, CSV, \
         plots, timelines) to {}",
        args.sizes.len(),
        args.accel.len(),
        tiles,
        args.out.display()
    )
}

/// One size and accelerator of the study: what its measurements share, and where they go.
struct Case<'a> {
    args: &'a EfficiencyArgs,
    /// The orbit every run renders (`--frames` above 1), else `None`: one frame.
    sequence: Option<&'a parrt_render::sequence::Sequence>,
    label: String,
    threads: &'a [usize],
    cores: usize,
    size: u32,
    accel: AccelKind,
    /// Parse and build seconds, added to every time for the whole-render tables.
    pre: f64,
}

impl Case<'_> {
    /// The tracing and whole-render tables of one mode, titled `title`.
    fn tables(&self, title: &str) -> (EfficiencyTable, EfficiencyTable) {
        let frames = self.sequence.map_or(1, |s| s.len());
        let title = match frames {
            1 => title.to_string(),
            n => format!("{title}, {n} frames"),
        };
        let table = |what: &str| {
            EfficiencyTable::new(
                format!("{title}: {what}"),
                self.threads.to_vec(),
                self.args.tiles.clone(),
                self.cores,
            )
            .with_frames(frames)
        };
        (table("tracing"), table("whole render"))
    }

    /// The timeline's description of a render of this case at `tile`.
    fn job(&self, tile: u32) -> crate::timeline::Job<'_> {
        crate::timeline::Job {
            scene: &self.label,
            width: self.size,
            height: self.size,
            tile_size: tile,
        }
    }

    /// The plot's series of `trace`: one per thread count above 1, efficiency against tile.
    fn series(&self, name: &str, trace: &EfficiencyTable) -> Vec<Series> {
        self.threads
            .iter()
            .filter(|&&n| n > 1)
            .map(|&n| Series {
                label: format!("{name} n={n}"),
                points: self
                    .args
                    .tiles
                    .iter()
                    .filter_map(|&t| trace.get(n, t).map(|c| (t as f64, c.efficiency)))
                    .collect(),
                line: true,
            })
            .collect()
    }

    /// Appends the two tables to the report and the CSV.
    fn write_tables(
        md: &mut String,
        csv: &mut csv::Writer<Vec<u8>>,
        trace: &EfficiencyTable,
        whole: &EfficiencyTable,
    ) -> anyhow::Result<()> {
        md.push_str(&trace.to_markdown());
        md.push('\n');
        md.push_str(&whole.to_markdown());
        md.push('\n');
        trace.write_csv(csv)?;
        whole.write_csv(csv)?;
        Ok(())
    }

    /// The SMP executor `ex` at every tile size and thread count, a timeline at the most
    /// threads, and (for the paper's queue) the schedule model's prediction beside each
    /// measurement, as rows of `sim_lines`.
    fn smp(
        &self,
        renderer: &Renderer,
        ex: Executor,
        out: &mut Report,
        sim_lines: &mut String,
    ) -> anyhow::Result<Vec<Series>> {
        if let Some(seq) = self.sequence {
            return self.smp_sequence(seq, renderer.settings(), ex, out);
        }
        let (size, accel, repeat) = (self.size, self.accel, self.args.repeat);
        let render = |n: usize, tile: u32| {
            let options = SmpOptions {
                threads: n,
                tile,
                executor: ex,
            };
            render_smp(renderer, &options, &|_, _| {})
        };
        let time = |n: usize, tile: u32| -> (f64, Vec<f64>) {
            let mut ts = Vec::new();
            let mut costs = Vec::new();
            for _ in 0..repeat {
                let res = render(n, tile);
                ts.push(res.trace_s);
                costs = res.tile_seconds;
            }
            (median(&ts), costs)
        };
        let title = format!("{} {size}px {accel:?} smp {}", self.label, ex.name());
        let (mut trace, mut whole) = self.tables(&title);
        for &tile in &self.args.tiles {
            let (t1, costs1) = time(1, tile);
            for &n in self.threads {
                let tn = if n == 1 { t1 } else { time(n, tile).0 };
                trace.set(n, tile, t1, tn);
                whole.set(n, tile, self.pre + t1, self.pre + tn);
                if ex == Executor::Queue && n > 1 {
                    // The simulator's prediction for the paper's queue: one worker with n
                    // threads, every tile queued locally, no network.
                    let list = parrt_render::tile::tiles(size, size, tile);
                    let px: Vec<u64> = list.iter().map(|t| t.pixel_count() as u64).collect();
                    let mut p = SimParams::ideal(1, n);
                    p.window = list.len();
                    let sim = simulate(&costs1, &px, &p);
                    let _ = writeln!(
                        sim_lines,
                        "| {tile} | {n} | {:.4} | {:.4} | {:+.1}% |",
                        tn,
                        sim.makespan,
                        100.0 * (sim.makespan - tn) / tn
                    );
                }
            }
        }
        Self::write_tables(&mut out.md, &mut out.csv, &trace, &whole)?;
        // Where the time went: one more run at the most threads, drawn as a timeline.
        let (n, tile) = timeline_case(self.threads, &self.args.tiles);
        let res = render(n, tile);
        let tl =
            crate::timeline::Timeline::from_smp(&self.job(tile), n, &res.tile_spans, res.trace_s);
        let stem = format!("timeline-{size}-{accel:?}-{}", ex.name()).to_lowercase();
        out.md.push_str(&save_figure(
            &tl,
            &self.args.out,
            &stem,
            &format!("{} executor, {n} threads", ex.name()),
        )?);
        Ok(self.series(ex.name(), &trace))
    }

    /// Local worker processes of one thread each at every tile size and count, the bytes the
    /// protocol moved, and a timeline at the most workers.
    fn distributed(
        &self,
        desc: &SceneDescription,
        settings: &RenderSettings,
        out: &mut Report,
    ) -> anyhow::Result<Vec<Series>> {
        if let Some(seq) = self.sequence {
            return self.distributed_sequence(seq, settings, out);
        }
        let (size, accel) = (self.size, self.accel);
        let title = format!(
            "{} {size}px {accel:?} distributed (n workers × 1 thread, loopback)",
            self.label
        );
        let (mut trace, mut whole) = self.tables(&title);
        let mut overhead = String::new();
        for &tile in &self.args.tiles {
            let mut t1 = None;
            for &n in self.threads {
                let (tn, bytes, transfer) =
                    time_distributed(desc, settings, n, tile, self.args.repeat)?;
                let t1v = *t1.get_or_insert(tn);
                trace.set(n, tile, t1v, tn);
                whole.set(n, tile, self.pre + t1v, self.pre + tn);
                let tiles = parrt_render::tile::tiles(size, size, tile).len() as f64;
                let _ = writeln!(
                    overhead,
                    "| {tile} | {n} | {:.0} | {:.2} ms |",
                    bytes / tiles,
                    transfer * 1e3
                );
            }
        }
        Self::write_tables(&mut out.md, &mut out.csv, &trace, &whole)?;
        let (n, tile) = timeline_case(self.threads, &self.args.tiles);
        let rec = std::sync::Arc::new(crate::timeline::Recorder::new());
        let r = run_distributed(desc, settings, n, tile, Some(rec.clone()))?;
        let tl = rec.timeline(&self.job(tile), r.trace_s);
        let stem = format!("timeline-{size}-{accel:?}-distributed").to_lowercase();
        out.md.push_str(&save_figure(
            &tl,
            &self.args.out,
            &stem,
            &format!("{n} local workers × 1 thread"),
        )?);
        let _ = writeln!(
            out.md,
            "Protocol overhead (distributed):\n\n| tile | workers | bytes on the wire per tile (scene included) | scene transfer |\n|---:|---:|---:|---:|\n{overhead}"
        );
        Ok(self.series("distributed", &trace))
    }

    /// The plot of tracing efficiency against tile size, saved beside the report.
    fn chart(&self, series: Vec<Series>, md: &mut String) -> anyhow::Result<()> {
        let (size, accel) = (self.size, self.accel);
        let stem = format!("efficiency-{size}-{accel:?}").to_lowercase();
        let chart = Chart {
            title: format!(
                "{} {size}×{size} {accel:?}: tracing efficiency on {}",
                self.label,
                machine()
            ),
            x_label: "tile edge (pixels)".into(),
            y_label: "efficiency t1/(n·tn) (1 = ideal)".into(),
            y_range: Some(range_from_zero(&series, 1.0)),
            series,
            log_x: true,
            reference: Some(Reference::ideal_efficiency()),
        };
        save_chart(
            &chart,
            &self.args.out.join(format!("{stem}.svg")),
            &self.args.out.join(format!("{stem}.png")),
        )?;
        let _ = writeln!(md, "![{stem}]({stem}.png)\n");
        Ok(())
    }
}

/// What the study writes: the Markdown report and the CSV of every cell.
struct Report {
    md: String,
    csv: csv::Writer<Vec<u8>>,
}

/// Builds the renderer `repeat` times (the build is timed too) and keeps the last; returns it
/// with the median build seconds.
fn build(
    desc: &SceneDescription,
    settings: &RenderSettings,
    repeat: usize,
) -> anyhow::Result<(Renderer, f64)> {
    let mut builds = Vec::new();
    let mut renderer = Renderer::new(desc, settings).map_err(input_error)?;
    builds.push(renderer.build_info().build_s);
    for _ in 1..repeat {
        renderer = Renderer::new(desc, settings).map_err(input_error)?;
        builds.push(renderer.build_info().build_s);
    }
    Ok((renderer, median(&builds)))
}

/// Runs `parrt bench efficiency`.
pub fn run(args: EfficiencyArgs) -> anyhow::Result<ExitCode> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = if args.threads.is_empty() {
        (1..=cores).collect()
    } else {
        args.threads.clone()
    };
    if threads.contains(&0)
        || args.tiles.contains(&0)
        || args.sizes.contains(&0)
        || args.repeat == 0
        || args.frames == 0
    {
        return Err(input_error(anyhow::anyhow!(
            "threads, tiles, sizes, --frames and --repeat must be at least 1"
        )));
    }
    // Every image is checked against the pixel limit before the first is rendered, so a bad size
    // fails at once instead of after minutes of work or an allocation abort.
    for &size in &args.sizes {
        for &tile in &args.tiles {
            args.limits.check_image(size, size, tile)?;
        }
    }
    let accels: Vec<AccelKind> = args.accel.iter().map(|a| a.kind()).collect();
    let executors: Vec<Executor> = args.executors.iter().map(|e| e.executor()).collect();
    let spec = SceneSpec::parse(&args.scene)?;
    crate::cli_args::output::prepare_out_dir(&args.out)?;
    crate::errln!("parrt: {}", plan(&args, &threads));
    let mut out = Report {
        md: String::new(),
        csv: csv::Writer::from_writer(Vec::new()),
    };
    out.csv
        .write_record(crate::studies::efficiency::CSV_HEADER)?;
    let _ = writeln!(
        out.md,
        "# Efficiency: {}\n\nMachine: {}. Command: `parrt {}`. Median of {} runs. e = t₁/(n·tₙ), \
         t₁ the one-thread time at the same tile size. Cells: efficiency (tₙ).\n",
        spec.label(),
        machine(),
        std::env::args().skip(1).collect::<Vec<_>>().join(" "),
        args.repeat
    );
    for &size in &args.sizes {
        let (desc, parse_s) = spec.load(&args.limits.limits())?;
        let orbit = (args.frames > 1)
            .then(|| parrt_render::sequence::Sequence::orbit(desc.clone(), args.orbit, args.frames))
            .transpose()
            .map_err(|e| input_error(anyhow::anyhow!("--orbit {}: {e}", args.orbit)))?;
        for &accel in &accels {
            let mut settings = RenderSettings::new(size, size);
            settings.accel = accel;
            let (renderer, build_s) = build(&desc, &settings, args.repeat)?;
            let _ = writeln!(
                out.md,
                "## {size}×{size}, {accel:?}\n\nPreprocessing (sequential): parse {parse_s:.4}s, build {build_s:.4}s.\n"
            );
            let case = Case {
                args: &args,
                sequence: orbit.as_ref(),
                label: spec.label(),
                threads: &threads,
                cores,
                size,
                accel,
                pre: parse_s + build_s,
            };
            let mut series = Vec::new();
            let mut sim_lines = String::new();
            if args.mode.contains(&Mode::Smp) {
                for &ex in &executors {
                    series.extend(case.smp(&renderer, ex, &mut out, &mut sim_lines)?);
                }
            }
            if args.mode.contains(&Mode::Distributed) {
                series.extend(case.distributed(&desc, &settings, &mut out)?);
            }
            if !sim_lines.is_empty() {
                let _ = writeln!(
                    out.md,
                    "Simulator check (queue executor; prediction from the measured one-thread tile costs):\n\n\
                     | tile | n | measured tₙ s | predicted s | error |\n|---:|---:|---:|---:|---:|\n{sim_lines}"
                );
            }
            case.chart(series, &mut out.md)?;
            crate::errln!("parrt: measured {size}px {accel:?}");
        }
    }
    std::fs::write(args.out.join("efficiency.md"), &out.md)?;
    std::fs::write(args.out.join("efficiency.csv"), out.csv.into_inner()?)?;
    crate::outln!("{}", out.md);
    crate::errln!("parrt: wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}
