//! The command line's shared vocabulary: the flags and arguments more than one command takes,
//! each parsed and checked here, once, with the error a user sees (bad input, exit 2). Commands
//! flatten these into their own `Args`; nothing here runs a render or reads more than a flag
//! allows.
//!
//! - [`arg_error`]: the one error type here (`ArgError`), bad input by its type.
//! - [`scene_arg`]: the scene (NFF file, JSON description or `NAME[:SIZE]`).
//! - [`render_flags`]: the render settings (`RenderFlags`) and the accelerator and executor
//!   choices.
//! - [`limits`]: the parser and image limits (`LimitArgs`) and bounded reads of named files.
//! - [`durations`]: flags that are a number of seconds.
//! - [`size`]: `--size WxH`.
//! - [`output`]: the outputs a command writes, checked before any work.
//! - [`listen`]: `--listen ADDR`.
//! - [`live`]: the live view's flags (`--http`, ...).
//! - [`job_flags`]: what the distributed entry points share (`--checkpoint`, `--resume`,
//!   `--timeline` and the live view).
//! - [`tile_order`]: `--costly-first FILE`, the handout order from a previous render's costs.
//! - [`sequence`]: the flags that make a render a sequence (`--frames-from`, `--orbit`,
//!   `--frames`, `--window`) and the reading of a frame LIST.
//! - [`frame_pattern`]: a sequence's output pattern (`-o out/frame-%04d.png`).

pub mod arg_error;
pub mod durations;
pub mod frame_pattern;
pub mod job_flags;
pub mod limits;
pub mod listen;
pub mod live;
pub mod output;
pub mod render_flags;
pub mod scene_arg;
pub mod sequence;
pub mod size;
pub mod tile_order;

pub use arg_error::ArgError;
pub use job_flags::JobFlags;
pub use limits::LimitArgs;
pub use render_flags::{AccelArg, ExecutorArg, RenderFlags};
pub use scene_arg::SceneSpec;
