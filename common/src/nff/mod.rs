//! Haines NFF: a strict token-based reader and a writer that round-trips.

pub mod error;
pub mod limits;
pub mod parser;
pub mod writer;

pub use error::{NffError, NffErrorKind};
pub use limits::Limits;
pub use parser::{parse, parse_file};
pub use writer::to_nff;
