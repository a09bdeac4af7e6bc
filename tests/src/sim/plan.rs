//! The fault menu and one seed's schedule drawn from it. A seed fixes everything: how many
//! workers and threads, what a tile costs each, and which faults strike when — crashes with or
//! without a restart, late joins, held (stalled) and partitioned links that heal or not,
//! latency spikes, the master killed and resumed from its checkpoint, and hostile peers; and
//! whether it renders one frame or a sequence of a few.

use super::frames::MOST_FRAMES;
use super::world::{HEIGHT, TILE, WIDTH};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use std::time::Duration;

/// A hostile peer's behaviour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hostile {
    /// Sends random bytes.
    Junk,
    /// A worker that does not know the token.
    WrongToken,
    /// Authenticates, then answers with results of tiles it was never given.
    ImpossibleResults,
}

/// One fault, at a virtual time.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// Worker `w` crashes; restarts after `back` if given.
    Crash { w: usize, back: Option<Duration> },
    /// Messages between the master and worker `w` are held (a stalled link or process, as
    /// after SIGSTOP): released after `d` if given, else never (the worker is stuck for good
    /// while its connection stays open).
    Hold { w: usize, d: Option<Duration> },
    /// The link to worker `w` is cut; repaired after `heal` if given.
    Partition { w: usize, heal: Option<Duration> },
    /// The link to worker `w` gets `latency` for `d`.
    Latency {
        w: usize,
        latency: Duration,
        d: Duration,
    },
    /// The master is killed and started again after `back`, resuming from its checkpoint,
    /// whose last `torn` bytes the crash cut off (a write torn by a power loss; 0: none).
    MasterCrash { back: Duration, torn: u64 },
    /// A hostile peer connects.
    Hostile(Hostile),
}

/// One seed's world and schedule.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The seed it was drawn from.
    pub seed: u64,
    /// Worker hosts.
    pub workers: usize,
    /// Render threads of each.
    pub threads: Vec<usize>,
    /// Simulated cost of one tile on each worker.
    pub tile_cost: Vec<Duration>,
    /// Workers that start late, and by how much.
    pub late: Vec<Duration>,
    /// Workers the master waits for before starting.
    pub min_workers: usize,
    /// Faults by virtual time.
    pub faults: Vec<(Duration, Fault)>,
    /// Whether the master keeps a checkpoint (always when it may be killed).
    pub checkpoint: bool,
    /// The order the tiles are handed out in, when not raster: a shuffle, as an order by
    /// cost would be, which the master deals in rounds.
    pub order: Option<Vec<u32>>,
    /// Frames rendered as one job: 1, or a sequence of 2 to [`MOST_FRAMES`].
    pub frames: usize,
}

