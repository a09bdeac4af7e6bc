//! The live view (`--http`) as a client sees it: `/status` carries the documented keys and
//! agrees with the render, `/frame` is the written image, the page and the event stream are
//! served, the tiles the stream carries are the written image's pixels; on a non-loopback
//! address a missing or wrong view key gets 401 and nothing else. Its helpers serve
//! `live_guard`'s tests too.

use crate::EXE;
use parrt_worker::options::TILE_DELAY_ENV;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A `parrt render` with a live view; killed on drop.
pub(crate) struct Render {
    pub(crate) child: Child,
    /// The page's address (with its key, read from the file it printed, when it has one).
    pub(crate) url: String,
    /// `host:port` to dial.
    pub(crate) dial: String,
    /// The lines it printed on stderr up to the live view's address.
    pub(crate) printed: Vec<String>,
    /// The lines it prints on stderr, as they come.
    pub(crate) lines: std::sync::mpsc::Receiver<String>,
    /// Where it writes the file with its key: the render is killed, so it cannot remove that
    /// file itself, and this directory goes with the test instead of leaving it in /tmp.
    _key_dir: tempfile::TempDir,
}

impl Render {
    /// Waits (at most 60 s) for the line saying the image was written: the live view says
    /// `done` when the render ends, a moment before the file is there.
    pub(crate) fn written(&self) {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) if line.starts_with("parrt: wrote ") => return,
                Ok(_) => {}
                Err(e) => panic!("no `parrt: wrote` line: {e}"),
            }
        }
    }
}

impl Drop for Render {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The render `start` makes: 16 tiles of 16 pixels.
const SMALL: &[&str] = &[
    "--scene", "balls:2", "--width", "64", "--height", "64", "--tile", "16",
];

fn start(dir: &std::path::Path, extra: &[&str]) -> Render {
    start_render(dir, SMALL, extra, None)
}

/// Starts `parrt render` with `job` and `extra`; `tile_delay_ms` slows its workers' tiles.
pub(crate) fn start_render(
    dir: &std::path::Path,
    job: &[&str],
    extra: &[&str],
    tile_delay_ms: Option<u64>,
) -> Render {
    let mut cmd = Command::new(EXE);
    cmd.arg("render")
        .args(job)
        .args(["--threads", "2", "--http-linger", "60", "-o"])
        .arg(dir.join("out.png"))
        .args(extra);
    start_command(cmd, tile_delay_ms)
}

/// Starts `cmd` (a `parrt` with `--http`), reading its stderr until it tells the live view's
/// address; `tile_delay_ms` slows its workers' tiles.
pub(crate) fn start_command(mut cmd: Command, tile_delay_ms: Option<u64>) -> Render {
    let key_dir = tempfile::tempdir().expect("a directory for the key's file");
    cmd.env("XDG_RUNTIME_DIR", key_dir.path())
        .env_remove(TILE_DELAY_ENV)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    if let Some(ms) = tile_delay_ms {
        cmd.env(TILE_DELAY_ENV, ms.to_string());
    }
    let mut child = cmd.spawn().expect("parrt starts");
    let stderr = child.stderr.take().expect("stderr");
    let (tx, rx) = std::sync::mpsc::channel();
    // Owned (killed on drop) before anything below can fail.
    let mut r = Render {
        child,
        url: String::new(),
        dial: String::new(),
        printed: Vec::new(),
        lines: rx,
        _key_dir: key_dir,
    };
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let line = r
            .lines
            .recv_timeout(left)
            .expect("the live view's address is printed");
        r.printed.push(line.clone());
        if let Some(said) = line.strip_prefix("parrt: live view at ") {
            let mut url = said.split(' ').next().expect("an address").to_string();
            // Off a terminal the key is not printed: the address with it is in a file.
            if let Some((_, file)) = said.split_once(" the address with it is in ") {
                let file = file.split(", readable").next().expect("a path");
                url = std::fs::read_to_string(file)
                    .expect("the address's file")
                    .trim()
                    .to_string();
            }
            let port = url
                .trim_start_matches("http://")
                .split(['/', '?'])
                .next()
                .and_then(|hp| hp.rsplit(':').next())
                .expect("a port")
                .to_string();
            r.url = url;
            r.dial = format!("127.0.0.1:{port}");
            return r;
        }
    }
}

