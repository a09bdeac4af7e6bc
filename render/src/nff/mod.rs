//! Haines NFF: a strict token-based reader and a writer that round-trips.
//!
//! - [`lexer`]: bytes to tokens with line and column.
//! - [`number`]: correctly rounded reals and whole-number counts.
//! - [`checks`]: the geometric validity rules (camera, cone, polygon).
//! - [`parser`]: the file grammar; [`parse`], [`parse_file`] and their detailed forms.
//! - `entities`: each entity's fields after its keyword (the parser's, continued).
//! - [`read`]: a named file's bytes, bounded (regular files only, a size limit).
//! - [`summary`]: what a parsed file contains, counted (for `parrt info`).
//! - [`writer`]: [`to_nff`], which the parser reads back to the identical description.
//! - [`pov`]: [`to_pov`], the same scene as a POV-Ray scene (for the POV-Ray comparison).
//!
//! ```
//! let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 64 48\n\
//!             l 5 5 5\nf 1 0 0 1 0 0 0 0\ns 0 0 0 1\n";
//! let desc = parrt_render::nff::parse(text, "ball.nff", &parrt_render::nff::Limits::default())?;
//! assert_eq!(desc.primitives.len(), 1);
//! assert_eq!(parrt_render::nff::parse(&parrt_render::nff::to_nff(&desc), "again", &Default::default())?, desc);
//! # Ok::<(), parrt_render::nff::NffError>(())
//! ```

pub mod checks;
mod entities;
pub mod error;
pub mod lexer;
pub mod limits;
pub mod number;
pub mod parser;
pub mod pov;
pub mod read;
pub mod summary;
pub mod writer;

pub use error::{NffError, NffErrorKind};
pub use limits::Limits;
pub use parser::{parse, parse_bytes, parse_file, parse_file_bytes, ParsedNff};
pub use pov::to_pov;
pub use read::{read_bounded, ReadError};
pub use summary::Summary;
pub use writer::to_nff;
