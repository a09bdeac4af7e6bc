//! The live view's HTTP server: axum on a thread and current-thread runtime of its own (so
//! no page, however slow, shares a thread with the render), serving
//! - `GET /`: the page (`page.html`, with the status of the moment in it);
//! - `GET /status`: [`super::state::Status`] as JSON;
//! - `GET /events`: server-sent events: `reload` first (load the image again) and the status,
//!   then what [`super::batcher`] makes once for every page: `tiles` every 100 ms (a PNG of
//!   the tiles landed since, side by side on a sheet, in base64, then a line `x,y,w,h,sx,sy`
//!   per tile: where it goes and where it is on the sheet),
//!   `status` (the JSON) at most every 250 ms when it changed (`done` at the end); and `reload`
//!   again when the page fell behind and events were dropped for it;
//! - `GET /frame`: the image so far, 8-bit RGB row by row (`application/octet-stream`);
//! - `GET /image.png`: the image so far as a PNG.
//!
//! Every route is behind [`super::auth`].

use super::auth::{allowed, encode_token, needs_token};
use super::batcher::{status_event, Batcher};
use super::encode::{event, png_into};
use super::limits::{KEEP_ALIVE, MAX_STREAMS};
use super::state::LiveState;
use anyhow::Context;
use axum::body::Body;
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use bytes::Bytes;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::Arc;
use tokio::sync::{broadcast, oneshot, OwnedSemaphorePermit, Semaphore};

/// The page, served as it is.
const PAGE: &str = include_str!("page.html");

#[derive(Clone)]
struct App {
    state: Arc<LiveState>,
    token: Option<Arc<[u8]>>,
    streams: Arc<Semaphore>,
}