/// The view key in a page's address.
pub(crate) fn key_of(url: &str) -> String {
    url.split("key=")
        .nth(1)
        .expect("the address carries a key")
        .to_string()
}

/// One GET: the status code, the headers and the body.
pub(crate) fn get(dial: &str, path: &str, auth: Option<&str>) -> (u16, String, Vec<u8>) {
    get_as(dial, dial, path, auth)
}

/// One GET with `Host: host`: the status code, the headers and the body.
pub(crate) fn get_as(
    dial: &str,
    host: &str,
    path: &str,
    auth: Option<&str>,
) -> (u16, String, Vec<u8>) {
    let mut s = TcpStream::connect(dial).expect("connects");
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let auth = auth
        .map(|a| format!("Authorization: {a}\r\n"))
        .unwrap_or_default();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n{auth}\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    let _ = s.read_to_end(&mut raw);
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a response head");
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let code = head
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .expect("a status code");
    (code, head, raw[split + 4..].to_vec())
}

/// The first bytes of the event stream.
pub(crate) fn events_start(dial: &str, q: &str) -> String {
    events_until_done(dial, q, Duration::from_secs(5))
}

/// The event stream until its `done` event (or `wait`).
fn events_until_done(dial: &str, q: &str, wait: Duration) -> String {
    let mut s = TcpStream::connect(dial).expect("connects");
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(s, "GET /events{q} HTTP/1.1\r\nHost: {dial}\r\n\r\n").unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 65536];
    let deadline = Instant::now() + wait;
    while Instant::now() < deadline && !String::from_utf8_lossy(&got).contains("event: done") {
        match s.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => got.extend_from_slice(&buf[..n]),
        }
    }
    String::from_utf8_lossy(&got).to_string()
}

