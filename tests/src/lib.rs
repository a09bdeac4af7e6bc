//! Helpers shared by parrt's integration tests.

pub mod spd;
