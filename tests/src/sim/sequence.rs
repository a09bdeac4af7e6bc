//! A sequence in virtual time (`sim scale --frames N --orbit DEGREES`): what each frame of an
//! orbit replays, how a simulated worker knows which frame a tile belongs to, and where the
//! master's finished frames go.
//!
//! Recording every frame of a 4096² orbit at one thread would take hours, so the frames are
//! the one recorded frame *panned*: an orbit about the look-at point slides the image sideways,
//! so frame k replays the recording turned by k·DEGREES/N, the recorded width standing for a
//! whole turn: tile (column c, row r) of frame k plays the recorded tile (column
//! (c + s_k) mod C, row r), s_k = round(C · k·DEGREES/N / 360), C the image's full tile columns
//! (a narrower last column keeps its own tile). Its cost and its pixels are that recorded
//! tile's, so every frame has the recording's work, no two neighbouring frames have the same
//! cost map (the previous frame's measured order is as wrong as the pan makes it), and each
//! frame's image is known exactly: it is checked byte for byte against the recording panned.
//!
//! The master sends each frame as a job whose scene is the stand-in scene with its eye turned
//! by the frame's angle ([`eye`]); a simulated worker ([`SeqExec`]) reads the frame from the
//! eye of each Job it builds and replays that frame's tiles.

use parrt_protocol::JobSpec;
use parrt_render::description::SceneDescription;
use parrt_render::film::{Film, Rgb};
use parrt_render::sequence::Frame;
use parrt_render::settings::RenderSettings;
use parrt_render::tile::Tile;
use parrt_render::vec3::Vec3d;
use parrt_runtime::{DistError, FrameFinished, FrameSource};
use parrt_worker::error::WorkerError;
use parrt_worker::exec::{ExecEvent, Execute, InlineExec};
use parrt_worker::replay::Replay;
use parrt_worker::tiles::JobHandle;
use parrt_worker::WorkerOptions;
use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The frames of a panned orbit over one recording.
#[derive(Clone, Debug)]
pub struct Orbit {
    /// Frames in the sequence.
    pub frames: usize,
    /// Degrees turned over the whole sequence.
    pub degrees: f64,
    /// Tile columns of the image (the last may be narrower).
    pub cols: usize,
    /// Tile columns of full width: those the pan moves.
    full: usize,
}

impl Orbit {
    /// `frames` frames turning `degrees` over an image `width` wide in tiles of `tile`.
    pub fn new(frames: usize, degrees: f64, width: u32, tile: u32) -> Self {
        let tile = tile.max(1);
        Orbit {
            frames: frames.max(1),
            degrees,
            cols: width.div_ceil(tile) as usize,
            full: (width / tile) as usize,
        }
    }

    /// Frame `k`'s angle, degrees.
    pub fn angle(&self, k: usize) -> f64 {
        k as f64 * self.degrees / self.frames as f64
    }

    /// How many tile columns frame `k` is panned by.
    pub fn shift(&self, k: usize) -> usize {
        if self.full == 0 {
            return 0;
        }
        let s = (self.full as f64 * self.angle(k) / 360.0).round();
        (s.rem_euclid(self.full as f64)) as usize % self.full
    }

    /// The recorded tile that tile `id` of frame `k` replays.
    pub fn source(&self, k: usize, id: usize) -> usize {
        let cols = self.cols.max(1);
        let (row, col) = (id / cols, id % cols);
        if col >= self.full {
            return id;
        }
        row * cols + (col + self.shift(k)) % self.full
    }

    /// Frame `k`'s costs by tile id, from the recording's `costs` (by recorded tile id).
    pub fn costs(&self, k: usize, costs: &[f64]) -> Vec<f64> {
        (0..costs.len()).map(|i| costs[self.source(k, i)]).collect()
    }
}

/// Frame `k`'s eye: `desc`'s eye turned about its look-at point by `degrees` about its up
/// vector's axis (the vertical, in the stand-in scene).
pub fn eye(desc: &SceneDescription, degrees: f64) -> Vec3d {
    let v = &desc.view;
    let (s, c) = degrees.to_radians().sin_cos();
    let d = v.from - v.at;
    v.at + Vec3d::new(d.x * c + d.z * s, d.y, -d.x * s + d.z * c)
}

