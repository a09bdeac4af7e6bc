//! `parrt render` of a sequence: several scene files, a LIST of them (`--frames-from`) or one
//! scene and an orbit of the camera (`--orbit DEGREES --frames N`), rendered on this machine's
//! threads with a window of frames in flight ([`parrt_render::sequence_smp`]), each frame
//! written to the file the `-o` pattern names for it as soon as it is finished (docs/sequences.md).
//! With `--workers N` the frames render one after another through N local worker processes
//! that stay connected for the whole sequence ([`parrt_runtime::run_sequence`]), with
//! `--checkpoint`/`--resume` if asked ([`crate::sequence_checkpoint`]; on this machine's threads
//! a sequence keeps no checkpoint, as one frame keeps none), and with `--timeline FILE` its
//! tiles' timeline, each tile marked with its frame, and with `--http ADDR` a live view of the
//! newest frame being assembled with the frames done and in flight ([`crate::live::frames`]).
//! `--tile-costs` (one frame's measured costs) is refused. Every frame is checked (its scene
//! read, its settings and size) before the first is rendered.

use super::render::RenderArgs;
use super::report::RenderReport;
use crate::cli_args::frame_pattern::FramePattern;
use crate::cli_args::output::{check_distinct, check_file_output, check_image_output, write_whole};
use crate::cli_args::sequence::read_frame_list;
use crate::cli_args::{ArgError, SceneSpec};
use crate::exit::input_error;
use crate::sequence_checkpoint::{ResumableFrames, Resumed};
use crate::sequence_progress::SequenceProgress;
use anyhow::Context;
use parrt_render::nff::Limits;
use parrt_render::precision::Choice;
use parrt_render::render::Renderer;
use parrt_render::sequence::Sequence;
use parrt_render::sequence_build::FrameBuilder;
use parrt_render::sequence_smp::{render_sequence, FrameDone, SequenceOptions, SequenceResult};
use parrt_render::settings::RenderSettings;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Whether `args` ask for a sequence rather than one frame.
pub fn wanted(args: &RenderArgs) -> bool {
    args.files.len() > 1 || args.sequence.asked()
}

/// Set by Ctrl-C while a sequence renders: the threads stop taking tiles.
static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_sigint(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
    // A second Ctrl-C kills at once. signal() is async-signal-safe.
    // SAFETY: restoring the default disposition of SIGINT has no other effect.
    unsafe {
        libc::signal(libc::SIGINT, libc::SIG_DFL);
    }
}

/// Makes Ctrl-C stop the sequence between tiles, so that the frames being written are finished
/// and no half-written file is left.
fn stop_on_ctrl_c() {
    let handler = on_sigint as extern "C" fn(libc::c_int);
    // SAFETY: the handler only stores to an atomic and calls signal(), both async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, handler as libc::sighandler_t);
    }
}

/// What a sequence is made of, loaded: the frames, the input files (for the alias checks) and
/// a label per frame for messages.
pub struct Loaded {
    sequence: Sequence,
    inputs: Vec<(&'static str, PathBuf)>,
    labels: Vec<String>,
    scene: String,
}

/// What a sequence is made of, as any of the commands that render one was told: the scene
/// files or generated scene, the sequence flags, the render settings and the outputs.
pub struct SequenceInput<'a> {
    /// Scene files (one frame each, or the one an orbit turns about).
    pub files: &'a [PathBuf],
    /// A generated scene (`--scene`).
    pub scene: &'a Option<String>,
    /// `--frames-from`, `--orbit`, `--frames`, `--window`.
    pub sequence: &'a crate::cli_args::sequence::SequenceArgs,
    /// The render settings' flags.
    pub render: &'a crate::cli_args::RenderFlags,
    /// Parser and image limits.
    pub limits: &'a crate::cli_args::LimitArgs,
    /// Tile edge in pixels.
    pub tile: u32,
    /// The `-o` pattern.
    pub output: &'a PathBuf,
    /// `--stats-json`, checked against the outputs.
    pub stats_json: &'a Option<PathBuf>,
    /// `--timeline` and `--checkpoint`, checked against the outputs and the inputs.
    pub timeline: Option<&'a std::path::Path>,
    /// See `timeline`.
    pub checkpoint: Option<&'a std::path::Path>,
}

