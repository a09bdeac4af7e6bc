//! The live view (`--http ADDR` on `parrt render`, `parrt master` and `parrt cluster`): a small
//! web page that shows the image filling in tile by tile, a row per worker (or render thread),
//! faults, progress and ETA, and `GET /status` with the same as JSON (`docs/live-view.md`).
//!
//! ## Layout
//! - [`state`]: what the renderer pushes (never waiting: a mutex held for a copy that notes
//!   which tile landed, a few counters) and what the server reads.
//! - [`server`]: the HTTP server (axum) on a thread and runtime of its own, so a slow or stuck
//!   browser can never hold the render up.
//! - [`batcher`]: the server's task that encodes the tiles landed, once per 100 ms for every
//!   page, and the status, into events shared by all pages (lossy: a page that falls behind
//!   reloads).
//! - [`auth`]: who may see it: anyone on loopback, only holders of the token elsewhere.
//! - [`limits`]: the server's limits.
//! - [`encode`]: the bytes of the events (a batch of tiles as one PNG, in base64, at full
//!   resolution or averaged over blocks when tiles land faster than `--http-full-rate`).
//! - `page.html`: the page (HTML and plain JavaScript, served as it is).

pub mod auth;
pub mod batcher;
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
    /// With --http: send tiles to the page at full resolution while they land at up to this
    /// many megapixels a second; tiles landing faster are sent averaged over 2×2, 4×4 or 8×8
    /// blocks, so that watching costs the render little however fast it runs. The image at
    /// the end (and image.png) is always full resolution.
    #[arg(long, value_name = "MPIXELS", default_value_t = limits::FULL_RATE / 1e6, requires = "http")]
    pub http_full_rate: f64,
}

/// A live view serving one render: its state (to feed) and its server.
pub struct Live {
    /// What the renderer updates.
    pub state: std::sync::Arc<LiveState>,
    view: LiveView,
    linger: std::time::Duration,
}

impl Live {
    /// Starts the live view `args` ask for (`None` without `--http`) and prints its address.
    /// `token` is what a non-loopback address requires; without one (`parrt render`) a random
    /// one is made and printed in the address.
    pub fn start(args: &LiveArgs, token: Option<&[u8]>) -> anyhow::Result<Option<Live>> {
        use crate::exit::input_error;
        use std::net::ToSocketAddrs;
        let Some(http) = &args.http else {
            return Ok(None);
        };
        let linger = args.http_linger;
        if !linger.is_finite() || linger < 0.0 || linger > limits::MAX_LINGER.as_secs_f64() {
            return Err(input_error(anyhow::anyhow!(
                "--http-linger {linger}: must be between 0 and {} seconds",
                limits::MAX_LINGER.as_secs()
            )));
        }
        let rate = args.http_full_rate;
        if !rate.is_finite() || rate <= 0.0 || rate > 1e6 {
            return Err(input_error(anyhow::anyhow!(
                "--http-full-rate {rate}: must be more than 0 and at most 1000000 megapixels a second"
            )));
        }
        let addr = http
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.next())
            .ok_or_else(|| {
                input_error(anyhow::anyhow!(
                    "--http {http}: not an address to listen on; use HOST:PORT, e.g. 127.0.0.1:8080"
                ))
            })?;
        let made;
        let token = match token {
            Some(t) => Some(t),
            None if auth::needs_token(&addr) => {
                made = parrt_runtime::generate_token();
                Some(made.as_bytes())
            }
            None => None,
        };
        let state = std::sync::Arc::new(LiveState::empty());
        let view = LiveView::start(&addr.to_string(), state.clone(), token, rate * 1e6)?;
        eprintln!("parrt: live view at {}", view.url());
        Ok(Some(Live {
            state,
            view,
            linger: std::time::Duration::from_secs_f64(linger),
        }))
    }

    /// The state as an observer of a distributed render.
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
            self.state.finish(complete);
        }
        if !self.linger.is_zero() {
            eprintln!(
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
    }
}
