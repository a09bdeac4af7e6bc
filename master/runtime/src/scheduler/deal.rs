//! Handing out tiles: how many a worker is sent at once, which come first (the queues of the
//! frames open, oldest frame first, except a later frame's tile predicted so long that it
//! must start now; then, in a sequence, the next frame's; then backup copies of tiles still in
//! flight elsewhere once every queue is empty), and the assignment with its deadline.

use super::*;

impl Scheduler {
    /// The render threads of every ready worker.
    pub(super) fn ready_threads(&self) -> usize {
        self.workers
            .values()
            .filter(|w| w.ready_at.is_some())
            .map(|w| w.threads.max(1) as usize)
            .sum()
    }

    /// Tiles per assignment message now ([`crate::batch::batch_size`]), from the queue, the
    /// ready render threads (`threads`, counted once per fill: a sum over every worker for
    /// every batch made the fill quadratic in workers) and the mean tile cost seen so far.
    /// The queue counts the tiles of the frame given next in a sequence too: a frame's tail is
    /// filled by the next frame's tiles, so batches shrink toward the sequence's end only, not
    /// toward every frame's (at each frame's end a guided shrink to single tiles had cost about
    /// forty small messages a frame, each waking a worker and the master).
    pub(super) fn batch_size(&self, threads: usize) -> usize {
        let open: usize = self.open.iter().map(|f| f.queue.len()).sum();
        let next: usize = self.frames.as_ref().map_or(0, |s| {
            s.pending.iter().map(frames::NextFrame::to_render).sum()
        });
        crate::batch::batch_size(
            self.opts.max_batch,
            open + next,
            threads,
            self.mean_cost(),
            self.opts.batch_seconds,
        )
    }

    /// The mean render seconds of the tiles delivered so far (`None` before the first).
    pub(super) fn mean_cost(&self) -> Option<f64> {
        (self.cost.1 > 0).then(|| self.cost.0 / self.cost.1 as f64)
    }

    /// Hands out tiles to every ready worker with room in its window ([`Window::assignments`]
    /// batches), a batch being [`crate::batch::batch_size`] tiles sent in one message. In raster
    /// order each worker's window is filled in turn. In an order given by cost
    /// ([`Self::set_order`]) the workers with room (at the start of a render, all) are dealt
    /// in rounds, one batch each a round, as longest-first list scheduling does: otherwise the
    /// first worker's window would hold the costliest tiles, half of them waiting behind its
    /// busy threads (512 × 8 in virtual time: 0.276 filled in turn, 0.300 in rounds). Raster
    /// order is not dealt in rounds: a worker would then take tiles a fixed number apart, one
    /// above another in a column, and a costly patch of the image would stack on it (512 × 8:
    /// 0.257 in rounds, 0.292 filled in turn).
    pub fn fill(&mut self, now: Instant) {
        let ids: Vec<WorkerId> = self
            .workers
            .iter()
            .filter(|(_, w)| w.ready_at.is_some())
            .map(|(&id, _)| id)
            .collect();
        // The backup candidates, built once per fill when the queue runs dry.
        let mut backups = None;
        let threads = self.ready_threads();
        self.open_next(threads);
        let in_rounds = self
            .open
            .iter_mut()
            .find_map(|f| f.has_queued().then_some(f.deal_in_rounds));
        if in_rounds.unwrap_or(false) {
            let mut open = ids;
            while !open.is_empty() {
                open.retain(|&id| self.deal(id, now, threads, &mut backups));
            }
        } else {
            for id in ids {
                while self.deal(id, now, threads, &mut backups) {}
            }
        }
    }

    /// Gives worker `id` one batch if its window has room for one, or, once the queue is empty
    /// and the worker idle, its backups; says whether it may take more this fill.
    pub(super) fn deal(
        &mut self,
        id: WorkerId,
        now: Instant,
        threads: usize,
        backups: &mut Option<(Vec<Candidate>, usize)>,
    ) -> bool {
        // When no frame open has a tile queued, or too little work to start the next frame's
        // costliest tile in time, the next frame of a sequence opens.
        self.open_next(threads);
        let batch_size = self.batch_size(threads);
        let Some(w) = self.workers.get(&id) else {
            return false;
        };
        // Expired tiles still count: a stalled worker gets nothing new.
        let held = w.inflight.len();
        let mean = self.mean_cost().unwrap_or(0.0);
        let free = self
            .opts
            .window
            .assignments(w.threads as usize, w.round_trip, batch_size as f64 * mean)
            .saturating_mul(batch_size)
            .saturating_sub(held);
        // Keep batches whole: a busy worker waits for room for a full one.
        if free == 0 || (free < batch_size && held > 0) {
            return false;
        }
        let want = batch_size.min(free);
        // A batch is of one frame: the oldest with a tile queued that this worker does not
        // already hold (expired), unless a later frame's next tile is urgent.
        for p in self.deal_order(threads) {
            let mut batch = Vec::with_capacity(want);
            let mut skipped = Vec::new();
            let index = self.open[p].index;
            while batch.len() < want {
                match self.open[p].next_queued() {
                    Some(t) if self.workers[&id].inflight.contains_key(&(index, t)) => {
                        skipped.push(t)
                    }
                    Some(t) => batch.push(t),
                    None => break,
                }
            }
            for t in skipped.into_iter().rev() {
                self.open[p].queue.push_front(t);
            }
            if !batch.is_empty() {
                self.assign(id, p, &batch, now, false);
                return true;
            }
        }
        // Queue empty: an idle worker may take backups, up to one per thread.
        loop {
            let Some(w) = self.workers.get(&id) else {
                return false;
            };
            let idle = w.active(false) == 0;
            if !self.opts.backups || !idle || w.active(true) >= w.threads.max(1) as usize {
                return false;
            }
            match self.backup_candidate(id, backups) {
                Some((k, tile_id)) => {
                    let Some(p) = self.frame_at(k) else {
                        return false;
                    };
                    self.faults.backups += 1;
                    self.assign(id, p, &[tile_id], now, true);
                }
                None => return false,
            }
        }
    }

