//! What the live view shows, kept up to date by the render's reports: its one input is the
//! runtime's [`Observer`] interface (an SMP render reports its threads as workers), plus the
//! job's description ([`LiveState::set_job`]) before it starts. Every update is a short critical
//! section: a copy into the 8-bit frame that notes which tile landed (while a page is open),
//! a few counters; the renderer never encodes, allocates or waits for a page. The server reads
//! snapshots: [`LiveState::status`] (the `/status` JSON), [`LiveState::copy_frame`] (the image
//! so far, copied in bands of rows with the frame's lock released between them, so a tile
//! waits for one band at most) and [`LiveState::take_landed`] (the tiles landed since, which
//! the batcher encodes once and sends to every page on [`LiveState::subscribe`]'s channel).

use super::frames::FrameCounts;
use super::limits::{EVENT_BACKLOG, KEPT_DEPARTED, KEPT_FAULTS, SNAPSHOT_BAND};
pub use super::status::{Fault, Phase, Status, WorkerState, WorkerStatus};
use parrt_render::film::{to_u8_into, Rgb};
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use parrt_runtime::observer::Observer;
use parrt_runtime::scheduler::WorkerId;
use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tokio::sync::broadcast;

/// The image so far, and which tiles landed in it since the pages were last sent them.
struct Frame {
    /// Image width.
    width: usize,
    /// 8-bit RGB pixels row by row (what a written PNG holds).
    rgb: Vec<u8>,
    /// Tiles landed since the last batch while a page was open. Room for every tile of the
    /// image is reserved with it, so the renderer never allocates here.
    landed: Vec<Tile>,
    /// More tiles landed than `landed` had room for: the pages reload the image instead.
    overflow: bool,
    /// The frame of a sequence this image is (0 for one frame).
    shown: usize,
}

/// The tiles landed since the last call of [`LiveState::take_landed`] (their pixels go to the
/// caller's buffer).
pub struct Landed {
    /// The tiles, in the order they landed.
    pub tiles: Vec<Tile>,
    /// More landed than were noted: the pages must reload the whole image.
    pub overflow: bool,
}

struct Inner {
    status: Status,
    created: Instant,
    started: Option<Instant>,
    finished: Option<Instant>,
    /// Which worker holds each tile in flight (distributed).
    holder: HashMap<u32, u64>,
    faults: VecDeque<Fault>,
    /// A sequence's frames (`None` for one frame).
    sequence: Option<FrameCounts>,
}

/// The shared state of one render's live view.
pub struct LiveState {
    inner: Mutex<Inner>,
    frame: Mutex<Frame>,
    version: AtomicU64,
    /// The events every open page is sent (made once by the server's batcher).
    events: broadcast::Sender<bytes::Bytes>,
    /// Told when a page subscribes (the batcher sleeps while none is open).
    opened: tokio::sync::Notify,
    /// Tiles landed in the frame so far (any snapshot that counted fewer is older).
    landed_total: AtomicU64,
    /// Times a page was told to load the whole image (it subscribed, or fell behind): a
    /// snapshot of the frame older than the last is too old to serve.
    reloads: AtomicU64,
}

/// What the page is told about the job.
#[derive(Clone, Debug)]
pub struct JobInfo {
    /// The scene's label.
    pub scene: String,
    /// `smp` or `distributed`.
    pub mode: &'static str,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile edge.
    pub tile_size: u32,
}

impl LiveState {
    /// The state of a render of `job`, before anything happened.
    pub fn new(job: JobInfo) -> Arc<Self> {
        let s = Arc::new(LiveState::empty());
        s.set_job(job);
        s
    }

