//! # parrt-master
//!
//! The `parrt` command line as a library: argument parsing, the commands, the watchers of a
//! render (progress bar, live view, timeline) and the studies behind `parrt bench`. The binary
//! (`src/main.rs`) only calls [`cli::main`]. The renderer is the `parrt` crate, the master side of
//! distributed rendering the `parrt_runtime` crate; use those to render from Rust. What this
//! crate adds for a Rust user is the studies' engines, such as the image metrics of the
//! speed-against-error study.
//!
//! ## Example
//! ```
//! use parrt_master::studies::accuracy::metrics::compare;
//!
//! let reference = vec![[0.5f32, 0.5, 0.5]; 4];
//! let mut image = reference.clone();
//! image[0] = [0.5, 0.5, 0.6]; // one pixel of four off by 0.1 in blue
//! let e = compare(&image, &reference);
//! assert_eq!(e.off, 0.25); // the share of pixels off by more than 1/255
//! assert!((e.max - 0.1).abs() < 1e-6);
//! assert!((e.rmse - (0.01f64 / 12.0).sqrt()).abs() < 1e-6);
//! ```
//!
//! ## Layout
//! - [`cli`]: argument definitions and dispatch; `main.rs` only calls [`cli::main`].
//! - [`commands`]: one module per subcommand (`render`, `info`, `scene`, `master`, `worker`,
//!   `cluster`, `bench`, `plot-timeline`, `completions`, `man`).
//! - [`cli_args`]: the flags and arguments several commands share (scene, render settings,
//!   limits, durations, sizes, outputs), each parsed and checked once.
//! - the master side of distributed rendering is the `parrt_runtime` crate (`master/runtime`).
//! - [`progress`]: the one progress bar, an observer of every render.
//! - [`sequence_checkpoint`]: the frames of a sequence through workers, with its checkpoint.
//! - [`sequence_progress`]: the progress bar of a sequence (tiles and frames).
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
pub mod sequence_checkpoint;
pub mod sequence_progress;
pub mod studies;
pub mod timeline;
pub mod version;
