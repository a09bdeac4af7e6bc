//! Distributed rendering (DESIGN §8): a master hands tile tasks over TCP to worker processes
//! and assembles their results into the same film an SMP render produces, bit for bit.
//!
//! ## Layout
//! - [`server`]: binds, accepts, runs the scheduler loop, shuts down cleanly.
//! - [`connection`]: one task per peer: handshake, then relaying between socket and scheduler.
//! - [`scheduler`]: the job's state and rules (windows, deadlines, first result wins, backups);
//!   no I/O, tested alone.
//! - [`spawn`]: local worker processes for `parrt render --workers N`.
//! - [`checkpoint`]: the file of accepted tiles a killed master resumes from.
//! - [`progress`]: the progress line.
//! - [`observer`]: watchers told what happens to workers and tiles (timeline, live view).
//! - [`refusals`]: the bounded record of refused handshakes.
//! - [`launcher`]: rank, size and job id from `srun`/`mpirun`/`mpiexec`'s environment.
//! - [`rendezvous`]: the file through which the ranks of `parrt cluster` meet.
//!
//! [`render_distributed`] is the one-call entry point (used by `parrt render --workers` and
//! `parrt master`); [`server::Master`] is the async API underneath.

pub mod checkpoint;
pub mod connection;
pub mod launcher;
pub mod observer;
pub mod progress;
pub mod refusals;
pub mod rendezvous;
pub mod scheduler;
pub mod server;
pub mod spawn;

pub use scheduler::{FaultCounts, WorkerReport};
pub use server::Master;
pub use spawn::{spawn_local_workers, LocalWorkers};

use parrt::description::SceneDescription;
use parrt::film::Film;
use parrt::protocol::{PixelFormat, Token, DEFAULT_MAX_FRAME};
use parrt::settings::RenderSettings;
use parrt::stats::RayStats;
pub use parrt::window::Window;
use rand::Rng;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::time::Duration;
use thiserror::Error;
use tokio_util::sync::CancellationToken;

/// The default address of `parrt master`: loopback only; any other must be asked for.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:7878";

/// How often the master sends heartbeats (whole seconds; `--heartbeat-timeout` is at least two).
pub const DEFAULT_HEARTBEAT: Duration = Duration::from_secs(1);

