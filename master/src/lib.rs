//! parrt's command line and distributed scheduler.
//!
//! ## Layout
//! - [`cli`]: argument definitions and dispatch; `main.rs` only calls [`cli::main`].
//! - [`commands`]: one module per subcommand (`render`, `info`, `scene`, `master`, `worker`,
//!   `cluster`, `bench`, `plot-timeline`, `completions`, `man`).
//! - [`cli_args`]: the flags and arguments several commands share (scene, render settings,
//!   limits, durations, sizes, outputs), each parsed and checked once.
//! - the master side of distributed rendering is the `parrt_runtime` crate (`master/runtime`).
//! - [`progress`]: the one progress bar, an observer of every render.
//! - [`observed_smp`]: an SMP render reported to the same observers as a distributed one (its
//!   threads as workers), so every watcher has one input.
//! - [`machine`]: what machine a measurement ran on.
//! - [`studies`]: the engines of the studies behind `parrt bench` (the speed-against-error
//!   study, the emulated cluster), a public API the bench commands and the tests call.
//! - [`plot`]: charts (SVG and PNG) for the studies.
//! - [`timeline`]: per-tile timelines of renders (`--timeline`) and their plots.
//! - [`live`]: the live view in a browser (`--http`).
//! - [`exit`]: how errors map to exit codes (2 bad input or usage, 1 anything else).
//! - [`version`]: what build this is (`--version`).
//! - [`console`]: printing that a closed stdout or stderr cannot turn into a panic.
#![deny(missing_docs)]

pub mod cli;
pub mod cli_args;
pub mod commands;
pub mod console;
pub mod exit;
pub mod live;
pub mod machine;
pub mod observed_smp;
pub mod plot;
pub mod progress;
pub mod studies;
pub mod timeline;
pub mod version;
