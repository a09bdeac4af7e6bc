//! Deterministic simulation of the distributed system (turmoil): the real master runtime and
//! the real worker session on simulated hosts and TCP, in virtual time, under faults drawn
//! from a seed. Every failure replays exactly from its seed (same trace hash).
//!
//! - [`args`]: the `sim` binary's flags and their ranges.
//! - [`plan`]: the fault menu and a seed's schedule.
//! - [`world`]: one seed's hosts, the fault driver and the invariants.
//! - [`frames`]: the sequences some seeds render, and their invariant.
//! - [`trace`]: the event trace (its hash) and the accepted tiles.
//! - [`net`]: turmoil's TCP in the runtime's and the worker's network seams.
//! - [`scale`]: fault-free runs of many workers over a recorded render, in virtual time.
//! - [`sequence`]: a sequence of frames in such a run: each frame the recording panned.
//! - [`tail`]: what binds such a run, read from its event trace.
//!
//! The binary `sim` (`cargo run --release -p parrt-tests --bin sim -- explore --seeds N`)
//! explores and replays; docs/simulation.md describes the world.

pub mod args;
pub mod frames;
pub mod net;
pub mod plan;
pub mod scale;
pub mod sequence;
pub mod tail;
pub mod trace;
pub mod world;

pub use world::{run_seed, run_seed_with, Outcome};
