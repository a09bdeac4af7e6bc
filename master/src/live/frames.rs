//! A sequence in the live view: which frame the page shows and how many are done and in
//! flight. The page shows the newest frame a tile of which has landed (it fills in from
//! nothing, as a one-frame render does); tiles of older frames still in flight (the tail the
//! newer frame fills) are counted, not drawn.

use super::state::JobInfo;

/// Counts of a sequence's frames for the page.
#[derive(Debug)]
pub struct FrameCounts {
    /// Each frame's job (its size may differ from frame to frame).
    jobs: Vec<JobInfo>,
    /// By frame: tiles in it.
    tiles: Vec<usize>,
    /// By frame: tiles accepted so far.
    accepted: Vec<usize>,
    /// By frame: whether a tile of it was handed out or landed.
    opened: Vec<bool>,
    /// Frames opened so far.
    opened_count: usize,
    /// Frames every tile of which landed.
    done: usize,
}

impl FrameCounts {
    /// The counts of a sequence whose frame k is `jobs[k]`, before anything happened.
    pub fn new(jobs: Vec<JobInfo>) -> FrameCounts {
        let tiles: Vec<usize> = jobs
            .iter()
            .map(|j| parrt_render::tile::tiles(j.width, j.height, j.tile_size.max(1)).len())
            .collect();
        let n = jobs.len();
        FrameCounts {
            jobs,
            tiles,
            accepted: vec![0; n],
            opened: vec![false; n],
            opened_count: 0,
            done: 0,
        }
    }

    /// Frame `k`'s job (`None` for a frame the sequence does not have).
    pub fn job(&self, k: usize) -> Option<&JobInfo> {
        self.jobs.get(k)
    }

    /// Frames in the sequence.
    pub fn total(&self) -> usize {
        self.jobs.len()
    }

    /// Notes that work of frame `k` went out or came in.
    pub fn open(&mut self, k: usize) {
        if let Some(o) = self.opened.get_mut(k) {
            if !std::mem::replace(o, true) {
                self.opened_count += 1;
            }
        }
    }

    /// Notes a tile of frame `k` accepted.
    pub fn accepted(&mut self, k: usize) {
        self.open(k);
        if let (Some(a), Some(&t)) = (self.accepted.get_mut(k), self.tiles.get(k)) {
            if *a < t {
                *a += 1;
                if *a == t {
                    self.done += 1;
                }
            }
        }
    }

    /// Frames every tile of which landed.
    pub fn done(&self) -> usize {
        self.done
    }

    /// Frames opened and not yet done.
    pub fn in_flight(&self) -> usize {
        self.opened_count - self.done
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(width: u32) -> JobInfo {
        JobInfo {
            scene: "s".into(),
            mode: "smp",
            width,
            height: 2,
            tile_size: 2,
        }
    }

    #[test]
    fn frames_are_done_when_their_last_tile_lands_and_in_flight_once_opened() {
        // Frame 0 has 2 tiles, frame 1 has 1.
        let mut c = FrameCounts::new(vec![job(4), job(2)]);
        assert_eq!((c.total(), c.done(), c.in_flight()), (2, 0, 0));
        c.open(0);
        c.accepted(0);
        assert_eq!((c.done(), c.in_flight()), (0, 1));
        c.accepted(1);
        assert_eq!((c.done(), c.in_flight()), (1, 1));
        // A duplicate beyond a frame's tiles, or a frame the sequence lacks, changes nothing.
        c.accepted(1);
        c.accepted(7);
        c.accepted(0);
        assert_eq!((c.done(), c.in_flight()), (2, 0));
        c.accepted(0);
        assert_eq!((c.done(), c.in_flight()), (2, 0));
        assert_eq!(c.job(1).map(|j| j.width), Some(2));
    }
}
