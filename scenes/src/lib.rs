//! SPD-style procedural scene generators: each builds a [`parrt::description::SceneDescription`]
//! deterministically from a name and a size factor. STUB registry until the generators land:
//! signatures are final.
#![deny(missing_docs)]

use parrt::description::SceneDescription;
use thiserror::Error;

/// Errors choosing or running a generator.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum GenError {
    /// No generator has this name.
    #[error("unknown scene '{0}' (known: {1})")]
    UnknownScene(String, String),
    /// The size factor is outside what the generator supports.
    #[error("scene '{name}' does not support size {size}: {why}")]
    BadSize {
        /// Generator name.
        name: String,
        /// Requested size.
        size: u32,
        /// Why not.
        why: String,
    },
}

/// A generator's name and default size factor.
#[derive(Clone, Copy, Debug)]
pub struct GeneratorInfo {
    /// Name as used on the command line (`balls`, `mount`, ...).
    pub name: &'static str,
    /// SPD's compiled-in default size factor.
    pub default_size: u32,
    /// One-line description.
    pub about: &'static str,
}

/// The generators, in alphabetical order.
pub fn generators() -> &'static [GeneratorInfo] {
    &[]
}

/// Generates scene `name` at size factor `size` (`None`: the generator's default).
pub fn generate(name: &str, size: Option<u32>) -> Result<SceneDescription, GenError> {
    let _ = size;
    Err(GenError::UnknownScene(
        name.to_string(),
        generators()
            .iter()
            .map(|g| g.name)
            .collect::<Vec<_>>()
            .join(", "),
    ))
}
