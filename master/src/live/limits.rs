//! The live view's limits, in one place.

use std::time::Duration;

/// Pages (event streams) open at once; more get 503 until one closes.
pub const MAX_STREAMS: usize = 32;

/// Events (each a batch of tiles or a status) buffered for the pages, about 2 s of them; a page
/// that falls this far behind is told to reload the whole image instead.
pub const EVENT_BACKLOG: usize = 24;

/// How often the tiles landed since are sent to the open pages (in one event, made once).
pub const PUSH_EVERY: Duration = Duration::from_millis(100);

/// The longest side of one `tiles` event's PNG (a sheet of its tiles side by side), unless one
/// tile is bigger; a bigger batch is sent as several events. Far under what browsers decode.
pub const SHEET_SIDE: u32 = 4096;

/// Pixels a second sent to the pages at full resolution unless `--http-full-rate` says
/// otherwise: a render of 2 megapixels that takes 4 s or more is shown at full resolution as
/// it runs; faster ones as a preview (the measurements behind it: `docs/live-view.md`).
pub const FULL_RATE: f64 = 0.5e6;

/// The coarsest preview: tiles landing too fast for the full rate are sent averaged over
/// blocks of at most this many pixels a side.
pub const MAX_PREVIEW_SCALE: u32 = 8;

/// How often the open pages are sent the status (when it changed).
pub const STATUS_EVERY: Duration = Duration::from_millis(250);

/// A page's stream sends a comment when it sent nothing for this long (so proxies keep it).
pub const KEEP_ALIVE: Duration = Duration::from_secs(10);

/// Faults kept for the page and `/status` (the newest; the count of all is kept too).
pub const KEPT_FAULTS: usize = 100;

/// The longest `--http-linger`.
pub const MAX_LINGER: Duration = Duration::from_secs(24 * 3600);
