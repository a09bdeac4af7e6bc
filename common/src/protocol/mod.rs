//! The master/worker wire protocol (DESIGN §8): what the messages are ([`message`]), how they are
//! framed and encoded ([`codec`]), how a tile's pixels travel ([`pixels`]), how a worker proves it knows the shared token ([`auth`]), and
//! the one type that touches a socket ([`connection`]).
//!
//! ## Wire format
//! Every message is one frame: a 4-byte big-endian length, then the message encoded with
//! [postcard](https://docs.rs/postcard). A frame longer than the connection's limit is an error
//! before any of it is buffered; the master keeps the limit tiny until a peer has authenticated.
//!
//! ## Conversation
//! ```text
//! worker                         master
//!   Hello{version,name,threads} →
//!                               ← Challenge{nonce}        (or Refused: wrong version)
//!   Auth{mac = HMAC(token,nonce)} →
//!                               ← Welcome                 (or Refused: wrong token)
//!                               ← Job{job_id, scene, settings, tile_size}
//!   Ready{job_id, build_s}      →                         (or Error{reason}: cannot build)
//!                               ← Assign{job_id, tile, attempt}   (a window of several)
//!   TileResult{...}             →
//!   Heartbeat                   →                         (every few seconds, both ways)
//!                               ← Cancel{job_id} / Shutdown
//! ```
//! [`message::Message::Hello`] is variant 0 and its `version` field comes first, so a peer of any
//! version can read the version of another and refuse it with a reason.

pub mod auth;
pub mod codec;
pub mod connection;
pub mod message;
pub mod pixels;

pub use auth::{AuthError, Token};
pub use codec::{MessageCodec, ProtocolError, WireCounters};
pub use connection::Connection;
pub use message::{JobSpec, Message};
pub use pixels::{PixelError, PixelFormat, TilePixels};

/// The protocol version spoken by this build; bumped on any incompatible change.
pub const PROTOCOL_VERSION: u32 = 2;

/// The default largest frame accepted from an authenticated peer: 256 MiB (a large scene).
pub const DEFAULT_MAX_FRAME: usize = 256 * 1024 * 1024;

/// The largest frame accepted before a peer has authenticated: Hello and Auth are tiny, so an
/// unauthenticated peer can never make us reserve much memory.
pub const HANDSHAKE_MAX_FRAME: usize = 64 * 1024;
