//! The master/worker wire protocol (docs/design.md, *Protocol*): what the messages are
//! ([`message`]), how they are framed and encoded ([`codec`]), how a tile's pixels travel
//! ([`pixels`]), the encrypted channel keyed by the token that every connection runs inside
//! ([`channel`]), how master and worker prove to each other that they know the shared token
//! ([`auth`]), the one type that touches a socket ([`connection`]), and the named limits on
//! everything a peer controls ([`limits`]).
//!
//! ## Layers
//! A connection first runs a Noise handshake keyed by the token ([`channel::connect`] on the
//! worker, [`channel::accept`] on the master); everything below, frames included, travels
//! encrypted and authenticated inside the [`channel::SecureStream`] it gives.
//!
//! ## Wire format
//! Every message is one frame: a 4-byte big-endian length, then the message encoded with
//! [postcard](https://docs.rs/postcard). A frame longer than the connection's limit is an error
//! before any of it is buffered. The limit follows the conversation: tiny until a peer has
//! authenticated ([`limits::HANDSHAKE_MAX_FRAME`]); then on the master what the job's largest
//! tile needs ([`limits::worker_frame_limit`]); on the worker its frame limit, since a
//! sequence sends a Job for each frame (every other master message is far smaller,
//! [`limits::MASTER_FRAME_AFTER_JOB`]). A frame may arrive slowly, but not forever:
//! bytes arriving count as life, and a frame of `n` bytes must be whole within the peer timeout
//! plus `n / 64 KiB/s` ([`limits::MIN_FRAME_RATE`]).
//!
//! ## Conversation
//! ```text
//! worker                         master
//!   Hello{version,name,threads,nonce_w} →
//!                               ← Challenge{nonce_m, proof}  (or Refused: version, threads)
//!       proof = HMAC(token, "parrt master proof" ‖ nonce_w ‖ nonce_m)
//!   (the worker checks the proof; if wrong it hangs up without answering)
//!   Auth{mac}                   →
//!       mac = HMAC(token, "parrt worker proof" ‖ nonce_m ‖ nonce_w)
//!                               ← Welcome                 (or Refused: wrong token)
//!                               ← Job{job_id, scene, settings, tile_size}
//!   Ready{job_id, build_s}      →                         (or Error{reason}: cannot build)
//!                               ← Assign{job_id, tile, attempt}   (a window of several)
//!   TileResult{...}             →
//!   Heartbeat                   →                         (every few seconds, both ways)
//!                               ← Cancel{job_id} / Shutdown
//! ```
//! In a sequence, each later frame is a further Job, or, when it only moves the camera of a
//! scene the worker holds, a View{job_id, base_job_id, view, settings} answered the same way.
//! [`message::Message::Hello`] is variant 0 and its `version` field comes first, so a peer of any
//! version can read the version of another and refuse it with a reason (a Hello of another
//! version that does not decode as ours is reported as [`ProtocolError::OtherVersion`]).
//!
//! ## What the handshake proves, and what it does not
//! The channel's handshake already proves the token both ways (a peer without it gets a
//! refusal or nothing, and never a byte of the conversation); the HMAC exchange inside it
//! proves it again, over nonces both chose, as it did before the channel existed. A relay
//! between the two sees only the handshake's ephemeral keys and ciphertext: it learns the
//! endpoints, the timing and the sizes of messages, and any byte it changes ends the
//! connection (docs/distributed.md).

pub mod auth;
pub mod channel;
pub mod codec;
pub mod connection;
pub mod limits;
pub mod message;
pub mod pixels;
pub mod scene_key;
pub mod seconds;
pub mod shared_pixels;

pub use auth::{AuthError, Token};
pub use channel::{ChannelError, LinkKey, SecureStream};

/// The environment variable that carries the shared token to a worker (and a master): how a
/// master hands it to the workers it starts without putting it on a command line.
pub const TOKEN_ENV: &str = "PARRT_TOKEN";

/// The environment variable of a worker's log filter (`warn`, `info`, …).
pub const LOG_ENV: &str = "PARRT_LOG";
pub use codec::{Encoded, MessageCodec, ProtocolError, WireCounters};
pub use connection::Connection;
pub use limits::{DEFAULT_MAX_FRAME, HANDSHAKE_MAX_FRAME};
pub use message::{JobSpec, Message, ViewSpec};
pub use pixels::{Packing, PixelError, PixelFormat, TilePixels};
pub use scene_key::{scene_key, SceneContent, SceneKey};
pub use shared_pixels::{SharedError, SharedPixels, SHARED_PIXELS_ENV};

/// The protocol version spoken by this build; bumped on any incompatible change (2: mutual
/// authentication, a nonce in Hello and the master's proof in Challenge; pixels as the output
/// needs them; batches of tiles; 3: every connection inside a Noise channel keyed by the token,
/// and the worker's instruction-set tier in Hello; 4: a sequence sends a further Job on the same
/// connection for each frame, which a worker builds in place of the one before; 5: a frame that
/// only moves the camera is a View of a scene the worker holds, which a worker of version 4
/// could not read; 6: a result's pixels say how they are packed, LZ4 when that is smaller; 7: a
/// worker the master started may leave them in memory the two share, which a master of version
/// 6 could not read).
pub const PROTOCOL_VERSION: u32 = 7;
