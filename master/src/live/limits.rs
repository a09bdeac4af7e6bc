//! The live view's limits, in one place.

use std::time::Duration;

/// Event streams open at once. A stream past it closes the one that took an event least
/// recently (a stuck one first), so pages are never refused for streams others hold.
pub const MAX_STREAMS: usize = 32;

/// Connections open at once. A connection past it closes the oldest one still waiting for its
/// request's head; when every one has been served a request, the newcomer is closed instead.
/// Far under the usual 1 024 descriptors a process may hold, so no flood of connections can
/// take the descriptors the render's workers need.
pub const MAX_CONNECTIONS: usize = 128;

/// How long a connection may take to send a request's head (from its opening, or from the end
/// of its last response); then it is closed.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(5);

/// `GET /frame` and `GET /image.png` responses being sent at once; more get 503. Each holds at
/// most one snapshot of the frame until its client has read it.
pub const MAX_IMAGE_RESPONSES: usize = 4;

/// The frame snapshot that `/frame` and `/image.png` serve is taken again at most this often,
/// however many ask.
pub const SNAPSHOT_EVERY: Duration = Duration::from_millis(100);

/// A snapshot of the frame is copied in bands of about this many bytes, the frame's lock
/// taken and released for each, so a tile landing waits for one band's copy at most.
pub const SNAPSHOT_BAND: usize = 64 * 1024;

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

/// Departed workers listed on the page and in `/status` (the newest; the count of all is kept
/// too, and every worker still connected is listed).
pub const KEPT_DEPARTED: usize = 32;

/// The longest `--http-linger`.
pub const MAX_LINGER: Duration = Duration::from_secs(24 * 3600);

/// What one connection buffers of a response before its client reads (hyper's write buffer).
/// hyper bounds a request's head by it too, but loosely (it checks the size only after a read
/// that did not complete the head, so heads of up to about twice this can get through); the
/// limit a head is held to is [`super::head_limit::MAX_REQUEST_HEAD`], exact and well under it.
pub const RESPONSE_BUFFER: usize = 64 * 1024;

/// `/frame` and `/image.png` are sent in copied chunks of this many bytes, so a connection
/// never buffers more than a chunk or two of a snapshot.
pub const SEND_CHUNK: usize = 16 * 1024;