impl<'a> SequenceInput<'a> {
    /// The sequence `parrt render` was asked for.
    fn of_render(args: &'a RenderArgs) -> Self {
        SequenceInput {
            files: &args.files,
            scene: &args.scene,
            sequence: &args.sequence,
            render: &args.render,
            limits: &args.limits,
            tile: args.tile,
            output: &args.output,
            stats_json: &args.stats_json,
            timeline: args.job.timeline.as_deref(),
            checkpoint: args.job.checkpoint.as_deref(),
        }
    }
}

/// A sequence read and checked: its frames, each frame's settings and output, and the seconds
/// reading took.
pub struct Prepared {
    /// The frames, their inputs and labels.
    pub loaded: Loaded,
    /// Each frame's settings, as rendering it alone would make them.
    pub settings: Vec<(RenderSettings, Choice)>,
    /// Each frame's output file.
    pub outputs: Vec<PathBuf>,
    /// Seconds spent reading the scenes.
    pub parse_s: f64,
}

/// Checks the sequence flags, reads every frame's scene and checks every frame's settings
/// and output, before any work.
pub fn prepare(input: &SequenceInput<'_>) -> anyhow::Result<Prepared> {
    check_sequence_flags(input)?;
    let limits = input.limits.limits();
    let t0 = Instant::now();
    let loaded = load(input, &limits)?;
    let parse_s = t0.elapsed().as_secs_f64();
    let settings = frame_settings(input, &loaded)?;
    let outputs = frame_outputs(input, &loaded)?;
    Ok(Prepared {
        loaded,
        settings,
        outputs,
        parse_s,
    })
}

/// Refuses sequence flags that contradict one another.
fn check_sequence_flags(args: &SequenceInput<'_>) -> anyhow::Result<()> {
    let seq = args.sequence;
    let conflict = |m: &str| Err(ArgError::Conflict(m.to_string()).into());
    if seq.frames.is_some() && seq.orbit.is_none() {
        return conflict(
            "--frames N counts the frames of --orbit; give --orbit DEGREES too (several files \
             or --frames-from make one frame each)",
        );
    }
    if seq.orbit.is_some() {
        if seq.frames.is_none() {
            return conflict("--orbit needs --frames N (how many frames the turn is cut into)");
        }
        if args.files.len() > 1 || seq.frames_from.is_some() {
            return conflict(
                "--orbit turns the camera about one scene; give one scene file (or --scene), \
                 not several files or --frames-from",
            );
        }
    }
    if seq.frames_from.is_some() && !args.files.is_empty() {
        return conflict("give the frames either as scene files or with --frames-from, not both");
    }
    if args.scene.is_some() && (seq.frames_from.is_some() || args.files.len() > 1) {
        return conflict("--scene renders one generated scene; give it without scene files");
    }
    if args.tile == 0 {
        return Err(ArgError::Value("--tile must be at least 1".into()).into());
    }
    if seq.window() == 0 {
        return Err(ArgError::Value("--window must be at least 1".into()).into());
    }
    Ok(())
}

/// Refuses what a sequence cannot do yet with `parrt render`.
fn refuse_unsupported(args: &RenderArgs) -> anyhow::Result<()> {
    let conflict = |m: &str| Err(ArgError::Conflict(m.to_string()).into());
    if args.workers == Some(0) {
        return Err(ArgError::Value("--workers must be at least 1".into()).into());
    }
    if args.tile_costs.is_some() {
        return conflict(
            "--tile-costs is not available for sequences: each frame after the first is \
             handed out costliest first by the frames before it",
        );
    }
    if args.threads == Some(0) {
        return Err(ArgError::Value("--threads must be at least 1".into()).into());
    }
    Ok(())
}

