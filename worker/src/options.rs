//! Worker options: everything a worker is told before it dials. Defaults suit a LAN; the test
//! hook [`TILE_DELAY_ENV`] exists only to make fault tests deterministic.

use parrt_protocol::{Token, DEFAULT_MAX_FRAME};
use std::time::Duration;

/// Testing aid: when set to a number of milliseconds, the worker sleeps that long before each
/// tile, so a test can kill or stop it while it holds tiles ("mid-job") even with a fast scene.
/// Never needed in production.
pub const TILE_DELAY_ENV: &str = "PARRT_WORKER_TILE_DELAY_MS";

/// How a worker connects and works.
#[derive(Clone, Debug)]
pub struct WorkerOptions {
    /// The master's address, `host:port`.
    pub connect: String,
    /// Render threads (the size of the rayon pool); 1 to [`parrt_protocol::limits::MAX_THREADS`].
    pub threads: usize,
    /// The shared secret.
    pub token: Token,
    /// The name reported to the master (host and pid by default).
    pub name: String,
    /// How long to keep dialling (exponential backoff) before giving up.
    pub dial_timeout: Duration,
    /// First backoff delay; doubles up to [`WorkerOptions::max_backoff`].
    pub initial_backoff: Duration,
    /// Largest backoff delay.
    pub max_backoff: Duration,
    /// How long a handshake reply may take.
    pub handshake_timeout: Duration,
    /// How often to send a heartbeat.
    pub heartbeat: Duration,
    /// Give up when the master sends nothing (not even a heartbeat) for this long.
    pub master_timeout: Duration,
    /// Largest frame accepted from the master (a Job; a sequence sends one a frame), and
    /// largest frame sent.
    pub max_frame: usize,
    /// Most bytes of pixels one assignment's results may hold at once (a batch's results are
    /// sent together); tiles past it are refused with an Error to the master, not rendered.
    /// [`parrt_protocol::limits::MAX_BATCH_RESULT_BYTES`] by default.
    pub batch_budget: usize,
    /// Sleep before each tile (testing aid, see [`TILE_DELAY_ENV`]).
    pub tile_delay: Option<Duration>,
    /// Seed of the handshake nonces (simulation aid): `None` (the default) draws them from the
    /// thread's cryptographic generator; `Some` from a generator seeded with it, so a simulated
    /// run replays exactly. Never set it for a worker on a real network.
    pub nonce_seed: Option<u64>,
    /// The memory a master that started this worker shares with it for pixels
    /// ([`parrt_protocol::shared_pixels`]): `None` (the default) sends every tile's pixels
    /// over the connection.
    pub shared_pixels: Option<std::sync::Arc<parrt_protocol::SharedPixels>>,
}

impl WorkerOptions {
    /// Default options for dialling `connect` with `token`: all cores, a 30 s dial budget.
    pub fn new(connect: impl Into<String>, token: Token) -> Self {
        WorkerOptions {
            connect: connect.into(),
            threads: std::thread::available_parallelism()
                .map_or(1, |n| n.get())
                .min(parrt_protocol::limits::MAX_THREADS as usize),
            token,
            name: default_name(),
            dial_timeout: Duration::from_secs(30),
            initial_backoff: Duration::from_millis(50),
            max_backoff: Duration::from_secs(2),
            handshake_timeout: Duration::from_secs(10),
            heartbeat: Duration::from_secs(1),
            master_timeout: Duration::from_secs(30),
            max_frame: DEFAULT_MAX_FRAME,
            batch_budget: parrt_protocol::limits::MAX_BATCH_RESULT_BYTES,
            tile_delay: tile_delay_from_env(),
            nonce_seed: None,
            shared_pixels: None,
        }
    }

    /// Render threads: [`WorkerOptions::threads`] kept within 1 ..=
    /// [`parrt_protocol::limits::MAX_THREADS`]. What Hello announces and the pool is built with.
    pub fn render_threads(&self) -> usize {
        self.threads
            .clamp(1, parrt_protocol::limits::MAX_THREADS as usize)
    }
}

/// `host-pid`, from the kernel's host name when it can be read.
pub fn default_name() -> String {
    let host = std::env::var("HOSTNAME")
        .ok()
        .or_else(|| std::fs::read_to_string("/proc/sys/kernel/hostname").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "worker".to_string());
    format!("{host}-{}", std::process::id())
}

/// The tile delay from [`TILE_DELAY_ENV`], if set to a whole number of milliseconds.
pub fn tile_delay_from_env() -> Option<Duration> {
    std::env::var(TILE_DELAY_ENV)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .filter(|&ms| ms > 0)
        .map(Duration::from_millis)
}
