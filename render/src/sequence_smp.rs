//! A sequence rendered on this machine's threads with a window of frames in flight. The threads
//! take tiles from one queue that spans frames: when frame k has no tile left to hand out, the
//! next frame is opened (its renderer built by the thread that opens it, while the others
//! finish frame k), so frame k+1's tiles fill the tail of frame k. At most `window` frames are
//! alive at once — opened, being rendered or being written — so the films take at most
//! `window × width × height × 12` bytes (three `f32` a pixel), or `× 3` with 8-bit films for an
//! 8-bit output ([`SequenceOptions::rgb8`]), besides each frame's renderer.
//!
//! Each frame is handed to `write` by the thread that finished its last tile, as soon as it is
//! finished: frames may complete out of order, and each is written exactly once. Frame 0's
//! tiles go out in the executor's usual order (row by row for `queue` and `rayon`, Morton order
//! for `morton` and `guided`); every later frame's tiles go out costliest first by the latest
//! measured time of each tile (the previous frame's, where it has finished), when the frames
//! have the same size. The order never changes a pixel: each frame is the same bits as
//! rendering it alone, whatever the threads, tile size, executor or window.

use crate::film::{Film, Rgb};
use crate::render::Renderer;
use crate::smp::{morton_order, Executor, TileSpan};
use crate::stats::RayStats;
use crate::tile::{tiles, Tile};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

/// Options of a sequence render on this machine.
#[derive(Clone, Copy, Debug)]
pub struct SequenceOptions {
    /// Render threads (at least 1).
    pub threads: usize,
    /// Tile edge in pixels.
    pub tile: u32,
    /// Frame 0's tile order (later frames go costliest first); tiles are handed out one at a
    /// time whatever the executor.
    pub executor: Executor,
    /// Most frames alive at once (at least 1).
    pub window: usize,
    /// Films of 8-bit RGB ([`Film::new_rgb8`]), for outputs that keep no more (PNG, PPM): a
    /// quarter of the memory, and the same file bytes.
    pub rgb8: bool,
}

/// Bytes a linear film takes a pixel (three `f32`).
pub const FILM_BYTES_PER_PIXEL: u64 = 12;

/// A finished frame, as `write` receives it.
#[derive(Debug)]
pub struct FrameDone {
    /// The frame's index in the sequence.
    pub index: usize,
    /// Its image.
    pub film: Film,
    /// Its ray statistics.
    pub stats: RayStats,
    /// Seconds each of its tiles took, by tile id.
    pub tile_seconds: Vec<f64>,
}

/// One finished tile of a sequence, as `on_tile` receives it (after it is in its frame's film).
pub struct SequenceTile<'a> {
    /// The tile's frame.
    pub frame: usize,
    /// The tile.
    pub tile: &'a Tile,
    /// Its pixels, row by row.
    pub pixels: &'a [Rgb],
    /// Its ray statistics.
    pub stats: &'a RayStats,
    /// When (from the start of the sequence) and on which thread it was rendered.
    pub span: TileSpan,
}

/// What a sequence render did.
#[derive(Debug, Default)]
pub struct SequenceResult {
    /// Frames written.
    pub frames: usize,
    /// Tiles rendered.
    pub tiles: usize,
    /// Ray statistics summed over every frame written.
    pub stats: RayStats,
    /// Wall time from the first frame's opening to the last frame's writing.
    pub wall_s: f64,
    /// Most frames that were alive at once.
    pub most_alive: usize,
    /// True when `stop` ended the render early (the frames written are complete).
    pub stopped: bool,
}

/// A frame in flight: its renderer, the tiles still to hand out, and its film.
struct Open {
    index: usize,
    /// Width, height and tile edge: which frames' tile costs order this one's successors.
    key: (u32, u32, u32),
    renderer: Arc<Renderer>,
    order: Vec<Tile>,
    next: usize,
    left: usize,
    film: Film,
    stats: RayStats,
    seconds: Vec<f64>,
}

/// The latest measured seconds of each tile, by tile id, for images of one width, height and
/// tile edge (the key): what orders the next frame's tiles.
type TileCosts = Option<((u32, u32, u32), Vec<f64>)>;

