//! `parrt cluster`: one command for every rank of a job started by `srun -n N`, `mpirun -np N`
//! or `mpiexec -n N`. Rank 0 becomes the master and publishes its address and a fresh token in
//! a rendezvous file; the other ranks read it and render as workers. Arguments and dispatch
//! only: the environment is read by [`parrt_runtime::launcher`], the file protocol is
//! [`parrt_runtime::rendezvous`], the render is [`parrt_runtime::run`]'s.

use super::distributed::{master_config, MasterSetup};
use super::report::print_summary;
use super::watch::{start_live, Watch};
use crate::cli_args::durations::{seconds_flag, MAX_FLAG_DURATION};
use crate::cli_args::listen::check_listen;
use crate::cli_args::output::check_image_output;
use crate::cli_args::{JobFlags, LimitArgs, RenderFlags, SceneSpec};
use crate::exit::input_error;
use anyhow::Context;
use clap::Args;
use parrt_protocol::Token;
use parrt_runtime::launcher::{self, Rank};
use parrt_runtime::rendezvous::{self, Rendezvous};
use parrt_runtime::Job;
use parrt_worker::cli::{init_logging, log_level, TokenArgs, WorkerArgs};
use rand::Rng;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of `parrt cluster` (the same for every rank).
#[derive(Debug, Args)]
pub struct ClusterArgs {
    /// The NFF scene to render, or parrt's JSON form if it ends in .json (read by rank 0 only;
    /// workers receive it over TCP). Several files render a sequence, one frame each.
    #[arg(value_name = "SCENE.nff")]
    pub files: Vec<PathBuf>,
    /// A generated scene, NAME or NAME:SIZE.
    #[arg(long, value_name = "NAME[:SIZE]")]
    pub scene: Option<String>,
    /// Output image: .png, .ppm (8-bit binary P6) or .exr (linear float), written by rank 0.
    #[arg(short, long, value_name = "OUT", default_value = "parrt.png")]
    pub output: PathBuf,
    /// A directory every rank sees (a shared file system) where rank 0 publishes its address
    /// and the job's token.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub rendezvous: PathBuf,
    /// Seconds the other ranks wait for rank 0's rendezvous file (and to dial it).
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub rendezvous_timeout: f64,
    /// The job's id, the same for every rank (default: from the launcher: Slurm's job and step,
    /// Open MPI's job id, else a hash of the launcher's variables, which under MPICH's Hydra
    /// is the same for every job of one size: give e.g. `--job-id $(date +%s%N)` there).
    #[arg(long, value_name = "ID")]
    pub job_id: Option<String>,
    /// Address rank 0 listens on (default: every interface, a free port).
    #[arg(long, value_name = "ADDR", default_value = "0.0.0.0:0")]
    pub listen: String,
    /// The host name the other ranks dial (default: rank 0's host name when listening on every
    /// interface, else the --listen address).
    #[arg(long, value_name = "HOST")]
    pub advertise: Option<String>,
    /// Render threads of each worker rank (default: SLURM_CPUS_PER_TASK, else the cores this
    /// process is bound to).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Tile edge in pixels.
    #[arg(long, value_name = "S", default_value_t = 32)]
    pub tile: u32,
    /// Seconds rank 0 waits for every other rank to be ready (and, mid-job, for any worker when
    /// all have left) before giving up; at most a week.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub wait_workers: f64,
    /// Checkpoint (kept on rank 0), timeline and live view.
    #[command(flatten)]
    pub job: JobFlags,
    /// A sequence: `--frames-from`, `--orbit`/`--frames` (then `-o` is a pattern).
    #[command(flatten)]
    pub sequence: crate::cli_args::sequence::SequenceArgs,
    /// The order tiles are handed out in.
    #[command(flatten)]
    pub order: crate::cli_args::tile_order::OrderArgs,
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

/// Runs one rank of `parrt cluster`.
pub fn run(args: ClusterArgs) -> anyhow::Result<ExitCode> {
    init_logging(log_level(args.verbose));
    let env = |k: &str| std::env::var(k).ok();
    let rank = launcher::rank_from(&env).map_err(input_error)?;
    let vars: Vec<(String, String)> = std::env::vars().collect();
    let job = match &args.job_id {
        Some(j) if j.trim().is_empty() => {
            return Err(input_error(anyhow::anyhow!("--job-id must not be empty")))
        }
        Some(j) => j.clone(),
        None => launcher::job_id(&vars),
    };
    let timeout = seconds_flag(
        "--rendezvous-timeout",
        args.rendezvous_timeout,
        Duration::ZERO,
        MAX_FLAG_DURATION,
    )?;
    if rank.rank == 0 {
        run_master(&args, &rank, &job, timeout)
    } else {
        run_worker(&args, &rank, &job, timeout)
    }
}

fn fresh_token() -> anyhow::Result<(String, Token)> {
    let mut rng = rand::thread_rng();
    let text: String = (0..32)
        .map(|_| char::from_digit(rng.gen_range(0..16), 16).unwrap_or('0'))
        .collect();
    let token = Token::new(&text).context("cannot make a token")?;
    Ok((text, token))
}

/// The address the other ranks dial for a master bound at `bound`.
fn advertised(args: &ClusterArgs, bound: SocketAddr) -> String {
    let host = match &args.advertise {
        Some(h) => h.clone(),
        None if bound.ip().is_unspecified() => rendezvous::host_name(),
        None => return bound.to_string(),
    };
    if host.contains(':') {
        format!("[{host}]:{}", bound.port())
    } else {
        format!("{host}:{}", bound.port())
    }
}

/// Rank 0's checks of what the user gave, before the scene is read: the flags, the outputs,
/// the listen address and the rendezvous directory (a leftover file there is refused).
/// Returns `--wait-workers`.
fn check_master_flags(
    args: &ClusterArgs,
    job: &str,
    timeout: Duration,
) -> anyhow::Result<Duration> {
    if args.tile == 0 {
        return Err(input_error(anyhow::anyhow!("--tile must be at least 1")));
    }
    let wait_workers = seconds_flag(
        "--wait-workers",
        args.wait_workers,
        Duration::ZERO,
        MAX_FLAG_DURATION,
    )?;
    check_image_output(&args.output)?;
    args.job.check_outputs(&[
        ("-o", Some(&args.output)),
        ("the scene", args.files.first().map(PathBuf::as_path)),
        ("--costly-first", args.order.costly_first.as_deref()),
    ])?;
    check_listen(&args.listen)?;
    if !args.rendezvous.is_dir() {
        return Err(input_error(anyhow::anyhow!(
            "--rendezvous {}: not a directory (give one every rank sees)",
            args.rendezvous.display()
        )));
    }
    // A leftover file is refused before the scene is even read.
    rendezvous::check_free(&args.rendezvous, job, timeout)
        .map_err(|e| input_error(anyhow::Error::new(e)))?;
    Ok(wait_workers)
}

fn run_master(
    args: &ClusterArgs,
    rank: &Rank,
    job: &str,
    timeout: Duration,
) -> anyhow::Result<ExitCode> {
    if args.files.len() > 1 || args.sequence.asked() {
        return run_master_sequence(args, rank, job, timeout);
    }
    let wait_workers = check_master_flags(args, job, timeout)?;
    let spec = SceneSpec::from_args(args.files.first().cloned(), args.scene.as_deref(), None)?;
    let (desc, _) = spec.load(&args.limits.limits())?;
    let label = spec.label();
    let settings = args.render.settings(&desc)?;
    args.limits
        .check_image(settings.width, settings.height, args.tile)?;
    parrt_render::render::validate_job(&desc, &settings)
        .map_err(input_error)
        .with_context(|| format!("no worker could render {label}"))?;
    let (token_text, token) = fresh_token()?;
    let live = start_live(&args.job.live, Some(token.as_bytes()))?;
    let watch = Watch::new(
        args.job.timeline.as_deref(),
        live,
        crate::live::state::JobInfo {
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
        // The job's token is fresh in every run: nothing to key a resume with.
        keyed: false,
        tile: args.tile,
        min_workers: rank.size - 1,
        output: &args.output,
    });
    config.schedule.wait_workers = wait_workers;
    config.schedule.await_all_workers = true;
    config.schedule.order = args
        .order
        .order(settings.width, settings.height, args.tile)?;
    config.net.listen = args.listen.clone();
    config.net.token = Some(token);
    let (w, h) = (settings.width, settings.height);
    let ready = Job::<parrt_runtime::DistError>::ready(desc, settings);
    let mut published = None;
    let result = parrt_runtime::run(
        &config,
        ready,
        &mut |bound| {
            let line = format!("{label} at {w}x{h}");
            published = Some(publish(
                args,
                rank,
                job,
                &token_text,
                bound,
                timeout,
                wait_workers,
                &line,
            )?);
            Ok(None)
        },
        None,
    );
    // The rendezvous file goes as soon as the render ends, whatever its outcome.
    drop(published);
    let result = result.context("distributed render failed")?.result;
    result
        .film
        .save(&args.output)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    print_summary(&result, &args.output);
    watch.end(result.trace_s)?;
    Ok(ExitCode::SUCCESS)
}

/// Publishes rank 0's address and the job's token in the rendezvous file, and says so.
#[allow(clippy::too_many_arguments)]
fn publish(
    args: &ClusterArgs,
    rank: &Rank,
    job: &str,
    token_text: &str,
    bound: SocketAddr,
    timeout: Duration,
    wait_workers: Duration,
    what: &str,
) -> Result<rendezvous::Published, parrt_runtime::DistError> {
    let r = Rendezvous {
        version: rendezvous::VERSION,
        job: job.to_string(),
        size: rank.size,
        address: advertised(args, bound),
        token: token_text.to_string(),
        pid: std::process::id(),
        host: rendezvous::host_name(),
        created: rendezvous::now_unix(),
    };
    let p = rendezvous::publish(&args.rendezvous, &r, timeout)?;
    crate::errln!(
        "parrt cluster: rank 0 of {} ({}, job {job}) is the master on {bound}, published as {} in {}; {what}",
        rank.size,
        rank.launcher,
        r.address,
        p.path().display(),
    );
    crate::errln!(
        "parrt cluster: {}",
        super::master::waiting_line(rank.size - 1, wait_workers)
    );
    Ok(p)
}

/// Rank 0 of a sequence: every frame through the other ranks, one after another on the same
/// workers, each written by rank 0 as soon as it is complete.
fn run_master_sequence(
    args: &ClusterArgs,
    rank: &Rank,
    job: &str,
    timeout: Duration,
) -> anyhow::Result<ExitCode> {
    use super::render_sequence::{prepare, refuse_for_sequences, through_runtime, SequenceInput};
    use super::sequence_watch::SequenceWatch;
    refuse_for_sequences(&[("--costly-first", args.order.costly_first.is_some())])?;
    let wait_workers = check_master_flags(args, job, timeout)?;
    let p = prepare(&SequenceInput {
        files: &args.files,
        scene: &args.scene,
        sequence: &args.sequence,
        render: &args.render,
        limits: &args.limits,
        tile: args.tile,
        output: &args.output,
        stats_json: &None,
        timeline: args.job.timeline.as_deref(),
        checkpoint: args.job.checkpoint.as_deref(),
    })?;
    let (token_text, token) = fresh_token()?;
    let mut watch = SequenceWatch::start(&args.job, token.as_bytes(), &p.as_ref(), args.tile)?;
    let mut config = master_config(MasterSetup {
        observers: watch.observers(),
        job: &args.job,
        keyed: false,
        tile: args.tile,
        min_workers: rank.size - 1,
        output: &p.outputs[0],
    });
    config.schedule.wait_workers = wait_workers;
    config.schedule.await_all_workers = true;
    config.schedule.frames_window = args.sequence.window();
    config.net.listen = args.listen.clone();
    config.net.token = Some(token);
    let n = p.outputs.len();
    let what = format!(
        "{} frames ({} … {})",
        n,
        p.outputs[0].display(),
        p.outputs[n - 1].display()
    );
    let mut published = None;
    let result = through_runtime("parrt cluster", &config, &p.as_ref(), None, &mut |bound| {
        published = Some(publish(
            args,
            rank,
            job,
            &token_text,
            bound,
            timeout,
            wait_workers,
            &what,
        )?);
        Ok(None)
    });
    drop(published);
    let r = result?;
    watch.finish("parrt cluster", &args.job, &p.as_ref(), args.tile, &r)?;
    Ok(ExitCode::SUCCESS)
}

fn run_worker(
    args: &ClusterArgs,
    rank: &Rank,
    job: &str,
    timeout: Duration,
) -> anyhow::Result<ExitCode> {
    let env = |k: &str| std::env::var(k).ok();
    let threads = args
        .threads
        .unwrap_or_else(|| launcher::default_threads(&env));
    let r = rendezvous::wait(&args.rendezvous, job, rank.size, timeout)
        .map_err(|e| input_error(anyhow::Error::new(e)))
        .with_context(|| format!("rank {} of {} ({})", rank.rank, rank.size, rank.launcher))?;
    tracing::info!(
        rank = rank.rank,
        size = rank.size,
        master = %r.address,
        threads,
        "joining the job"
    );
    let worker = WorkerArgs {
        connect: r.address,
        threads: Some(threads),
        name: Some(format!("rank{}@{}", rank.rank, rendezvous::host_name())),
        dial_timeout: timeout.as_secs_f64(),
        replay: None,
        cost_scale: 1.0,
        verbose: args.verbose,
        token: TokenArgs {
            token: Some(r.token),
            token_file: None,
        },
    };
    // The same program as `parrt worker`, with the same exit codes.
    parrt_worker::cli::run(worker).map_err(crate::exit::worker_error)
}
