//! What the simulation watches on the master: every event, hashed in order with its virtual
//! time (the trace hash a replay must reproduce), and every accepted tile (the "accepted
//! exactly once" invariant). An [`parrt_runtime::observer::Observer`], like the live view.

use parrt_render::film::Rgb;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use parrt_runtime::observer::Observer;
use parrt_runtime::scheduler::WorkerId;
use sha2::{Digest, Sha256};
use std::sync::{Arc, Mutex};
use tokio::time::Instant;

/// The trace of one seed, shared by the master's incarnations and the fault driver.
#[derive(Clone, Default)]
pub struct Trace(Arc<Mutex<TraceState>>);

#[derive(Default)]
struct TraceState {
    hash: Sha256,
    events: u64,
    /// Tiles accepted by the current master incarnation, in order, with their frame (the
    /// runtime's index: 0 for one frame).
    accepted: Vec<(usize, u32)>,
}

impl Trace {
    /// Adds an event line (virtual milliseconds first).
    pub fn note(&self, what: &str) {
        let ms = turmoil::sim_elapsed().map_or(0, |d| d.as_micros());
        if std::env::var_os("PARRT_SIM_LOG").is_some() {
            eprintln!("{:>10.3} ms  {what}", ms as f64 / 1e3);
        }
        let mut s = self.0.lock().unwrap_or_else(|p| p.into_inner());
        s.hash.update(format!("{ms} {what}\n").as_bytes());
        s.events += 1;
    }

    /// A new master incarnation begins: its accepted tiles are counted afresh.
    pub fn master_started(&self) {
        let mut s = self.0.lock().unwrap_or_else(|p| p.into_inner());
        s.accepted.clear();
    }

    /// The trace hash so far, in hex.
    pub fn hex(&self) -> String {
        let s = self.0.lock().unwrap_or_else(|p| p.into_inner());
        s.hash
            .clone()
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }

    /// Events so far.
    pub fn events(&self) -> u64 {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).events
    }

    /// Tiles the current master accepted, with their frame.
    pub fn accepted(&self) -> Vec<(usize, u32)> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .accepted
            .clone()
    }
}

impl Observer for Trace {
    fn started(&self, _now: Instant) {
        self.note("started");
    }
    fn joined(&self, id: WorkerId, name: &str, threads: u32, _now: Instant) {
        self.note(&format!("joined {id} {name} {threads}"));
    }
    fn ready(&self, id: WorkerId, _now: Instant) {
        self.note(&format!("ready {id}"));
    }
    fn assigned_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        attempt: u32,
        backup: bool,
        _now: Instant,
    ) {
        let t = tile_name(frame, tile);
        self.note(&format!("assigned {id} {t} {attempt} {backup}"));
    }
    fn result_in(
        &self,
        frame: usize,
        id: WorkerId,
        tile: &Tile,
        _pixels: &[Rgb],
        _stats: &RayStats,
        _seconds: f64,
        accepted: bool,
    ) {
        self.note(&format!(
            "result {id} {} {accepted}",
            tile_name(frame, tile)
        ));
        let mut s = self.0.lock().unwrap_or_else(|p| p.into_inner());
        if accepted {
            s.accepted.push((frame, tile.id));
        }
    }
    fn requeued(&self, tile_id: u32) {
        self.note(&format!("requeued {tile_id}"));
    }
    fn left(&self, id: WorkerId, reason: &str) {
        self.note(&format!("left {id} {reason}"));
    }
    fn finished(&self, complete: bool, _now: Instant) {
        self.note(&format!("finished {complete}"));
    }
}

/// A tile in the trace: its id, after its frame for a later frame of a sequence (frame 0's
/// lines are those of a one-frame render, so one-frame seeds trace as they always did).
fn tile_name(frame: usize, tile: &Tile) -> String {
    match frame {
        0 => tile.id.to_string(),
        f => format!("{f}:{}", tile.id),
    }
}
