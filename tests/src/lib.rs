//! # parrt-tests
//!
//! Helpers shared by parrt's integration tests (`tests/tests/`), and the deterministic
//! simulation of the distributed system with its command line (`sim`). Not published: it exists
//! for the workspace's own tests.
//!
//! - [`dist`]: small scenes built in code, the SMP reference render, masters and workers
//!   started in-process or as processes over loopback.
//! - [`deliveries`]: an observer a test can wait on, to inject a fault once a worker is
//!   known to be mid-job.
//! - [`sim`]: the real master runtime and worker sessions on simulated hosts and TCP (turmoil),
//!   in virtual time, under faults drawn from a seed.
//!
//! ## Example
//! One seed of the simulation: its faults, every invariant checked, and a trace hash that a
//! replay of the same seed reproduces.
//! ```no_run
//! let outcome = parrt_tests::sim::world::run_seed(7);
//! assert!(outcome.failures.is_empty(), "{:?}", outcome.failures);
//! assert_eq!(parrt_tests::sim::world::run_seed(7).trace, outcome.trace);
//! ```

pub mod deliveries;
pub use deliveries::Deliveries;
pub mod dist;
pub mod sim;
pub use dist::*;
