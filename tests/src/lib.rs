//! Helpers shared by parrt's integration tests.
