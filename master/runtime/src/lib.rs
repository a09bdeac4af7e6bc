//! # parrt-runtime
//!
//! The master side of a distributed render (docs/design.md, *Distributed runtime*), as a library:
//! the scheduler, the connections, the checkpoint, local worker processes and the cluster
//! launchers' rendezvous. It knows no command line, plotting or HTTP, and decides no exit codes:
//! errors are typed ([`DistError`], with [`DistError::is_bad_input`]) and watchers plug in as
//! [`observer::Observer`]s. Network and clock are seams ([`net::Listener`], [`clock::Clock`]), so
//! the same code runs over TCP and under the deterministic simulation.
//!
//! ## Layout
//! - [`run`] (this file): the one entry point: listen, start local workers, render, stop.
//! - [`options`]: what a master is told, split by concern ([`MasterConfig`]).
//! - [`server`]: the accept loop and the run loop ([`server::Master`], the async API).
//! - [`admission`]: who may hold a connection before authenticating (budgets, deadlines,
//!   eviction of silent squatters, penalties).
//! - [`connection`]: one task per peer: handshake, then relaying between socket and scheduler.
//! - [`scheduler`]: the job's state and rules (windows, deadlines, first result wins,
//!   backups); no I/O, tested alone on a paused clock.
//! - [`lifecycle`]: the job's phases: when to stop waiting for workers, which failure to say.
//! - [`frames`]: the frames of a sequence, one after another on the same workers.
//! - [`checkpoint`]: the file format of accepted tiles and its lifecycle; [`sink`]: where
//!   accepted tiles go while the loop runs (a background writer, never the loop's thread).
//! - [`observer`]: watchers told what happens to workers and tiles (progress, timeline, live view).
//! - [`spawn`]: local worker processes.
//! - [`refusals`]: the bounded record of refused handshakes.
//! - [`launcher`]: rank, size and job id from `srun`/`mpirun`/`mpiexec`'s environment.
//! - [`rendezvous`]: the file through which the ranks of `parrt cluster` meet.
//! - [`file_guard`]: opening users' files safely (no links, FIFOs or others' files) and locking them.
//! - [`batch`], [`window`]: how many tiles go in one message, and how much work a worker holds at
//!   once (rules the analytic model in `parrt bench` follows too).
//! - [`mutation`]: planted bugs (feature `mutations`) that the simulation must catch.
//! - [`net`], [`clock`]: the seams; [`cpu_time`]: CPU clocks; [`error`]: what goes wrong.
//!
//! ## Example
//! ```no_run
//! use parrt_runtime::{run, Job, MasterConfig};
//! let desc = parrt_scenes::generate("balls", Some(1)).expect("a built-in scene");
//! let settings = parrt_render::settings::RenderSettings::new(64, 64);
//! let mut config = MasterConfig::default();
//! config.spawn.count = 2; // two local worker processes of this executable
//! config.spawn.threads = 1;
//! let done = run(&config, Job::<parrt_runtime::DistError>::ready(desc, settings), &mut |_| Ok(None), None)?;
//! println!("{} tiles, {:.3} s", done.result.tiles, done.result.trace_s);
//! # Ok::<(), parrt_runtime::DistError>(())
//! ```
#![deny(missing_docs)]

pub mod admission;
pub mod batch;
pub mod checkpoint;
pub mod clock;
pub mod connection;
pub mod cpu_time;
pub mod error;
pub mod file_guard;
pub mod frames;
pub mod launcher;
pub mod lifecycle;
pub mod mutation;
pub mod net;
pub mod observer;
pub mod options;
pub mod outgoing;
pub mod prediction;
pub mod refusals;
pub mod rendezvous;
pub mod scheduler;
pub mod server;
pub mod shared_regions;
pub mod sink;
pub mod spawn;
pub mod window;

pub use error::DistError;
pub use options::{CheckpointAt, MasterConfig, Net, Schedule, Spawn, WorkerCommand};
pub use scheduler::FrameFinished;
pub use scheduler::{FaultCounts, WorkerReport};
pub use server::{FrameSource, Master, Writer};
use shared_regions::SharedRegions;
pub use spawn::{spawn_workers, LocalWorkers};

pub use crate::window::Window;
use parrt_protocol::{PixelFormat, Token};
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use rand::Rng;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use tokio_util::sync::CancellationToken;

/// The default address of `parrt master`: loopback only; any other must be asked for.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:7878";