/// Every frame's scene: `desc` with its eye turned by the frame's angle.
pub fn scenes(desc: &SceneDescription, orbit: &Orbit) -> Vec<SceneDescription> {
    (0..orbit.frames)
        .map(|k| {
            let mut d = desc.clone();
            d.view.from = eye(desc, orbit.angle(k));
            d
        })
        .collect()
}

/// A simulated worker replaying a panned orbit: the inline executor, each tile's cost and
/// pixels those of the frame its job stands for (known from the Job's eye when it is built).
pub struct SeqExec {
    inner: InlineExec,
    /// Job id → frame, as this worker built them.
    jobs: Arc<Mutex<HashMap<u64, usize>>>,
    /// Each frame's eye.
    eyes: Arc<Vec<Vec3d>>,
}

impl SeqExec {
    /// Replays `replay` (its costs already scaled) panned as `orbit` says; `eyes` are the
    /// frames' eyes ([`scenes`]).
    pub fn new(replay: Arc<Replay>, orbit: Orbit, eyes: Arc<Vec<Vec3d>>) -> Self {
        let jobs: Arc<Mutex<HashMap<u64, usize>>> = Arc::default();
        let frame_of = {
            let jobs = jobs.clone();
            move |job: &JobHandle| {
                jobs.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .get(&job.job_id)
                    .copied()
            }
        };
        let (r, o, f) = (replay.clone(), orbit.clone(), frame_of.clone());
        let cost = move |job: &JobHandle, t: &Tile| {
            f(job)
                .and_then(|k| r.tiles.get(o.source(k, t.id as usize)))
                .and_then(|src| r.cost(src).ok())
                .unwrap_or(Duration::ZERO)
        };
        let pixels = move |job: &JobHandle, t: &Tile, out: &mut Vec<Rgb>| {
            let k = frame_of(job).ok_or_else(|| format!("job {} is no frame", job.job_id))?;
            let src = replay
                .tiles
                .get(orbit.source(k, t.id as usize))
                .filter(|s| s.w == t.w && s.h == t.h)
                .ok_or_else(|| format!("tile {} of frame {k} has no recorded tile", t.id))?;
            replay.pixels(src, out).map_err(|e| e.to_string())
        };
        SeqExec {
            inner: InlineExec::per_job(cost).with_job_pixels(pixels),
            jobs,
            eyes,
        }
    }
}

impl SeqExec {
    /// Job `job_id` stands for the frame whose eye is `eye` (a Job built here, or a View of
    /// one: a frame of the orbit that only moved the camera).
    fn learn(&mut self, job_id: u64, eye: Vec3d) {
        if let Some(k) = self.eyes.iter().position(|e| *e == eye) {
            self.jobs
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .insert(job_id, k);
        }
    }
}

impl Execute for SeqExec {
    fn start(&mut self, opts: &WorkerOptions) {
        self.inner.start(opts);
    }

    fn build(&mut self, spec: JobSpec) {
        self.learn(spec.job_id, spec.scene.view.from);
        self.inner.build(spec);
    }

    fn viewed(&mut self, spec: &parrt_protocol::ViewSpec) {
        self.learn(spec.job_id, spec.view.from);
    }

    fn submit(&mut self, job: &JobHandle, tiles: Vec<(Tile, u32)>) {
        self.inner.submit(job, tiles);
    }

    fn next(&mut self) -> impl Future<Output = Result<ExecEvent, WorkerError>> + Send {
        self.inner.next()
    }
}

/// One finished frame as the simulation keeps it: its image checked, its span.
#[derive(Clone, Debug)]
pub struct FrameSeen {
    /// The frame.
    pub index: usize,
    /// Its image is the recording panned for it, byte for byte.
    pub identical: bool,
    /// Virtual seconds from its first tile handed out to its last accepted (dilated).
    pub latency_s: f64,
}