    /// The frames open with a tile queued, in the order a batch is looked for: first the
    /// frames whose next tile is *urgent*, costliest first, then the rest oldest first. A
    /// tile is urgent when it is predicted to take at least as long as the work not done in
    /// every frame open (queued or in flight), spread over the `threads` ready, would: dealt
    /// after the frames before it, it would end after the rest, and the threads that finish
    /// the rest would wait for it (the last frame of a sequence, opened early for that,
    /// [`Scheduler::open_next`]).
    /// Longest-first list scheduling across the frames does the same at the end but starves
    /// the oldest frame's cheap tiles meanwhile, and a frame not closed holds up the window.
    fn deal_order(&mut self, threads: usize) -> Vec<usize> {
        let mean = self.mean_cost();
        let left: Option<f64> = self.open.iter().map(|f| f.work_left(mean)).sum();
        let mut urgent: Vec<(f64, usize)> = Vec::new();
        let mut rest: Vec<usize> = Vec::with_capacity(self.open.len());
        for (p, f) in self.open.iter_mut().enumerate() {
            let Some(cost) = f.front_cost() else {
                continue;
            };
            match left {
                Some(q) if cost.is_finite() && cost * threads as f64 >= q => urgent.push((cost, p)),
                _ => rest.push(p),
            }
        }
        urgent.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        urgent.into_iter().map(|(_, p)| p).chain(rest).collect()
    }

    /// The oldest in-flight tile with a single active holder, not held by `id` (the oldest
    /// assignment first; equal times by worker, then tile). `list` caches, for one fill, the
    /// live assignments of singly held tiles in that order, with how many at its front are
    /// spent: a tile given out as a backup has two holders from then on, so each idle worker
    /// looks at the next candidates instead of every worker's every tile.
    pub(super) fn backup_candidate(
        &self,
        id: WorkerId,
        list: &mut Option<(Vec<Candidate>, usize)>,
    ) -> Option<Key> {
        let mine = &self.workers.get(&id)?.inflight;
        let (list, spent) = list.get_or_insert_with(|| {
            let mut v: Vec<Candidate> = self
                .workers
                .iter()
                .flat_map(|(&wid, w)| {
                    w.inflight
                        .iter()
                        .filter(|(_, a)| !a.expired)
                        .map(move |(&key, a)| (a.since, wid, key))
                })
                .filter(|&(_, _, (k, t))| {
                    self.frame_at(k)
                        .is_some_and(|p| self.open[p].holders[t as usize] == 1)
                })
                .collect();
            v.sort_unstable();
            (v, 0)
        });
        let usable = |(k, t): Key| {
            self.frame_at(k).is_some_and(|p| {
                self.open[p].state[t as usize] == TileState::InFlight
                    && self.active_holders(p, t) == 1
            })
        };
        while list.get(*spent).is_some_and(|&(_, _, key)| !usable(key)) {
            *spent += 1;
        }
        list[*spent..]
            .iter()
            .find(|&&(_, wid, key)| wid != id && !mine.contains_key(&key) && usable(key))
            .map(|&(_, _, key)| key)
    }

    /// Assigns `tiles` of the open frame at `p` to worker `id` in one message (`Assign` for
    /// one, `AssignBatch` for more).
    pub(super) fn assign(
        &mut self,
        id: WorkerId,
        p: usize,
        tiles: &[u32],
        now: Instant,
        backup: bool,
    ) {
        let f = &mut self.open[p];
        f.first_out.get_or_insert(now);
        let mut sent = Vec::with_capacity(tiles.len());
        for &tile_id in tiles {
            let t = tile_id as usize;
            f.attempts[t] += 1;
            f.set_state(t, TileState::InFlight);
            sent.push((f.tiles[t], f.attempts[t]));
        }
        let Some(w) = self.workers.get_mut(&id) else {
            return;
        };
        for &(tile, attempt) in &sent {
            self.observers
                .each(|o| o.assigned_in(f.index, id, &tile, attempt, backup, now));
            let old = w.inflight.insert(
                (f.index, tile.id),
                Assignment {
                    attempt,
                    since: now,
                    expired: false,
                    backup,
                    single: sent.len() == 1,
                },
            );
            f.holders[tile.id as usize] += 1;
            if old.is_some_and(|a| !a.expired) {
                f.holders[tile.id as usize] -= 1;
            }
        }
        let msg = match sent[..] {
            [(tile, attempt)] => Message::Assign {
                job_id: f.job_id,
                tile,
                attempt,
            },
            _ => Message::AssignBatch {
                job_id: f.job_id,
                tiles: sent,
            },
        };
        if w.outbox.send(msg.into()).is_err() {
            // Its connection task has ended; the Gone event is on its way.
            self.remove(id, "connection closed".into());
        }
    }
}