    /// A state whose job is not known yet ([`Self::set_job`] tells it).
    pub fn empty() -> Self {
        let job = JobInfo {
            scene: String::new(),
            mode: "smp",
            width: 0,
            height: 0,
            tile_size: 1,
        };
        let tiles_total = 0;
        LiveState {
            inner: Mutex::new(Inner {
                status: Status {
                    scene: job.scene,
                    mode: job.mode,
                    width: job.width,
                    height: job.height,
                    tile_size: job.tile_size,
                    state: Phase::Starting,
                    tiles_total,
                    tiles_done: 0,
                    elapsed_s: 0.0,
                    eta_s: None,
                    rays: 0,
                    mrays_per_s: 0.0,
                    workers: Vec::new(),
                    faults: Vec::new(),
                    faults_total: 0,
                    requeued: 0,
                    lost: 0,
                    departed_folded: 0,
                    version: 0,
                    frame: None,
                    frames_total: None,
                    frames_done: None,
                    frames_in_flight: None,
                },
                created: Instant::now(),
                started: None,
                finished: None,
                holder: HashMap::new(),
                faults: VecDeque::new(),
                sequence: None,
            }),
            frame: Mutex::new(Frame {
                width: 0,
                rgb: Vec::new(),
                landed: Vec::new(),
                overflow: false,
                shown: 0,
            }),
            version: AtomicU64::new(0),
            events: broadcast::channel(EVENT_BACKLOG).0,
            opened: tokio::sync::Notify::new(),
            landed_total: AtomicU64::new(0),
            reloads: AtomicU64::new(0),
        }
    }

    /// Sets the job (before its first tile): its size, tiles and label.
    pub fn set_job(&self, job: JobInfo) {
        let tiles_total =
            parrt_render::tile::tiles(job.width, job.height, job.tile_size.max(1)).len();
        let pixels = (job.width as usize)
            .saturating_mul(job.height as usize)
            .saturating_mul(3);
        *self.frame.lock().unwrap_or_else(|e| e.into_inner()) = Frame {
            width: job.width as usize,
            rgb: vec![0; pixels],
            landed: Vec::with_capacity(tiles_total),
            overflow: false,
            shown: 0,
        };
        self.with(|i| {
            let s = &mut i.status;
            s.scene = job.scene;
            s.mode = job.mode;
            s.width = job.width;
            s.height = job.height;
            s.tile_size = job.tile_size;
            s.tiles_total = tiles_total;
        });
    }

    /// Sets a sequence's frames (before its first tile): frame k is `jobs[k]`. The page shows
    /// frame 0 first, then each newer frame from its first tile landed (see [`FrameCounts`]).
    pub fn set_sequence(&self, jobs: Vec<JobInfo>) {
        if let Some(first) = jobs.first() {
            self.set_job(first.clone());
        }
        self.with(|i| {
            let counts = FrameCounts::new(jobs);
            Self::count_frames(&mut i.status, &counts, 0);
            i.sequence = Some(counts);
        });
    }

    /// The status's frame fields: `shown` of `counts`.
    fn count_frames(s: &mut Status, counts: &FrameCounts, shown: usize) {
        s.frame = Some(shown);
        s.frames_total = Some(counts.total());
        s.frames_done = Some(counts.done());
        s.frames_in_flight = Some(counts.in_flight());
    }

    /// Shows frame `k` of the sequence `counts` in `f` from now on: an empty image of its size
    /// (the pages reload it), its tiles none of them in yet.
    fn show_frame(&self, f: &mut Frame, s: &mut Status, counts: &FrameCounts, k: usize) {
        let Some(job) = counts.job(k) else {
            return;
        };
        let tiles_total =
            parrt_render::tile::tiles(job.width, job.height, job.tile_size.max(1)).len();
        let pixels = (job.width as usize)
            .saturating_mul(job.height as usize)
            .saturating_mul(3);
        f.shown = k;
        f.width = job.width as usize;
        f.rgb.clear();
        f.rgb.resize(pixels, 0);
        f.landed.clear();
        f.landed.reserve(tiles_total);
        f.overflow = true;
        s.scene.clone_from(&job.scene);
        s.width = job.width;
        s.height = job.height;
        s.tile_size = job.tile_size;
        s.tiles_total = tiles_total;
        s.tiles_done = 0;
        self.reloading();
    }

    fn with<R>(&self, f: impl FnOnce(&mut Inner) -> R) -> R {
        let r = f(&mut self.inner.lock().unwrap_or_else(|e| e.into_inner()));
        self.version.fetch_add(1, Ordering::Release);
        r
    }