/// Reads the scenes (or generates the one an orbit turns about) into a sequence.
fn load(args: &SequenceInput<'_>, limits: &Limits) -> anyhow::Result<Loaded> {
    let seq = &args.sequence;
    if let (Some(degrees), Some(n)) = (seq.orbit, seq.frames) {
        let spec = SceneSpec::from_args(args.files.first().cloned(), args.scene.as_deref(), None)?;
        let (desc, _) = spec.load(limits)?;
        let sequence = Sequence::orbit(desc, degrees, n).map_err(ArgError::refused)?;
        let scene = format!("{}, orbit {degrees}° in {n} frames", spec.label());
        let labels = (0..n).map(|k| format!("frame {k} of {}", spec.label()));
        return Ok(Loaded {
            sequence,
            inputs: args
                .files
                .iter()
                .map(|f| ("the scene", f.clone()))
                .collect(),
            labels: labels.collect(),
            scene,
        });
    }
    let (files, mut inputs, scene) = match &seq.frames_from {
        Some(list) => {
            let listed = read_frame_list(list, limits.max_file_bytes)?;
            let named = listed
                .into_iter()
                .map(|f| {
                    let at = format!("{}:{}", list.display(), f.line);
                    (f.path, Some(at))
                })
                .collect::<Vec<_>>();
            let scene = format!("{} frames from {}", named.len(), list.display());
            (named, vec![("--frames-from", list.clone())], scene)
        }
        None => {
            let named = args.files.iter().map(|f| (f.clone(), None)).collect();
            let scene = format!("{} scene files", args.files.len());
            (named, Vec::new(), scene)
        }
    };
    let mut scenes = Vec::with_capacity(files.len());
    let mut labels = Vec::with_capacity(files.len());
    for (path, at) in files {
        let read = SceneSpec::file(path.clone()).load(limits);
        let (desc, _) = match at {
            Some(at) => read.context(at)?,
            None => read?,
        };
        scenes.push(desc);
        labels.push(path.display().to_string());
        inputs.push(("a scene", path));
    }
    let sequence = Sequence::from_scenes(scenes).map_err(ArgError::refused)?;
    Ok(Loaded {
        sequence,
        inputs,
        labels,
        scene,
    })
}

/// Every frame's settings, as rendering it alone would make them, each checked (image limits,
/// the job's own checks once per distinct scene) before any work.
fn frame_settings(
    args: &SequenceInput<'_>,
    loaded: &Loaded,
) -> anyhow::Result<Vec<(RenderSettings, Choice)>> {
    let n = loaded.sequence.len();
    let mut settings: Vec<(RenderSettings, Choice)> = Vec::with_capacity(n);
    for (k, frame) in loaded.sequence.frames().iter().enumerate() {
        let desc = frame.description();
        let s = args
            .render
            .settings_and_precision(&desc)
            .with_context(|| loaded.labels[k].clone())?;
        args.limits
            .check_image(s.0.width, s.0.height, args.tile)
            .with_context(|| loaded.labels[k].clone())?;
        let first_of_scene =
            k == 0 || !std::sync::Arc::ptr_eq(&frame.scene, &loaded.sequence.frames()[k - 1].scene);
        if first_of_scene {
            parrt_render::render::validate_job(&desc, &s.0)
                .map_err(input_error)
                .with_context(|| format!("cannot prepare {}", loaded.labels[k]))?;
        }
        settings.push(s);
    }
    Ok(settings)
}

