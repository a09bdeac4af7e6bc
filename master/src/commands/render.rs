//! `parrt render`: renders an NFF file, a generated scene or the built-in default scene to an
//! image on this machine's cores (or through local workers with `--workers`), with a progress
//! bar on a terminal and the ray statistics (docs/design-measures.md, *Ray statistics*) on
//! request. Several frames (several files, `--frames-from`, `--orbit`) are a sequence, rendered
//! by [`super::render_sequence`].

use super::report::RenderReport;
use super::watch::{start_live, watchers};
use crate::cli_args::output::{check_file_output, check_image_output};
use crate::cli_args::{ExecutorArg, JobFlags, LimitArgs, RenderFlags, SceneSpec};
use crate::exit::input_error;
use crate::observed_smp::render_smp_observed;
use anyhow::Context;
use clap::Args;
use parrt_render::film::{Film, ImageFormat};
use parrt_render::precision::Choice;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::SmpOptions;
use parrt_render::stats::RayStats;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `parrt render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// NFF scene file, or parrt's JSON form if it ends in .json (omit it, and --scene, to render
    /// the built-in default scene: mount). Several files render a sequence, one frame each.
    #[arg(value_name = "SCENE.nff")]
    pub files: Vec<PathBuf>,
    /// Render a generated scene instead of a file: NAME or NAME:SIZE (see `parrt scene --list`).
    #[arg(long, value_name = "NAME[:SIZE]")]
    pub scene: Option<String>,
    /// Output image: .png (default), .ppm (8-bit binary P6) or .exr (linear float).
    #[arg(short, long, value_name = "OUT", default_value = "parrt.png")]
    pub output: PathBuf,
    /// Render threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Tile edge in pixels.
    #[arg(long, value_name = "S", default_value_t = 32)]
    pub tile: u32,
    /// How tiles are handed to threads.
    #[arg(long, value_enum, default_value_t = ExecutorArg::Queue)]
    pub executor: ExecutorArg,
    /// Print ray statistics and timings after the render.
    #[arg(long)]
    pub stats: bool,
    /// Trace every ray on its own instead of in 4×4 packets (eye rays, their shadow rays and
    /// coherent reflections and refractions). The image is the same bits; the box and primitive test counts of --stats are then per single
    /// ray (what `bench/bvh_quality.sh` compares).
    #[arg(long)]
    pub no_packets: bool,
    /// Write ray statistics and timings as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub stats_json: Option<PathBuf>,
    /// Write each tile's render time as CSV (tile,x,y,w,h,seconds) to FILE, for
    /// `parrt bench simulate`.
    #[arg(long, value_name = "FILE")]
    pub tile_costs: Option<PathBuf>,
    /// Render through N local worker processes (master/worker over TCP on 127.0.0.1; their
    /// pixels come through memory the master shares with them).
    #[arg(long, value_name = "N")]
    pub workers: Option<usize>,
    /// Checkpoint (with --workers), timeline and live view.
    #[command(flatten)]
    pub job: JobFlags,
    /// Render settings.
    #[command(flatten)]
    pub render: RenderFlags,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
    /// Sequences: several frames as one job.
    #[command(flatten)]
    pub sequence: crate::cli_args::sequence::SequenceArgs,
}

/// What one way of rendering produced, for the common reporting.
struct Outcome {
    film: parrt_render::film::Film,
    stats: RayStats,
    tile_seconds: Vec<f64>,
    trace_s: f64,
    build_s: f64,
    /// Lines for `--stats` after the scene line.
    describe: Vec<String>,
    /// Extra keys for `--stats-json`.
    extra: serde_json::Value,
    /// The timeline, when `--timeline` asked for one.
    timeline: Option<crate::timeline::Timeline>,
}

/// The live view's description of this render.
fn live_job(
    spec: &SceneSpec,
    settings: &RenderSettings,
    tile: u32,
    mode: &'static str,
) -> crate::live::state::JobInfo {
    crate::live::state::JobInfo {
        scene: spec.label(),
        mode,
        width: settings.width,
        height: settings.height,
        tile_size: tile,
    }
}

/// Renders on this machine's cores. Takes the description so that it is freed before the
/// accelerator is built.
fn render_here(
    args: &RenderArgs,
    spec: &SceneSpec,
    desc: parrt_render::description::SceneDescription,
    settings: &RenderSettings,
    live: Option<&crate::live::Live>,
) -> anyhow::Result<Outcome> {
    let mut renderer = Renderer::from_description(desc, settings)
        .map_err(input_error)
        .with_context(|| format!("cannot prepare {}", spec.label()))?;
    renderer.set_packets(!args.no_packets);
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let opts = SmpOptions {
        threads,
        tile: args.tile,
        executor: args.executor.executor(),
    };
    if let Some(l) = live {
        l.set_job(live_job(spec, settings, args.tile, "smp"));
    }
    // The SMP timeline comes from the render's own per-tile spans (measured on the threads),
    // not from a recorder.
    // An 8-bit output's film keeps 8 bits as tiles land (3 bytes a pixel, not 12), and is
    // written from its own bytes.
    let format = ImageFormat::from_path(&args.output).map_err(input_error)?;
    let film = Film::for_output(settings.width, settings.height, format);
    let result = render_smp_observed(&renderer, &opts, film, &watchers(None, live));
    let timeline = args.job.timeline.as_ref().map(|_| {
        let label = spec.label();
        let job = timeline_job(&label, settings, args.tile);
        crate::timeline::Timeline::from_smp(&job, threads, &result.tile_spans, result.trace_s)
    });
    let info = renderer.build_info();
    let a = &info.accel;
    Ok(Outcome {
        film: result.film,
        stats: result.stats,
        tile_seconds: result.tile_seconds,
        trace_s: result.trace_s,
        build_s: info.build_s,
        describe: vec![
            format!(
                "primitives        {} after triangulation, scene {} KiB ({:.0} B/primitive with the accelerator)",
                info.primitives,
                info.scene_bytes / 1024,
                (info.scene_bytes + a.bytes) as f64 / info.primitives.max(1) as f64
            ),
            format!(
                "image             {}x{}, {} threads, tile {}, {} executor, {:?}",
                settings.width,
                settings.height,
                threads,
                args.tile,
                opts.executor.name(),
                settings.accel
            ),
            format!(
                "accelerator       {}: {} nodes, {} leaves, SAH cost {:.1}, depth {}, {} KiB, built in {:.3}s",
                a.kind,
                a.nodes,
                a.leaves,
                a.sah_cost,
                a.max_depth,
                a.bytes / 1024,
                a.build_s
            ),
        ],
        extra: json!({
            "threads": threads,
            "executor": opts.executor.name(),
            "accel": a,
            "primitives": info.primitives,
            "scene_bytes": info.scene_bytes,
        }),
        timeline,
    })
}

/// What a timeline says of the job it records: scene, image and tile size.
fn timeline_job<'a>(
    label: &'a str,
    settings: &RenderSettings,
    tile: u32,
) -> crate::timeline::Job<'a> {
    crate::timeline::Job {
        scene: label,
        width: settings.width,
        height: settings.height,
        tile_size: tile,
    }
}

/// Renders through `n` local worker processes started from this executable.
fn render_through_workers(
    args: &RenderArgs,
    spec: &SceneSpec,
    n: usize,
    live: Option<&crate::live::Live>,
) -> anyhow::Result<(Outcome, f64, RenderSettings, Choice)> {
    use parrt_runtime::{DistError, Job};
    /// A failure of the distributed render or of preparing its job.
    enum Failed {
        Dist(DistError),
        Job(anyhow::Error),
    }
    impl From<DistError> for Failed {
        fn from(e: DistError) -> Self {
            Failed::Dist(e)
        }
    }
    if n == 0 {
        return Err(input_error(anyhow::anyhow!("--workers must be at least 1")));
    }
    // Loading the scene runs while the worker processes start.
    let parse_s = std::cell::Cell::new(0.0);
    let choice = std::cell::RefCell::new(None);
    let prepare = || {
        let (desc, settings, why, secs) = load_job(args, spec).map_err(Failed::Job)?;
        parse_s.set(secs);
        *choice.borrow_mut() = Some(why);
        if let Some(l) = live {
            l.set_job(live_job(spec, &settings, args.tile, "distributed"));
        }
        Ok((desc, settings))
    };
    // The workers each refuse a scene they cannot build; if they all did, the check says why,
    // once, as bad input. A render that succeeds needs no check (every worker built the job).
    let job = Job::prepared(prepare).check(|desc, settings| {
        parrt_render::render::validate_job(desc, settings).map_err(|e| Failed::Job(input_error(e)))
    });
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let threads = args.threads.unwrap_or((cores / n).max(1));
    let recorder = args
        .job
        .timeline
        .as_ref()
        .map(|_| std::sync::Arc::new(crate::timeline::Recorder::new()));
    let mut config = super::distributed::master_config(super::distributed::MasterSetup {
        observers: watchers(recorder.as_ref(), live),
        job: &args.job,
        // The workers' token is made for this run only: nothing to key a resume with.
        keyed: false,
        tile: args.tile,
        min_workers: n,
        output: &args.output,
    });
    super::distributed::local_workers(&mut config, n, threads);
    let (r, settings) = match parrt_runtime::run(&config, job, &mut |_| Ok(None), None) {
        Ok(done) => (done.result, done.settings),
        Err(Failed::Job(e)) => return Err(e),
        Err(Failed::Dist(e)) => {
            return Err(anyhow::Error::new(e).context("distributed render failed"))
        }
    };
    if let Some(c) = &args.job.checkpoint {
        crate::errln!(
            "parrt: checkpoint {}: {} tiles restored, {} bad records dropped",
            c.display(),
            r.restored_tiles,
            r.checkpoint_bad_records
        );
    }
    let build_s = r.per_worker.iter().map(|w| w.build_s).fold(0.0, f64::max);
    let describe = describe_workers(&r, &settings, n, threads, args.tile);
    let (per_tile_us, per_mb_ms) = (r.master_cpu_per_tile_us(), r.master_cpu_per_mb_ms());
    let outcome = Outcome {
        film: r.film,
        stats: r.stats,
        tile_seconds: r.tile_seconds,
        trace_s: r.trace_s,
        build_s,
        describe,
        extra: json!({
            "workers": n,
            "threads_per_worker": threads,
            "tiles_per_worker": r.per_worker.iter().map(|w| w.tiles).collect::<Vec<_>>(),
            "restored_tiles": r.restored_tiles,
            "checkpoint_bad_records": r.checkpoint_bad_records,
            "bytes_sent": r.bytes_sent,
            "bytes_received": r.bytes_received,
            "tiles_shared": r.tiles_shared,
            "scene_transfer_s": r.scene_transfer_s,
            "master_cpu_s": r.master_cpu_s,
            "master_cpu_per_tile_us": per_tile_us,
            "master_cpu_per_mb_ms": per_mb_ms,
        }),
        timeline: recorder.map(|rec| {
            let label = spec.label();
            rec.timeline(&timeline_job(&label, &settings, args.tile), r.trace_s)
        }),
    };
    let choice = choice.into_inner().unwrap_or_else(|| Choice {
        precision: settings.precision,
        reason: String::new(),
    });
    Ok((outcome, parse_s.get(), settings, choice))
}

/// The `--stats` lines of a render through `n` local workers of `threads` threads: the image,
/// each worker, the network and the master's CPU.
fn describe_workers(
    r: &parrt_runtime::DistResult,
    settings: &RenderSettings,
    n: usize,
    threads: usize,
    tile: u32,
) -> Vec<String> {
    let mut describe = vec![format!(
        "image             {}x{}, {n} local workers × {threads} threads, tile {}, {:?}",
        settings.width, settings.height, tile, settings.accel
    )];
    for w in &r.per_worker {
        describe.push(format!(
            "  worker {:<10} {} threads, {}, {} tiles, render {:.3}s, build {:.3}s{}",
            w.name,
            w.threads,
            w.isa,
            w.tiles,
            w.render_s,
            w.build_s,
            w.left
                .as_deref()
                .map(|l| format!(", left: {l}"))
                .unwrap_or_default()
        ));
    }
    describe.push(format!(
        "network           {} bytes sent, {} received, scene transfer {:.4}s",
        r.bytes_sent, r.bytes_received, r.scene_transfer_s
    ));
    if r.tiles_shared > 0 {
        describe.push(format!(
            "shared memory     {} tiles' pixels came through it, not over the connections",
            r.tiles_shared
        ));
    }
    let (per_tile_us, per_mb_ms) = (r.master_cpu_per_tile_us(), r.master_cpu_per_mb_ms());
    describe.push(format!(
        "master CPU        {:.4}s ({per_tile_us:.1} µs per tile, {per_mb_ms:.2} ms per MB received)",
        r.master_cpu_s
    ));
    describe
}

/// Loads the scene and the settings the flags make of it, checking the image's size: the
/// description, the settings, why their precision is what it is, and the seconds spent parsing
/// or generating.
fn load_job(
    args: &RenderArgs,
    spec: &SceneSpec,
) -> anyhow::Result<(
    parrt_render::description::SceneDescription,
    RenderSettings,
    Choice,
    f64,
)> {
    let (desc, parse_s) = spec.load(&args.limits.limits())?;
    let (settings, choice) = args.render.settings_and_precision(&desc)?;
    args.limits
        .check_image(settings.width, settings.height, args.tile)?;
    Ok((desc, settings, choice, parse_s))
}

/// Runs `parrt render`.
pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    if args.workers.is_none() && args.job.checkpoint.is_some() {
        return Err(input_error(anyhow::anyhow!(
            "--checkpoint records the tiles of a render through workers; add --workers N (a \
             render on this machine's threads keeps no checkpoint)"
        )));
    }
    if super::render_sequence::wanted(&args) {
        return super::render_sequence::run(&args);
    }
    if args.sequence.window.is_some() {
        return Err(crate::cli_args::ArgError::Conflict(
            "--window sets how many frames of a sequence are in flight; this render has one \
             frame (give several scene files, --frames-from or --orbit)"
                .into(),
        )
        .into());
    }
    let file = args.files.first().cloned();
    let spec = SceneSpec::from_args(file.clone(), args.scene.as_deref(), None)?;
    // Every output is checked before the render, so a typo costs nothing.
    check_image_output(&args.output)?;
    for p in [&args.stats_json, &args.tile_costs].into_iter().flatten() {
        check_file_output(p)?;
    }
    args.job.check_outputs(&[
        ("-o", Some(&args.output)),
        ("the scene", file.as_deref()),
        ("--stats-json", args.stats_json.as_deref()),
        ("--tile-costs", args.tile_costs.as_deref()),
    ])?;
    if args.tile == 0 {
        return Err(input_error(anyhow::anyhow!("--tile must be at least 1")));
    }
    if args.threads == Some(0) {
        return Err(input_error(anyhow::anyhow!("--threads must be at least 1")));
    }
    let live = start_live(&args.job.live, None)?;
    let (out, parse_s, settings, choice) = match args.workers {
        Some(n) => render_through_workers(&args, &spec, n, live.as_ref())?,
        None => {
            let (desc, settings, choice, parse_s) = load_job(&args, &spec)?;
            (
                render_here(&args, &spec, desc, &settings, live.as_ref())?,
                parse_s,
                settings,
                choice,
            )
        }
    };
    let precision = parrt_render::precision::name(choice.precision);
    out.film
        .save(&args.output)
        .with_context(|| format!("rendering {}", spec.label()))?;
    let report = RenderReport {
        stats: out.stats,
        parse_s,
        build_s: out.build_s,
        trace_s: out.trace_s,
    };
    if args.stats {
        crate::outln!("scene             {}", spec.label());
        crate::outln!("precision         {precision} ({})", choice.reason);
        for line in &out.describe {
            crate::outln!("{line}");
        }
        report.print();
    }
    if let Some(path) = &args.tile_costs {
        let list = parrt_render::tile::tiles(settings.width, settings.height, args.tile);
        crate::studies::efficiency::write_tile_costs(path, &list, &out.tile_seconds)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let (Some(path), Some(t)) = (&args.job.timeline, &out.timeline) {
        t.write(path)?;
    }
    if let Some(path) = &args.stats_json {
        let mut extra = json!({
            "scene": spec.label(),
            "width": settings.width,
            "height": settings.height,
            "tile": args.tile,
            "precision": precision,
            "precision_reason": choice.reason,
        });
        if let (Some(e), serde_json::Value::Object(more)) = (extra.as_object_mut(), out.extra) {
            e.extend(more);
        }
        let text = serde_json::to_string_pretty(&report.to_json(extra))?;
        std::fs::write(path, text + "\n")
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    crate::errln!(
        "parrt: wrote {} ({}x{}) in {:.2}s",
        args.output.display(),
        settings.width,
        settings.height,
        parse_s + out.build_s + out.trace_s
    );
    if let Some(l) = live {
        l.end(true);
    }
    Ok(ExitCode::SUCCESS)
}