    /// A number that changes whenever the state does.
    pub fn version(&self) -> u64 {
        self.version.load(Ordering::Acquire)
    }

    /// The status now.
    pub fn status(&self) -> Status {
        let version = self.version();
        let i = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        let now = i.finished.unwrap_or_else(Instant::now);
        let mut s = i.status.clone();
        s.version = version;
        s.faults = i.faults.iter().cloned().collect();
        if let Some(start) = i.started {
            let el = now.saturating_duration_since(start).as_secs_f64();
            s.elapsed_s = el;
            if el > 0.0 {
                s.mrays_per_s = s.rays as f64 / el / 1e6;
            }
            s.eta_s = match s.state {
                Phase::Done => Some(0.0),
                _ if s.tiles_done > 0 => Some(
                    el * (s.tiles_total - s.tiles_done.min(s.tiles_total)) as f64
                        / s.tiles_done as f64,
                ),
                _ => None,
            };
        }
        for w in &mut s.workers {
            if let Some(r) = w.ready_at {
                let t = w
                    .end_at
                    .unwrap_or(now)
                    .saturating_duration_since(r)
                    .as_secs_f64();
                w.mrays_per_s = if t > 0.0 {
                    w.rays as f64 / t / 1e6
                } else {
                    0.0
                };
            }
        }
        s
    }

    /// The image so far (8-bit RGB), a fresh copy (see [`Self::copy_frame`]).
    pub fn frame(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.copy_frame(&mut out);
        out
    }

    /// Copies the image so far (8-bit RGB) into `out` in bands of whole rows of about
    /// [`SNAPSHOT_BAND`] bytes, taking the frame's lock for each band only, so a tile landing
    /// meanwhile waits for one band's copy at most (and may be in the copy in part: it landed
    /// after the copy began, so a page that loads it still receives the tile in an event).
    pub fn copy_frame(&self, out: &mut Vec<u8>) {
        self.copy_frame_with(out, || {});
    }

    /// [`Self::copy_frame`], calling `between` between bands with the lock released.
    pub(crate) fn copy_frame_with(&self, out: &mut Vec<u8>, mut between: impl FnMut()) {
        let (len, row) = {
            let f = self.frame.lock().unwrap_or_else(|e| e.into_inner());
            (f.rgb.len(), f.width * 3)
        };
        out.clear();
        out.resize(len, 0);
        let band = (SNAPSHOT_BAND / row.max(1)).max(1) * row.max(1);
        let mut at = 0;
        while at < len {
            if at > 0 {
                between();
            }
            let end = (at + band).min(len);
            let f = self.frame.lock().unwrap_or_else(|e| e.into_inner());
            // The frame is only replaced before the render (`set_job`); a size that changed
            // under a copy leaves the rest black.
            if let (Some(dst), Some(src)) = (out.get_mut(at..end), f.rgb.get(at..end)) {
                dst.copy_from_slice(src);
            }
            at = end;
        }
    }

    /// Tiles landed in the frame so far.
    pub fn landed_total(&self) -> u64 {
        self.landed_total.load(Ordering::Acquire)
    }

    /// Times a page was told to load the whole image so far.
    pub fn reloads(&self) -> u64 {
        self.reloads.load(Ordering::Acquire)
    }

    /// A page is about to be told to load the whole image: snapshots taken before are too old
    /// for it.
    pub fn reloading(&self) {
        self.reloads.fetch_add(1, Ordering::AcqRel);
    }

    /// Whether the render ended (the frame will not change again).
    pub fn ended(&self) -> bool {
        let i = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        matches!(i.status.state, Phase::Done | Phase::Failed)
    }

    /// The events sent to every open page (`tiles` batches, statuses), as the bytes of the
    /// event stream. A receiver that lags gets `Lagged` and should reload the frame. While
    /// one is open the renderer notes which tiles land.
    pub fn subscribe(&self) -> broadcast::Receiver<bytes::Bytes> {
        let rx = self.events.subscribe();
        self.reloading();
        self.opened.notify_one();
        rx
    }

