//! The live view (`--http ADDR` on `parrt render`, `parrt master` and `parrt cluster`): a small
//! web page that shows the image filling in tile by tile, a row per worker (or render thread),
//! faults, progress and ETA, and `GET /status` with the same as JSON (`docs/live-view.md`).
//!
//! ## Layout
//! - [`state`]: what the renderer pushes (never waiting: a mutex held for a copy, a lossy
//!   broadcast of tiles) and what the server reads.
//! - [`server`]: the HTTP server (axum) on a thread and runtime of its own, so a slow or stuck
//!   browser can never hold the render up.
//! - [`auth`]: who may see it: anyone on loopback, only holders of the token elsewhere.
//! - [`limits`]: the server's limits.
//! - [`encode`]: base64 for the tiles sent to the page.
//! - `page.html`: the page (HTML and plain JavaScript, served as it is).

pub mod auth;
pub mod encode;
pub mod limits;
pub mod server;
pub mod state;

pub use server::LiveView;
pub use state::LiveState;

use clap::Args;

/// The live-view flags.
#[derive(Debug, Clone, Args)]
pub struct LiveArgs {
    /// Serve a live view of the render at ADDR (HOST:PORT; port 0 picks one). Loopback
    /// addresses are open to local users; any other address needs the token, as
    /// `Authorization: Bearer TOKEN` or `?token=TOKEN`. Without this flag no port is opened.
    #[arg(long, value_name = "ADDR")]
    pub http: Option<String>,
    /// With --http: keep serving the finished image this many seconds after the render
    /// (Ctrl-C ends it sooner).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, requires = "http")]
    pub http_linger: f64,
}