/// The master's side of the sequence: gives frames 1.. and checks each finished one at once
/// (a 4096² film is not kept for 24 frames).
#[derive(Clone)]
pub struct SimFrames {
    /// Every frame's scene.
    pub scenes: Vec<SceneDescription>,
    /// The settings of all.
    pub settings: RenderSettings,
    /// What each frame replays.
    pub orbit: Orbit,
    /// The recorded image, 8-bit.
    pub want: Arc<Vec<u8>>,
    /// The tile list.
    pub tiles: Arc<Vec<Tile>>,
    /// The frames finished, in the order they finished.
    pub seen: Arc<Mutex<Vec<FrameSeen>>>,
}

impl SimFrames {
    /// Checks frame `k`'s image and notes it with its span.
    pub fn note(
        &self,
        k: usize,
        film: &Film,
        span: (Option<tokio::time::Instant>, tokio::time::Instant),
    ) {
        let identical = panned_equal(film, &self.want, &self.tiles, &self.orbit, k);
        let latency_s = span
            .0
            .map_or(0.0, |first| span.1.duration_since(first).as_secs_f64());
        self.seen
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(FrameSeen {
                index: k,
                identical,
                latency_s,
            });
    }
}

impl FrameSource for SimFrames {
    fn count(&self) -> usize {
        self.scenes.len()
    }

    fn frame(&mut self, k: usize) -> Result<(Frame, RenderSettings), DistError> {
        let d = self.scenes.get(k).or(self.scenes.last()).cloned();
        let d = d.unwrap_or_else(|| crate::dist::test_scene(1, 1));
        Ok((Frame::from(d), self.settings.clone()))
    }

    fn finished(&mut self, k: usize, frame: FrameFinished) -> Result<(), DistError> {
        self.note(k, &frame.film, (frame.first_out, frame.done_at));
        Ok(())
    }
}

/// Whether `film` (frame `k`) is the recorded image `want` (8-bit) panned as `orbit` says.
pub fn panned_equal(film: &Film, want: &[u8], tiles: &[Tile], orbit: &Orbit, k: usize) -> bool {
    let got = film.to_rgb8();
    if got.len() != want.len() {
        return false;
    }
    let w = film.width as usize;
    tiles.iter().all(|t| {
        let Some(src) = tiles.get(orbit.source(k, t.id as usize)) else {
            return false;
        };
        (t.y..t.y + t.h).all(|y| {
            let row = y as usize * w;
            let a = (row + t.x as usize) * 3;
            let b = (row + src.x as usize) * 3;
            let n = t.w as usize * 3;
            got.get(a..a + n) == want.get(b..b + n)
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_pan_whole_full_columns_and_keep_a_narrow_last_one() {
        // 10 pixels in tiles of 4: columns 0 and 1 full, column 2 two pixels wide.
        let o = Orbit::new(4, 360.0, 10, 4);
        assert_eq!((0..4).map(|k| o.shift(k)).collect::<Vec<_>>(), [0, 1, 1, 0]);
        // Row 1 (ids 3, 4, 5) of frame 1: the full columns swap, the narrow one stays.
        assert_eq!(
            (3..6).map(|i| o.source(1, i)).collect::<Vec<_>>(),
            [4, 3, 5]
        );
        assert_eq!(o.costs(1, &[1.0, 2.0, 3.0]), [2.0, 1.0, 3.0]);
    }

    #[test]
    fn a_frame_is_checked_against_its_own_pan() {
        let list = parrt_render::tile::tiles(8, 4, 4);
        let mut recorded = Film::new(8, 4);
        for (i, p) in recorded.pixels.iter_mut().enumerate() {
            *p = [(i % 8) as f32 / 8.0, 0.5, 0.25];
        }
        let want = recorded.to_rgb8();
        let o = Orbit::new(2, 360.0, 8, 4);
        let mut panned = Film::new(8, 4);
        for t in &list {
            let src = &list[o.source(1, t.id as usize)];
            let px: Vec<Rgb> = (0..4)
                .flat_map(|y| (0..4).map(move |x| (x, y)))
                .map(|(x, y)| recorded.get(src.x + x, y))
                .collect();
            panned.write_tile(t, &px).unwrap();
        }
        assert!(panned_equal(&panned, &want, &list, &o, 1));
        assert!(
            !panned_equal(&panned, &want, &list, &o, 0),
            "frame 1 is not frame 0"
        );
        assert!(panned_equal(&recorded, &want, &list, &o, 0));
    }
}