    /// Returns once a page subscribed since the last call (at once if one did meanwhile).
    pub async fn page_opened(&self) {
        self.opened.notified().await;
    }

    /// Whether a page is open.
    pub fn watched(&self) -> bool {
        self.events.receiver_count() > 0
    }

    /// Sends `event` to every open page (lossy: with no room the oldest goes, and a page that
    /// missed it reloads).
    pub fn send(&self, event: bytes::Bytes) {
        let _ = self.events.send(event);
    }

    /// The tiles landed since the last call; their 8-bit RGB pixels, row by row, one tile after
    /// the other, replace what `rgb` held (copied under the frame's lock, a memory copy into
    /// the caller's buffer, kept from call to call; the encoding is the caller's, off the
    /// renderer's threads).
    pub fn take_landed(&self, rgb: &mut Vec<u8>) -> Landed {
        let mut f = self.frame.lock().unwrap_or_else(|e| e.into_inner());
        let f = &mut *f;
        let tiles: Vec<Tile> = f.landed.drain(..).collect();
        let overflow = std::mem::take(&mut f.overflow);
        rgb.clear();
        rgb.reserve(tiles.iter().map(|t| t.pixel_count() * 3).sum());
        for t in &tiles {
            let row = t.w as usize * 3;
            for y in 0..t.h as usize {
                let at = ((t.y as usize + y) * f.width + t.x as usize) * 3;
                match f.rgb.get(at..at + row) {
                    Some(src) => rgb.extend_from_slice(src),
                    None => rgb.resize(rgb.len() + row, 0),
                }
            }
        }
        Landed { tiles, overflow }
    }

    fn worker(i: &mut Inner, id: u64) -> Option<&mut WorkerStatus> {
        i.status.workers.iter_mut().find(|w| w.id == id)
    }

    /// A tile of frame `frame` (0 for one frame) landed, rendered by `id`: drawn when the
    /// image is of its frame (a newer frame of a sequence is shown from its first tile on).
    /// The frame's lock is held throughout, so a tile is drawn and counted in the same image.
    fn tile_done(&self, frame: usize, id: u64, tile: &Tile, pixels: &[Rgb], rays: u64) {
        let mut guard = self.frame.lock().unwrap_or_else(|e| e.into_inner());
        let f = &mut *guard;
        let drawn = self.with(|i| {
            let Inner {
                status, sequence, ..
            } = i;
            if let Some(counts) = sequence {
                counts.accepted(frame);
                if frame > f.shown {
                    self.show_frame(f, status, counts, frame);
                }
                Self::count_frames(status, counts, f.shown);
            }
            frame == f.shown
        });
        if drawn {
            let w = tile.w as usize;
            for y in 0..tile.h as usize {
                let at = ((tile.y as usize + y) * f.width + tile.x as usize) * 3;
                if let (Some(dst), Some(src)) = (
                    f.rgb.get_mut(at..at + w * 3),
                    pixels.get(y * w..(y + 1) * w),
                ) {
                    to_u8_into(dst, src.as_flattened());
                }
            }
            self.landed_total.fetch_add(1, Ordering::AcqRel);
            // Which tile landed, for the server to encode (only while a page is open).
            if pixels.len() == tile.pixel_count() && self.watched() {
                if f.landed.len() < f.landed.capacity() {
                    f.landed.push(*tile);
                } else {
                    f.overflow = true;
                }
            }
        }
        self.with(|i| {
            if drawn {
                i.status.tiles_done += 1;
            }
            i.holder.remove(&tile.id);
            i.status.rays += rays;
            if let Some(w) = Self::worker(i, id) {
                w.tiles += 1;
                w.rays += rays;
                if w.state == WorkerState::Requeued {
                    w.state = WorkerState::Rendering;
                }
            }
        });
    }

