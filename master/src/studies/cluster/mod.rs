//! The emulated cluster behind `parrt bench cluster`, to measure the distributed machinery at
//! a scale this machine cannot trace: real worker processes replay a recorded render against a real
//! master over real TCP on 127.0.0.1, each behind an emulated LAN link.
//!
//! - [`emulate`]: one emulated run ([`emulate::run`] with an [`emulate::EmulatedRun`]).
//! - [`link`]: the emulated LAN (a relay with per-link bandwidth and latency).
//! - [`cpu`]: CPU accounting of a run (the master's threads, the emulation, the machine).

pub mod cpu;
pub mod emulate;
pub mod link;
