//! `parrt master`: loads a scene, listens for workers, hands them tiles, writes the image.
//! Argument parsing and reporting only; the work is in [`parrt_runtime::run`].

use super::distributed::{master_config, MasterSetup};
use super::report::{print_summary, report_json};
use super::watch::{start_live, Watch};
use crate::cli_args::durations::{
    seconds_flag, MAX_FLAG_DURATION, MIN_HEARTBEAT_TIMEOUT, MIN_TILE_DEADLINE,
};
use crate::cli_args::listen::check_listen;
use crate::cli_args::output::{check_file_output, check_image_output};
use crate::cli_args::{JobFlags, LimitArgs, RenderFlags, SceneSpec};
use crate::exit::input_error;
use crate::live::state::JobInfo;
use anyhow::Context;
use clap::Args;
use parrt_render::description::SceneDescription;
use parrt_runtime::{Job, DEFAULT_LISTEN};
use parrt_worker::cli::{init_logging, log_level, TokenArgs};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of `parrt master`.
#[derive(Debug, Args)]
pub struct MasterArgs {
    /// The NFF scene to render, or parrt's JSON form if it ends in .json (or --scene
    /// NAME[:SIZE], or --scene-json FILE).
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    /// Several files render a sequence, one frame each.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE.nff")]
    pub files: Vec<PathBuf>,
    /// A generated scene, NAME or NAME:SIZE.
    #[arg(long, value_name = "NAME[:SIZE]", conflicts_with = "scene_json")]
    pub scene: Option<String>,
    /// A scene description in parrt's JSON form (serde of `SceneDescription`).
    #[arg(long, value_name = "FILE", conflicts_with = "files")]
    pub scene_json: Option<PathBuf>,
    /// Output image: .png, .ppm (8-bit binary P6) or .exr (linear float).
    #[arg(short, long, value_name = "OUT", default_value = "parrt.png")]
    pub output: PathBuf,
    /// Address to listen on; anything but loopback must be asked for (e.g. 0.0.0.0:7878).
    #[arg(long, value_name = "ADDR", default_value = DEFAULT_LISTEN)]
    pub listen: String,
    /// Tile edge in pixels.
    #[arg(long, value_name = "S", default_value_t = 32)]
    pub tile: u32,
    /// Workers that must be ready before rendering starts.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub min_workers: usize,
    /// Seconds to wait for workers before giving up (exit 1); at most a week.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub wait_workers: f64,
    /// Seconds before a tile not returned is given to another worker (1 s to a week).
    #[arg(long, value_name = "SECONDS", default_value_t = 120.0)]
    pub tile_deadline: f64,
    /// Seconds of silence after which a worker is considered gone (2 s, two heartbeats, to a
    /// week).
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub heartbeat_timeout: f64,
    /// Assignments (each a batch of up to --max-batch tiles) a worker holds at once: N per
    /// thread, or `auto`: one per thread plus what the worker's measured round trip needs (two
    /// per thread until it is measured).
    #[arg(long, value_name = "N|auto", default_value = "2")]
    pub window: parrt_runtime::window::Window,
    /// Most tiles in one assignment (the help text is `max_batch_help`'s, which reads the
    /// batch rule's constants).
    #[arg(long, value_name = "N", default_value_t = 8, help = max_batch_help())]
    pub max_batch: usize,
    /// Never duplicate in-flight tiles onto idle workers.
    #[arg(long)]
    pub no_backups: bool,
    /// Write timings, traffic and per-worker figures as JSON.
    #[arg(long, value_name = "FILE")]
    pub report_json: Option<PathBuf>,
    /// Token flags (a token is required).
    #[command(flatten)]
    pub token: TokenArgs,
    /// Checkpoint, timeline and live view.
    #[command(flatten)]
    pub job: JobFlags,
    /// The order tiles are handed out in.
    #[command(flatten)]
    pub order: crate::cli_args::tile_order::OrderArgs,
    /// A sequence: `--frames-from`, `--orbit`/`--frames` (then `-o` is a pattern).
    #[command(flatten)]
    pub frames: crate::cli_args::sequence::FrameArgs,
    /// Render settings (the same flags as `parrt render`, so the same bits).
    #[command(flatten)]
    pub render: RenderFlags,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
    /// Log what happens (workers joining and leaving, faults) as timestamped lines on stderr,
    /// as PARRT_LOG=info does; without it, and without PARRT_LOG, only parrt's own lines and
    /// warnings.
    #[arg(short, long)]
    pub verbose: bool,
}

