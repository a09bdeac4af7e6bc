//! The job's phases and the rules between them: waiting for enough workers, tracing, done;
//! when to give up waiting, and which failure to report (no worker came, or every worker
//! left mid-job). Pure: facts and time come in as arguments, a [`Step`] goes out; the
//! scheduler owns one and the run loop only acts on what it says.

use std::time::Duration;
use tokio::time::Instant;

/// When the master stops waiting.
#[derive(Clone, Copy, Debug)]
pub struct Rules {
    /// Workers that must be ready before tiles are handed out (at least 1).
    pub min_workers: usize,
    /// How long to wait for them (and, mid-job, for any worker when all have left).
    pub wait_workers: Duration,
    /// Keep waiting for `min_workers` even when nothing is left to render, so each can be
    /// told to shut down.
    pub await_all_workers: bool,
    /// `Some(n)`: only `n` known workers can ever join (the master made up the token and
    /// started them itself), so once `n` have left nobody else is coming.
    pub closed_to: Option<usize>,
}

impl Default for Rules {
    /// One worker, a minute's wait, no known closed set.
    fn default() -> Self {
        Rules {
            min_workers: 1,
            wait_workers: Duration::from_secs(60),
            await_all_workers: false,
            closed_to: None,
        }
    }
}

/// What the run loop does next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Every tile is in: stop.
    Done,
    /// Hand out tiles (`started`: the trace phase begins now).
    Run {
        /// True on the first step with enough workers.
        started: bool,
    },
    /// Not enough workers yet: wait for events.
    Wait,
    /// Give up.
    Fail(Verdict),
}

/// Why the master gave up waiting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Tiles were never handed out: too few workers became ready.
    NoWorkers {
        /// How long it waited.
        waited: Duration,
        /// Workers needed.
        wanted: usize,
        /// Workers ready.
        ready: usize,
    },
    /// Every worker left mid-job and none came back in time.
    AllWorkersLost {
        /// How long it waited.
        waited: Duration,
    },
}

/// The phase a job is in.
#[derive(Clone, Debug)]
pub struct Lifecycle {
    rules: Rules,
    started: Option<Instant>,
    waiting_since: Option<Instant>,
}

impl Lifecycle {
    /// A job not yet started, waiting from `now`.
    pub fn new(rules: Rules, now: Instant) -> Self {
        Lifecycle {
            rules: Rules {
                min_workers: rules.min_workers.max(1),
                ..rules
            },
            started: None,
            waiting_since: Some(now),
        }
    }

    /// When tiles were first handed out.
    pub fn started(&self) -> Option<Instant> {
        self.started
    }

    /// The next step, given whether every tile is in, how many workers are ready and how
    /// many have left so far.
    pub fn step(&mut self, now: Instant, done: bool, ready: usize, departures: usize) -> Step {
        if done && (self.started.is_some() || !self.rules.await_all_workers) {
            return Step::Done;
        }
        let needed = if self.started.is_some() {
            1
        } else {
            self.rules.min_workers
        };
        if ready >= needed {
            self.waiting_since = None;
            let started = self.started.is_none();
            if started {
                self.started = Some(now);
            }
            return Step::Run { started };
        }
        let since = *self.waiting_since.get_or_insert(now);
        let waited = now.duration_since(since);
        let nobody_else = self.rules.closed_to.is_some_and(|n| departures >= n);
        let patience = if crate::mutation::is(crate::mutation::Mutation::GiveUpAtOnce)
            && self.started.is_some()
        {
            Duration::ZERO
        } else {
            self.rules.wait_workers
        };
        if !nobody_else && waited <= patience {
            return Step::Wait;
        }
        Step::Fail(if self.started.is_none() {
            Verdict::NoWorkers {
                waited,
                wanted: self.rules.min_workers,
                ready,
            }
        } else {
            Verdict::AllWorkersLost { waited }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rules(min: usize) -> Rules {
        Rules {
            min_workers: min,
            wait_workers: Duration::from_secs(10),
            await_all_workers: false,
            closed_to: None,
        }
    }

    #[tokio::test(start_paused = true)]
    async fn waits_for_enough_workers_then_gives_up_with_no_workers() {
        let t0 = Instant::now();
        let mut l = Lifecycle::new(rules(2), t0);
        assert_eq!(l.step(t0, false, 1, 0), Step::Wait);
        let late = t0 + Duration::from_secs(10);
        assert_eq!(
            l.step(late, false, 1, 0),
            Step::Wait,
            "the limit itself waits"
        );
        let later = late + Duration::from_millis(1);
        assert_eq!(
            l.step(later, false, 1, 0),
            Step::Fail(Verdict::NoWorkers {
                waited: Duration::from_millis(10_001),
                wanted: 2,
                ready: 1
            })
        );
    }

    #[tokio::test(start_paused = true)]
    async fn starts_once_then_needs_one_and_reports_all_lost() {
        let t0 = Instant::now();
        let mut l = Lifecycle::new(rules(2), t0);
        let t1 = t0 + Duration::from_secs(1);
        assert_eq!(l.step(t1, false, 2, 0), Step::Run { started: true });
        assert_eq!(l.started(), Some(t1));
        assert_eq!(l.step(t1, false, 1, 1), Step::Run { started: false });
        let t2 = t1 + Duration::from_secs(2);
        assert_eq!(l.step(t2, false, 0, 2), Step::Wait);
        // The wait is counted from when the last worker went, not from the start.
        let t3 = t2 + Duration::from_secs(11);
        assert_eq!(
            l.step(t3, false, 0, 2),
            Step::Fail(Verdict::AllWorkersLost {
                waited: Duration::from_secs(11)
            })
        );
    }

    #[tokio::test(start_paused = true)]
    async fn a_worker_back_in_time_resets_the_wait() {
        let t0 = Instant::now();
        let mut l = Lifecycle::new(rules(1), t0);
        assert_eq!(l.step(t0, false, 1, 0), Step::Run { started: true });
        assert_eq!(l.step(t0 + Duration::from_secs(1), false, 0, 1), Step::Wait);
        let back = t0 + Duration::from_secs(9);
        assert_eq!(l.step(back, false, 1, 1), Step::Run { started: false });
        let gone = back + Duration::from_secs(1);
        assert_eq!(l.step(gone, false, 0, 2), Step::Wait);
        assert_eq!(
            l.step(gone + Duration::from_secs(10), false, 0, 2),
            Step::Wait
        );
    }

    #[tokio::test(start_paused = true)]
    async fn own_workers_all_gone_fails_at_once() {
        let t0 = Instant::now();
        let mut l = Lifecycle::new(
            Rules {
                closed_to: Some(2),
                ..rules(2)
            },
            t0,
        );
        assert_eq!(l.step(t0, false, 0, 1), Step::Wait);
        assert!(matches!(
            l.step(t0, false, 0, 2),
            Step::Fail(Verdict::NoWorkers { ready: 0, .. })
        ));
    }

    #[tokio::test(start_paused = true)]
    async fn done_ends_at_once_unless_told_to_await_every_worker() {
        let t0 = Instant::now();
        let mut l = Lifecycle::new(rules(3), t0);
        assert_eq!(l.step(t0, true, 0, 0), Step::Done);
        let mut waiting = Lifecycle::new(
            Rules {
                await_all_workers: true,
                ..rules(3)
            },
            t0,
        );
        assert_eq!(waiting.step(t0, true, 2, 0), Step::Wait);
        assert_eq!(waiting.step(t0, true, 3, 0), Step::Run { started: true });
        assert_eq!(waiting.step(t0, true, 3, 0), Step::Done);
    }
}