/// A running live view; dropping it (or [`LiveView::stop`]) stops the server.
pub struct LiveView {
    addr: SocketAddr,
    url: String,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl LiveView {
    /// Binds `addr` and serves `state` from a thread of its own, tiles at full resolution up
    /// to `full_rate` pixels a second. `token` is required from clients when `addr` is not
    /// loopback (an error without one).
    pub fn start(
        addr: &str,
        state: Arc<LiveState>,
        token: Option<&[u8]>,
        full_rate: f64,
    ) -> anyhow::Result<Self> {
        let listener = std::net::TcpListener::bind(addr)
            .with_context(|| format!("--http {addr}: cannot listen"))?;
        let bound = listener.local_addr().context("--http: no local address")?;
        listener
            .set_nonblocking(true)
            .context("--http: cannot set the socket non-blocking")?;
        let token: Option<Arc<[u8]>> = if needs_token(&bound) {
            Some(Arc::from(token.context(
                "a live view on a non-loopback address needs a token",
            )?))
        } else {
            None
        };
        let host = match bound.ip() {
            ip if ip.is_unspecified() => "localhost".to_string(),
            std::net::IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        let url = match &token {
            Some(t) => format!("http://{host}:{}/?token={}", bound.port(), encode_token(t)),
            None => format!("http://{host}:{}/", bound.port()),
        };
        let app = App {
            state,
            token,
            streams: Arc::new(Semaphore::new(MAX_STREAMS)),
        };
        let (stop_tx, stop_rx) = oneshot::channel::<()>();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .context("--http: cannot start the server's runtime")?;
        let thread = std::thread::Builder::new()
            .name("parrt-http".into())
            .spawn(move || {
                rt.block_on(async move {
                    let listener = match tokio::net::TcpListener::from_std(listener) {
                        Ok(l) => l,
                        Err(e) => {
                            tracing::warn!(error = %e, "live view: cannot serve");
                            return;
                        }
                    };
                    tokio::spawn(Batcher::new(app.state.clone(), full_rate).run());
                    let router = Router::new()
                        .route("/", get(page))
                        .route("/status", get(status))
                        .route("/events", get(events))
                        .route("/frame", get(frame))
                        .route("/image.png", get(png))
                        .layer(middleware::from_fn_with_state(app.clone(), guard))
                        .with_state(app);
                    tokio::select! {
                        r = axum::serve(listener, router) => {
                            if let Err(e) = r {
                                tracing::warn!(error = %e, "live view stopped");
                            }
                        }
                        _ = stop_rx => {}
                    }
                })
            })
            .context("--http: cannot start the server's thread")?;
        Ok(LiveView {
            addr: bound,
            url,
            stop: Some(stop_tx),
            thread: Some(thread),
        })
    }

    /// The address bound.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address (with the token when one is needed).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Stops serving and waits for the server's thread.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// 401 and nothing else unless the request may be served.
async fn guard(State(app): State<App>, req: Request, next: Next) -> Response {
    let auth = req
        .headers()
        .get(header::AUTHORIZATION)
        .map(|v| v.as_bytes());
    if allowed(app.token.as_deref(), auth, req.uri().query()) {
        next.run(req).await
    } else {
        (
            StatusCode::UNAUTHORIZED,
            [(header::WWW_AUTHENTICATE, "Bearer")],
            "401 unauthorized: this live view needs its token\n",
        )
            .into_response()
    }
}

/// The page with the status of the moment in it (so it shows something before any request
/// of its own returns). `<` is escaped so that no scene name can end the script.
async fn page(State(app): State<App>) -> Html<String> {
    let json = serde_json::to_string(&app.state.status())
        .unwrap_or_else(|_| "null".into())
        .replace('<', "\\u003c");
    Html(PAGE.replace("__STATUS__", &json))
}

async fn status(State(app): State<App>) -> Response {
    match serde_json::to_string(&app.state.status()) {
        Ok(json) => (
            [
                (header::CONTENT_TYPE, "application/json"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            json,
        )
            .into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, format!("{e}\n")).into_response(),
    }
}

async fn frame(State(app): State<App>) -> Response {
    (
        [
            (header::CONTENT_TYPE, "application/octet-stream"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        app.state.frame(),
    )
        .into_response()
}

async fn png(State(app): State<App>) -> Response {
    let s = app.state.status();
    let rgb = app.state.frame();
    let mut out = Vec::new();
    match png_into(&rgb, s.width, s.height, &mut out) {
        Ok(()) => (
            [
                (header::CONTENT_TYPE, "image/png"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            out,
        )
            .into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, format!("{e}\n")).into_response(),
    }
}

/// One page's event stream: what it is owed first (`reload`, the status), then the events the
/// batcher sends to every page, as they come, the same bytes for all.
struct Stream {
    state: Arc<LiveState>,
    events: broadcast::Receiver<Bytes>,
    queue: std::collections::VecDeque<Bytes>,
    _permit: OwnedSemaphorePermit,
}

impl Stream {
    async fn next(&mut self) -> Option<Bytes> {
        if let Some(e) = self.queue.pop_front() {
            return Some(e);
        }
        match tokio::time::timeout(KEEP_ALIVE, self.events.recv()).await {
            Err(_) => Some(Bytes::from_static(b": keep-alive\n\n")),
            Ok(Ok(e)) => Some(e),
            Ok(Err(broadcast::error::RecvError::Lagged(_))) => {
                // Events were dropped for this page: it reloads the whole image, and is told
                // the status it may have missed.
                self.queue.push_back(status_event(&self.state));
                Some(event("reload", "lagged"))
            }
            Ok(Err(broadcast::error::RecvError::Closed)) => None,
        }
    }
}

async fn events(State(app): State<App>) -> Response {
    let Ok(permit) = app.streams.clone().try_acquire_owned() else {
        return (
            StatusCode::SERVICE_UNAVAILABLE,
            "too many live pages open; close one\n",
        )
            .into_response();
    };
    // Subscribed before the page is told to fetch the frame: from now on the renderer notes
    // every tile that lands, so none falls between the two.
    let stream = Stream {
        events: app.state.subscribe(),
        queue: [event("reload", "frame"), status_event(&app.state)].into(),
        state: app.state.clone(),
        _permit: permit,
    };
    let body = futures::stream::unfold(stream, |mut s| async move {
        s.next().await.map(|e| (Ok::<_, Infallible>(e), s))
    });
    (
        [
            (header::CONTENT_TYPE, "text/event-stream"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        Body::from_stream(body),
    )
        .into_response()
}