/// The frames' output paths from the `-o` pattern, their folder made if missing, and every
/// output checked against the inputs and the other outputs.
fn frame_outputs(args: &SequenceInput<'_>, loaded: &Loaded) -> anyhow::Result<Vec<PathBuf>> {
    let n = loaded.sequence.len();
    let pattern = FramePattern::parse(args.output, n)?;
    let outputs: Vec<PathBuf> = (0..n).map(|k| pattern.path(k)).collect();
    if !pattern.dir().as_os_str().is_empty() && !pattern.dir().exists() {
        std::fs::create_dir_all(pattern.dir()).map_err(|e| {
            ArgError::file(
                pattern.dir(),
                format!("cannot create the output folder: {e}"),
            )
        })?;
    }
    check_image_output(&outputs[0])?;
    if let Some(p) = &args.stats_json {
        check_file_output(p)?;
    }
    let mut files: Vec<(&str, Option<&std::path::Path>)> =
        outputs.iter().map(|p| ("-o", Some(p.as_path()))).collect();
    files.extend(loaded.inputs.iter().map(|(f, p)| (*f, Some(p.as_path()))));
    files.push(("--stats-json", args.stats_json.as_deref()));
    files.push(("--timeline", args.timeline));
    files.push(("--checkpoint", args.checkpoint));
    check_distinct(&files)?;
    Ok(outputs)
}

/// What a finished sequence prints: `--stats`, `--stats-json` and the closing line.
#[allow(clippy::too_many_arguments)]
fn print_report(
    args: &RenderArgs,
    loaded: &Loaded,
    settings: &[(RenderSettings, Choice)],
    outputs: &[PathBuf],
    opts: &SequenceOptions,
    result: SequenceResult,
    through: Option<&SequenceDone>,
    parse_s: f64,
    build_s: f64,
) -> anyhow::Result<()> {
    let n = loaded.sequence.len();
    let threads = opts.threads;
    let report = RenderReport {
        stats: result.stats,
        parse_s,
        build_s,
        trace_s: result.wall_s,
    };
    let (s0, choice) = &settings[0];
    let same_size = settings
        .iter()
        .all(|(s, _)| (s.width, s.height) == (s0.width, s0.height));
    let size = if same_size {
        format!("{}x{}", s0.width, s0.height)
    } else {
        "sizes differ".to_string()
    };
    let precision = parrt_render::precision::name(choice.precision);
    if args.stats {
        crate::outln!("scene             {}", loaded.scene);
        crate::outln!(
            "precision         {precision} ({}) [frame 0]",
            choice.reason
        );
        crate::outln!(
            "frames            {n}, {size}, {threads} threads, tile {}, window {} (at most {} alive)",
            args.tile,
            opts.window,
            result.most_alive
        );
        crate::outln!("tiles             {}", result.tiles);
        report.print();
        if let Some(d) = through {
            crate::outln!(
                "network           {} bytes sent, {} received; {} tiles' pixels through shared memory",
                d.bytes_sent,
                d.bytes_received,
                d.tiles_shared
            );
            crate::outln!(
                "master CPU        {:.4}s ({:.1} µs per tile)",
                d.master_cpu_s,
                d.master_cpu_s * 1e6 / result.tiles.max(1) as f64
            );
        }
    }
    if let Some(path) = &args.stats_json {
        let mut extra = json!({
            "scene": loaded.scene,
            "frames": n,
            "width": s0.width,
            "height": s0.height,
            "tile": args.tile,
            "threads": threads,
            "executor": opts.executor.name(),
            "window": opts.window,
            "most_alive": result.most_alive,
            "tiles": result.tiles,
            "precision": precision,
        });
        if let Some(d) = through {
            extra["bytes_sent"] = json!(d.bytes_sent);
            extra["bytes_received"] = json!(d.bytes_received);
            extra["tiles_shared"] = json!(d.tiles_shared);
            extra["master_cpu_s"] = json!(d.master_cpu_s);
        }
        let text = serde_json::to_string_pretty(&report.to_json(extra))?;
        write_whole(path, (text + "\n").as_bytes())?;
    }
    crate::errln!(
        "parrt: wrote {n} frames ({} … {}, {size}) in {:.2}s",
        outputs[0].display(),
        outputs[n - 1].display(),
        parse_s + result.wall_s
    );
    Ok(())
}

