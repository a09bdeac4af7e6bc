//! The messages master and worker exchange. Plain data: no I/O, no validation beyond types
//! (the receiver checks ids, attempts and pixel counts against its own state).

use super::pixels::{PixelFormat, TilePixels};
use parrt_render::description::{SceneDescription, View};
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use serde::{Deserialize, Serialize};

/// Length of each side's nonce in bytes.
pub const NONCE_LEN: usize = 32;

/// One render job: everything a worker needs to render any of its tiles. The scene travels in
/// its compact description form; a worker never reads files on the master's say-so.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobSpec {
    /// Identifies the job in every later message (random per master run).
    pub job_id: u64,
    /// The scene.
    pub scene: SceneDescription,
    /// Settings deciding pixel values (same on every node: same bits).
    pub settings: RenderSettings,
    /// Tile edge in pixels (informational: tiles arrive whole in `Assign`).
    pub tile_size: u32,
    /// How results carry their pixels (8-bit when the output keeps no more).
    pub pixel_format: PixelFormat,
    /// Whether 8-bit results are packed ([`TilePixels::pack`]): over a network, where fewer
    /// bytes pay; not for workers on the master's own machine, where packing only costs CPU.
    pub pack_pixels: bool,
}

/// A frame of a sequence that only moves the camera: the scene of a job the worker holds, seen
/// from another view. The worker renders it with the base job's built scene and accelerator
/// ([`parrt_render::render::Renderer::with_view`]); the master sends it only to a worker it
/// has sent the base's Job and not yet told to drop it, and only when the base's build is the
/// one this frame would get ([`crate::scene_key()`]), else the frame's whole Job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewSpec {
    /// The frame's job id, as a Job's.
    pub job_id: u64,
    /// The job whose scene this frame shares.
    pub base_job_id: u64,
    /// The camera of this frame (its `width` and `height` are not used: the settings' are).
    pub view: View,
    /// Settings deciding pixel values: the base's but for the size and samples per pixel.
    pub settings: RenderSettings,
    /// Tile edge in pixels (informational, as a Job's).
    pub tile_size: u32,
    /// How results carry their pixels.
    pub pixel_format: PixelFormat,
    /// Whether 8-bit results are packed, as a Job's.
    pub pack_pixels: bool,
}

/// A protocol message. Variant order is part of the wire format: never reorder, only append.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message {
    /// Worker → master, first message: who I am. Must stay variant 0 with `version` first.
    Hello {
        /// The worker's [`super::PROTOCOL_VERSION`].
        version: u32,
        /// A human-readable name (host and pid) for logs.
        name: String,
        /// Render threads the worker will use (at most [`super::limits::MAX_THREADS`]).
        threads: u32,
        /// The worker's random bytes, fresh per connection: the master's proof must cover them.
        nonce: [u8; NONCE_LEN],
        /// The worker's instruction-set tier ([`parrt_render::isa`]), for the master's report.
        isa: parrt_render::isa::Isa,
    },
    /// Master → worker: the master's proof that it knows the token, and its own nonce for the
    /// worker to prove the same.
    Challenge {
        /// Random bytes, fresh per connection.
        nonce: [u8; NONCE_LEN],
        /// [`super::Token::master_proof`] of the worker's nonce and this one.
        proof: [u8; super::auth::MAC_LEN],
    },
    /// Worker → master, sent only once the master's proof checked out:
    /// [`super::Token::worker_proof`] of the master's nonce and the worker's.
    Auth {
        /// The MAC bytes.
        mac: Vec<u8>,
    },
    /// Master → worker: authenticated; a job follows.
    Welcome,
    /// Master → worker: not accepted; the connection closes after this.
    Refused {
        /// Why, for the worker's log.
        reason: String,
    },
    /// Master → worker: the job to render.
    Job(Box<JobSpec>),
    /// Worker → master: the job's renderer is built; tiles may be assigned.
    Ready {
        /// The job built.
        job_id: u64,
        /// Seconds the worker spent building its renderer.
        build_s: f64,
    },
    /// Master → worker: render this tile.
    Assign {
        /// The job it belongs to.
        job_id: u64,
        /// The tile.
        tile: Tile,
        /// Attempt number (1 for the first assignment of this tile anywhere).
        attempt: u32,
    },
    /// Worker → master: a rendered tile.
    TileResult {
        /// The job it belongs to.
        job_id: u64,
        /// Tile id.
        tile_id: u32,
        /// The attempt this answers.
        attempt: u32,
        /// Pixels, row-major within the tile, in the job's [`PixelFormat`].
        pixels: TilePixels,
        /// Ray statistics of this tile.
        stats: RayStats,
        /// Seconds the worker spent rendering it.
        seconds: f64,
    },
    /// Either way: I am alive.
    Heartbeat,
    /// Master → worker: drop the job's remaining tiles.
    Cancel {
        /// The job.
        job_id: u64,
    },
    /// Master → worker: the work is over; disconnect and exit.
    Shutdown,
    /// Either way: something went wrong (e.g. the worker cannot build the job).
    Error {
        /// What, for the other side's log.
        reason: String,
    },
    /// Master → worker: render these tiles, and send their results together (one write, one
    /// wake-up of the master for the lot) when the last is done. Batches are how a master
    /// keeps its per-tile cost low; it shrinks them as the work runs out.
    AssignBatch {
        /// The job they belong to.
        job_id: u64,
        /// The tiles, each with its attempt number.
        tiles: Vec<(Tile, u32)>,
    },
    /// Master → worker: a frame of a sequence that only moves the camera ([`ViewSpec`]),
    /// answered as a Job is (Ready, or Error when the base is not held or the view is bad).
    View(Box<ViewSpec>),
}

impl Message {
    /// A short name of the variant, for logs (never the payload).
    pub fn kind(&self) -> &'static str {
        match self {
            Message::Hello { .. } => "Hello",
            Message::Challenge { .. } => "Challenge",
            Message::Auth { .. } => "Auth",
            Message::Welcome => "Welcome",
            Message::Refused { .. } => "Refused",
            Message::Job(_) => "Job",
            Message::Ready { .. } => "Ready",
            Message::Assign { .. } => "Assign",
            Message::TileResult { .. } => "TileResult",
            Message::Heartbeat => "Heartbeat",
            Message::Cancel { .. } => "Cancel",
            Message::Shutdown => "Shutdown",
            Message::Error { .. } => "Error",
            Message::AssignBatch { .. } => "AssignBatch",
            Message::View(_) => "View",
        }
    }
}
