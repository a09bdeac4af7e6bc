//! Named limits on sizes that come from a file; exceeding one is a clear error, never an
//! allocation failure. Each can be raised from the command line.

use serde::{Deserialize, Serialize};

/// Default maximum vertices of one polygon or patch.
pub const DEFAULT_MAX_VERTICES: u32 = 1 << 16;
/// Default maximum number of primitives in a scene.
pub const DEFAULT_MAX_PRIMITIVES: u64 = 1 << 26;
/// Default maximum pixels of an image (width × height).
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 28;

/// Limits applied while parsing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Limits {
    /// Maximum vertices of one `p`/`pp`.
    pub max_vertices: u32,
    /// Maximum primitives.
    pub max_primitives: u64,
    /// Maximum width × height.
    pub max_pixels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_vertices: DEFAULT_MAX_VERTICES,
            max_primitives: DEFAULT_MAX_PRIMITIVES,
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}