    fn fault(
        i: &mut Inner,
        kind: &'static str,
        worker: Option<String>,
        tile: Option<u32>,
        detail: String,
    ) {
        let t_s = i.created.elapsed().as_secs_f64();
        i.status.faults_total += 1;
        if i.faults.len() == KEPT_FAULTS {
            i.faults.pop_front();
        }
        i.faults.push_back(Fault {
            t_s,
            kind,
            worker,
            tile,
            detail,
        });
    }
}

/// The live view's one input: what the render reports, SMP (a worker per render thread) or
/// distributed.
impl Observer for LiveState {
    fn started(&self, _now: tokio::time::Instant) {
        self.with(|i| {
            i.started.get_or_insert_with(Instant::now);
            i.status.state = Phase::Rendering;
        });
    }

    fn joined(&self, id: WorkerId, name: &str, threads: u32, _now: tokio::time::Instant) {
        self.with(|i| {
            i.status.workers.push(WorkerStatus {
                name: name.to_string(),
                threads,
                state: WorkerState::Building,
                tiles: 0,
                rays: 0,
                mrays_per_s: 0.0,
                left: None,
                id,
                ready_at: None,
                end_at: None,
            })
        });
    }

    fn ready(&self, id: WorkerId, _now: tokio::time::Instant) {
        self.with(|i| {
            if let Some(w) = Self::worker(i, id) {
                w.state = WorkerState::Rendering;
                w.ready_at = Some(Instant::now());
            }
        });
    }

    fn assigned(
        &self,
        id: WorkerId,
        tile: &Tile,
        _attempt: u32,
        backup: bool,
        _now: tokio::time::Instant,
    ) {
        if !backup {
            let mut i = self.inner.lock().unwrap_or_else(|e| e.into_inner());
            i.holder.insert(tile.id, id);
        }
    }

    fn result(
        &self,
        id: WorkerId,
        tile: &Tile,
        pixels: &[Rgb],
        stats: &RayStats,
        seconds: f64,
        accepted: bool,
    ) {
        self.result_in(0, id, tile, pixels, stats, seconds, accepted);
    }

