//! What a master is told before it runs, split by concern: how tiles are scheduled
//! ([`Schedule`]), how the network behaves ([`Net`]), which local workers it starts
//! ([`Spawn`]), where accepted tiles are kept ([`CheckpointAt`]), who watches
//! ([`crate::observer::Observers`]) and where randomness comes from (`seed`). Plain data:
//! nothing here does I/O.

use crate::observer::Observers;
use crate::window::Window;
use parrt_protocol::{PixelFormat, Token, DEFAULT_MAX_FRAME};
use std::path::PathBuf;
use std::time::Duration;

/// How often the master sends heartbeats (whole seconds; `--heartbeat-timeout` is at least two).
pub const DEFAULT_HEARTBEAT: Duration = Duration::from_secs(1);

/// The most local worker processes one master starts (`render --workers`, `bench cluster`):
/// more than any machine has cores for, few enough that a typo cannot fork-bomb the host.
pub const MAX_SPAWNED_WORKERS: usize = 1024;

/// Everything a master needs besides the job.
#[derive(Clone, Debug, Default)]
pub struct MasterConfig {
    /// How tiles are handed out and when the master stops waiting.
    pub schedule: Schedule,
    /// Listening, the token, timeouts and frame limits.
    pub net: Net,
    /// Local worker processes to start.
    pub spawn: Spawn,
    /// Record each accepted tile here (and resume from it).
    pub checkpoint: Option<CheckpointAt>,
    /// Told what happens to workers and tiles (progress bar, `--timeline`, `--http`).
    pub observers: Observers,
    /// Seeds the job id and the handshake nonces (`None`: from the operating system). Only
    /// the deterministic simulation sets it.
    pub seed: Option<u64>,
}

/// Scheduling knobs and the rules for waiting on workers.
#[derive(Clone, Debug)]
pub struct Schedule {
    /// Tile edge in pixels.
    pub tile: u32,
    /// Assignments (batches) in flight per worker: a fixed number per thread (two by default),
    /// or its threads plus what its measured round trip needs ([`Window::Auto`]).
    pub window: Window,
    /// The most tiles in one assignment; batches shrink to single tiles as work runs out
    /// (1: every tile on its own).
    pub max_batch: usize,
    /// The most work one batch may hold, in seconds at the mean tile cost seen so far
    /// ([`crate::batch::BATCH_SECONDS`], 2 ms, by default). The deterministic simulation
    /// stretches it with the rest of time when it dilates a frame too short for its timers.
    pub batch_seconds: f64,
    /// The order tiles are handed out in, by tile id (`None`: raster order). A render that
    /// knows its tiles' costs (a previous frame's `--tile-costs`) can hand the costliest out
    /// first, so the frame does not end waiting on one costly tile started late.
    pub order: Option<Vec<u32>>,
    /// A tile not returned within this is given to another worker.
    pub tile_deadline: Duration,
    /// Failures after which a worker is dropped.
    pub max_failures: u32,
    /// Duplicate in-flight tiles onto idle workers when the queue is empty.
    pub backups: bool,
    /// How workers send pixels: [`PixelFormat::Rgb8`] when only an 8-bit image will be
    /// written (a quarter of the bytes; the written image is the same), `F32` for the exact
    /// film (the default).
    pub pixel_format: PixelFormat,
    /// Whether workers pack 8-bit pixels ([`parrt_protocol::TilePixels::pack`]): yes (the
    /// default) for workers across a network, where a tenth of the bytes lets a 1 Gbit/s link
    /// keep up with thousands of cores; no for workers on this machine, whose loopback costs
    /// nothing to cross while packing and unpacking cost CPU the render threads want.
    pub pack_pixels: bool,
    /// Workers that must be ready before tiles are handed out.
    pub min_workers: usize,
    /// How long to wait for `min_workers` (and, mid-job, for any worker when all have left).
    pub wait_workers: Duration,
    /// In a sequence, the most frames open at once (at least 1): when no tile of those open
    /// is left to hand out, the next frame opens and its tiles fill the tail of the frames
    /// before. Each open frame holds a film here and a built scene on every worker.
    pub frames_window: usize,
    /// Wait for `min_workers` even when a resumed checkpoint left nothing to render, so that
    /// each is told to shut down (`parrt cluster`: its worker ranks would otherwise wait for a
    /// master that has gone).
    pub await_all_workers: bool,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule {
            tile: 32,
            window: Window::default(),
            max_batch: 8,
            batch_seconds: crate::batch::BATCH_SECONDS,
            order: None,
            tile_deadline: Duration::from_secs(120),
            max_failures: 3,
            backups: true,
            pixel_format: PixelFormat::F32,
            pack_pixels: true,
            min_workers: 1,
            wait_workers: Duration::from_secs(60),
            frames_window: 2,
            await_all_workers: false,
        }
    }
}

