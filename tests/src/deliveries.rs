//! An observer of a distributed render that a test can wait on: the tiles each worker (by name)
//! has delivered into the image, so a fault is injected once a worker is known to be mid-job,
//! whatever the machine's speed, instead of after a sleep guessed to be long enough.

use parrt_render::film::Rgb;
use parrt_render::stats::RayStats;
use parrt_render::tile::Tile;
use parrt_runtime::observer::{Observer, Observers};
use parrt_runtime::scheduler::WorkerId;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::watch;

/// Accepted tiles per worker name, as the scheduler reports them.
pub struct Deliveries {
    names: Mutex<BTreeMap<WorkerId, String>>,
    tiles: watch::Sender<BTreeMap<String, u64>>,
}

impl Deliveries {
    /// A new, empty record.
    pub fn new() -> Arc<Self> {
        Arc::new(Deliveries {
            names: Mutex::new(BTreeMap::new()),
            tiles: watch::Sender::new(BTreeMap::new()),
        })
    }

    /// This record as the observers of a render (`DistOptions::observers`).
    pub fn observers(self: &Arc<Self>) -> Observers {
        Observers(vec![self.clone() as Arc<dyn Observer>])
    }

    /// Waits until a worker whose name ends with `suffix` has delivered at least `n` tiles;
    /// panics after `limit`, saying what every worker had delivered by then.
    pub async fn wait_for(&self, suffix: &str, n: u64, limit: Duration) {
        let mut rx = self.tiles.subscribe();
        let reached =
            |m: &BTreeMap<String, u64>| m.iter().any(|(name, &t)| name.ends_with(suffix) && t >= n);
        if tokio::time::timeout(limit, rx.wait_for(reached))
            .await
            .is_err()
        {
            panic!(
                "no worker named *{suffix} delivered {n} tile(s) within {limit:?}; delivered: {:?}",
                *self.tiles.borrow()
            );
        }
    }
}

impl Observer for Deliveries {
    fn joined(&self, id: WorkerId, name: &str, _threads: u32, _now: tokio::time::Instant) {
        self.names
            .lock()
            .expect("not poisoned")
            .insert(id, name.to_string());
    }

    fn result(
        &self,
        id: WorkerId,
        _tile: &Tile,
        _pixels: &[Rgb],
        _stats: &RayStats,
        _seconds: f64,
        accepted: bool,
    ) {
        if !accepted {
            return;
        }
        let name = self.names.lock().expect("not poisoned").get(&id).cloned();
        if let Some(name) = name {
            self.tiles.send_modify(|m| *m.entry(name).or_default() += 1);
        }
    }
}
