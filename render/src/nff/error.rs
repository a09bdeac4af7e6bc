//! Errors of the NFF reader: each names the file, line and column and what was expected.

use thiserror::Error;

/// What went wrong while reading NFF.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NffErrorKind {
    /// The file could not be read.
    Io,
    /// A syntax or semantic error in the text.
    Syntax,
    /// A named limit was exceeded.
    Limit,
}

/// An error reading NFF, with its location (1-based line and column; 0 when not applicable).
#[derive(Debug, Clone, Error, PartialEq, Eq)]
#[error("{file}:{line}:{column}: {message}")]
pub struct NffError {
    /// The file name as given by the caller.
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based column.
    pub column: u32,
    /// What was wrong and what was expected.
    pub message: String,
    /// Category.
    pub kind: NffErrorKind,
}