/// The queue spanning frames, under one lock.
struct State<E> {
    /// The next frame to open.
    next_frame: usize,
    /// Frames in flight, in frame order.
    open: Vec<Open>,
    /// Frames being built or written (alive, but not in `open`).
    elsewhere: usize,
    /// Latest measured seconds of each tile, for images of this width, height and tile size.
    costs: TileCosts,
    failed: Option<E>,
    result: SequenceResult,
}

impl<E> State<E> {
    fn alive(&self) -> usize {
        self.open.len() + self.elsewhere
    }

    /// What a thread does next, of `frames` frames with at most `window` alive: the next tile
    /// of the oldest open frame with tiles left, else open the next frame if the window has
    /// room, else wait for a frame to open or finish, or end (stopped, failed or all done).
    fn next_step(&mut self, frames: usize, window: usize, stop: &AtomicBool) -> Step {
        if stop.load(Ordering::Relaxed) || self.failed.is_some() {
            return Step::Done;
        }
        if let Some(f) = self.open.iter_mut().find(|f| f.next < f.order.len()) {
            let tile = f.order[f.next];
            f.next += 1;
            return Step::Tile(f.index, f.renderer.clone(), tile);
        }
        if self.next_frame < frames && self.alive() < window {
            let k = self.next_frame;
            self.next_frame += 1;
            self.elsewhere += 1;
            let alive = self.alive();
            self.result.most_alive = self.result.most_alive.max(alive);
            return Step::Open(k);
        }
        if self.next_frame >= frames && self.open.is_empty() {
            Step::Done
        } else {
            Step::Wait
        }
    }
}

/// What a thread does next.
enum Step {
    Tile(usize, Arc<Renderer>, Tile),
    Open(usize),
    Wait,
    Done,
}

