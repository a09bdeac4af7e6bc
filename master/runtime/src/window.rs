//! How much work a worker holds at once: the window of assignments in flight. A worker needs one
//! assignment per render thread to stay busy, plus enough queued behind them to cover the time a
//! result takes to come back and be answered (its round trip). More than that does not make it
//! faster; it only parks tiles behind busy threads, where an expensive tile can wait while other
//! workers run dry at the end of a render. The master and the simulator size windows with the
//! same rule, so the model predicts the schedule the master runs.

use std::fmt;
use std::str::FromStr;

/// The window policy. The default is two per thread: on the emulated 512-core run `Auto` did
/// not beat it (BENCHMARKS.md, "Emulated cluster"), so it is there to be measured, not assumed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Window {
    /// One assignment per thread plus the prefetch a measured round trip needs
    /// ([`auto_prefetch`]); twice the threads until a round trip has been measured.
    Auto,
    /// A fixed number of assignments per thread.
    PerThread(usize),
}

impl Window {
    /// Assignments a worker of `threads` threads may hold. `round_trip_s` is the least time
    /// seen between handing it an assignment and hearing back, beyond the render itself
    /// (`None`: not measured yet); `assignment_s` is the work in one assignment.
    pub fn assignments(
        self,
        threads: usize,
        round_trip_s: Option<f64>,
        assignment_s: f64,
    ) -> usize {
        let threads = threads.max(1);
        match self {
            Window::PerThread(k) => threads.saturating_mul(k.max(1)),
            Window::Auto => match round_trip_s {
                None => threads.saturating_mul(2),
                Some(rt) => threads.saturating_add(auto_prefetch(threads, rt, assignment_s)),
            },
        }
    }
}

impl Default for Window {
    fn default() -> Self {
        Window::PerThread(2)
    }
}

/// Assignments queued beyond one per thread: enough that a thread finishing never waits for
/// the round trip — the round trip (doubled, for jitter) over the time between two threads of
/// the worker finishing (an assignment's work over the threads), rounded up; at least one, at
/// most one per thread (the fixed window of two per thread).
pub fn auto_prefetch(threads: usize, round_trip_s: f64, assignment_s: f64) -> usize {
    let threads = threads.max(1);
    if !(round_trip_s.is_finite() && assignment_s.is_finite() && assignment_s > 0.0) {
        return threads;
    }
    let between = assignment_s / threads as f64;
    let need = (2.0 * round_trip_s.max(0.0) / between).ceil();
    if need >= threads as f64 {
        threads
    } else {
        (need as usize).clamp(1, threads)
    }
}

/// `auto` or a positive number of assignments per thread.
impl FromStr for Window {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Window::Auto);
        }
        match s.parse::<usize>() {
            Ok(k) if (1..=1024).contains(&k) => Ok(Window::PerThread(k)),
            _ => Err(format!(
                "`{s}` is not a window: `auto` or assignments per thread, 1 to 1024"
            )),
        }
    }
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Window::Auto => f.write_str("auto"),
            Window::PerThread(k) => write!(f, "{k}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_two_per_thread() {
        assert_eq!(Window::default(), Window::PerThread(2));
    }

    #[test]
    fn fixed_windows_are_per_thread() {
        assert_eq!(Window::PerThread(2).assignments(8, Some(0.001), 0.07), 16);
        assert_eq!(Window::PerThread(1).assignments(3, None, 1.0), 3);
    }

    #[test]
    fn auto_is_two_per_thread_until_a_round_trip_is_measured() {
        assert_eq!(Window::Auto.assignments(8, None, 0.07), 16);
    }

    #[test]
    fn auto_queues_what_the_round_trip_needs() {
        // 8 threads of 73 ms tiles finish one every 9 ms: a 1 ms round trip needs one queued.
        assert_eq!(Window::Auto.assignments(8, Some(0.001), 0.073), 9);
        // A 10 ms round trip (doubled: 20 ms) needs three.
        assert_eq!(Window::Auto.assignments(8, Some(0.010), 0.073), 11);
        // Cheap work behind a slow link: never more than two per thread.
        assert_eq!(Window::Auto.assignments(8, Some(0.5), 0.001), 16);
        // One thread: one queued behind it, as the fixed window of two.
        assert_eq!(Window::Auto.assignments(1, Some(0.0002), 0.005), 2);
        // No round trip at all still keeps one queued.
        assert_eq!(Window::Auto.assignments(4, Some(0.0), 0.1), 5);
    }

    #[test]
    fn windows_parse_and_print() {
        assert_eq!("auto".parse::<Window>(), Ok(Window::Auto));
        assert_eq!("3".parse::<Window>(), Ok(Window::PerThread(3)));
        for bad in ["0", "-1", "x", "", "1025"] {
            assert!(bad.parse::<Window>().is_err(), "{bad}");
        }
        assert_eq!(Window::PerThread(2).to_string(), "2");
        assert_eq!(Window::Auto.to_string(), "auto");
    }
}