/// The network side: where to listen, who may join, how long anyone may stay silent.
#[derive(Clone, Debug)]
pub struct Net {
    /// Address to listen on (`127.0.0.1:0` picks a free port).
    pub listen: String,
    /// Shared secret; `None` generates a random one (fine for spawned workers only: then no
    /// one else can join, and the master stops waiting once they have all left).
    pub token: Option<Token>,
    /// How often the master sends heartbeats.
    pub heartbeat: Duration,
    /// A worker silent this long is considered gone.
    pub heartbeat_timeout: Duration,
    /// Time allowed for a peer's handshake.
    pub handshake_timeout: Duration,
    /// Largest frame sent to a worker (the Job with its scene is the large one); what the
    /// master accepts from a worker is the smaller of this and what a result of the job's
    /// tile size needs ([`parrt_protocol::limits::worker_frame_limit`]).
    pub max_frame: usize,
    /// Most simultaneous connections (handshaking or working).
    pub max_connections: usize,
}

impl Default for Net {
    fn default() -> Self {
        Net {
            listen: "127.0.0.1:0".into(),
            token: None,
            heartbeat: DEFAULT_HEARTBEAT,
            heartbeat_timeout: Duration::from_secs(10),
            handshake_timeout: Duration::from_secs(10),
            max_frame: DEFAULT_MAX_FRAME,
            max_connections: 1024,
        }
    }
}

/// Local worker processes the master starts once it listens.
#[derive(Clone, Debug, Default)]
pub struct Spawn {
    /// How many (0: only external workers). At most [`MAX_SPAWNED_WORKERS`].
    pub count: usize,
    /// Render threads of each.
    pub threads: usize,
    /// How to start one.
    pub command: WorkerCommand,
    /// Whether each gets a region of memory shared with the master for its pixels
    /// ([`parrt_protocol::shared_pixels`]), so that they skip the connection's sealing,
    /// copies and kernel crossings. Only for workers doing real work on this machine (not an
    /// emulated cluster, whose network is the point).
    pub share_pixels: bool,
}

/// The command line of a local worker: `<exe> <prefix…> --connect ADDR --threads T --name N
/// <extra…>`, with the token in its environment (never on the command line, where `ps` would
/// show it).
#[derive(Clone, Debug)]
pub struct WorkerCommand {
    /// The executable (`None`: this process's own, via `current_exe`).
    pub exe: Option<PathBuf>,
    /// Arguments before the worker's own flags (`["worker"]` for `parrt worker`).
    pub prefix: Vec<String>,
    /// Arguments after them (`--replay FILE`, `--dial-timeout 60`, …).
    pub extra: Vec<String>,
    /// Prefix of each worker's `--name` (`local` gives `local-0`, `local-1`, …).
    pub name_prefix: String,
    /// The workers' log filter when the environment sets none.
    pub log: String,
}

impl Default for WorkerCommand {
    fn default() -> Self {
        WorkerCommand {
            exe: None,
            prefix: vec!["worker".into()],
            extra: Vec::new(),
            name_prefix: "local".into(),
            log: "warn".into(),
        }
    }
}

/// The checkpoint file and whether to continue it.
#[derive(Clone, Debug)]
pub struct CheckpointAt {
    /// The file.
    pub path: PathBuf,
    /// Continue the render recorded there (else an existing file is refused).
    pub resume: bool,
    /// Seal the records with a key derived from the master's token
    /// ([`crate::checkpoint::Seal::Keyed`]): only for a token that outlives the run (`parrt
    /// master`'s), since a resume must give the same one. Without it they are sealed plain.
    pub keyed: bool,
}
