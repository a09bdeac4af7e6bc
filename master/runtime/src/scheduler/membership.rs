//! Workers failing, leaving and missing deadlines: failures counted until a worker is dropped,
//! its tiles put back at the front of the queue, deadlines expired.

use super::*;

impl Scheduler {
    /// Counts a failure against `id`; drops it when it has failed too often.
    pub(super) fn fail(&mut self, id: WorkerId, reason: String) {
        let Some(w) = self.workers.get_mut(&id) else {
            return;
        };
        w.failures += 1;
        warn!(worker = id, name = %w.name, failures = w.failures, %reason, "worker fault");
        let failures = w.failures;
        if failures >= self.opts.max_failures {
            self.drop_worker(id, format!("failed {failures} times; last: {reason}"));
        }
    }

    /// Drops a worker (its outbox is closed, so its connection says Shutdown and closes).
    pub(super) fn drop_worker(&mut self, id: WorkerId, reason: String) {
        if let Some(w) = self.workers.get(&id) {
            warn!(worker = id, name = %w.name, %reason, "dropping worker");
            let _ = w.outbox.send(
                Message::Error {
                    reason: reason.clone(),
                }
                .into(),
            );
            self.faults.dropped += 1;
            self.remove(id, reason);
        }
    }

    /// Removes a worker; its unfinished tiles go back to the front of the queue.
    pub(super) fn remove(&mut self, id: WorkerId, reason: String) {
        let Some(w) = self.workers.remove(&id) else {
            return;
        };
        self.observers.each(|o| o.left(id, &reason));
        // Its tiles, by frame.
        let mut held: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
        for (&(k, t), a) in &w.inflight {
            let Some(p) = self.frame_at(k) else {
                continue;
            };
            if !a.expired {
                self.open[p].holders[t as usize] -= 1;
            }
            held.entry(p).or_default().push(t);
        }
        if !mutation::is(Mutation::ForgetDeadWorkersTiles) {
            for (p, mut tiles) in held {
                self.requeue_all(p, &mut tiles);
            }
        }
        self.gone.push(report(&w, Some(reason)));
    }

    /// Puts a tile of the open frame at `p` back at the front of its queue unless it is done
    /// or still actively held.
    pub(super) fn requeue(&mut self, p: usize, tile_id: u32) {
        let t = tile_id as usize;
        if self.open[p].state[t] == TileState::Done || self.active_holders(p, tile_id) > 0 {
            return;
        }
        let f = &mut self.open[p];
        f.set_state(t, TileState::Queued);
        f.queue.push_front(tile_id);
        self.faults.requeued += 1;
        self.observers.each(|o| o.requeued(tile_id));
    }

    /// Requeues tiles of the open frame at `p` so that the lowest id comes out of the queue
    /// first.
    pub(super) fn requeue_all(&mut self, p: usize, tiles: &mut [u32]) {
        tiles.sort_unstable();
        for &t in tiles.iter().rev() {
            self.requeue(p, t);
        }
    }

    pub(super) fn active_holders(&self, p: usize, tile_id: u32) -> usize {
        let f = &self.open[p];
        let n = f.holders[tile_id as usize] as usize;
        // Tests and the simulation's debug build check the count against a scan.
        debug_assert_eq!(
            n,
            self.workers
                .values()
                .filter(|w| w
                    .inflight
                    .get(&(f.index, tile_id))
                    .is_some_and(|a| !a.expired))
                .count(),
            "holders of tile {tile_id} of frame {}",
            f.index
        );
        n
    }

    /// Marks assignments past their deadline as expired and requeues their tiles; each worker
    /// with a miss in this round takes one failure.
    pub fn expire(&mut self, now: Instant) {
        let deadline = self.opts.tile_deadline;
        let mut late: Vec<(WorkerId, Vec<Key>)> = Vec::new();
        for (&id, w) in self.workers.iter_mut() {
            let mut tiles = Vec::new();
            for (&key, a) in w.inflight.iter_mut() {
                if !a.expired && now.duration_since(a.since) > deadline {
                    a.expired = true;
                    if let Some(f) = self.open.iter_mut().find(|f| f.index == key.0) {
                        f.holders[key.1 as usize] -= 1;
                    }
                    tiles.push(key);
                }
            }
            if !tiles.is_empty() {
                late.push((id, tiles));
            }
        }
        for (id, keys) in late {
            let mut by_frame: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
            for &(k, t) in &keys {
                if let Some(p) = self.frame_at(k) {
                    by_frame.entry(p).or_default().push(t);
                }
            }
            for (p, mut tiles) in by_frame {
                self.requeue_all(p, &mut tiles);
            }
            self.fail(
                id,
                format!(
                    "{} tile(s) past the {} deadline",
                    keys.len(),
                    parrt_protocol::seconds::seconds(deadline)
                ),
            );
        }
    }
}
