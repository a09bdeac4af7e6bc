//! Why a command line cannot be used: the one error type of [`crate::cli_args`]. Every variant
//! is bad input (exit status 2 wherever [`ArgError::is_in`] finds one in an error's chain), and
//! its message names the flag, file or argument at fault.

use std::path::PathBuf;

/// A flag, argument or named file the command cannot use.
#[derive(Debug, thiserror::Error)]
pub enum ArgError {
    /// A flag's value is malformed or out of its range (the message names flag and value).
    #[error("{0}")]
    Value(String),
    /// Arguments that cannot be given together, or one that is missing.
    #[error("{0}")]
    Conflict(String),
    /// A file or directory a flag names cannot be read, written or used as asked.
    #[error("{}: {why}", path.display())]
    File {
        /// The file as the command line named it.
        path: PathBuf,
        /// What was wrong with it.
        why: String,
    },
    /// A library's check refused what the command line asked (an output format, a scene file,
    /// render settings); its own error says what and where.
    #[error(transparent)]
    Refused(Box<dyn std::error::Error + Send + Sync + 'static>),
}

impl ArgError {
    /// A library's refusal of a value the command line gave.
    pub fn refused(e: impl Into<Box<dyn std::error::Error + Send + Sync + 'static>>) -> Self {
        ArgError::Refused(e.into())
    }

    /// Whether an `ArgError` is anywhere in `e`'s chain: the command line was at fault.
    pub fn is_in(e: &anyhow::Error) -> bool {
        e.chain().any(|c| c.is::<ArgError>())
    }

    /// A named file that cannot be used, and why.
    pub fn file(path: impl Into<PathBuf>, why: impl std::fmt::Display) -> Self {
        ArgError::File {
            path: path.into(),
            why: why.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_variant_is_found_in_the_chain_and_keeps_its_message() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let cases = [
            (
                ArgError::Value("--tile must be at least 1".into()),
                "--tile must be at least 1",
            ),
            (ArgError::Conflict("give one".into()), "give one"),
            (
                ArgError::file("a/b.nff", "not UTF-8 text"),
                "a/b.nff: not UTF-8 text",
            ),
            (ArgError::refused(io), "no such file"),
        ];
        for (e, text) in cases {
            let e = anyhow::Error::new(e).context("while starting");
            assert!(ArgError::is_in(&e), "{e:#}");
            assert!(format!("{e:#}").ends_with(text), "{e:#}");
        }
    }
}