impl Plan {
    /// The plan of `seed`.
    pub fn draw(seed: u64) -> Plan {
        let mut r = StdRng::seed_from_u64(seed ^ 0x005E_ED0F_FA17);
        let workers = r.gen_range(1..=4usize);
        let threads = (0..workers).map(|_| r.gen_range(1..=3usize)).collect();
        let tile_cost = (0..workers)
            .map(|_| Duration::from_millis(r.gen_range(40..=400)))
            .collect();
        let late = (0..workers)
            .map(|_| {
                if r.gen_bool(0.2) {
                    Duration::from_millis(r.gen_range(100..=3_000))
                } else {
                    Duration::ZERO
                }
            })
            .collect();
        let min_workers = r.gen_range(1..=workers);
        let mut faults = Vec::new();
        let n = r.gen_range(0..=4usize);
        let at = |r: &mut StdRng| Duration::from_millis(r.gen_range(0..=4_000));
        let ms = |r: &mut StdRng, lo: u64, hi: u64| Duration::from_millis(r.gen_range(lo..=hi));
        for _ in 0..n {
            let w = r.gen_range(0..workers);
            let f = match r.gen_range(0..9u32) {
                0 | 1 => Fault::Crash {
                    w,
                    back: r.gen_bool(0.6).then(|| ms(&mut r, 100, 3_000)),
                },
                2 => Fault::Hold {
                    w,
                    d: r.gen_bool(0.8).then(|| ms(&mut r, 100, 8_000)),
                },
                3 => Fault::Partition {
                    w,
                    heal: r.gen_bool(0.6).then(|| ms(&mut r, 100, 6_000)),
                },
                4 => Fault::Latency {
                    w,
                    latency: ms(&mut r, 5, 400),
                    d: ms(&mut r, 500, 5_000),
                },
                5 => Fault::MasterCrash {
                    back: ms(&mut r, 50, 2_000),
                    torn: 0,
                },
                6 => Fault::Hostile(Hostile::Junk),
                7 => Fault::Hostile(Hostile::WrongToken),
                _ => Fault::Hostile(Hostile::ImpossibleResults),
            };
            faults.push((at(&mut r), f));
        }
        faults.sort_by_key(|(t, _)| *t);
        // Torn checkpoints come from a second stream of the seed, so adding them left every
        // other draw of a seed as it was: half the master's crashes cut 1–1 200 bytes (up to
        // about a record and a half) off the checkpoint's end.
        let mut tear = StdRng::seed_from_u64(seed ^ 0x7042_2E0C);
        for (_, f) in &mut faults {
            if let Fault::MasterCrash { torn, .. } = f {
                *torn = if tear.gen_bool(0.5) {
                    tear.gen_range(1..=1_200)
                } else {
                    0
                };
            }
        }
        let checkpoint = faults
            .iter()
            .any(|(_, f)| matches!(f, Fault::MasterCrash { .. }))
            || r.gen_bool(0.3);
        // A third stream, for the same reason: three seeds in ten hand the tiles out in a
        // shuffled order (`Schedule::order`, as `--costly-first` does).
        let mut shuffle = StdRng::seed_from_u64(seed ^ 0x0DE4_1B0A);
        let order = shuffle.gen_bool(0.3).then(|| {
            let n = WIDTH.div_ceil(TILE) * HEIGHT.div_ceil(TILE);
            let mut v: Vec<u32> = (0..n).collect();
            v.shuffle(&mut shuffle);
            v
        });
        // A fourth stream: one seed in four renders a sequence.
        let mut sequence = StdRng::seed_from_u64(seed ^ 0x5E0F_4A3E);
        let frames = if sequence.gen_bool(0.25) {
            sequence.gen_range(2..=MOST_FRAMES)
        } else {
            1
        };
        Plan {
            seed,
            workers,
            threads,
            tile_cost,
            late,
            min_workers,
            faults,
            checkpoint,
            order,
            frames,
        }
    }

    /// Workers that no fault removes for good (they can always finish the render).
    pub fn survivors(&self) -> usize {
        (0..self.workers)
            .filter(|&w| {
                !self.faults.iter().any(|(_, f)| match f {
                    Fault::Crash { w: x, back: None } => *x == w,
                    Fault::Partition { w: x, heal: None } => *x == w,
                    Fault::Hold { w: x, d: None } => *x == w,
                    _ => false,
                })
            })
            .count()
    }

    /// When the last fault has played out.
    pub fn faults_end(&self) -> Duration {
        self.faults
            .iter()
            .map(|(t, f)| {
                *t + match f {
                    Fault::Crash { back, .. } => back.unwrap_or_default(),
                    Fault::Hold { d, .. } => d.unwrap_or_default(),
                    Fault::Latency { d, .. } => *d,
                    Fault::Partition { heal, .. } => heal.unwrap_or_default(),
                    Fault::MasterCrash { back, .. } => *back,
                    Fault::Hostile(_) => Duration::ZERO,
                }
            })
            .max()
            .unwrap_or_default()
            .max(self.late.iter().copied().max().unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_draws_the_same_plan_every_time() {
        for seed in 0..50 {
            let (a, b) = (Plan::draw(seed), Plan::draw(seed));
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
        }
        let kinds: std::collections::BTreeSet<String> = (0..400)
            .flat_map(|s| Plan::draw(s).faults)
            .map(|(_, f)| {
                format!("{f:?}")
                    .split([' ', '('])
                    .next()
                    .unwrap()
                    .to_string()
            })
            .collect();
        assert_eq!(kinds.len(), 6, "every kind of fault is drawn: {kinds:?}");
    }
}
