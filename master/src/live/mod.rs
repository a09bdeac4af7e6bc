//! The live view (`--http ADDR` on `parrt render`, `parrt master` and `parrt cluster`): a small
//! web page that shows the image filling in tile by tile, a row per worker (or render thread),
//! faults, progress and ETA, and `GET /status` with the same as JSON (`docs/live-view.md`).
//!
//! ## Layout
//! - [`state`]: what the render reports, as an observer (never waiting: a mutex held for a
//!   copy that notes which tile landed, a few counters) and what the server reads. Its flags
//!   are `crate::cli_args::live`'s; it never decides an exit code.
//! - [`status`]: what `/status` returns (the state keeps it up to date).
//! - [`server`]: the HTTP server (axum) on a thread and runtime of its own, so a slow or stuck
//!   browser can never hold the render up.
//! - [`batcher`]: the server's task that encodes the tiles landed, once per 100 ms for every
//!   page, and the status, into events shared by all pages (lossy: a page that falls behind
//!   reloads).
//! - [`auth`]: who may see it: anyone on loopback (through a `Host` naming it), only holders of
//!   the view key elsewhere (derived one way from the workers' token, never the token itself).
//! - [`gate`]: which connections and event streams stay open when there are too many.
//! - [`frames`]: a sequence's frames: which the page shows, how many are done and in flight.
//! - [`snapshot`]: the one copy of the frame `/frame` and `/image.png` serve.
//! - [`announce`]: where the page's address is told (the key only to a terminal or a 0600
//!   file, never to a log).
//! - [`limits`]: the server's limits; [`head_limit`]: the one on a request's head, exact.
//! - [`encode`]: the bytes of the events (a batch of tiles as one PNG, in base64, at full
//!   resolution or averaged over blocks when tiles land faster than `--http-full-rate`).
//! - `page.html`: the page (HTML and plain JavaScript, served as it is).

pub mod announce;
pub mod auth;
pub mod batcher;
pub mod encode;
pub mod frames;
pub mod gate;
pub mod head_limit;
pub mod limits;
pub mod server;
pub mod snapshot;
pub mod state;
pub mod status;

pub use server::LiveView;
pub use state::LiveState;

use parrt_runtime::observer::Observer;
use std::net::SocketAddr;
use std::time::Duration;

/// What a live view serves and how: checked values (the flags that give them, and their
/// checks, are `crate::cli_args::live`'s).
#[derive(Clone, Debug)]
pub struct LiveOptions {
    /// The address to listen on.
    pub addr: SocketAddr,
    /// How long to keep serving the finished image (at most [`limits::MAX_LINGER`]).
    pub linger: Duration,
    /// Pixels a second sent to the pages at full resolution (see [`limits::FULL_RATE`]).
    pub full_rate: f64,
}

/// A live view serving one render: its state (to feed) and its server.
pub struct Live {
    /// What the render's reports update (as an observer) and the server reads.
    state: std::sync::Arc<LiveState>,
    view: LiveView,
    linger: std::time::Duration,
    /// Where the address with the key was written (removed at the end).
    announced: announce::Announced,
}

impl Live {
    /// Starts a live view at `opts.addr` and tells its address (see [`announce`]). On a
    /// non-loopback address a page needs the view key, derived from `token` (the workers'
    /// secret, which itself does not open the view); without one (`parrt render`) a random
    /// token is made for it. Fails only when the address cannot be served.
    pub fn start(opts: &LiveOptions, token: Option<&[u8]>) -> anyhow::Result<Live> {
        // Fresh random bytes per run bind the key to this run: a leftover address opens
        // nothing later.
        let run = parrt_runtime::generate_token();
        let key = auth::needs_token(&opts.addr).then(|| match token {
            Some(t) => auth::view_key(t, run.as_bytes()),
            None => auth::view_key(parrt_runtime::generate_token().as_bytes(), run.as_bytes()),
        });
        let state = std::sync::Arc::new(LiveState::empty());
        let view = LiveView::start(
            &opts.addr.to_string(),
            state.clone(),
            key.as_deref().map(str::as_bytes),
            opts.full_rate,
        )?;
        let announced = announce::announce(&view, &mut std::io::stderr())?;
        Ok(Live {
            state,
            view,
            linger: opts.linger,
            announced,
        })
    }

    /// Tells the page what is rendered (before the render starts).
    pub fn set_job(&self, job: state::JobInfo) {
        self.state.set_job(job);
    }

    /// Tells the page the frames of a sequence (before the render starts): frame k is
    /// `jobs[k]`.
    pub fn set_sequence(&self, jobs: Vec<state::JobInfo>) {
        self.state.set_sequence(jobs);
    }

    /// The state as an observer of the render.
    pub fn observer(&self) -> std::sync::Arc<dyn parrt_runtime::observer::Observer> {
        self.state.clone()
    }

    /// The address served.
    pub fn local_addr(&self) -> std::net::SocketAddr {
        self.view.local_addr()
    }

    /// Marks the render ended (if nothing did yet), serves the final state for the linger
    /// time (Ctrl-C ends it) and stops the server.
    pub fn end(self, complete: bool) {
        if matches!(
            self.state.status().state,
            state::Phase::Starting | state::Phase::Rendering
        ) {
            self.state.finished(complete, tokio::time::Instant::now());
        }
        if !self.linger.is_zero() {
            crate::errln!(
                "parrt: live view stays up {:.0} s more (Ctrl-C ends it)",
                self.linger.as_secs_f64()
            );
            if let Ok(rt) = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            {
                rt.block_on(async {
                    tokio::select! {
                        _ = tokio::time::sleep(self.linger) => {}
                        _ = tokio::signal::ctrl_c() => {}
                    }
                });
            }
        }
        self.view.stop();
        let mut announced = self.announced;
        announced.remove();
    }
}