/// Renders the sequence through `n` local worker processes, frame after frame on the same
/// workers, each frame written as soon as it is complete. Returns what the sequence did, the
/// threads of each worker and what the runtime counted (bytes, the master's CPU).
fn render_through_workers(
    args: &RenderArgs,
    loaded: &Loaded,
    settings: &[(RenderSettings, Choice)],
    outputs: &[PathBuf],
    n: usize,
    progress: &std::sync::Arc<SequenceProgress>,
    live: Option<&crate::live::Live>,
) -> anyhow::Result<(SequenceResult, usize, SequenceDone)> {
    use parrt_runtime::observer::{Observer, Observers};
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let threads = args.threads.unwrap_or((cores / n).max(1));
    let mut observers = if progress.drawn() {
        Observers(vec![progress.clone() as std::sync::Arc<dyn Observer>])
    } else {
        Observers::default()
    };
    let recorder = sequence_recorder(&mut observers, args.job.timeline.is_some());
    if let Some(l) = live {
        observers.0.push(l.observer());
    }
    let mut config = super::distributed::master_config(super::distributed::MasterSetup {
        observers,
        job: &args.job,
        keyed: false,
        tile: args.tile,
        min_workers: n,
        output: &outputs[0],
    });
    super::distributed::local_workers(&mut config, n, threads);
    config.schedule.frames_window = args.sequence.window();
    let prepared = PreparedRef {
        loaded,
        settings,
        outputs,
    };
    let done = through_runtime("parrt", &config, &prepared, Some(progress), &mut |_| {
        Ok(None)
    })?;
    write_sequence_timeline(
        recorder.as_deref(),
        args.job.timeline.as_deref(),
        &prepared,
        args.tile,
        done.trace_s,
    )?;
    let result = SequenceResult {
        frames: loaded.sequence.len(),
        tiles: done.tiles,
        stats: done.stats,
        wall_s: done.trace_s,
        most_alive: done.most_open_frames,
        stopped: false,
    };
    Ok((result, threads, done))
}

/// The live view of a sequence when `--http` asked for one, told each frame's label and size.
/// `token`: the workers' lasting secret the view key derives from (`parrt master`), if any.
pub fn sequence_live(
    args: &crate::cli_args::live::LiveArgs,
    token: Option<&[u8]>,
    p: &PreparedRef<'_>,
    tile: u32,
    mode: &'static str,
) -> anyhow::Result<Option<crate::live::Live>> {
    let live = super::watch::start_live(args, token)?;
    if let Some(l) = &live {
        let jobs = p.settings.iter().zip(&p.loaded.labels);
        l.set_sequence(
            jobs.map(|((s, _), label)| crate::live::state::JobInfo {
                scene: label.clone(),
                mode,
                width: s.width,
                height: s.height,
                tile_size: tile,
            })
            .collect(),
        );
    }
    Ok(live)
}

/// A timeline recorder of a sequence's tiles, each with its frame, added to `observers` when
/// `--timeline` was given.
pub fn sequence_recorder(
    observers: &mut parrt_runtime::observer::Observers,
    asked: bool,
) -> Option<std::sync::Arc<crate::timeline::Recorder>> {
    asked.then(|| {
        let rec = std::sync::Arc::new(crate::timeline::Recorder::for_sequence());
        observers.0.push(rec.clone());
        rec
    })
}

/// What a sequence's timeline says of its job: the sequence, frame 0's image, the tile.
fn sequence_job<'a>(p: &'a PreparedRef<'_>, tile: u32) -> crate::timeline::Job<'a> {
    let s0 = &p.settings[0].0;
    crate::timeline::Job {
        scene: &p.loaded.scene,
        width: s0.width,
        height: s0.height,
        tile_size: tile,
    }
}

/// Writes the timeline `rec` recorded of a sequence through workers to `path`, if both are
/// given.
pub fn write_sequence_timeline(
    rec: Option<&crate::timeline::Recorder>,
    path: Option<&std::path::Path>,
    p: &PreparedRef<'_>,
    tile: u32,
    trace_s: f64,
) -> anyhow::Result<()> {
    match (rec, path) {
        (Some(rec), Some(path)) => rec.timeline(&sequence_job(p, tile), trace_s).write(path),
        _ => Ok(()),
    }
}

