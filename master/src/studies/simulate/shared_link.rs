//! The master's link in the schedule model: every worker's results cross it, one message at a
//! time, the workers with results waiting taking turns (one message each, round the line), as
//! TCP flows into one host share its link. Served in the order they finished instead, a worker
//! whose results came out first would empty its window early and take the next tiles while the
//! others' results still queued — a schedule a real link (and the simulated world, which reads
//! each stream a frame at a time) does not give.

use std::collections::VecDeque;

/// Results waiting for the master's link, by worker, and whose turn is next.
#[derive(Debug, Default)]
pub(super) struct SharedLink {
    /// Per worker, its messages waiting: (batch, bytes), oldest first.
    waiting: Vec<VecDeque<(usize, f64)>>,
    /// Workers with messages waiting, in the order the link serves them.
    turns: VecDeque<usize>,
    /// A message is crossing now.
    busy: bool,
}

impl SharedLink {
    /// A link shared by `workers` workers.
    pub(super) fn new(workers: usize) -> Self {
        SharedLink {
            waiting: vec![VecDeque::new(); workers],
            turns: VecDeque::new(),
            busy: false,
        }
    }

    /// `worker`'s message of `bytes` (its `batch`'s results) reaches the link's queue.
    pub(super) fn arrive(&mut self, worker: usize, batch: usize, bytes: f64) {
        self.waiting[worker].push_back((batch, bytes));
        if self.waiting[worker].len() == 1 {
            self.turns.push_back(worker);
        }
    }

    /// The next message to cross, if the link is free and one waits: (worker, batch, bytes).
    /// The link is busy until [`Self::done`].
    pub(super) fn start(&mut self) -> Option<(usize, usize, f64)> {
        if self.busy {
            return None;
        }
        let worker = self.turns.pop_front()?;
        let (batch, bytes) = self.waiting[worker].pop_front()?;
        if !self.waiting[worker].is_empty() {
            self.turns.push_back(worker);
        }
        self.busy = true;
        Some((worker, batch, bytes))
    }

    /// The message crossing has crossed.
    pub(super) fn done(&mut self) {
        self.busy = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn workers_with_results_waiting_take_turns() {
        let mut link = SharedLink::new(2);
        for batch in 0..3 {
            link.arrive(0, batch, 100.0);
        }
        link.arrive(1, 3, 100.0);
        let mut order = Vec::new();
        while let Some((worker, batch, _)) = link.start() {
            assert!(link.start().is_none(), "one message at a time");
            order.push((worker, batch));
            link.done();
        }
        // Worker 1's one message goes second, not behind worker 0's backlog.
        assert_eq!(order, [(0, 0), (1, 3), (0, 1), (0, 2)]);
    }

    #[test]
    fn a_worker_joining_later_waits_for_those_in_line() {
        let mut link = SharedLink::new(3);
        link.arrive(0, 0, 1.0);
        link.arrive(1, 1, 1.0);
        assert_eq!(link.start().map(|m| m.0), Some(0));
        link.arrive(2, 2, 1.0);
        link.arrive(0, 3, 1.0);
        link.done();
        let mut order = Vec::new();
        while let Some((worker, batch, _)) = link.start() {
            order.push((worker, batch));
            link.done();
        }
        assert_eq!(order, [(1, 1), (2, 2), (0, 3)]);
    }
}
