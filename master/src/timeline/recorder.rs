//! The timeline of a distributed render, recorded from the scheduler's reports (an
//! [`Observer`]): assignment and arrival of every result, and the faults on the way.

use super::{Attempt, EventKind, Job, Row, TileRecord, Timeline, TimelineEvent};
use parrt_render::film::Rgb;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use parrt_runtime::observer::Observer;
use parrt_runtime::scheduler::WorkerId;
use std::collections::HashMap;
use std::sync::Mutex;
use tokio::time::Instant;

/// A tile result as it came, with raw instants.
struct RawTile {
    frame: usize,
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
    /// Live assignments: (worker, frame, tile) → (when, attempt, backup).
    assigned: HashMap<(WorkerId, usize, u32), (Instant, u32, bool)>,
    tiles: Vec<RawTile>,
    events: Vec<RawEvent>,
}

/// Records a distributed render's timeline; [`Recorder::timeline`] gives it afterwards.
#[derive(Default)]
pub struct Recorder {
    inner: Mutex<Inner>,
    /// Whether the render is a sequence: each tile's frame is then recorded.
    sequence: bool,
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

    /// A recorder of a sequence: each tile record says its frame.
    pub fn for_sequence() -> Self {
        Recorder {
            sequence: true,
            ..Recorder::default()
        }
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
                            frame: self.sequence.then(|| u32::try_from(t.frame).ok()).flatten(),
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
        self.assigned_in(0, id, tile, attempt, backup, now);
    }

