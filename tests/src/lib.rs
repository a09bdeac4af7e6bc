//! Helpers shared by parrt's integration tests.

pub mod deliveries;
pub use deliveries::Deliveries;
pub mod dist;
/// Deterministic simulation of the distributed system (turmoil).
pub mod sim;
pub use dist::*;