/// The region each started worker gets for its pixels: a slot for every tile it may hold at
/// once (its window of assignments, each of up to `max_batch` tiles; at most
/// [`parrt_protocol::shared_pixels::MAX_SLOTS`]), each slot a whole tile in the job's format.
/// A tile past that (a region full, a slot too small) goes over the connection.
fn shared_slots<'a>(config: &MasterConfig, regions: &'a SharedRegions) -> spawn::Share<'a> {
    let (s, threads) = (&config.schedule, config.spawn.threads);
    let held = s
        .window
        .assignments(threads, None, 0.0)
        .saturating_mul(s.max_batch.max(1));
    let tile = s.tile as usize;
    let bytes = tile
        .saturating_mul(tile)
        .saturating_mul(s.pixel_format.bytes_per_pixel());
    spawn::Share {
        regions,
        slots: held.clamp(1, parrt_protocol::shared_pixels::MAX_SLOTS as usize) as u32,
        slot_bytes: bytes.clamp(1, parrt_protocol::shared_pixels::MAX_SLOT_BYTES as usize) as u32,
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
    /// The most messages that ever waited in the master's queues.
    pub queue_peaks: QueuePeaks,
    /// The most frames of a sequence open at once (1 for one frame).
    pub most_open_frames: usize,
    /// A sequence's last frame: when its first tile went out and its last came in (the
    /// earlier frames' go to the [`FrameSource`]); `None` for a render of one frame.
    pub last_frame_span: Option<(Option<tokio::time::Instant>, tokio::time::Instant)>,
    /// Tiles whose pixels came through memory shared with a worker this master started
    /// (counted when taken, accepted or not).
    pub tiles_shared: u64,
}

/// High-water marks of the master's in-memory queues (the deterministic simulation checks
/// that they stay bounded whatever the faults).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QueuePeaks {
    /// Events from the connections waiting for the scheduler (results, joins, departures).
    pub events: usize,
    /// Messages waiting in any one connection's outbox to be written to its worker.
    pub outbox: usize,
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
    match parrt_render::film::ImageFormat::from_path(output) {
        Ok(parrt_render::film::ImageFormat::Png | parrt_render::film::ImageFormat::Ppm) => {
            PixelFormat::Rgb8
        }
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

/// A check of the job, run only if the render fails ([`Job::check`]).
pub type JobCheck<'a, E> =
    Box<dyn FnOnce(&SceneDescription, &RenderSettings) -> Result<(), E> + 'a>;

/// The job of a run: ready, or prepared (parsed, checked) while local workers start.
pub struct Job<'a, E> {
    prepare: Box<dyn FnOnce() -> Result<(SceneDescription, RenderSettings), E> + 'a>,
    check: Option<JobCheck<'a, E>>,
}

impl<'a, E> Job<'a, E> {
    /// A job already in hand.
    pub fn ready(desc: SceneDescription, settings: RenderSettings) -> Self
    where
        E: 'a,
    {
        Job {
            prepare: Box::new(move || Ok((desc, settings))),
            check: None,
        }
    }

    /// A job made by `prepare` (parse the scene, check it), run while the local workers start
    /// up, so process start, connection and handshake overlap the parse instead of following
    /// it. With a checkpoint the job is prepared first (the checkpoint is checked against it
    /// before anything listens).
    pub fn prepared(
        prepare: impl FnOnce() -> Result<(SceneDescription, RenderSettings), E> + 'a,
    ) -> Self {
        Job {
            prepare: Box::new(prepare),
            check: None,
        }
    }

    /// Checks the job only if the render fails: each worker builds the job itself and refuses
    /// one it cannot build, so a render that succeeds needs no check, and one that fails
    /// because of the job gets the check's error (bad input) instead of the workers'
    /// departures.
    pub fn check(
        mut self,
        check: impl FnOnce(&SceneDescription, &RenderSettings) -> Result<(), E> + 'a,
    ) -> Self {
        self.check = Some(Box::new(check));
        self
    }
}

/// What [`run`] gives back: the render and the job it rendered.
#[derive(Debug)]
pub struct Rendered {
    /// The render.
    pub result: DistResult,
    /// The scene.
    pub desc: SceneDescription,
    /// The settings.
    pub settings: RenderSettings,
}

