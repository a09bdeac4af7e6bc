//! The frames of a sequence on one scheduler: the first frame's Job kept for workers that
//! join late, and the switch to the next frame when one is complete (its tiles costliest first
//! by the frame before's measured times; workers, failures and the lifecycle carried over).

use super::*;

/// The frames of a sequence rendered one after another on the same workers.
pub(super) struct Frames {
    /// The current frame's Job message.
    pub(super) job: Message,
    /// Ids of the frames already finished: a late Ready or result naming one is stale, not a
    /// fault.
    pub(super) past: Vec<u64>,
}

/// One finished frame of a sequence ([`Scheduler::next_frame`]).
#[derive(Debug)]
pub struct FrameFinished {
    /// The frame's image.
    pub film: Film,
    /// Its ray statistics.
    pub stats: RayStats,
    /// Seconds each of its tiles took, by tile id.
    pub tile_seconds: Vec<f64>,
}

impl Scheduler {
    /// Makes this scheduler's job the first frame of a sequence whose Job message is `job`:
    /// later frames follow on the same workers through [`Self::next_frame`].
    pub fn start_frames(&mut self, job: Message) {
        self.frames = Some(Frames {
            job,
            past: Vec::new(),
        });
    }

    /// Closes the finished frame (every tile done) and opens the next one, job `job_id` of
    /// `tiles` in the image `settings` describe (`lights` lights), whose Job message `job` goes
    /// to every worker now: each builds it and says Ready before it is dealt tiles again. The
    /// next frame's tiles go out costliest first by this frame's measured tile times when the
    /// two frames have the same tiles, in the usual order otherwise. Workers, their failures
    /// and the lifecycle carry over; backups still out for the finished frame are forgotten
    /// (their results name the old job and are ignored). Returns the finished frame.
    pub fn next_frame(
        &mut self,
        job_id: u64,
        settings: &RenderSettings,
        lights: usize,
        tiles: Vec<Tile>,
        job: Message,
    ) -> FrameFinished {
        let n = tiles.len();
        let same_tiles = tiles == self.tiles;
        let film = match self.opts.pixel_format {
            PixelFormat::Rgb8 => Film::new_rgb8(settings.width, settings.height),
            PixelFormat::F32 => Film::new(settings.width, settings.height),
        };
        let finished = FrameFinished {
            film: std::mem::replace(&mut self.film, film),
            stats: std::mem::take(&mut self.stats),
            tile_seconds: std::mem::replace(&mut self.tile_seconds, vec![0.0; n]),
        };
        let old = std::mem::replace(&mut self.job_id, job_id);
        let frames = self.frames.get_or_insert_with(|| Frames {
            job: job.clone(),
            past: Vec::new(),
        });
        frames.past.push(old);
        frames.job = job;
        self.settings = settings.clone();
        self.lights = lights;
        self.tiles = tiles;
        self.state = vec![TileState::Queued; n];
        self.attempts = vec![0; n];
        self.holders = vec![0; n];
        self.queue = (0..n as u32).collect();
        self.deal_in_rounds = false;
        self.done = 0;
        if same_tiles {
            let mut order: Vec<u32> = (0..n as u32).collect();
            // Costliest first; ties keep the usual order (a stable sort), so the order is the
            // same on every run with the same measured times.
            order.sort_by(|&a, &b| {
                finished.tile_seconds[b as usize].total_cmp(&finished.tile_seconds[a as usize])
            });
            self.set_order(&order);
        }
        let message = self.frames.as_ref().map(|f| f.job.clone());
        for w in self.workers.values_mut() {
            w.inflight.clear();
            w.ready_at = None;
            if let Some(m) = &message {
                let _ = w.outbox.send(m.clone());
            }
        }
        finished
    }

    /// Whether `job_id` names a frame of this sequence already finished.
    pub(super) fn is_past(&self, job_id: u64) -> bool {
        self.frames
            .as_ref()
            .is_some_and(|f| f.past.contains(&job_id))
    }
}