    fn assigned_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        attempt: u32,
        backup: bool,
        now: tokio::time::Instant,
    ) {
        self.with(|i| {
            if let Some(counts) = &mut i.sequence {
                counts.open(frame);
                let shown = i.status.frame.unwrap_or(0);
                Self::count_frames(&mut i.status, counts, shown);
            }
        });
        self.assigned(id, tile, attempt, backup, now);
    }

    fn result_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        pixels: &[Rgb],
        stats: &RayStats,
        _seconds: f64,
        accepted: bool,
    ) {
        if accepted {
            self.tile_done(frame, id, tile, pixels, stats.total_rays());
        }
    }

    fn requeued(&self, tile_id: u32) {
        self.with(|i| {
            i.status.requeued += 1;
            let holder = i.holder.remove(&tile_id);
            let name = holder.and_then(|h| {
                let w = Self::worker(i, h)?;
                if w.state != WorkerState::Lost {
                    w.state = WorkerState::Requeued;
                }
                Some(w.name.clone())
            });
            Self::fault(i, "tile-requeued", name, Some(tile_id), String::new());
        });
    }

    fn left(&self, id: WorkerId, reason: &str) {
        self.with(|i| {
            i.status.lost += 1;
            let name = Self::worker(i, id).map(|w| {
                w.state = WorkerState::Lost;
                w.left = Some(reason.to_string());
                w.end_at = Some(Instant::now());
                w.name.clone()
            });
            Self::fault(i, "worker-lost", name, None, reason.to_string());
            // Departed workers are folded as faults are: the oldest departures leave the list
            // (counted), so join-and-leave cycles cannot grow every status event.
            let departed = i
                .status
                .workers
                .iter()
                .filter(|w| w.state == WorkerState::Lost)
                .count();
            if departed > KEPT_DEPARTED {
                if let Some(at) = i
                    .status
                    .workers
                    .iter()
                    .position(|w| w.state == WorkerState::Lost)
                {
                    i.status.workers.remove(at);
                    i.status.departed_folded += 1;
                }
            }
        });
    }

    fn finished(&self, complete: bool, _now: tokio::time::Instant) {
        self.with(|i| {
            let now = Instant::now();
            i.finished = Some(now);
            i.status.state = if complete { Phase::Done } else { Phase::Failed };
            for w in &mut i.status.workers {
                w.end_at.get_or_insert(now);
                if w.state != WorkerState::Lost {
                    w.state = WorkerState::Done;
                }
            }
        });
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Reports to `s` a tile of `pixels` rendered by `id` with `rays` rays, accepted.
    pub(crate) fn land(s: &LiveState, id: WorkerId, tile: &Tile, pixels: &[Rgb], rays: u64) {
        let stats = RayStats {
            eye_rays: rays,
            ..RayStats::default()
        };
        s.result(id, tile, pixels, &stats, 0.0, true);
    }

    /// A sequence's newest frame begun is shown from its first tile: the image emptied (the
    /// pages reload it), the tile counts its own; an older frame's tiles are counted, not drawn.
    #[test]
    fn a_sequence_shows_its_newest_frame_and_counts_frames_done_and_in_flight() {
        let s = LiveState::empty();
        s.set_sequence(vec![job(), job()]);
        let tiles = parrt_render::tile::tiles(4, 2, 2);
        let (red, blue) = ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        let land_in = |frame: usize, t: &Tile, rgb: Rgb| {
            let stats = RayStats {
                eye_rays: 4,
                ..RayStats::default()
            };
            s.assigned_in(frame, 0, t, 1, false, tokio::time::Instant::now());
            s.result_in(frame, 0, t, &[rgb; 4], &stats, 0.0, true);
        };
        let counts = |s: &LiveState| {
            let v = s.status();
            (
                v.frame,
                v.frames_total,
                v.frames_done,
                v.frames_in_flight,
                v.tiles_done,
            )
        };
        assert_eq!(counts(&s), (Some(0), Some(2), Some(0), Some(0), 0));
        land_in(0, &tiles[0], red);
        assert_eq!(counts(&s), (Some(0), Some(2), Some(0), Some(1), 1));
        let reloads = s.reloads();
        land_in(1, &tiles[1], blue);
        assert_eq!(counts(&s), (Some(1), Some(2), Some(0), Some(2), 1));
        assert!(s.reloads() > reloads, "the pages reload the emptied image");
        let blue_tile = [0, 0, 0, 0, 0, 255, 0, 0, 255];
        let row = |y: usize| s.frame()[y * 12..y * 12 + 12].to_vec();
        assert_eq!(
            row(0)[..6],
            [0; 6],
            "frame 0's tile is not in frame 1's image"
        );
        assert_eq!(row(0)[6..], blue_tile[3..]);
        // Frame 0's last tile: counted done, not drawn over frame 1.
        land_in(0, &tiles[1], red);
        assert_eq!(counts(&s), (Some(1), Some(2), Some(1), Some(1), 1));
        assert_eq!(row(1)[6..], blue_tile[3..]);
        land_in(1, &tiles[0], blue);
        assert_eq!(counts(&s), (Some(1), Some(2), Some(2), Some(0), 2));
        assert_eq!(s.status().rays, 16, "every frame's rays count");
    }

    fn job() -> JobInfo {
        JobInfo {
            scene: "test".into(),
            mode: "distributed",
            width: 4,
            height: 2,
            tile_size: 2,
        }
    }

    #[test]
    fn tiles_fill_the_frame_and_counts() {
        let s = LiveState::new(job());
        let _rx = s.subscribe();
        let now = tokio::time::Instant::now();
        s.joined(7, "w", 2, now);
        s.ready(7, now);
        s.started(now);
        let tile = parrt_render::tile::tiles(4, 2, 2)[1];
        land(&s, 7, &tile, &[[1.0, 0.0, 0.0]; 4], 10);
        let f = s.frame();
        assert_eq!(&f[6..9], &[255, 0, 0]);
        assert_eq!(&f[0..3], &[0, 0, 0]);
        let st = s.status();
        assert_eq!((st.tiles_done, st.tiles_total, st.rays), (1, 2, 10));
        assert_eq!(st.workers[0].tiles, 1);
        let mut rgb = vec![9; 99];
        let landed = s.take_landed(&mut rgb);
        assert_eq!(landed.tiles, [tile]);
        assert_eq!(rgb, [255, 0, 0].repeat(4));
        assert!(!landed.overflow);
        assert!(s.take_landed(&mut rgb).tiles.is_empty(), "taken once");
        assert!(rgb.is_empty());
    }

    #[test]
    fn a_frame_copy_takes_the_lock_a_band_at_a_time() {
        // 1 024 pixels a row (3 KiB): 21 rows a 64 KiB band, 4 bands for 64 rows.
        let s = LiveState::new(JobInfo {
            scene: "test".into(),
            mode: "smp",
            width: 1024,
            height: 64,
            tile_size: 32,
        });
        let _rx = s.subscribe();
        let tiles = parrt_render::tile::tiles(1024, 64, 32);
        let mut between = 0;
        let mut out = vec![7; 5];
        s.copy_frame_with(&mut out, || {
            assert!(
                s.frame.try_lock().is_ok(),
                "the frame's lock is free between bands"
            );
            // A tile lands meanwhile, as the renderer would: it does not wait for the copy.
            land(&s, 0, &tiles[between], &[[1.0; 3]; 32 * 32], 1);
            between += 1;
        });
        assert_eq!(between, 3);
        assert_eq!(out.len(), 1024 * 64 * 3);
        assert_eq!(&out[..3], &[0, 0, 0], "the first band was copied before");
        assert_eq!(s.landed_total(), 3);
        // Every tile that landed during the copy is noted for the pages.
        assert_eq!(s.take_landed(&mut Vec::new()).tiles, tiles[..3].to_vec());
        assert_eq!(s.frame()[..3], [255, 255, 255]);
    }

    #[test]
    fn no_tile_is_noted_while_no_page_is_open() {
        let s = LiveState::new(job());
        let tile = parrt_render::tile::tiles(4, 2, 2)[0];
        land(&s, 0, &tile, &[[0.5; 3]; 4], 1);
        assert!(s.take_landed(&mut Vec::new()).tiles.is_empty());
        assert_eq!(&s.frame()[0..3], &[128, 128, 128]);
    }

    #[test]
    fn faults_mark_workers_and_are_bounded() {
        let s = LiveState::new(job());
        Observer::joined(&*s, 1, "a", 1, tokio::time::Instant::now());
        let tile = parrt_render::tile::tiles(4, 2, 2)[0];
        Observer::assigned(&*s, 1, &tile, 1, false, tokio::time::Instant::now());
        Observer::requeued(&*s, 0);
        assert_eq!(s.status().workers[0].state, WorkerState::Requeued);
        Observer::left(&*s, 1, "gone");
        for t in 0..200 {
            Observer::requeued(&*s, t);
        }
        let st = s.status();
        assert_eq!(st.workers[0].state, WorkerState::Lost);
        assert_eq!(st.faults.len(), KEPT_FAULTS);
        assert_eq!(st.faults_total, 202);
        assert_eq!(st.lost, 1);
    }

    /// Thousands of workers that join and leave leave a bounded list: the newest departures
    /// and the ones still here, the rest counted.
    #[test]
    fn departed_workers_are_folded_into_a_count() {
        let s = LiveState::new(job());
        let now = tokio::time::Instant::now();
        Observer::joined(&*s, 0, "stays", 2, now);
        for id in 1..=2000 {
            Observer::joined(&*s, id, &format!("w{id}"), 1, now);
            Observer::left(&*s, id, "gone");
        }
        let st = s.status();
        assert_eq!(st.workers.len(), 1 + KEPT_DEPARTED);
        assert_eq!(st.workers[0].name, "stays");
        assert_eq!(st.workers[1].name, format!("w{}", 2001 - KEPT_DEPARTED));
        assert_eq!(st.workers.last().unwrap().name, "w2000");
        assert_eq!(st.lost, 2000);
        assert_eq!(st.departed_folded, 2000 - KEPT_DEPARTED as u64);
    }
}