/// A prepared sequence, borrowed.
pub struct PreparedRef<'a> {
    /// The frames.
    pub loaded: &'a Loaded,
    /// Each frame's settings.
    pub settings: &'a [(RenderSettings, Choice)],
    /// Each frame's output file.
    pub outputs: &'a [PathBuf],
}

impl Prepared {
    /// The prepared sequence, borrowed as [`through_runtime`] takes it.
    pub fn as_ref(&self) -> PreparedRef<'_> {
        PreparedRef {
            loaded: &self.loaded,
            settings: &self.settings,
            outputs: &self.outputs,
        }
    }
}

/// Refuses the first of `flags` given (`(flag, given)`) that sequences do not take yet (exit 2).
pub fn refuse_for_sequences(flags: &[(&str, bool)]) -> anyhow::Result<()> {
    match flags.iter().find(|(_, given)| *given) {
        Some((flag, _)) => Err(ArgError::Conflict(format!(
            "{flag} is not available for sequences yet; render the frame alone for it"
        ))
        .into()),
        None => Ok(()),
    }
}

/// The line `parrt master` and `parrt cluster` end a sequence with: the frames written, the
/// tiles, the trace time, the rays and the bytes each way.
pub fn report_frames(who: &str, outputs: &[PathBuf], r: &SequenceDone) {
    let n = outputs.len();
    crate::errln!(
        "{who}: wrote {n} frames ({} … {}; {} tiles in {:.3} s; {} rays; {} bytes out, {} in)",
        outputs[0].display(),
        outputs[n - 1].display(),
        r.tiles,
        r.trace_s,
        r.stats.total_rays(),
        r.bytes_sent,
        r.bytes_received,
    );
}

/// What a sequence rendered through workers did: summed over its frames, those a resumed
/// checkpoint had already (their tiles and ray statistics from its records) included.
pub struct SequenceDone {
    /// Tiles over every frame.
    pub tiles: usize,
    /// Ray statistics over every frame.
    pub stats: parrt_render::stats::RayStats,
    /// Wall seconds of this run's trace, through the last frame's writing (0 when nothing
    /// was left to render).
    pub trace_s: f64,
    /// Bytes sent to the workers.
    pub bytes_sent: u64,
    /// Bytes received from them.
    pub bytes_received: u64,
    /// Tiles whose pixels came through memory shared with a worker the master started.
    pub tiles_shared: u64,
    /// The most frames open at once.
    pub most_open_frames: usize,
    /// The master's CPU seconds over this run's trace, the last frame's writing included (its
    /// process: every thread).
    pub master_cpu_s: f64,
}