/// Errors of a distributed render.
#[derive(Debug, Error)]
pub enum DistError {
    /// The listen address could not be bound. (The cause is the source, printed after the
    /// message by `{:#}`; not repeated here.)
    #[error("cannot listen on {addr}")]
    Bind {
        /// The address asked for.
        addr: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Not enough workers arrived in time.
    #[error("{}", no_workers_message(*waited, *wanted, *ready, failed))]
    NoWorkers {
        /// How long we waited.
        waited: Duration,
        /// Workers needed to start.
        wanted: usize,
        /// Workers that were ready.
        ready: usize,
        /// Workers that connected and left before being ready, as `name: reason` (those that
        /// could not build the job say why here).
        failed: Vec<String>,
    },
    /// Every worker left mid-job and none came back in time.
    #[error("all workers left and none returned within {waited:?} ({done}/{total} tiles done)")]
    AllWorkersLost {
        /// How long we waited.
        waited: Duration,
        /// Tiles done.
        done: usize,
        /// Tiles in all.
        total: usize,
    },
    /// Cancelled (Ctrl-C); workers were told to shut down.
    #[error("interrupted; workers were told to shut down")]
    Interrupted,
    /// The accept loop ended unexpectedly.
    #[error("the listener stopped accepting connections")]
    AcceptFailed,
    /// Local workers could not be started.
    #[error(transparent)]
    Spawn(#[from] spawn::SpawnError),
    /// A tile's pixels would not fit one frame.
    #[error("tiles of {tile}x{tile} pixels do not fit the {max_frame}-byte frame limit")]
    TileTooLarge {
        /// The tile edge.
        tile: u32,
        /// The frame limit.
        max_frame: usize,
    },
    /// The checkpoint could not be used (another job's, exists without `--resume`, I/O).
    #[error(transparent)]
    Checkpoint(#[from] checkpoint::CheckpointError),
    /// The ranks of `parrt cluster` could not meet (a leftover or foreign rendezvous file, I/O).
    #[error(transparent)]
    Rendezvous(#[from] rendezvous::RendezvousError),
    /// The async runtime could not start.
    #[error("cannot start the async runtime: {0}")]
    Runtime(std::io::Error),
    /// The job message could not be encoded.
    #[error("cannot encode the job: {0}")]
    EncodeJob(parrt::protocol::ProtocolError),
    /// The job (its scene) is larger than a frame may be.
    #[error(
        "the job (scene and settings) is {bytes} bytes, more than the {max_frame}-byte frame limit"
    )]
    JobTooLarge {
        /// Bytes of the encoded job.
        bytes: usize,
        /// The frame limit.
        max_frame: usize,
    },
}

impl DistError {
    /// Whether the user's input caused it (exit 2): a tile too large for a frame, a checkpoint
    /// of another job or one that exists without `--resume`.
    pub fn is_bad_input(&self) -> bool {
        match self {
            DistError::TileTooLarge { .. } | DistError::JobTooLarge { .. } => true,
            DistError::Checkpoint(e) => e.is_bad_input(),
            DistError::Rendezvous(e) => e.is_bad_input(),
            _ => false,
        }
    }
}

/// Reasons shown in [`DistError::NoWorkers`] at most.
const SHOWN_FAILURES: usize = 3;
/// Characters of each reason shown (a peer chooses its name).
const SHOWN_REASON_CHARS: usize = 300;

fn no_workers_message(waited: Duration, wanted: usize, ready: usize, failed: &[String]) -> String {
    if failed.is_empty() {
        return format!(
            "no worker arrived within {waited:?} ({ready} of the {wanted} needed connected and \
             built the job); start workers with `parrt worker --connect ADDR` and the same token"
        );
    }
    let mut reasons = failed
        .iter()
        .take(SHOWN_FAILURES)
        .map(|r| match r.char_indices().nth(SHOWN_REASON_CHARS) {
            Some((cut, _)) => format!("{}…", &r[..cut]),
            None => r.clone(),
        })
        .collect::<Vec<_>>()
        .join("; ");
    if failed.len() > SHOWN_FAILURES {
        reasons += &format!("; and {} more", failed.len() - SHOWN_FAILURES);
    }
    format!(
        "{} worker{} connected but could not build the job within {waited:?} ({ready} of the \
         {wanted} needed ready): {reasons}",
        failed.len(),
        if failed.len() == 1 { "" } else { "s" }
    )
}

/// How to run a distributed render.
#[derive(Clone, Debug)]
pub struct DistOptions {
    /// Local worker processes to start (0: only external workers).
    pub workers_to_spawn: usize,
    /// Render threads of each spawned worker.
    pub threads_per_worker: usize,
    /// Executable for spawned workers (`None`: this process's own, via `current_exe`).
    pub worker_exe: Option<std::path::PathBuf>,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Address to listen on (`127.0.0.1:0` picks a free port).
    pub listen: String,
    /// Shared secret; `None` generates a random one (fine for spawned workers only).
    pub token: Option<Token>,
    /// Workers that must be ready before tiles are handed out.
    pub min_workers: usize,
    /// How long to wait for `min_workers` (and, mid-job, for any worker when all have left).
    pub wait_workers: Duration,
    /// Assignments (batches) in flight per worker: a fixed number per thread (two by default),
    /// or its threads plus what its measured round trip needs ([`Window::Auto`]).
    pub window: Window,
    /// The most tiles in one assignment; batches shrink to single tiles as work runs out
    /// (1: every tile on its own, as before batching).
    pub max_batch: usize,
    /// A tile not returned within this is given to another worker.
    pub tile_deadline: Duration,
    /// How often the master sends heartbeats.
    pub heartbeat: Duration,
    /// A worker silent this long is considered gone.
    pub heartbeat_timeout: Duration,
    /// Time allowed for a peer's handshake.
    pub handshake_timeout: Duration,
    /// Failures after which a worker is dropped.
    pub max_failures: u32,
    /// Duplicate in-flight tiles onto idle workers when the queue is empty.
    pub backups: bool,
    /// Largest frame sent to a worker (the Job with its scene is the large one); what the master
    /// accepts from a worker is the smaller of this and what a result of the job's tile size
    /// needs ([`parrt::protocol::limits::worker_frame_limit`]).
    pub max_frame: usize,
    /// Most simultaneous connections (handshaking or working).
    pub max_connections: usize,
    /// Show the progress bar (only ever drawn on a terminal).
    pub progress: bool,
    /// How workers send pixels: [`PixelFormat::Rgb8`] when only an 8-bit image will be
    /// written (a quarter of the bytes; the written image is the same), `F32` for the exact
    /// film (the default).
    pub pixel_format: PixelFormat,
    /// Record each accepted tile in this file ([`checkpoint`]).
    pub checkpoint: Option<std::path::PathBuf>,
    /// Continue the render recorded in `checkpoint` (else an existing file is refused).
    pub resume: bool,
    /// Wait for `min_workers` even when a resumed checkpoint left nothing to render, so that
    /// each is told to shut down (`parrt cluster`: its worker ranks would otherwise wait for a
    /// master that has gone).
    pub await_all_workers: bool,
    /// Told what happens to workers and tiles (`--timeline`, `--http`); none by default.
    pub observers: observer::Observers,
}

impl Default for DistOptions {
    fn default() -> Self {
        DistOptions {
            workers_to_spawn: 0,
            threads_per_worker: 1,
            worker_exe: None,
            tile: 32,
            listen: "127.0.0.1:0".into(),
            token: None,
            min_workers: 1,
            wait_workers: Duration::from_secs(60),
            window: Window::default(),
            max_batch: 8,
            tile_deadline: Duration::from_secs(120),
            heartbeat: DEFAULT_HEARTBEAT,
            heartbeat_timeout: Duration::from_secs(10),
            handshake_timeout: Duration::from_secs(10),
            max_failures: 3,
            backups: true,
            max_frame: DEFAULT_MAX_FRAME,
            max_connections: 1024,
            progress: true,
            pixel_format: PixelFormat::F32,
            checkpoint: None,
            resume: false,
            await_all_workers: false,
            observers: Default::default(),
        }
    }
}

/// What a distributed render produced.
#[derive(Debug)]
pub struct DistResult {
    /// The image (equal to the SMP film).
    pub film: Film,
    /// Ray statistics merged from the winning result of each tile.
    pub stats: RayStats,
    /// Seconds each tile took on the worker that delivered it, by tile id.
    pub tile_seconds: Vec<f64>,
    /// Wall time from the first tile handed out to the last one received.
    pub trace_s: f64,
    /// CPU seconds the master process spent over the same span (all its threads): receiving,
    /// decoding and checking results, filling the film, scheduling, heartbeats.
    pub master_cpu_s: f64,
    /// Every worker that took part.
    pub per_worker: Vec<WorkerReport>,
    /// Bytes sent to authenticated workers (frames with prefixes).
    pub bytes_sent: u64,
    /// Bytes received from authenticated workers.
    pub bytes_received: u64,
    /// Mean seconds to get the scene to a worker (job sent → Ready, minus its build).
    pub scene_transfer_s: f64,
    /// Faults met and handled.
    pub faults: FaultCounts,
    /// Tiles in the image.
    pub tiles: usize,
    /// Tiles taken from the checkpoint rather than rendered.
    pub restored_tiles: usize,
    /// Checkpoint records not trusted on resume (bad checksum, not a tile of this job).
    pub checkpoint_bad_records: usize,
}

impl DistResult {
    /// The master's CPU microseconds per tile delivered.
    pub fn master_cpu_per_tile_us(&self) -> f64 {
        self.master_cpu_s * 1e6 / self.tiles.max(1) as f64
    }

    /// The master's CPU milliseconds per megabyte (10⁶ bytes) received from workers.
    pub fn master_cpu_per_mb_ms(&self) -> f64 {
        if self.bytes_received == 0 {
            0.0
        } else {
            self.master_cpu_s * 1e3 / (self.bytes_received as f64 / 1e6)
        }
    }
}

/// The pixel format workers should send for an image written to `output`: 8-bit for PNG and
/// PPM (all those files keep), exact f32 for EXR or an unknown extension.
pub fn pixel_format_for(output: &std::path::Path) -> PixelFormat {
    match parrt::film::ImageFormat::from_path(output) {
        Ok(parrt::film::ImageFormat::Png | parrt::film::ImageFormat::Ppm) => PixelFormat::Rgb8,
        _ => PixelFormat::F32,
    }
}

/// A random 32-character hex token, for workers this process starts itself.
pub fn generate_token() -> Token {
    let mut rng = rand::thread_rng();
    let text: String = (0..32)
        .map(|_| char::from_digit(rng.gen_range(0..16), 16).unwrap_or('0'))
        .collect();
    Token::new(&text).expect("a 32-character token is not empty")
}

/// The address local workers should dial for a master bound at `addr` (an unspecified
/// address such as 0.0.0.0 becomes loopback).
pub fn dial_address(addr: SocketAddr) -> SocketAddr {
    if addr.ip().is_unspecified() {
        let ip = match addr.ip() {
            IpAddr::V4(_) => IpAddr::V4(Ipv4Addr::LOCALHOST),
            IpAddr::V6(_) => IpAddr::V6(std::net::Ipv6Addr::LOCALHOST),
        };
        SocketAddr::new(ip, addr.port())
    } else {
        addr
    }
}

/// Renders `desc` on workers: binds `opts.listen`, starts `opts.workers_to_spawn` local worker
/// processes, serves tiles until the image is complete, and stops the workers. Ctrl-C cancels
/// cleanly ([`DistError::Interrupted`]). `on_listen` is told the bound address before any
/// worker is started (`parrt master` prints it). Must not be called from inside an async
/// runtime (it starts its own).
pub fn render_distributed(
    desc: &SceneDescription,
    settings: &RenderSettings,
    opts: &DistOptions,
    on_listen: &dyn Fn(SocketAddr),
) -> Result<DistResult, DistError> {
    render_distributed_announced(desc, settings, opts, &mut |addr| {
        on_listen(addr);
        Ok(())
    })
}

/// [`render_distributed`] whose `on_listen` may fail (then nothing is rendered and its error is
/// returned) and may keep state until the render ends: `parrt cluster` publishes its
/// rendezvous file there and removes it when the closure is dropped.
pub fn render_distributed_announced(
    desc: &SceneDescription,
    settings: &RenderSettings,
    opts: &DistOptions,
    on_listen: &mut dyn FnMut(SocketAddr) -> Result<(), DistError>,
) -> Result<DistResult, DistError> {
    render_distributed_prepared(
        opts,
        on_listen,
        || Ok((desc.clone(), settings.clone())),
        None,
    )
    .map(|(r, _, _)| r)
}

/// A check of the job run beside the render ([`render_distributed_prepared`]).
pub type JobCheck<E> = Box<dyn FnOnce(&SceneDescription, &RenderSettings) -> Result<(), E>>;

/// Like [`render_distributed_announced`], but the job comes from `prepare` (parse the scene,
/// check it), which runs while the local workers start up: process start, connection and
/// handshake overlap the parse and the scene check instead of following them. With a
/// checkpoint the job is prepared first (the checkpoint must be checked against it before
/// anything listens). `check`, if given, checks the job only if the render fails: each worker
/// builds the job itself and refuses one it cannot build, so a render that succeeds needs no
/// check, and one that fails because of the job gets the check's error (bad input) instead of
/// the workers' departures. Returns the result with the job's description and settings.
pub fn render_distributed_prepared<E: From<DistError>>(
    opts: &DistOptions,
    on_listen: &mut dyn FnMut(SocketAddr) -> Result<(), DistError>,
    prepare: impl FnOnce() -> Result<(SceneDescription, RenderSettings), E>,
    check: Option<JobCheck<E>>,
) -> Result<(DistResult, SceneDescription, RenderSettings), E> {
    let token = opts.token.clone().unwrap_or_else(generate_token);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(DistError::Runtime)?;
    let mut prepare = Some(prepare);
    // Called once on either path below; a second call would be a bug here, not bad input.
    let mut prepare_once = || (prepare.take().expect("the job is prepared once"))();
    let mut job = None;
    // The checkpoint is opened (and a wrong one refused) before anything listens.
    let opened = match &opts.checkpoint {
        Some(path) => {
            let (desc, settings) = prepare_once()?;
            let o = open_checkpoint(path, &desc, &settings, opts)?;
            job = Some((desc, settings));
            Some(o)
        }
        None => None,
    };
    rt.block_on(async {
        let mut master = Master::bind(opts, token.clone()).await?;
        if let Some(o) = opened {
            master.set_checkpoint(o);
        }
        let addr = master.local_addr();
        on_listen(addr)?;
        let _children = if opts.workers_to_spawn > 0 {
            let (n, t, at) = (
                opts.workers_to_spawn,
                opts.threads_per_worker,
                dial_address(addr),
            );
            Some(
                match &opts.worker_exe {
                    Some(exe) => spawn::spawn_workers_from(exe, n, t, at, &token),
                    None => spawn_local_workers(n, t, at, &token),
                }
                .map_err(DistError::from)?,
            )
        } else {
            None
        };
        // Workers dial and wait in the listen backlog while the job is prepared.
        let (desc, settings) = match job {
            Some(j) => j,
            None => prepare_once()?,
        };
        let cancel = CancellationToken::new();
        let on_signal = cancel.clone();
        let signal = tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                on_signal.cancel();
            }
        });
        let result = master.render(&desc, &settings, cancel).await;
        signal.abort();
        if result.is_err() {
            if let Some(check) = check {
                // A job the workers could not build is the input's fault: say so, once.
                check(&desc, &settings)?;
            }
        }
        Ok((result?, desc, settings))
    })
}

