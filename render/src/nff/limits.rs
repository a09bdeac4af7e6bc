//! Named limits on sizes that come from a file; exceeding one is a clear error, never an
//! allocation failure. Each can be raised from the command line.

use serde::{Deserialize, Serialize};

/// Default maximum vertices of one polygon or patch.
pub const DEFAULT_MAX_VERTICES: u32 = 1 << 16;
/// Default maximum number of primitives in a scene.
pub const DEFAULT_MAX_PRIMITIVES: u64 = 1 << 26;
/// Default maximum pixels of an image (width × height).
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 28;
/// Default maximum bytes of a file read from a path (1 GiB; the largest SPD file is 1.5 MB).
pub const DEFAULT_MAX_FILE_BYTES: u64 = 1 << 30;

fn default_max_file_bytes() -> u64 {
    DEFAULT_MAX_FILE_BYTES
}

/// Limits applied while parsing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Limits {
    /// Maximum vertices of one `p`/`pp`.
    pub max_vertices: u32,
    /// Maximum primitives.
    pub max_primitives: u64,
    /// Maximum width × height.
    pub max_pixels: u64,
    /// Maximum bytes of a file read from a path ([`super::read_bounded`]).
    #[serde(default = "default_max_file_bytes")]
    pub max_file_bytes: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_vertices: DEFAULT_MAX_VERTICES,
            max_primitives: DEFAULT_MAX_PRIMITIVES,
            max_pixels: DEFAULT_MAX_PIXELS,
            max_file_bytes: DEFAULT_MAX_FILE_BYTES,
        }
    }
}