/// Renders a prepared sequence through the distributed runtime as `config` says (local
/// workers, a listen address, a token), every frame on the same workers, each written to its
/// output as soon as it is complete (the last when the render returns). With a checkpoint in
/// `config` (`--checkpoint`, `--resume`) the sequence's checkpoint is opened first
/// ([`crate::sequence_checkpoint`]) and only the frames it does not hold are rendered.
/// `on_listen` is [`parrt_runtime::run`]'s; `who` begins the line that says what a resume
/// found.
pub fn through_runtime(
    who: &str,
    config: &parrt_runtime::MasterConfig,
    p: &PreparedRef<'_>,
    progress: Option<&SequenceProgress>,
    on_listen: &mut dyn FnMut(
        std::net::SocketAddr,
    )
        -> Result<Option<std::net::SocketAddr>, parrt_runtime::DistError>,
) -> anyhow::Result<SequenceDone> {
    let frame_settings: Vec<RenderSettings> = p.settings.iter().map(|(s, _)| s.clone()).collect();
    let write = |k: usize, film: &parrt_render::film::Film| -> anyhow::Result<()> {
        film.save(&p.outputs[k])
            .with_context(|| format!("cannot write frame {k}"))?;
        if let Some(bar) = progress {
            bar.frame();
        }
        Ok(())
    };
    let mut frames = ResumableFrames::all(&p.loaded.sequence, &frame_settings, p.outputs, &write);
    let mut before = Resumed::default();
    let mut config = config.clone();
    if let Some(at) = config.checkpoint.take() {
        let secret = config.net.token.as_ref().filter(|_| at.keyed);
        let opened = frames.with_checkpoint(
            &at.path,
            at.resume,
            secret.map(|t| t.as_bytes()),
            config.schedule.tile,
            config.schedule.pixel_format,
        )?;
        (frames, before) = opened;
        if before.resumed {
            crate::errln!(
                "{who}: checkpoint {}: {} of {} frames already written, {} assembled from it, \
                 {} tiles of the others restored, {} bad records dropped",
                at.path.display(),
                before.skipped,
                p.outputs.len(),
                before.assembled,
                before.restored_tiles,
                before.bad_records
            );
        }
    }
    let mut done = SequenceDone {
        tiles: before.tiles_before,
        stats: before.stats_before,
        trace_s: 0.0,
        bytes_sent: 0,
        bytes_received: 0,
        tiles_shared: 0,
        most_open_frames: 0,
        master_cpu_s: 0.0,
    };
    let (Some(&first), Some(&last)) = (frames.todo().first(), frames.todo().last()) else {
        frames.close()?;
        return Ok(done);
    };
    let desc = p.loaded.sequence.frames()[first].description().into_owned();
    let job =
        parrt_runtime::Job::<parrt_runtime::DistError>::ready(desc, frame_settings[first].clone());
    let r = parrt_runtime::run_sequence(&config, job, &mut frames, on_listen, None)
        .context("distributed render failed")?;
    // The last frame is written here, after the runtime's trace ended: its writing counts in
    // the trace and the master's CPU, as it does in SMP's trace (which ends when the last
    // frame is written).
    let (writing, cpu_before) = (
        std::time::Instant::now(),
        parrt_runtime::cpu_time::process_cpu_s(),
    );
    frames.write_frame(last, &r.result.film)?;
    let last_write_s = writing.elapsed().as_secs_f64();
    let last_write_cpu_s = parrt_runtime::cpu_time::process_cpu_s() - cpu_before;
    frames.close()?;
    let r = r.result;
    done.tiles += r.tiles;
    done.stats += r.stats;
    done.trace_s = r.trace_s + last_write_s;
    done.bytes_sent = r.bytes_sent;
    done.bytes_received = r.bytes_received;
    done.tiles_shared = r.tiles_shared;
    done.most_open_frames = r.most_open_frames;
    done.master_cpu_s = r.master_cpu_s + last_write_cpu_s;
    Ok(done)
}