/// Renders `frames` frames: `build(k)` makes frame k's renderer, `write` receives each
/// finished frame (once, as soon as it is finished), `on_tile` each finished tile. Stops at
/// the first error of `build` or `write` (returned; frames already written stay) or when
/// `stop` is set (frames in flight are dropped; [`SequenceResult::stopped`]).
pub fn render_sequence<E: Send>(
    frames: usize,
    opts: &SequenceOptions,
    build: &(dyn Fn(usize) -> Result<Renderer, E> + Sync),
    write: &(dyn Fn(FrameDone) -> Result<(), E> + Sync),
    on_tile: &(dyn Fn(SequenceTile<'_>) + Sync),
    stop: &AtomicBool,
) -> Result<SequenceResult, E> {
    let window = opts.window.max(1);
    let state = Mutex::new(State {
        next_frame: 0,
        open: Vec::new(),
        elsewhere: 0,
        costs: None,
        failed: None,
        result: SequenceResult::default(),
    });
    let changed = Condvar::new();
    let start = Instant::now();
    let lock = || state.lock().unwrap_or_else(|e| e.into_inner());
    let work = |thread: usize| {
        let mut buf: Vec<Rgb> = Vec::new();
        let mut st = lock();
        loop {
            match st.next_step(frames, window, stop) {
                Step::Done => {
                    changed.notify_all();
                    return;
                }
                Step::Wait => {
                    // A frame opening or finishing wakes the waiters; the timeout only guards
                    // against a stop flag set from a signal handler, which cannot notify.
                    st = changed
                        .wait_timeout(st, std::time::Duration::from_millis(100))
                        .map(|(g, _)| g)
                        .unwrap_or_else(|e| e.into_inner().0);
                }
                Step::Open(k) => {
                    drop(st);
                    let built = build(k);
                    st = lock();
                    st.elsewhere -= 1;
                    match built {
                        Ok(r) => {
                            let opened = open(k, r, opts, &st.costs);
                            let at = st.open.partition_point(|f| f.index < k);
                            st.open.insert(at, opened);
                        }
                        Err(e) => {
                            st.failed.get_or_insert(e);
                        }
                    }
                    changed.notify_all();
                }
                Step::Tile(k, renderer, tile) => {
                    drop(st);
                    let start_s = start.elapsed().as_secs_f64();
                    let mut stats = RayStats::default();
                    renderer.render_tile(&tile, &mut buf, &mut stats);
                    let span = TileSpan {
                        thread: thread as u32,
                        start_s,
                        end_s: start.elapsed().as_secs_f64(),
                    };
                    st = lock();
                    let finished = land(&mut st, k, &tile, &buf, stats, span);
                    drop(st);
                    on_tile(SequenceTile {
                        frame: k,
                        tile: &tile,
                        pixels: &buf,
                        stats: &stats,
                        span,
                    });
                    if let Some(done) = finished {
                        let frame_stats = done.stats;
                        let written = write(done);
                        st = lock();
                        st.elsewhere -= 1;
                        match written {
                            Ok(()) => {
                                st.result.frames += 1;
                                st.result.stats += frame_stats;
                            }
                            Err(e) => {
                                st.failed.get_or_insert(e);
                            }
                        }
                        changed.notify_all();
                    } else {
                        st = lock();
                    }
                }
            }
        }
    };
    std::thread::scope(|scope| {
        for i in 0..opts.threads.max(1) {
            let work = &work;
            scope.spawn(move || work(i));
        }
    });
    let mut st = state.into_inner().unwrap_or_else(|e| e.into_inner());
    if let Some(e) = st.failed.take() {
        return Err(e);
    }
    st.result.wall_s = start.elapsed().as_secs_f64();
    st.result.stopped = st.result.frames < frames;
    Ok(st.result)
}

/// Frame `index` opened with its renderer: its film, and its tiles in handout order.
fn open(index: usize, renderer: Renderer, opts: &SequenceOptions, costs: &TileCosts) -> Open {
    let (w, h) = (renderer.settings().width, renderer.settings().height);
    let key = (w, h, opts.tile);
    let list = tiles(w, h, opts.tile);
    let mut order = match opts.executor {
        Executor::Queue | Executor::Rayon => list.clone(),
        Executor::Morton | Executor::Guided => morton_order(&list, opts.tile),
    };
    if let Some((measured, seconds)) = costs {
        if *measured == key {
            // Stable: tiles not measured yet (0 s) keep the usual order, last.
            order.sort_by(|a, b| seconds[b.id as usize].total_cmp(&seconds[a.id as usize]));
        }
    }
    Open {
        index,
        key,
        renderer: Arc::new(renderer),
        left: order.len(),
        seconds: vec![0.0; order.len()],
        order,
        next: 0,
        film: if opts.rgb8 {
            Film::new_rgb8(w, h)
        } else {
            Film::new(w, h)
        },
        stats: RayStats::default(),
    }
}

/// Puts a rendered tile into its frame; returns the frame when that was its last tile (taken
/// out of the queue and counted as alive elsewhere until written).
fn land<E>(
    st: &mut State<E>,
    frame: usize,
    tile: &Tile,
    pixels: &[Rgb],
    stats: RayStats,
    span: TileSpan,
) -> Option<FrameDone> {
    let at = st.open.iter().position(|f| f.index == frame)?;
    let f = &mut st.open[at];
    f.film
        .write_tile(tile, pixels)
        .expect("tiles come from the film's own size");
    let seconds = span.end_s - span.start_s;
    f.seconds[tile.id as usize] = seconds;
    f.stats += stats;
    f.left -= 1;
    let key = f.key;
    let n = f.seconds.len();
    let left = f.left;
    match &mut st.costs {
        Some((k, c)) if *k == key => c[tile.id as usize] = seconds,
        costs => {
            let mut c = vec![0.0; n];
            c[tile.id as usize] = seconds;
            *costs = Some((key, c));
        }
    }
    st.result.tiles += 1;
    if left > 0 {
        return None;
    }
    let f = st.open.remove(at);
    st.elsewhere += 1;
    Some(FrameDone {
        index: f.index,
        film: f.film,
        stats: f.stats,
        tile_seconds: f.seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sequence::Sequence;
    use crate::settings::RenderSettings;
    use crate::smp::{render_smp, SmpOptions};

    fn renderers() -> (Sequence, RenderSettings) {
        let text = "v from 0 -6 2 at 0 0 0.5 up 0 0 1 angle 40 hither 0.01 resolution 24 16\n\
                    l 5 -5 5\nf 1 0 0 1 0 0 0 0\ns 0 0 0.5 1\nf 0 1 0 1 0 0 0 0\n\
                    p 4 -3 -3 0 3 -3 0 3 3 0 -3 3 0\n";
        let d = crate::nff::parse(text, "t.nff", &crate::nff::Limits::default()).unwrap();
        (
            Sequence::orbit(d, 300.0, 5).unwrap(),
            RenderSettings::new(24, 16),
        )
    }

    /// Every frame written once, each the bits of its own render, at most `window` alive.
    #[test]
    fn each_frame_once_and_the_same_bits_whatever_the_window() {
        let (seq, settings) = renderers();
        let build = |k: usize| Renderer::new(&seq.frames()[k].description(), &settings);
        let alone: Vec<Film> = (0..seq.len())
            .map(|k| {
                let opts = SmpOptions {
                    threads: 1,
                    tile: 8,
                    executor: Executor::Queue,
                };
                render_smp(&build(k).unwrap(), &opts, &|_, _| {}).film
            })
            .collect();
        for (threads, tile, window, rgb8) in [
            (1, 8, 1, false),
            (2, 5, 2, false),
            (3, 8, 3, false),
            (2, 16, 5, false),
            (2, 5, 2, true),
            (1, 7, 3, true),
        ] {
            let opts = SequenceOptions {
                threads,
                tile,
                executor: Executor::Morton,
                window,
                rgb8,
            };
            let written = Mutex::new(Vec::new());
            let write = |f: FrameDone| -> Result<(), crate::render::RenderError> {
                written.lock().unwrap().push((f.index, f.film));
                Ok(())
            };
            let r = render_sequence(
                seq.len(),
                &opts,
                &build,
                &write,
                &|_| {},
                &AtomicBool::new(false),
            )
            .unwrap();
            let mut got = written.into_inner().unwrap();
            got.sort_by_key(|(k, _)| *k);
            let ids: Vec<usize> = got.iter().map(|(k, _)| *k).collect();
            assert_eq!(ids, [0, 1, 2, 3, 4], "each frame once");
            for (k, film) in got {
                // An 8-bit frame holds the bytes the linear frame's PNG holds.
                let same = match rgb8 {
                    false => film == alone[k],
                    true => film.is_rgb8() && film.to_rgb8() == alone[k].to_rgb8(),
                };
                assert!(same, "frame {k}, {threads} threads, tile {tile}, {rgb8}");
            }
            assert_eq!((r.frames, r.stopped), (5, false));
            assert!(
                r.most_alive <= window && r.most_alive >= 1,
                "{}",
                r.most_alive
            );
            let per_frame = tiles(24, 16, tile).len();
            assert_eq!(r.tiles, 5 * per_frame);
        }
    }

    #[test]
    fn a_stopped_sequence_writes_nothing_more_and_says_so() {
        let (seq, settings) = renderers();
        let build = |k: usize| Renderer::new(&seq.frames()[k].description(), &settings);
        let opts = SequenceOptions {
            threads: 2,
            tile: 8,
            executor: Executor::Queue,
            window: 2,
            rgb8: false,
        };
        let write = |_: FrameDone| -> Result<(), crate::render::RenderError> {
            panic!("nothing is written once stopped")
        };
        let r = render_sequence(5, &opts, &build, &write, &|_| {}, &AtomicBool::new(true));
        let r = r.unwrap();
        assert_eq!((r.frames, r.tiles, r.stopped), (0, 0, true));
    }

    /// After frame 0, a frame's tiles go out costliest first by the latest measured costs;
    /// unmeasured tiles keep the usual order, last.
    #[test]
    fn later_frames_go_costliest_first() {
        let (seq, settings) = renderers();
        let r = || Renderer::new(&seq.frames()[0].description(), &settings).unwrap();
        let opts = SequenceOptions {
            threads: 1,
            tile: 8,
            executor: Executor::Queue,
            window: 2,
            rgb8: false,
        };
        // 24 × 16 in tiles of 8: 3 × 2 tiles, ids 0..6 row by row.
        let first = open(0, r(), &opts, &None);
        let ids = |o: &Open| o.order.iter().map(|t| t.id).collect::<Vec<_>>();
        assert_eq!(ids(&first), [0, 1, 2, 3, 4, 5]);
        let costs = Some(((24, 16, 8), vec![0.1, 0.0, 0.5, 0.0, 0.3, 0.0]));
        assert_eq!(ids(&open(1, r(), &opts, &costs)), [2, 4, 0, 1, 3, 5]);
        let other_size = Some(((32, 16, 8), vec![0.0, 0.0, 0.0, 0.0, 0.9, 0.0, 0.0, 0.0]));
        assert_eq!(ids(&open(1, r(), &opts, &other_size)), [0, 1, 2, 3, 4, 5]);
    }
}
