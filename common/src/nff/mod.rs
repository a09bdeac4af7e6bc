//! Haines NFF: a strict token-based reader and a writer that round-trips.

pub mod writer;

pub use writer::to_nff;
