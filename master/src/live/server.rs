//! The live view's HTTP server: axum routes served by hyper on a thread and current-thread
//! runtime of its own (so no page, however slow, shares a thread with the render), serving
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
//! Every route is behind [`super::auth`] (the `Host` check, then the key). Its own accept loop
//! puts every connection through [`super::gate`] (a cap on connections and on event streams
//! that never refuses a newcomer for the stuck ones) and gives each [`HEAD_TIMEOUT`] to send
//! a request's head, of at most [`super::head_limit::MAX_REQUEST_HEAD`] bytes; `/frame` and `/image.png` send [`super::snapshot`]'s shared snapshot.

use super::auth::{allowed, encode_key, host_allowed, hosts};
use super::batcher::{status_event, Batcher};
use super::encode::event;
use super::gate::{Conn, Gate, StreamSlot};
use super::head_limit::too_large;
use super::limits::{
    HEAD_TIMEOUT, KEEP_ALIVE, MAX_CONNECTIONS, MAX_STREAMS, RESPONSE_BUFFER, SEND_CHUNK,
};
use super::snapshot::{Lease, Snapshots};
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
use tokio::sync::{broadcast, oneshot};

/// The page, served as it is.
const PAGE: &str = include_str!("page.html");

#[derive(Clone)]
struct App {
    state: Arc<LiveState>,
    /// The view key a request must carry (`None` on loopback).
    key: Option<Arc<[u8]>>,
    /// The `Host` values served (`None`: any, the key being required).
    hosts: Option<Arc<[String]>>,
    snapshots: Arc<Snapshots>,
}

