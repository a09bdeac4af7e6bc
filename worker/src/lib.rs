//! # parrt-worker
//!
//! The render worker of parrt's distributed mode (docs/design.md, *Distributed runtime*): a plain
//! process that dials a master, proves it knows the shared token, receives a job (scene description
//! and settings), builds its own renderer once, and renders the tiles it is assigned on a rayon
//! pool, streaming the pixels back. Rendering never runs on the async runtime: tiles go to rayon
//! and come back through a channel.
//!
//! ## Layout
//! - [`options`]: what a worker is told (address, threads, token, timeouts, test hooks).
//! - [`net`]: the network seam, how a connection is opened (TCP, or a simulated stream).
//! - [`dial`]: connecting with bounded exponential backoff.
//! - [`session`]: handshake and the message loop with one master ([`session::run`] for the
//!   real worker, [`session::run_with`] for a simulation or a test).
//! - [`exec`]: the execution seam, where builds and tiles run (the rayon pool, or inline in
//!   simulated time; either replaying a recording).
//! - [`tiles`]: the bridge from the async loop to the rayon pool.
//! - [`replay`]: the recorded render a replaying worker plays instead of tracing (a bench aid).
//! - [`logging`]: diagnostics as plain lines for people, or the timestamped log on request.
//! - [`cli`]: `parrt worker` / `parrt-worker` arguments and entry point (both binaries call it).
//! - [`error`]: what can go wrong.
//!
//! ## Example
//! ```no_run
//! use parrt_protocol::Token;
//! use parrt_worker::{options::WorkerOptions, session};
//! # async fn f() -> Result<(), parrt_worker::error::WorkerError> {
//! let opts = WorkerOptions::new("127.0.0.1:7878", Token::new("secret").unwrap());
//! let summary = session::run(&opts, tokio_util::sync::CancellationToken::new()).await?;
//! println!("rendered {} tiles", summary.tiles_rendered);
//! # Ok(()) }
//! ```
#![deny(missing_docs)]

pub mod cli;
pub mod dial;
pub mod error;
pub mod exec;
pub mod logging;
pub mod net;
pub mod options;
pub mod replay;
pub mod session;
pub mod tiles;

pub use error::WorkerError;
pub use options::WorkerOptions;