    fn assigned_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        attempt: u32,
        backup: bool,
        now: Instant,
    ) {
        self.with(|i| {
            i.assigned
                .insert((id, frame, tile.id), (now, attempt, backup));
        });
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

    fn result_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        _pixels: &[Rgb],
        _stats: &RayStats,
        seconds: f64,
        accepted: bool,
    ) {
        let end = Instant::now();
        self.with(|i| {
            let a = i.assigned.remove(&(id, frame, tile.id));
            let attempt = match a {
                _ if !accepted => Attempt::DuplicateIgnored,
                Some((_, _, true)) => Attempt::Backup,
                Some((_, n, false)) if n > 1 => Attempt::Requeued,
                _ => Attempt::First,
            };
            i.tiles.push(RawTile {
                frame,
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

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_protocol::{Message, PixelFormat, TilePixels};
    use parrt_render::settings::RenderSettings;
    use parrt_render::tile::tiles;
    use parrt_runtime::observer::Observers;
    use parrt_runtime::scheduler::{Event, Outgoing, SchedOptions, Scheduler};
    use std::sync::Arc;
    use std::time::Duration;
    use tokio::sync::mpsc::{unbounded_channel, UnboundedReceiver};

    const JOB: u64 = 5;

    fn join(s: &mut Scheduler, id: WorkerId, now: Instant) -> UnboundedReceiver<Outgoing> {
        let (tx, rx) = unbounded_channel();
        s.handle(
            Event::Joined {
                id,
                name: "same-name".into(),
                threads: 1,
                isa: parrt_render::isa::Isa::Scalar,
                outbox: tx,
                counters: Arc::default(),
            },
            now,
        );
        s.handle(
            Event::Ready {
                id,
                job_id: JOB,
                build_s: 0.0,
                job_to_ready_s: 0.0,
            },
            now,
        );
        rx
    }

    fn assigned(rx: &mut UnboundedReceiver<Outgoing>) -> Vec<(Tile, u32)> {
        let mut v = Vec::new();
        while let Ok(m) = rx.try_recv() {
            match m {
                Outgoing::Message(Message::Assign { tile, attempt, .. }) => v.push((tile, attempt)),
                Outgoing::Message(Message::AssignBatch { tiles, .. }) => v.extend(tiles),
                _ => {}
            }
        }
        v
    }

    fn result(id: WorkerId, tile: &Tile, attempt: u32) -> Event {
        Event::Result {
            id,
            job_id: JOB,
            tile_id: tile.id,
            attempt,
            pixels: TilePixels::encode(&vec![[0.5; 3]; tile.pixel_count()], PixelFormat::F32),
            stats: RayStats {
                eye_rays: tile.pixel_count() as u64,
                ..RayStats::default()
            },
            seconds: 0.25,
        }
    }

    /// A worker lost mid-render: its tiles come back as `requeued` copies rendered by the
    /// other, the loss and the requeues are events, and a late copy is a duplicate.
    #[tokio::test(start_paused = true)]
    async fn faults_and_attempts_are_recorded() {
        let list = tiles(8, 4, 4); // 2 tiles
        let mut s = Scheduler::new(
            JOB,
            &RenderSettings::new(8, 4),
            1,
            list,
            SchedOptions {
                window: parrt_runtime::window::Window::PerThread(1),
                tile_deadline: Duration::from_secs(60),
                max_failures: 3,
                backups: true,
                max_batch: 1,
                batch_seconds: parrt_runtime::batch::BATCH_SECONDS,
                pixel_format: PixelFormat::F32,
                pack_pixels: true,
                rules: Default::default(),
            },
        );
        let rec = Arc::new(Recorder::new());
        s.set_observers(Observers(vec![rec.clone()]));
        let t0 = Instant::now();
        let mut a = join(&mut s, 1, t0);
        let mut b = join(&mut s, 2, t0);
        rec.started(t0);
        s.fill(t0);
        let (ta, tb) = (assigned(&mut a), assigned(&mut b));
        assert_eq!((ta.len(), tb.len()), (1, 1));
        tokio::time::advance(Duration::from_secs(1)).await;
        let now = Instant::now();
        s.handle(result(2, &tb[0].0, tb[0].1), now);
        s.handle(
            Event::Gone {
                id: 1,
                reason: "connection reset".into(),
            },
            now,
        );
        s.fill(now);
        let again = assigned(&mut b);
        assert_eq!(again, vec![(ta[0].0, 2)]);
        tokio::time::advance(Duration::from_secs(1)).await;
        s.handle(result(2, &again[0].0, 2), Instant::now());
        assert!(s.is_done());

        let label = "test".to_string();
        let job = Job {
            scene: &label,
            width: 8,
            height: 4,
            tile_size: 4,
        };
        let t = rec.timeline(&job, 2.0);
        assert_eq!(t.mode, "distributed");
        // Two workers of one name get distinct labels.
        assert_eq!(t.rows.len(), 2);
        assert_ne!(t.rows[0].worker, t.rows[1].worker);
        assert_eq!(t.tiles.len(), 2);
        let first = &t.tiles[0];
        assert_eq!(first.attempt, Attempt::First);
        assert_eq!(first.worker, t.rows[1].worker);
        assert!((first.end_s - 1.0).abs() < 1e-6, "{first:?}");
        assert!(
            (first.start_s - 0.75).abs() < 1e-6,
            "start = end - seconds: {first:?}"
        );
        assert_eq!(first.assigned_s, Some(0.0));
        let second = &t.tiles[1];
        assert_eq!(second.attempt, Attempt::Requeued);
        assert_eq!(second.tile, ta[0].0.id);
        assert!((second.end_s - 2.0).abs() < 1e-6);
        assert_eq!(second.assigned_s, Some(1.0));
        let kinds: Vec<EventKind> = t.events.iter().map(|e| e.kind).collect();
        assert!(kinds.contains(&EventKind::WorkerLost), "{kinds:?}");
        let lost = t
            .events
            .iter()
            .find(|e| e.kind == EventKind::WorkerLost)
            .expect("lost");
        assert_eq!(lost.worker.as_deref(), Some(t.rows[0].worker.as_str()));
        assert_eq!(lost.detail, "connection reset");
        assert!(t
            .events
            .iter()
            .any(|e| e.kind == EventKind::TileRequeued && e.tile == Some(ta[0].0.id)));
    }
}
