//! The explorer's sequences: a seed may render 2–5 frames as one job, frame k the test scene
//! with its eye turned by k · [`STEP_DEGREES`] (so frame k is the same whatever the count). The
//! master host renders them as `parrt render --workers`/`master`/`cluster` do, through the
//! command line's own resumable frames ([`ResumableFrames`]): every finished frame written to a
//! file and, with a checkpoint, recorded, so a master killed and started again skips the frames
//! written, assembles those whose every tile it recorded and renders the rest. The invariant:
//! every frame written exactly once, over all the master's lives, equal to its own
//! single-frame SMP render bit for bit.

use super::net::SimListener;
use super::world::{Durable, HEIGHT, TILE, WIDTH};
use crate::dist::{smp_reference, test_scene};
use parrt_master::sequence_checkpoint::ResumableFrames;
use parrt_protocol::PixelFormat;
use parrt_render::film::Film;
use parrt_render::sequence::Sequence;
use parrt_render::settings::RenderSettings;
use parrt_runtime::{DistError, DistResult, Master};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use tokio_util::sync::CancellationToken;

/// Most frames a seed renders.
pub const MOST_FRAMES: usize = 5;
/// Degrees the eye turns from one frame to the next.
pub const STEP_DEGREES: f64 = 30.0;

/// The orbit of `frames` frames (at most [`MOST_FRAMES`]) and each frame's settings.
fn orbit(frames: usize) -> (Sequence, Vec<RenderSettings>) {
    let seq = Sequence::orbit(
        test_scene(WIDTH, HEIGHT),
        STEP_DEGREES * frames as f64,
        frames,
    )
    .expect("the test scene has an up vector");
    (seq, vec![RenderSettings::new(WIDTH, HEIGHT); frames])
}

/// Frame k's single-frame SMP image, for every k up to [`MOST_FRAMES`].
fn references() -> &'static [Film] {
    static R: OnceLock<Vec<Film>> = OnceLock::new();
    R.get_or_init(|| {
        let (seq, settings) = orbit(MOST_FRAMES);
        seq.frames()
            .iter()
            .zip(&settings)
            .map(|(f, s)| smp_reference(&f.description(), s, TILE).0)
            .collect()
    })
}

/// The bytes a frame's file holds here: its pixels' bits.
fn frame_bytes(film: &Film) -> Vec<u8> {
    film.pixels
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_bits().to_le_bytes()))
        .collect()
}

/// The frames written over all the master's lives: how many times each, in the order written.
#[derive(Clone, Default)]
pub struct Written(Arc<Mutex<Vec<usize>>>);

impl Written {
    fn note(&self, k: usize) {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).push(k);
    }
}

/// How one life of the master host ended (one frame or a sequence).
pub enum MasterEnd {
    /// The runtime ran: its result (of a sequence: the last frame written after it, when it
    /// succeeded).
    Ran(Box<Result<DistResult, DistError>>),
    /// A resume found every frame written or recorded whole: nothing left for workers.
    NothingLeft,
    /// The frames could not be set up (the checkpoint refused, a frame not written).
    Broken(String),
}

/// Renders the `frames` frames with `master`, each written to a file in `dir` (and noted in
/// `written`), resuming the checkpoint at `checkpoint` if given (and telling `durable` how
/// much of it is on the disk, which a torn write cannot take back).
pub async fn render(
    master: Master<SimListener>,
    frames: usize,
    checkpoint: Option<&Path>,
    dir: &Path,
    written: &Written,
    durable: &Durable,
) -> MasterEnd {
    let (seq, settings) = orbit(frames);
    let outputs: Vec<PathBuf> = (0..frames).map(|k| dir.join(format!("f{k}"))).collect();
    let write = |k: usize, film: &Film| -> anyhow::Result<()> {
        std::fs::write(&outputs[k], frame_bytes(film))?;
        written.note(k);
        Ok(())
    };
    let mut source = ResumableFrames::all(&seq, &settings, &outputs, &write);
    if let Some(path) = checkpoint {
        match source.with_checkpoint(path, true, None, TILE, PixelFormat::F32) {
            Ok((s, _)) => {
                *durable.lock().unwrap_or_else(|p| p.into_inner()) = s.durable();
                source = s;
            }
            Err(e) => return MasterEnd::Broken(format!("checkpoint: {e:#}")),
        }
    }
    let (Some(&first), Some(&last)) = (source.todo().first(), source.todo().last()) else {
        return match source.close() {
            Ok(()) => MasterEnd::NothingLeft,
            Err(e) => MasterEnd::Broken(format!("{e:#}")),
        };
    };
    let desc = seq.frames()[first].description().into_owned();
    let out = master
        .render_sequence(
            &desc,
            &settings[first],
            &mut source,
            CancellationToken::new(),
        )
        .await;
    if let Ok(r) = &out {
        if let Err(e) = source
            .write_frame(last, &r.film)
            .and_then(|()| source.close())
        {
            return MasterEnd::Broken(format!("the last frame: {e:#}"));
        }
    }
    MasterEnd::Ran(Box::new(out))
}

/// The sequence's invariant once the render ended: frames 0..`frames` each written exactly
/// once (over every life of the master), each file equal to its frame's SMP image.
pub fn check(frames: usize, dir: &Path, written: &Written, failures: &mut Vec<String>) {
    let order = written.0.lock().unwrap_or_else(|p| p.into_inner()).clone();
    for k in 0..frames {
        let times = order.iter().filter(|&&w| w == k).count();
        if times != 1 {
            failures.push(format!(
                "frames: frame {k} written {times} times ({order:?})"
            ));
            continue;
        }
        let want = frame_bytes(&references()[k]);
        if std::fs::read(dir.join(format!("f{k}"))).ok().as_deref() != Some(&want[..]) {
            failures.push(format!(
                "frames: frame {k} differs from its single-frame image"
            ));
        }
    }
    if let Some(k) = order.iter().find(|&&k| k >= frames) {
        failures.push(format!("frames: frame {k} written, of {frames}"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_k_is_the_same_whatever_the_count_and_the_frames_differ() {
        let (two, _) = orbit(2);
        let (five, _) = orbit(5);
        assert_eq!(
            two.frames()[1].description().view.from,
            five.frames()[1].description().view.from
        );
        let r = references();
        assert_eq!(r.len(), MOST_FRAMES);
        assert_ne!(frame_bytes(&r[0]), frame_bytes(&r[1]));
    }

    #[test]
    fn a_frame_written_twice_missing_or_wrong_is_a_failure() {
        let dir = tempfile::tempdir().unwrap();
        let w = Written::default();
        for k in 0..2 {
            std::fs::write(
                dir.path().join(format!("f{k}")),
                frame_bytes(&references()[k]),
            )
            .unwrap();
            w.note(k);
        }
        let mut f = Vec::new();
        check(2, dir.path(), &w, &mut f);
        assert!(f.is_empty(), "{f:?}");
        w.note(1);
        check(3, dir.path(), &w, &mut f);
        assert_eq!(
            f,
            [
                "frames: frame 1 written 2 times ([0, 1, 1])",
                "frames: frame 2 written 0 times ([0, 1, 1])"
            ]
        );
        f.clear();
        let w = Written::default();
        w.note(0);
        std::fs::write(dir.path().join("f0"), frame_bytes(&references()[1])).unwrap();
        check(1, dir.path(), &w, &mut f);
        assert_eq!(f, ["frames: frame 0 differs from its single-frame image"]);
    }
}
