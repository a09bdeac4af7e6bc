//! The live view's limits, in one place.

use std::time::Duration;

/// Pages (event streams) open at once; more get 503 until one closes.
pub const MAX_STREAMS: usize = 32;

/// Tile messages buffered for the pages; a page that falls this far behind is told to reload
/// the whole image instead.
pub const TILE_BACKLOG: usize = 1024;

/// How often an open page's stream wakes to send the tiles landed since (in one event).
pub const PUSH_EVERY: Duration = Duration::from_millis(100);

/// How often an open page is sent the status (when it changed).
pub const STATUS_EVERY: Duration = Duration::from_millis(250);

/// Faults kept for the page and `/status` (the newest; the count of all is kept too).
pub const KEPT_FAULTS: usize = 100;

/// The longest `--http-linger`.
pub const MAX_LINGER: Duration = Duration::from_secs(24 * 3600);