/// Opens (or creates) the checkpoint of this job, refusing one of another job.
fn open_checkpoint(
    path: &std::path::Path,
    desc: &SceneDescription,
    settings: &RenderSettings,
    opts: &DistOptions,
) -> Result<checkpoint::Opened, DistError> {
    let key = checkpoint::JobKey::new(desc, settings, opts.tile, opts.pixel_format)?;
    let list = parrt::tile::tiles(settings.width, settings.height, opts.tile.max(1));
    let o = checkpoint::open(path, &key, &list, opts.resume)?;
    if !o.created {
        tracing::info!(
            checkpoint = %path.display(),
            tiles = o.scan.tiles.len(),
            bad_records = o.scan.bad_records,
            cut_bytes = o.scan.cut_bytes,
            "resuming"
        );
    }
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_workers_says_who_came_and_why_they_failed() {
        let e = |failed: Vec<String>| DistError::NoWorkers {
            waited: Duration::from_secs(2),
            wanted: 1,
            ready: 0,
            failed,
        };
        assert!(e(vec![])
            .to_string()
            .starts_with("no worker arrived within 2s"));
        assert_eq!(
            e(vec!["w1: cannot take the job: bad material".into()]).to_string(),
            "1 worker connected but could not build the job within 2s (0 of the 1 needed \
             ready): w1: cannot take the job: bad material"
        );
        let many: Vec<String> = (0..5)
            .map(|i| format!("w{i}: {}", "x".repeat(400)))
            .collect();
        let m = e(many).to_string();
        assert!(
            m.starts_with("5 workers connected but could not build the job"),
            "{m}"
        );
        assert!(m.ends_with("; and 2 more"), "{m}");
        assert!(
            m.len() < 4 * 320 + 200,
            "reasons are truncated: {}",
            m.len()
        );
    }
}
