//! parrt's command line and distributed scheduler.
//!
//! ## Layout
//! - [`cli`]: argument definitions and dispatch; `main.rs` only calls [`cli::main`].
//! - [`commands`]: one module per subcommand (`render`, `info`, `scene`, `master`, `worker`,
//!   `cluster`, `bench`).
//! - [`distributed`]: the master side of distributed rendering (server, scheduler, workers).
//! - [`accuracy`]: the speed-against-error study behind `parrt bench accuracy`.
//! - [`plot`]: charts (SVG and PNG) for the studies.
//! - [`timeline`]: per-tile timelines of renders (`--timeline`) and their plots.
//! - [`cpu_time`]: thread and process CPU clocks (benchmarks, the master's own cost).
//! - [`live`]: the live view in a browser (`--http`).
//! - [`exit`]: how errors map to exit codes (2 bad input or usage, 1 anything else).
#![deny(missing_docs)]

pub mod accuracy;
pub mod cli;
pub mod commands;
pub mod cpu_time;
pub mod distributed;
pub mod exit;
pub mod live;
pub mod plot;
pub mod timeline;