pub(crate) fn status_when_done(dial: &str, auth: Option<&str>) -> serde_json::Value {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let (code, _, body) = get(dial, "/status", auth);
        assert_eq!(code, 200);
        let v: serde_json::Value = serde_json::from_slice(&body).expect("JSON");
        if v["state"] == "done" || Instant::now() > deadline {
            return v;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn status_frame_page_and_events_on_loopback() {
    let dir = tempfile::tempdir().unwrap();
    let r = start(dir.path(), &["--http", "127.0.0.1:0"]);
    assert!(!r.url.contains("key"), "loopback needs no key: {}", r.url);
    let v = status_when_done(&r.dial, None);
    for key in [
        "scene",
        "mode",
        "width",
        "height",
        "tile_size",
        "state",
        "tiles_total",
        "tiles_done",
        "elapsed_s",
        "eta_s",
        "rays",
        "mrays_per_s",
        "workers",
        "faults",
        "faults_total",
        "requeued",
        "lost",
        "version",
    ] {
        assert!(v.get(key).is_some(), "/status lacks {key}: {v}");
    }
    assert_eq!(v["state"], "done");
    assert_eq!(v["mode"], "smp");
    assert_eq!(
        (v["width"].as_u64(), v["height"].as_u64()),
        (Some(64), Some(64))
    );
    assert_eq!(v["tiles_total"], 16);
    assert_eq!(v["tiles_done"], 16);
    assert_eq!(v["eta_s"], 0.0);
    let workers = v["workers"].as_array().expect("workers");
    assert_eq!(workers.len(), 2, "a row per render thread: {v}");
    let mut tiles = 0;
    for w in workers {
        for key in [
            "name",
            "threads",
            "state",
            "tiles",
            "rays",
            "mrays_per_s",
            "left",
        ] {
            assert!(w.get(key).is_some(), "worker row lacks {key}: {w}");
        }
        assert_eq!(w["state"], "done");
        tiles += w["tiles"].as_u64().unwrap();
    }
    assert_eq!(tiles, 16);
    assert!(v["rays"].as_u64().unwrap() >= 64 * 64);

    // The frame is the written image, byte for byte.
    r.written();
    let (code, _, frame) = get(&r.dial, "/frame", None);
    assert_eq!(code, 200);
    let png = image::open(dir.path().join("out.png")).unwrap().to_rgb8();
    assert_eq!(frame, png.into_raw());
    let (code, head, body) = get(&r.dial, "/image.png", None);
    assert_eq!(code, 200);
    assert!(head.to_ascii_lowercase().contains("image/png"), "{head}");
    assert!(image::load_from_memory(&body).is_ok());
    let (code, _, page) = get(&r.dial, "/", None);
    assert_eq!(code, 200);
    let page = String::from_utf8_lossy(&page);
    assert!(page.contains("<canvas") && page.contains("EventSource"));
    // The stream starts by asking for the frame, then reports the finished render.
    let ev = events_start(&r.dial, "");
    let reload = ev.find("event: reload").expect("a reload event");
    let done = ev.find("event: done").expect("a done event");
    assert!(reload < done, "{ev}");
}

#[test]
fn off_loopback_a_missing_or_wrong_key_gets_401_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let r = start(dir.path(), &["--http", "0.0.0.0:0"]);
    let key = key_of(&r.url);
    assert!(key.len() >= 32);
    for path in ["/status", "/", "/frame", "/image.png", "/events"] {
        for auth in [None, Some("Bearer wrong"), Some(&*format!("Basic {key}"))] {
            let (code, _, body) = get(&r.dial, path, auth);
            assert_eq!(code, 401, "{path} {auth:?}");
            let body = String::from_utf8_lossy(&body);
            assert!(
                !body.contains("tiles_total") && !body.contains("<canvas"),
                "{body}"
            );
        }
        let (code, _, _) = get(&r.dial, &format!("{path}?key=wrong{key}"), None);
        assert_eq!(code, 401, "{path} with a wrong parameter");
    }
    let v = status_when_done(&r.dial, Some(&format!("Bearer {key}")));
    assert_eq!(v["tiles_done"], 16);
    let (code, _, body) = get(&r.dial, &format!("/status?key={key}"), None);
    assert_eq!(code, 200);
    assert!(String::from_utf8_lossy(&body).contains("tiles_total"));
    let ev = events_start(&r.dial, &format!("?key={key}"));
    assert!(ev.contains("event: reload"), "{ev}");
}

#[test]
fn distributed_render_shows_a_row_per_worker() {
    let dir = tempfile::tempdir().unwrap();
    let r = start(dir.path(), &["--workers", "2", "--http", "127.0.0.1:0"]);
    let v = status_when_done(&r.dial, None);
    assert_eq!(v["state"], "done");
    assert_eq!(v["mode"], "distributed");
    let workers = v["workers"].as_array().expect("workers");
    assert_eq!(workers.len(), 2, "{v}");
    let tiles: u64 = workers.iter().map(|w| w["tiles"].as_u64().unwrap()).sum();
    assert_eq!(tiles, 16);
    r.written();
    let (_, _, frame) = get(&r.dial, "/frame", None);
    let png = image::open(dir.path().join("out.png")).unwrap().to_rgb8();
    assert_eq!(frame, png.into_raw());
}

/// A 3-frame orbit through the live view, on this machine's threads and through 2 workers: the
/// page ends on the last frame, every frame counted done, its tile counts the frame's own, its
/// image the last frame written; the rows are the render threads or the workers.
#[test]
fn a_sequence_shows_its_newest_frame_and_counts_the_frames() {
    for (mode, extra) in [
        ("smp", &["--threads", "2"][..]),
        ("distributed", &["--workers", "2"]),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let mut cmd = Command::new(EXE);
        cmd.arg("render")
            .args(SMALL)
            .args(["--orbit", "90", "--frames", "3", "--http", "127.0.0.1:0"])
            .args(["--http-linger", "60", "-o"])
            .arg(dir.path().join("f-%d.png"))
            .args(extra);
        let r = start_command(cmd, None);
        let v = status_when_done(&r.dial, None);
        assert_eq!(v["state"], "done", "{mode}: {v}");
        assert_eq!(v["mode"], mode);
        assert_eq!(
            (
                &v["frame"],
                &v["frames_total"],
                &v["frames_done"],
                &v["frames_in_flight"]
            ),
            (&2.into(), &3.into(), &3.into(), &0.into()),
            "{mode}: {v}"
        );
        assert_eq!(
            (&v["tiles_done"], &v["tiles_total"]),
            (&16.into(), &16.into())
        );
        assert!(
            v["scene"].as_str().unwrap().starts_with("frame 2 of "),
            "{v}"
        );
        let rows = v["workers"].as_array().expect("workers");
        assert_eq!(rows.len(), 2, "{mode}: {v}");
        let tiles: u64 = rows.iter().map(|w| w["tiles"].as_u64().unwrap()).sum();
        assert_eq!(
            tiles,
            3 * 16,
            "{mode}: every frame's tiles, by thread or worker"
        );
        let (code, _, frame) = get(&r.dial, "/frame", None);
        assert_eq!(code, 200);
        let last = image::open(dir.path().join("f-2.png")).unwrap().to_rgb8();
        assert_eq!(
            frame,
            last.into_raw(),
            "{mode}: the image is the last frame"
        );
        let first = image::open(dir.path().join("f-0.png")).unwrap().to_rgb8();
        assert_ne!(frame, first.into_raw(), "{mode}: the orbit turned");
    }
}

#[test]
fn bad_http_flags_are_usage_errors() {
    for args in [
        &["--http", "not an address"][..],
        &["--http", "127.0.0.1:0", "--http-linger", "-1"][..],
        &["--http-linger", "5"][..],
        &["--http", "127.0.0.1:0", "--http-full-rate", "0"][..],
        &["--http", "127.0.0.1:0", "--http-full-rate", "nan"][..],
        &["--http-full-rate", "2"][..],
    ] {
        let out = Command::new(EXE)
            .args([
                "render", "--scene", "balls:1", "--width", "8", "--height", "8", "-o",
            ])
            .arg(std::env::temp_dir().join("parrt-live-unused.png"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// The body of a chunked HTTP response (its head and chunk sizes dropped).
fn dechunk(raw: &str) -> String {
    let (_, mut rest) = raw.split_once("\r\n\r\n").expect("a response head");
    let mut out = String::new();
    while let Some((size, after)) = rest.split_once("\r\n") {
        let n = usize::from_str_radix(size, 16).expect("a chunk size");
        let Some(chunk) = after.get(..n) else {
            break;
        };
        out.push_str(chunk);
        rest = after.get(n + 2..).unwrap_or("");
    }
    out
}

/// Standard base64 back to bytes.
fn unbase64(s: &str) -> Vec<u8> {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let v = |c: u8| ALPHABET.iter().position(|&a| a == c).expect("base64") as u32;
    let mut out = Vec::new();
    for chunk in s.trim_end_matches('=').as_bytes().chunks(4) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0, |n, (i, &c)| n | v(c) << (18 - 6 * i));
        out.extend_from_slice(&n.to_be_bytes()[1..chunk.len()]);
    }
    out
}

#[test]
fn tiles_events_carry_the_written_pixels() {
    // 12 288 pixels in about half a second: far under the full rate, every tile at full
    // resolution.
    let scales = tiles_events_against_the_written_image(&[]);
    assert_eq!(scales.keys().copied().collect::<Vec<_>>(), [1]);
}

#[test]
fn tiles_landing_faster_than_the_full_rate_carry_block_means() {
    // 100 pixels a second at full resolution, 10 a 100-ms tick: one 16 × 16 tile (256 pixels)
    // is already 16 at scale 4, so every tile goes at scale 8 (4 at a late tick), as block
    // means.
    let scales = tiles_events_against_the_written_image(&["--http-full-rate", "0.0001"]);
    assert!(
        !scales.contains_key(&1) && !scales.is_empty(),
        "every tile coarse: {scales:?}"
    );
}

/// Renders balls:2 at 128 × 96 on two workers with `--http` and `extra`, reads the event stream
/// from before the first tile to the end, and checks every tile of every `tiles` event against
/// the written PNG: the same pixels at scale 1, the means of the PNG's `s` × `s` blocks (cut at
/// the tile's edges, rounded half up) at scale `s`. Returns how many tiles went at each scale.
fn tiles_events_against_the_written_image(
    extra: &[&str],
) -> std::collections::BTreeMap<u32, usize> {
    let dir = tempfile::tempdir().unwrap();
    // Two workers: the stream is open while they start, before the first tile lands. Their
    // 48 tiles take at least 40 ms each on 4 threads: the render lasts half a second after
    // they start, so a client slowed by a loaded machine still connects before its end.
    let job = [
        "--scene", "balls:2", "--width", "128", "--height", "96", "--tile", "16", "--spp", "4",
    ];
    let mut flags = vec!["--workers", "2", "--http", "127.0.0.1:0"];
    flags.extend_from_slice(extra);
    let r = start_render(dir.path(), &job, &flags, Some(40));
    let ev = events_until_done(&r.dial, "", Duration::from_secs(60));
    assert!(ev.contains("event: done"), "the stream reports the end");
    let ev = dechunk(&ev);
    r.written();
    let png = image::open(dir.path().join("out.png")).unwrap().to_rgb8();
    let mut seen = std::collections::BTreeSet::new();
    let mut scales = std::collections::BTreeMap::new();
    let mut first_state = None;
    for e in ev.split("\n\n") {
        let mut lines = e.lines();
        match lines.next() {
            Some("event: tiles") => {}
            Some("event: status") | Some("event: done") => {
                if first_state.is_none() {
                    let json = lines.next().and_then(|l| l.strip_prefix("data: "));
                    let v: serde_json::Value = serde_json::from_str(json.expect("data")).unwrap();
                    first_state = Some(v["state"].as_str().unwrap_or("").to_string());
                }
                continue;
            }
            _ => continue,
        }
        // A PNG of a sheet of the tiles, then where each goes and where it is on the sheet.
        let sheet = lines.next().and_then(|l| l.strip_prefix("data: "));
        let sheet = image::load_from_memory(&unbase64(sheet.expect("the PNG")))
            .expect("a PNG")
            .to_rgb8();
        for line in lines {
            let p: Vec<u32> = line
                .strip_prefix("data: ")
                .expect("data")
                .split(',')
                .map(|n| n.parse().expect("a number"))
                .collect();
            let (x, y, w, h, sx, sy, s) = match p[..] {
                [x, y, w, h, sx, sy] => (x, y, w, h, sx, sy, 1),
                [x, y, w, h, sx, sy, s] if s > 1 => (x, y, w, h, sx, sy, s),
                _ => panic!("x,y,w,h,sx,sy[,scale]: {line}"),
            };
            let (cw, ch) = (w.div_ceil(s), h.div_ceil(s));
            assert!(
                sx + cw <= sheet.width() && sy + ch <= sheet.height(),
                "tile at {x},{y} is on the sheet"
            );
            let tile = image::imageops::crop_imm(&sheet, sx, sy, cw, ch).to_image();
            let want = image::RgbImage::from_fn(cw, ch, |bx, by| {
                let (x0, y0) = (x + bx * s, y + by * s);
                let (x1, y1) = ((x0 + s).min(x + w), (y0 + s).min(y + h));
                let n = (x1 - x0) * (y1 - y0);
                let mut sum = [0u32; 3];
                for py in y0..y1 {
                    for px in x0..x1 {
                        for (c, v) in png.get_pixel(px, py).0.iter().enumerate() {
                            sum[c] += u32::from(*v);
                        }
                    }
                }
                image::Rgb(sum.map(|v| ((v + n / 2) / n) as u8))
            });
            assert!(
                tile == want,
                "tile at {x},{y} (scale {s}) differs from the written image"
            );
            seen.insert((x, y));
            *scales.entry(s).or_insert(0) += 1;
        }
    }
    assert!(
        !seen.is_empty(),
        "no tiles event: {}",
        &ev[..ev.len().min(2000)]
    );
    if first_state.as_deref() == Some("starting") {
        assert_eq!(seen.len(), 8 * 6, "open from the start, every tile is sent");
    }
    scales
}
