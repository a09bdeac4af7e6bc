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
            let _ = w.outbox.send(Message::Error {
                reason: reason.clone(),
            });
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
        for (&t, a) in &w.inflight {
            if !a.expired {
                self.holders[t as usize] -= 1;
            }
        }
        let mut held: Vec<u32> = w.inflight.keys().copied().collect();
        if mutation::is(Mutation::ForgetDeadWorkersTiles) {
            held.clear();
        }
        self.requeue_all(&mut held);
        self.gone.push(report(&w, Some(reason)));
    }

    /// Puts a tile back at the front of the queue unless it is done or still actively held.
    pub(super) fn requeue(&mut self, tile_id: u32) {
        let t = tile_id as usize;
        if self.state[t] == TileState::Done || self.active_holders(tile_id) > 0 {
            return;
        }
        self.state[t] = TileState::Queued;
        self.queue.push_front(tile_id);
        self.faults.requeued += 1;
        self.observers.each(|o| o.requeued(tile_id));
    }

    /// Requeues tiles so that the lowest id comes out of the queue first.
    pub(super) fn requeue_all(&mut self, tiles: &mut [u32]) {
        tiles.sort_unstable();
        for &t in tiles.iter().rev() {
            self.requeue(t);
        }
    }

    pub(super) fn active_holders(&self, tile_id: u32) -> usize {
        let n = self.holders[tile_id as usize] as usize;
        // Tests and the simulation's debug build check the count against a scan.
        debug_assert_eq!(
            n,
            self.workers
                .values()
                .filter(|w| w.inflight.get(&tile_id).is_some_and(|a| !a.expired))
                .count(),
            "holders of tile {tile_id}"
        );
        n
    }

    /// Marks assignments past their deadline as expired and requeues their tiles; each worker
    /// with a miss in this round takes one failure.
    pub fn expire(&mut self, now: Instant) {
        let deadline = self.opts.tile_deadline;
        let mut late: Vec<(WorkerId, Vec<u32>)> = Vec::new();
        for (&id, w) in self.workers.iter_mut() {
            let mut tiles = Vec::new();
            for (&tile_id, a) in w.inflight.iter_mut() {
                if !a.expired && now.duration_since(a.since) > deadline {
                    a.expired = true;
                    self.holders[tile_id as usize] -= 1;
                    tiles.push(tile_id);
                }
            }
            if !tiles.is_empty() {
                late.push((id, tiles));
            }
        }
        for (id, mut tiles) in late {
            self.requeue_all(&mut tiles);
            self.fail(
                id,
                format!(
                    "{} tile(s) past the {} deadline",
                    tiles.len(),
                    parrt_protocol::seconds::seconds(deadline)
                ),
            );
        }
    }
}