/// `--max-batch`'s help, with the batch rule's own bound on a batch's work
/// ([`parrt_runtime::batch::BATCH_SECONDS`]) and the protocol's largest batch.
fn max_batch_help() -> String {
    format!(
        "Most tiles in one assignment. Batches are guided: large while much is queued and tiles \
         are cheap (at most {} ms of work), single tiles at the tail; 1 sends every tile on its \
         own; at most {}",
        parrt_runtime::batch::BATCH_SECONDS * 1e3,
        parrt_protocol::limits::MAX_BATCH
    )
}

/// The scene: a file, `--scene` or `--scene-json`, and its label for messages.
fn load_scene(args: &MasterArgs) -> anyhow::Result<(SceneDescription, String)> {
    let spec = SceneSpec::from_args(
        args.files.first().cloned(),
        args.scene.as_deref(),
        args.scene_json.clone(),
    )?;
    let (desc, _) = spec.load(&args.limits.limits())?;
    Ok((desc, spec.label()))
}

/// What a master says while no tile can be handed out yet: how many workers it waits for, and
/// how long.
pub fn waiting_line(workers: usize, wait: Duration) -> String {
    let plural = if workers == 1 { "" } else { "s" };
    format!(
        "waiting for {workers} worker{plural} (up to {} s)…",
        wait.as_secs_f64()
    )
}

