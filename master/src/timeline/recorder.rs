//! The timeline of a distributed render, recorded from the scheduler's reports (an
//! [`Observer`]): assignment and arrival of every result, and the faults on the way.

use super::{Attempt, EventKind, Job, Row, TileRecord, Timeline, TimelineEvent};
use crate::distributed::observer::Observer;
use crate::distributed::scheduler::WorkerId;
use parrt::film::Rgb;
use parrt::stats::RayStats;
use parrt::tile::Tile;
use std::collections::HashMap;
use std::sync::Mutex;
use tokio::time::Instant;

/// A tile result as it came, with raw instants.
struct RawTile {
    tile: u32,
    worker: WorkerId,
    assigned: Option<Instant>,
    seconds: f64,
    end: Instant,
    attempt: Attempt,
}

struct RawEvent {
    at: Instant,
    kind: EventKind,
    worker: Option<WorkerId>,
    tile: Option<u32>,
    detail: String,
}

#[derive(Default)]
struct Inner {
    origin: Option<Instant>,
    /// Unique labels of workers by id, in joining order.
    workers: Vec<(WorkerId, String, u32)>,
    /// Live assignments: (worker, tile) → (when, attempt, backup).
    assigned: HashMap<(WorkerId, u32), (Instant, u32, bool)>,
    tiles: Vec<RawTile>,
    events: Vec<RawEvent>,
}

/// Records a distributed render's timeline; [`Recorder::timeline`] gives it afterwards.
#[derive(Default)]
pub struct Recorder {
    inner: Mutex<Inner>,
}

/// Signed seconds from `origin` to `t`.
fn since(origin: Instant, t: Instant) -> f64 {
    if t >= origin {
        t.duration_since(origin).as_secs_f64()
    } else {
        -origin.duration_since(t).as_secs_f64()
    }
}

impl Recorder {
    /// A recorder with nothing recorded.
    pub fn new() -> Self {
        Recorder::default()
    }

    fn with<R>(&self, f: impl FnOnce(&mut Inner) -> R) -> R {
        f(&mut self.inner.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// The timeline so far, of `job`, whose trace phase took `trace_s`.
    pub fn timeline(&self, job: &Job<'_>, trace_s: f64) -> Timeline {
        self.with(|i| {
            let origin = i
                .origin
                .or_else(|| i.events.first().map(|e| e.at))
                .unwrap_or_else(Instant::now);
            let label = |id: WorkerId| {
                i.workers
                    .iter()
                    .find(|w| w.0 == id)
                    .map_or_else(|| format!("worker {id}"), |w| w.1.clone())
            };
            Timeline {
                mode: "distributed".into(),
                trace_s,
                rows: i
                    .workers
                    .iter()
                    .map(|(_, name, threads)| Row {
                        worker: name.clone(),
                        threads: *threads,
                    })
                    .collect(),
                tiles: i
                    .tiles
                    .iter()
                    .map(|t| {
                        let end_s = since(origin, t.end);
                        let assigned_s = t.assigned.map(|a| since(origin, a));
                        let secs = if t.seconds.is_finite() {
                            t.seconds.max(0.0)
                        } else {
                            0.0
                        };
                        let start_s = (end_s - secs).max(assigned_s.unwrap_or(f64::MIN));
                        TileRecord {
                            tile: t.tile,
                            worker: label(t.worker),
                            thread: None,
                            assigned_s,
                            start_s,
                            end_s,
                            attempt: t.attempt,
                        }
                    })
                    .collect(),
                events: i
                    .events
                    .iter()
                    .map(|e| TimelineEvent {
                        t_s: since(origin, e.at),
                        kind: e.kind,
                        worker: e.worker.map(label),
                        tile: e.tile,
                        detail: e.detail.clone(),
                    })
                    .collect(),
                ..Timeline::header(job)
            }
        })
    }
}

impl Observer for Recorder {
    fn started(&self, now: Instant) {
        self.with(|i| i.origin = Some(now));
    }

    fn joined(&self, id: WorkerId, name: &str, threads: u32, now: Instant) {
        self.with(|i| {
            let mut label = name.to_string();
            if i.workers.iter().any(|w| w.1 == label) {
                label = format!("{name}#{id}");
            }
            i.workers.push((id, label, threads));
            i.events.push(RawEvent {
                at: now,
                kind: EventKind::WorkerJoined,
                worker: Some(id),
                tile: None,
                detail: format!("{threads} threads"),
            });
        });
    }

    fn ready(&self, id: WorkerId, now: Instant) {
        self.with(|i| {
            i.events.push(RawEvent {
                at: now,
                kind: EventKind::WorkerReady,
                worker: Some(id),
                tile: None,
                detail: String::new(),
            })
        });
    }

    fn assigned(&self, id: WorkerId, tile: &Tile, attempt: u32, backup: bool, now: Instant) {
        self.with(|i| {
            i.assigned.insert((id, tile.id), (now, attempt, backup));
        });
    }

    fn result(
        &self,
        id: WorkerId,
        tile: &Tile,
        _pixels: &[Rgb],
        _stats: &RayStats,
        seconds: f64,
        accepted: bool,
    ) {
        let end = Instant::now();
        self.with(|i| {
            let a = i.assigned.remove(&(id, tile.id));
            let attempt = match a {
                _ if !accepted => Attempt::DuplicateIgnored,
                Some((_, _, true)) => Attempt::Backup,
                Some((_, n, false)) if n > 1 => Attempt::Requeued,
                _ => Attempt::First,
            };
            i.tiles.push(RawTile {
                tile: tile.id,
                worker: id,
                assigned: a.map(|a| a.0),
                seconds,
                end,
                attempt,
            });
        });
    }

    fn requeued(&self, tile_id: u32) {
        let at = Instant::now();
        self.with(|i| {
            i.events.push(RawEvent {
                at,
                kind: EventKind::TileRequeued,
                worker: None,
                tile: Some(tile_id),
                detail: String::new(),
            })
        });
    }

    fn left(&self, id: WorkerId, reason: &str) {
        let at = Instant::now();
        self.with(|i| {
            i.events.push(RawEvent {
                at,
                kind: EventKind::WorkerLost,
                worker: Some(id),
                tile: None,
                detail: reason.to_string(),
            })
        });
    }
}