/// The one entry point of a distributed render (`render --workers`, `master`, `cluster` and
/// the emulated cluster all come here): opens the checkpoint if asked, binds
/// `config.net.listen`, calls `on_listen` with the bound address, starts
/// `config.spawn.count` local workers (dialling the address `on_listen` returns, or the bound
/// one), prepares the job, serves tiles until the image is complete, and stops the workers.
/// Runs on a current-thread tokio runtime of its own on the calling thread; must not be
/// called from inside one. Ctrl-C or SIGTERM (also while the local workers are starting), or
/// `cancel` when given, cancels cleanly ([`DistError::Interrupted`]): the workers started are
/// killed and reaped. `on_listen` may fail (then nothing is rendered) and may keep
/// state until the render ends (`parrt cluster` publishes its rendezvous file there).
pub fn run<E: From<DistError>>(
    config: &MasterConfig,
    job: Job<'_, E>,
    on_listen: &mut dyn FnMut(SocketAddr) -> Result<Option<SocketAddr>, DistError>,
    cancel: Option<CancellationToken>,
) -> Result<Rendered, E> {
    run_frames(config, job, None, on_listen, cancel)
}

/// [`run`] of a sequence: `job` is frame 0, `frames` gives the later frames and takes each
/// finished one but the last, which is the result's film ([`Master::render_sequence`]). The
/// workers stay connected from the first frame to the last. `config.checkpoint` (one image's)
/// is refused with a sequence of more than one frame: a sequence's checkpoint is kept by
/// `frames` ([`FrameSource::keeps_tiles`], [`checkpoint::open_sequence`]).
pub fn run_sequence<E: From<DistError>>(
    config: &MasterConfig,
    job: Job<'_, E>,
    frames: &mut dyn FrameSource,
    on_listen: &mut dyn FnMut(SocketAddr) -> Result<Option<SocketAddr>, DistError>,
    cancel: Option<CancellationToken>,
) -> Result<Rendered, E> {
    run_frames(config, job, Some(frames), on_listen, cancel)
}

fn run_frames<E: From<DistError>>(
    config: &MasterConfig,
    job: Job<'_, E>,
    frames: Option<&mut dyn FrameSource>,
    on_listen: &mut dyn FnMut(SocketAddr) -> Result<Option<SocketAddr>, DistError>,
    cancel: Option<CancellationToken>,
) -> Result<Rendered, E> {
    if config.checkpoint.is_some() && frames.as_ref().is_some_and(|f| f.count() > 1) {
        return Err(DistError::Frame {
            frame: 0,
            reason: "a one-frame checkpoint cannot hold a sequence; a sequence's checkpoint is \
                     kept by its frames (FrameSource::keeps_tiles, checkpoint::open_sequence)"
                .into(),
        }
        .into());
    }
    if config.spawn.count > options::MAX_SPAWNED_WORKERS {
        return Err(DistError::TooManyWorkers {
            asked: config.spawn.count,
            max: options::MAX_SPAWNED_WORKERS,
        }
        .into());
    }
    let token = config.net.token.clone().unwrap_or_else(generate_token);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(DistError::Runtime)?;
    let Job { prepare, check } = job;
    let mut prepare = Some(prepare);
    // Called once on either path below; a second call would be a bug here, not bad input.
    let mut prepare_once = || (prepare.take().expect("the job is prepared once"))();
    let mut ready = None;
    // The checkpoint is opened (and a wrong one refused) before anything listens.
    let opened = match &config.checkpoint {
        Some(at) => {
            let (desc, settings) = prepare_once()?;
            let secret = at.keyed.then(|| token.as_bytes());
            let o = open_checkpoint(at, secret, &desc, &settings, &config.schedule)?;
            ready = Some((desc, settings));
            Some(o)
        }
        None => None,
    };
    rt.block_on(async {
        let mut master = Master::bind(config, token.clone()).await?;
        if let Some(o) = opened {
            master.set_checkpoint(o, Writer::Background);
        }
        // Signals are heard from before anything is announced or started: the handlers are in
        // place before `on_listen` prints where the master listens (a Ctrl-C right after that
        // line cancels cleanly), and a master told to stop while it starts hundreds of workers
        // stops starting them, and kills and reaps those it started.
        let signals = StopSignals::listen();
        let addr = master.local_addr();
        let dial = on_listen(addr)?.unwrap_or_else(|| dial_address(addr));
        let cancel = cancel.unwrap_or_default();
        let on_signal = cancel.clone();
        let signal = tokio::spawn(async move {
            if signals.wait().await {
                on_signal.cancel();
            }
        });
        let _children = if config.spawn.count > 0 {
            let s = &config.spawn;
            let regions = master.shared_regions();
            let share = s.share_pixels.then(|| shared_slots(config, &regions));
            let started = spawn::spawn_workers_until(
                &s.command, s.count, s.threads, dial, &token, share, &cancel,
            )
            .await
            .map_err(DistError::from)?;
            if cancel.is_cancelled() {
                signal.abort();
                return Err(DistError::Interrupted.into());
            }
            Some(started)
        } else {
            None
        };
        // Workers dial and wait in the listen backlog while the job is prepared.
        let (desc, settings) = match ready {
            Some(j) => j,
            None => prepare_once()?,
        };
        let result = match frames {
            Some(f) => master.render_sequence(&desc, &settings, f, cancel).await,
            None => master.render(&desc, &settings, cancel).await,
        };
        signal.abort();
        if result.is_err() {
            if let Some(check) = check {
                // A job the workers could not build is the input's fault: say so, once.
                check(&desc, &settings)?;
            }
        }
        Ok(Rendered {
            result: result?,
            desc,
            settings,
        })
    })
}