/// A running live view; dropping it (or [`LiveView::stop`]) stops the server.
pub struct LiveView {
    addr: SocketAddr,
    base: String,
    url: String,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl LiveView {
    /// Binds `addr` and serves `state` from a thread of its own, tiles at full resolution up
    /// to `full_rate` pixels a second. `key` (the view key, [`super::auth::view_key`]) is
    /// required from clients when `addr` is not loopback (an error without one).
    pub fn start(
        addr: &str,
        state: Arc<LiveState>,
        key: Option<&[u8]>,
        full_rate: f64,
    ) -> anyhow::Result<Self> {
        let listener = std::net::TcpListener::bind(addr)
            .with_context(|| format!("--http {addr}: cannot listen"))?;
        let bound = listener.local_addr().context("--http: no local address")?;
        listener
            .set_nonblocking(true)
            .context("--http: cannot set the socket non-blocking")?;
        let hosts = hosts(&bound);
        let key: Option<Arc<[u8]>> = if hosts.is_none() {
            Some(Arc::from(key.context(
                "a live view on a non-loopback address needs a key",
            )?))
        } else {
            None
        };
        let host = match bound.ip() {
            ip if ip.is_unspecified() => "localhost".to_string(),
            std::net::IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        let base = format!("http://{host}:{}/", bound.port());
        let url = match &key {
            Some(k) => format!("{base}?key={}", encode_key(k)),
            None => base.clone(),
        };
        let app = App {
            snapshots: Arc::new(Snapshots::new(state.clone())),
            state,
            key,
            hosts: hosts.map(Arc::from),
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
                        () = serve(listener, router, Gate::new(MAX_CONNECTIONS, MAX_STREAMS)) => {}
                        _ = stop_rx => {}
                    }
                })
            })
            .context("--http: cannot start the server's thread")?;
        Ok(LiveView {
            addr: bound,
            base,
            url,
            stop: Some(stop_tx),
            thread: Some(thread),
        })
    }

    /// The address bound.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address (with the key when one is needed).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The page's address without the key.
    pub fn base_url(&self) -> &str {
        &self.base
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

/// Accepts connections until the runtime stops, each through `gate` (a connection it closes
/// for another ends at once) and given [`HEAD_TIMEOUT`] for each request's head.
async fn serve(listener: tokio::net::TcpListener, router: Router, gate: Arc<Gate>) {
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(hyper_util::rt::TokioTimer::new())
        .header_read_timeout(HEAD_TIMEOUT)
        .max_buf_size(RESPONSE_BUFFER);
    loop {
        let stream = match listener.accept().await {
            Ok((stream, _)) => stream,
            Err(e) => {
                // Out of descriptors, most likely: wait rather than spin.
                tracing::debug!(error = %e, "live view: accept failed");
                tokio::time::sleep(std::time::Duration::from_millis(50)).await;
                continue;
            }
        };
        let Some(ticket) = gate.admit() else {
            continue;
        };
        let conn = ticket.conn();
        let router = router.clone();
        let service = hyper::service::service_fn(move |mut req: hyper::Request<_>| {
            req.extensions_mut().insert(conn.clone());
            let mut router = router.clone();
            async move { tower_service::Service::call(&mut router, req.map(Body::new)).await }
        });
        let serving = http.serve_connection(hyper_util::rt::TokioIo::new(stream), service);
        tokio::spawn(async move {
            tokio::select! {
                _ = serving => {}
                () = ticket.closed() => {}
            }
            drop(ticket);
        });
    }
}

/// 431 for a head longer than [`super::head_limit::MAX_REQUEST_HEAD`]; then 421 unless the
/// `Host` names this view (loopback), then 401 and nothing else unless the
/// request carries the key (elsewhere).
async fn guard(State(app): State<App>, req: Request, next: Next) -> Response {
    if let Some(refused) = too_large(&req) {
        return refused;
    }
    let host = req.headers().get(header::HOST).map(|v| v.as_bytes());
    if !host_allowed(app.hosts.as_deref(), host) {
        return (
            StatusCode::MISDIRECTED_REQUEST,
            format!(
                "421 misdirected request: this live view answers only to Host {}\n",
                app.hosts.as_deref().unwrap_or_default().join(" or ")
            ),
        )
            .into_response();
    }
    let auth = req
        .headers()
        .get(header::AUTHORIZATION)
        .map(|v| v.as_bytes());
    if allowed(app.key.as_deref(), auth, req.uri().query()) {
        if let Some(c) = req.extensions().get::<Conn>() {
            c.served();
        }
        next.run(req).await
    } else {
        (
            StatusCode::UNAUTHORIZED,
            [(header::WWW_AUTHENTICATE, "Bearer")],
            "401 unauthorized: this live view needs its key\n",
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

/// 503 for an image asked for while [`super::limits::MAX_IMAGE_RESPONSES`] are being sent.
fn busy() -> Response {
    (
        StatusCode::SERVICE_UNAVAILABLE,
        [(header::RETRY_AFTER, "1")],
        "503: the image is being sent to as many clients as it may be; try again\n",
    )
        .into_response()
}

/// `bytes` (part of `lease`'s snapshot) as a body sent in copied chunks of [`SEND_CHUNK`]: the
/// connection buffers a chunk, never the snapshot, and the lease (the snapshot and its place)
/// is let go once the last chunk is taken.
fn leased_body(lease: Lease, bytes: Bytes, content_type: &'static str) -> Response {
    let len = bytes.len();
    let chunks = futures::stream::unfold(Some((lease, 0usize)), move |held| {
        let bytes = bytes.clone();
        async move {
            let (lease, at) = held?;
            let end = (at + SEND_CHUNK).min(bytes.len());
            let chunk = Bytes::copy_from_slice(bytes.get(at..end)?);
            let next = (end < bytes.len()).then_some((lease, end));
            Some((Ok::<_, Infallible>(chunk), next))
        }
    });
    (
        [
            (header::CONTENT_TYPE, content_type.to_string()),
            (header::CACHE_CONTROL, "no-store".to_string()),
            (header::CONTENT_LENGTH, len.to_string()),
        ],
        Body::from_stream(chunks),
    )
        .into_response()
}

async fn frame(State(app): State<App>) -> Response {
    let Some(lease) = app.snapshots.lease() else {
        return busy();
    };
    let rgb = lease.snapshot.rgb.clone();
    leased_body(lease, rgb, "application/octet-stream")
}

async fn png(State(app): State<App>) -> Response {
    let Some(lease) = app.snapshots.lease() else {
        return busy();
    };
    match lease.snapshot.png().await {
        Ok(png) => leased_body(lease, png, "image/png"),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, format!("{e}\n")).into_response(),
    }
}

/// One page's event stream: what it is owed first (`reload`, the status), then the events the
/// batcher sends to every page, as they come, the same bytes for all.
struct Stream {
    state: Arc<LiveState>,
    events: broadcast::Receiver<Bytes>,
    queue: std::collections::VecDeque<Bytes>,
    /// Its place among the streams (`None` when served outside the gate).
    slot: Option<StreamSlot>,
}

impl Stream {
    async fn next(&mut self) -> Option<Bytes> {
        if let Some(s) = &self.slot {
            s.took();
        }
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
                self.state.reloading();
                Some(event("reload", "lagged"))
            }
            Ok(Err(broadcast::error::RecvError::Closed)) => None,
        }
    }
}

async fn events(State(app): State<App>, req: Request) -> Response {
    // Past the cap, the stalest stream's connection is closed for this one: a page is never
    // refused for streams that others hold.
    let slot = match req.extensions().get::<Conn>() {
        Some(c) => match c.open_stream() {
            Some(s) => Some(s),
            None => return StatusCode::SERVICE_UNAVAILABLE.into_response(),
        },
        None => None,
    };
    // Subscribed before the page is told to fetch the frame: from now on the renderer notes
    // every tile that lands, so none falls between the two.
    let stream = Stream {
        events: app.state.subscribe(),
        queue: [event("reload", "frame"), status_event(&app.state)].into(),
        state: app.state.clone(),
        slot,
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
