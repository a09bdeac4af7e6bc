//! What binds a fault-free run, read from its event trace: an [`Observer`] on the real
//! master that notes when each tile (of which frame) was handed out and when its result came
//! in, and from them how much thread time was idle once the queue had emptied (the tail) and
//! what the tiles handed out last cost against the mean of every tile.

use parrt_render::film::Rgb;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use parrt_runtime::observer::Observer;
use parrt_runtime::scheduler::WorkerId;
use std::sync::Mutex;
use tokio::time::Instant;

/// The trace of one run, as the master saw it.
#[derive(Default)]
pub struct TailTrace(Mutex<Seen>);

#[derive(Default)]
struct Seen {
    started: Option<Instant>,
    finished: Option<Instant>,
    /// When the last tile (not a backup copy) was handed out: the queue was empty after it.
    last_handout: Option<Instant>,
    /// Each first handout: (when, frame, tile id), in order.
    handouts: Vec<(Instant, usize, u32)>,
    /// Each accepted result: (when it came in, frame, tile id).
    results: Vec<(Instant, usize, u32)>,
}

/// What the trace says.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Tail {
    /// Share of the trace (first tile out to last result in) spent handing tiles out.
    pub handout_share: f64,
    /// Share of all thread time idle after the queue emptied: every thread's time from the
    /// last handout to the end, less the work still done then.
    pub idle_after_queue: f64,
    /// Mean cost of the last 1 % of tiles handed out, over the mean of all.
    pub last_tiles_cost: f64,
    /// Mean cost of the last 1 % of results to come in, over the mean of all: above 1, the
    /// render ends waiting on costly tiles handed out before the queue emptied.
    pub last_results_cost: f64,
    /// The costliest tile still out when the queue emptied, over the mean.
    pub costliest_out: f64,
}

impl TailTrace {
    /// Reads the trace of a run on `threads` render threads in all, whose tiles cost
    /// `costs[frame][tile id]` seconds of the trace's clock (one frame: `costs` of one).
    pub fn tail(&self, threads: usize, costs: &[Vec<f64>]) -> Tail {
        let s = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let (Some(t0), Some(end), Some(h)) = (s.started, s.finished, s.last_handout) else {
            return Tail::default();
        };
        let trace = end.duration_since(t0).as_secs_f64().max(1e-12);
        let after = end.duration_since(h).as_secs_f64();
        // Work done after the last handout: of each result that came in later, the part of
        // its cost that fits between the handout and its arrival.
        let cost = |frame: usize, id: u32| {
            costs
                .get(frame)
                .and_then(|c| c.get(id as usize))
                .copied()
                .unwrap_or(0.0)
        };
        let busy_after: f64 = s
            .results
            .iter()
            .filter(|(at, _, _)| *at > h)
            .map(|(at, f, id)| cost(*f, *id).min(at.duration_since(h).as_secs_f64()))
            .sum();
        let n = threads.max(1) as f64;
        let all = costs.iter().flatten();
        let mean = all.clone().sum::<f64>() / all.count().max(1) as f64;
        let k = (s.handouts.len() / 100).max(1);
        let last: Vec<f64> = s.handouts[s.handouts.len().saturating_sub(k)..]
            .iter()
            .map(|(_, f, id)| cost(*f, *id))
            .collect();
        let last_mean = last.iter().sum::<f64>() / last.len().max(1) as f64;
        let kr = (s.results.len() / 100).max(1);
        let last_in: Vec<f64> = s.results[s.results.len().saturating_sub(kr)..]
            .iter()
            .map(|(_, f, id)| cost(*f, *id))
            .collect();
        let last_in_mean = last_in.iter().sum::<f64>() / last_in.len().max(1) as f64;
        let costliest_out = s
            .results
            .iter()
            .filter(|(at, _, _)| *at > h)
            .map(|(_, f, id)| cost(*f, *id))
            .fold(0.0, f64::max);
        Tail {
            handout_share: h.duration_since(t0).as_secs_f64() / trace,
            idle_after_queue: ((n * after - busy_after) / (n * trace)).max(0.0),
            last_tiles_cost: last_mean / mean.max(1e-12),
            last_results_cost: last_in_mean / mean.max(1e-12),
            costliest_out: costliest_out / mean.max(1e-12),
        }
    }
}

impl Observer for TailTrace {
    fn started(&self, now: Instant) {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).started = Some(now);
    }

    fn assigned_in(
        &self,
        frame: usize,
        _id: WorkerId,
        tile: &Tile,
        attempt: u32,
        backup: bool,
        now: Instant,
    ) {
        if !backup && attempt <= 1 {
            let mut s = self.0.lock().unwrap_or_else(|p| p.into_inner());
            s.last_handout = Some(now);
            s.handouts.push((now, frame, tile.id));
        }
    }

    fn result_in(
        &self,
        frame: usize,
        _id: WorkerId,
        tile: &Tile,
        _pixels: &[Rgb],
        _stats: &RayStats,
        _seconds: f64,
        accepted: bool,
    ) {
        if accepted {
            let now = Instant::now();
            let mut s = self.0.lock().unwrap_or_else(|p| p.into_inner());
            s.results.push((now, frame, tile.id));
        }
    }

    fn finished(&self, _complete: bool, now: Instant) {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).finished = Some(now);
    }
}