/// The number of the signal that stopped a render through [`run`] (`SIGINT` or `SIGTERM`), 0
/// while none has.
static STOPPED_BY: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);

/// The signal (`libc::SIGINT` for Ctrl-C, `libc::SIGTERM`) that made a render end with
/// [`DistError::Interrupted`], if one did: a command line exits `128 + n` then, as a process
/// the signal killed would (130 for Ctrl-C), whether it rendered on its own cores or through
/// workers.
pub fn stopped_by_signal() -> Option<i32> {
    match STOPPED_BY.load(std::sync::atomic::Ordering::Relaxed) {
        0 => None,
        n => Some(n),
    }
}

/// SIGINT (Ctrl-C) and SIGTERM, listened for from the moment [`StopSignals::listen`] returns
/// (the handlers are installed then, not when first awaited).
struct StopSignals {
    interrupt: Option<tokio::signal::unix::Signal>,
    terminate: Option<tokio::signal::unix::Signal>,
}

impl StopSignals {
    /// Installs the handlers; must run inside the tokio runtime.
    fn listen() -> Self {
        use tokio::signal::unix::{signal, SignalKind};
        StopSignals {
            interrupt: signal(SignalKind::interrupt()).ok(),
            terminate: signal(SignalKind::terminate()).ok(),
        }
    }

    /// Waits for either signal and notes which ([`stopped_by_signal`]); `false` if neither
    /// can be listened for.
    async fn wait(mut self) -> bool {
        let heard = match (&mut self.interrupt, &mut self.terminate) {
            (Some(int), Some(term)) => tokio::select! {
                _ = int.recv() => libc::SIGINT,
                _ = term.recv() => libc::SIGTERM,
            },
            (Some(int), None) => {
                int.recv().await;
                libc::SIGINT
            }
            (None, Some(term)) => {
                term.recv().await;
                libc::SIGTERM
            }
            (None, None) => return false,
        };
        STOPPED_BY.store(heard, std::sync::atomic::Ordering::Relaxed);
        true
    }
}

/// Opens (or creates) the checkpoint of this job, refusing one of another job.
fn open_checkpoint(
    at: &CheckpointAt,
    secret: Option<&[u8]>,
    desc: &SceneDescription,
    settings: &RenderSettings,
    schedule: &options::Schedule,
) -> Result<checkpoint::Opened, DistError> {
    let path = &at.path;
    let mut key = checkpoint::JobKey::new(desc, settings, schedule.tile, schedule.pixel_format)?;
    if let Some(s) = secret {
        key = key.sealed_with(s);
    }
    let list = parrt_render::tile::tiles(settings.width, settings.height, schedule.tile.max(1));
    let o = checkpoint::open(path, &key, &list, at.resume)?;
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
    fn too_many_local_workers_are_refused_before_anything_starts() {
        let mut config = MasterConfig::default();
        config.spawn.count = options::MAX_SPAWNED_WORKERS + 1;
        let job = Job::<DistError>::prepared(|| panic!("nothing is prepared"));
        let e = run(&config, job, &mut |_| panic!("nothing listens"), None).unwrap_err();
        assert!(matches!(e, DistError::TooManyWorkers { .. }), "{e}");
        assert!(e.is_bad_input());
    }
}