/// Runs `parrt master`. Everything the user gave is checked before listening: flags, outputs,
/// the scene (built once as a worker would build it) and the image's size and tile count.
pub fn run(args: MasterArgs) -> anyhow::Result<ExitCode> {
    init_logging(log_level(args.verbose));
    let token = args
        .token
        .require("`parrt master`")
        .map_err(crate::exit::worker_error)?;
    if args.tile == 0 {
        return Err(input_error(anyhow::anyhow!("--tile must be at least 1")));
    }
    let wait_workers = seconds_flag(
        "--wait-workers",
        args.wait_workers,
        Duration::ZERO,
        MAX_FLAG_DURATION,
    )?;
    let tile_deadline = seconds_flag(
        "--tile-deadline",
        args.tile_deadline,
        MIN_TILE_DEADLINE,
        MAX_FLAG_DURATION,
    )?;
    let heartbeat_timeout = seconds_flag(
        "--heartbeat-timeout",
        args.heartbeat_timeout,
        MIN_HEARTBEAT_TIMEOUT,
        MAX_FLAG_DURATION,
    )?;
    check_image_output(&args.output)?;
    if let Some(p) = &args.report_json {
        check_file_output(p)?;
    }
    args.job.check_outputs(&[
        ("-o", Some(&args.output)),
        ("the scene", args.files.first().map(PathBuf::as_path)),
        ("--scene-json", args.scene_json.as_deref()),
        ("--report-json", args.report_json.as_deref()),
        ("--costly-first", args.order.costly_first.as_deref()),
        ("--token-file", args.token.token_file.as_deref()),
    ])?;
    check_listen(&args.listen)?;
    let sequence = args.files.len() > 1 || args.frames.sequence().asked();
    args.frames.check(sequence)?;
    if sequence {
        return run_sequence(&args, token, wait_workers, tile_deadline, heartbeat_timeout);
    }
    let (desc, label) = load_scene(&args)?;
    let settings = args.render.settings(&desc)?;
    args.limits
        .check_image(settings.width, settings.height, args.tile)?;
    parrt_render::render::validate_job(&desc, &settings)
        .map_err(input_error)
        .with_context(|| format!("no worker could render {label}"))?;
    let live = start_live(&args.job.live, Some(token.as_bytes()))?;
    let watch = Watch::new(
        args.job.timeline.as_deref(),
        live,
        JobInfo {
            scene: label.clone(),
            mode: "distributed",
            width: settings.width,
            height: settings.height,
            tile_size: args.tile,
        },
    );
    let mut config = master_config(MasterSetup {
        observers: watch.observers(),
        job: &args.job,
        // The token outlives the run (the user gives it again to resume).
        keyed: true,
        tile: args.tile,
        min_workers: args.min_workers.max(1),
        output: &args.output,
    });
    let s = &mut config.schedule;
    s.wait_workers = wait_workers;
    s.tile_deadline = tile_deadline;
    s.window = args.window;
    s.max_batch = args.max_batch.max(1);
    s.backups = !args.no_backups;
    s.order = args
        .order
        .order(settings.width, settings.height, args.tile)?;
    config.net.listen = args.listen.clone();
    config.net.token = Some(token);
    config.net.heartbeat_timeout = heartbeat_timeout;
    let (w, h, tile) = (settings.width, settings.height, args.tile);
    let waiting = waiting_line(s.min_workers, wait_workers);
    let result = parrt_runtime::run(
        &config,
        Job::<parrt_runtime::DistError>::ready(desc, settings),
        &mut |addr| {
            crate::errln!(
                "parrt master: listening on {addr}; {label} at {w}x{h}, tiles of {tile} px"
            );
            crate::errln!("parrt master: {waiting}");
            Ok(None)
        },
        None,
    )
    .context("distributed render failed")?
    .result;
    result
        .film
        .save(&args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    print_summary(&result, &args.output);
    if let Some(p) = &args.report_json {
        std::fs::write(p, report_json(&result).to_string())
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    watch.end(result.trace_s)?;
    Ok(ExitCode::SUCCESS)
}

/// `parrt master` of a sequence: every frame through the workers that connect, one after
/// another on the same workers, each written as soon as it is complete.
fn run_sequence(
    args: &MasterArgs,
    token: parrt_protocol::Token,
    wait_workers: Duration,
    tile_deadline: Duration,
    heartbeat_timeout: Duration,
) -> anyhow::Result<ExitCode> {
    use super::render_sequence::{prepare, refuse_for_sequences, through_runtime, SequenceInput};
    use super::sequence_watch::SequenceWatch;
    refuse_for_sequences(&[
        ("--scene-json", args.scene_json.is_some()),
        ("--report-json", args.report_json.is_some()),
    ])?;
    let sequence = args.frames.sequence();
    let p = prepare(&SequenceInput {
        files: &args.files,
        scene: &args.scene,
        sequence: &sequence,
        render: &args.render,
        limits: &args.limits,
        tile: args.tile,
        output: &args.output,
        stats_json: &None,
        timeline: args.job.timeline.as_deref(),
        checkpoint: args.job.checkpoint.as_deref(),
    })?;
    let mut watch = SequenceWatch::start(&args.job, token.as_bytes(), &p.as_ref(), args.tile)?;
    let mut config = master_config(MasterSetup {
        observers: watch.observers(),
        job: &args.job,
        keyed: true,
        tile: args.tile,
        min_workers: args.min_workers.max(1),
        output: &p.outputs[0],
    });
    let s = &mut config.schedule;
    s.wait_workers = wait_workers;
    s.tile_deadline = tile_deadline;
    s.window = args.window;
    s.max_batch = args.max_batch.max(1);
    s.frames_window = sequence.window();
    s.backups = !args.no_backups;
    config.net.listen = args.listen.clone();
    config.net.token = Some(token);
    config.net.heartbeat_timeout = heartbeat_timeout;
    let n = p.outputs.len();
    let waiting = waiting_line(config.schedule.min_workers, wait_workers);
    let r = through_runtime("parrt master", &config, &p.as_ref(), None, &mut |addr| {
        crate::errln!(
            "parrt master: listening on {addr}; {n} frames, tiles of {} px",
            args.tile
        );
        crate::errln!("parrt master: {waiting}");
        Ok(None)
    })?;
    watch.finish("parrt master", &args.job, &p.as_ref(), args.tile, &r)?;
    Ok(ExitCode::SUCCESS)
}