/// Runs `parrt render` of a sequence.
pub fn run(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    refuse_unsupported(args)?;
    let Prepared {
        loaded,
        settings,
        outputs,
        parse_s,
    } = prepare(&SequenceInput::of_render(args))?;
    let n = loaded.sequence.len();

    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let opts = SequenceOptions {
        threads,
        tile: args.tile,
        executor: args.executor.executor(),
        window: args.sequence.window(),
        // 8-bit films when every frame's file keeps 8 bits: a quarter of the memory.
        rgb8: outputs.iter().all(|o| {
            !matches!(
                parrt_render::film::ImageFormat::from_path(o),
                Ok(parrt_render::film::ImageFormat::Exr) | Err(_)
            )
        }),
    };
    let total_tiles = settings
        .iter()
        .map(|(s, _)| parrt_render::tile::tiles(s.width, s.height, args.tile).len())
        .sum();
    let progress = std::sync::Arc::new(SequenceProgress::new(total_tiles, n));
    let prepared = PreparedRef {
        loaded: &loaded,
        settings: &settings,
        outputs: &outputs,
    };
    let mode = if args.workers.is_some() {
        "distributed"
    } else {
        "smp"
    };
    let live = sequence_live(&args.job.live, None, &prepared, args.tile, mode)?;
    if let Some(workers) = args.workers {
        let (result, threads, done) = render_through_workers(
            args,
            &loaded,
            &settings,
            &outputs,
            workers,
            &progress,
            live.as_ref(),
        )?;
        progress.finish();
        if let Some(l) = live {
            l.end(true);
        }
        let opts = SequenceOptions {
            threads: workers * threads,
            ..opts
        };
        print_report(
            args,
            &loaded,
            &settings,
            &outputs,
            &opts,
            result,
            Some(&done),
            parse_s,
            0.0,
        )?;
        return Ok(ExitCode::SUCCESS);
    }
    let build_s = Mutex::new(0.0f64);
    // A later frame of the same scene (an orbit) that only moves the camera shares its build.
    let builder = FrameBuilder::new(&loaded.sequence);
    let build = |k: usize| -> anyhow::Result<Renderer> {
        let t = Instant::now();
        let mut r = builder
            .build(k, &settings[k].0)
            .map_err(input_error)
            .with_context(|| format!("cannot prepare {}", loaded.labels[k]))?;
        r.set_packets(!args.no_packets);
        *build_s.lock().unwrap_or_else(|e| e.into_inner()) += t.elapsed().as_secs_f64();
        Ok(r)
    };
    let write = |done: FrameDone| -> anyhow::Result<()> {
        let path = &outputs[done.index];
        done.film
            .save(path)
            .with_context(|| format!("cannot write frame {}", done.index))?;
        progress.frame();
        Ok(())
    };
    stop_on_ctrl_c();
    // With --timeline each tile's span (thread, start, end) is kept, with its frame.
    let spans = Mutex::new(Vec::new());
    let keep = args.job.timeline.is_some();
    // The live view sees the render threads as its workers, as for one frame.
    let watcher = live.as_ref().map(|l| l.observer());
    let origin = tokio::time::Instant::now();
    if let Some(o) = &watcher {
        for t in 0..threads {
            let id = t as parrt_runtime::scheduler::WorkerId;
            o.joined(id, &format!("thread {t}"), 1, origin);
            o.ready(id, origin);
        }
        o.started(origin);
    }
    let on_tile = |t: parrt_render::sequence_smp::SequenceTile<'_>| {
        progress.tile();
        if let Some(o) = &watcher {
            let id = parrt_runtime::scheduler::WorkerId::from(t.span.thread);
            let seconds = (t.span.end_s - t.span.start_s).max(0.0);
            o.assigned_in(t.frame, id, t.tile, 1, false, origin);
            o.result_in(t.frame, id, t.tile, t.pixels, t.stats, seconds, true);
        }
        if keep {
            let mut s = spans.lock().unwrap_or_else(|e| e.into_inner());
            s.push((t.frame, t.tile.id, t.span));
        }
    };
    let result = render_sequence(n, &opts, &build, &write, &on_tile, &STOP)?;
    progress.finish();
    if let Some(l) = live {
        l.end(!result.stopped);
    }
    if let Some(path) = &args.job.timeline {
        let spans = spans.into_inner().unwrap_or_else(|e| e.into_inner());
        let job = sequence_job(&prepared, args.tile);
        crate::timeline::Timeline::from_smp_sequence(&job, threads, &spans, result.wall_s)
            .write(path)?;
    }
    if result.stopped {
        crate::errln!(
            "parrt: stopped by Ctrl-C; {} of {n} frames written, each complete",
            result.frames
        );
        return Ok(crate::exit::stopped_by(libc::SIGINT));
    }
    let build_s = build_s.into_inner().unwrap_or_else(|e| e.into_inner());
    print_report(
        args, &loaded, &settings, &outputs, &opts, result, None, parse_s, build_s,
    )?;
    Ok(ExitCode::SUCCESS)
}
