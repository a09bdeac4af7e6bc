//! CPU accounting of an emulated-cluster run (Linux `/proc`; zeros elsewhere): the master's
//! runtime threads (the real master work, fed to the simulator), the whole emulation (this
//! process with its relay, plus the worker processes), and the whole machine. On a machine with
//! few cores the emulation of many nodes can itself run out of CPU; these say when it did.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Name of the master's runtime threads, whose CPU time is measured.
pub const MASTER_THREAD: &str = "parrt-master";

/// How often the sampler reads `/proc`: often enough to place a trace phase of a second or
/// more, seldom enough that its own reads (one stat file per worker process) stay a small
/// part of the emulation's CPU.
const PERIOD: Duration = Duration::from_millis(50);
/// How often the sampler looks for the master's threads and the worker processes again…
const RELIST: Duration = Duration::from_secs(1);
/// …after the first [`EARLY`], when it looks at every sample: the row's master thread and
/// its workers start just after the sampler, and a trace can begin well within a second
/// (until 2026-11-26 a row shorter than that could read no master and no worker CPU at all).
const EARLY: Duration = Duration::from_secs(2);

/// CPU seconds spent so far (or in an interval).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CpuSample {
    /// The master's runtime threads.
    pub master_s: f64,
    /// This process and the given child processes.
    pub own_s: f64,
    /// This process alone (the master and the relay).
    pub this_process_s: f64,
    /// Every process on the machine.
    pub machine_s: f64,
}

fn ticks_per_second() -> f64 {
    // SAFETY: sysconf has no preconditions.
    let t = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    if t > 0 {
        t as f64
    } else {
        100.0
    }
}

/// utime + stime of a `/proc/.../stat` file, in ticks.
fn stat_ticks(path: &str) -> u64 {
    let Ok(s) = std::fs::read_to_string(path) else {
        return 0;
    };
    // Fields after the command name (which may hold spaces) in parentheses.
    let Some(rest) = s.rfind(')').map(|i| &s[i + 1..]) else {
        return 0;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    // rest starts at field 3 (state); utime and stime are fields 14 and 15.
    let num = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    num(11) + num(12)
}

/// The `/proc/self/task` directories of the threads named [`MASTER_THREAD`]. Listing every
/// thread's name is the costly part of a sample (the relay has a thread per connection), so
/// the sampler does it once a second, not every sample.
fn master_threads() -> Vec<std::path::PathBuf> {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    dir.flatten()
        .map(|e| e.path())
        .filter(|p| {
            std::fs::read_to_string(p.join("comm"))
                .is_ok_and(|c| c.trim_end().starts_with(MASTER_THREAD))
        })
        .collect()
}

/// Nanoseconds on CPU of one thread (its task directory's schedstat); 0 once it has gone.
fn thread_cpu_ns(task: &std::path::Path) -> u64 {
    std::fs::read_to_string(task.join("schedstat"))
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .unwrap_or(0)
}

/// Busy ticks of the whole machine (all CPUs) from `/proc/stat`.
fn machine_ticks() -> u64 {
    let Ok(s) = std::fs::read_to_string("/proc/stat") else {
        return 0;
    };
    let Some(line) = s.lines().next().filter(|l| l.starts_with("cpu ")) else {
        return 0;
    };
    let v: Vec<u64> = line
        .split_whitespace()
        .skip(1)
        .filter_map(|x| x.parse().ok())
        .collect();
    // user nice system idle iowait irq softirq steal: busy is all but idle and iowait.
    v.iter().take(8).sum::<u64>() - v.get(3).copied().unwrap_or(0) - v.get(4).copied().unwrap_or(0)
}

/// This process's children, from each thread's `/proc/self/task/*/children` (empty where the
/// kernel does not list them).
fn child_pids() -> Vec<u32> {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    let mut pids: Vec<u32> = tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("children")).ok())
        .flat_map(|s| {
            s.split_whitespace()
                .filter_map(|p| p.parse().ok())
                .collect::<Vec<u32>>()
        })
        .collect();
    pids.sort_unstable();
    pids.dedup();
    pids
}

/// The last CPU read of every worker process and master thread ever listed: a process or
/// thread that has gone keeps its last value, so the sums only grow and the difference of two
/// samples is the CPU spent between them, whatever was listed when.
#[derive(Default)]
struct Seen {
    children: std::collections::BTreeMap<u32, u64>,
    master: std::collections::BTreeMap<std::path::PathBuf, u64>,
}

impl Seen {
    fn sample(&mut self, tick: f64) -> CpuSample {
        let this = stat_ticks("/proc/self/stat");
        for (p, last) in &mut self.children {
            *last = (*last).max(stat_ticks(&format!("/proc/{p}/stat")));
        }
        for (t, last) in &mut self.master {
            *last = (*last).max(thread_cpu_ns(t));
        }
        CpuSample {
            master_s: self.master.values().sum::<u64>() as f64 / 1e9,
            own_s: (this + self.children.values().sum::<u64>()) as f64 / tick,
            this_process_s: this as f64 / tick,
            machine_s: machine_ticks() as f64 / tick,
        }
    }

    fn relist(&mut self) {
        for p in child_pids() {
            self.children.entry(p).or_insert(0);
        }
        for t in master_threads() {
            self.master.entry(t).or_insert(0);
        }
    }
}

/// Samples CPU every `PERIOD` (50 ms) until dropped, so the CPU of an interval known only
/// afterwards (the tracing phase) can be read off.
pub struct CpuSampler {
    samples: Arc<Mutex<Vec<(Instant, CpuSample)>>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl CpuSampler {
    /// Starts sampling this process and its child processes (relisted as they come: the
    /// runtime starts the workers after the sampler).
    pub fn start() -> CpuSampler {
        let samples = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (s2, stop2) = (samples.clone(), stop.clone());
        let tick = ticks_per_second();
        let thread = std::thread::Builder::new()
            .name("cpu-sampler".into())
            .spawn(move || {
                let mut seen = Seen::default();
                let begun = Instant::now();
                let mut listed: Option<Instant> = None;
                while !stop2.load(Ordering::Relaxed) {
                    if begun.elapsed() < EARLY || listed.is_none_or(|t| t.elapsed() >= RELIST) {
                        seen.relist();
                        listed = Some(Instant::now());
                    }
                    let v = (Instant::now(), seen.sample(tick));
                    s2.lock().unwrap_or_else(|e| e.into_inner()).push(v);
                    std::thread::sleep(PERIOD);
                }
            })
            .ok();
        CpuSampler {
            samples,
            stop,
            thread,
        }
    }

    /// CPU spent between the samples nearest `from` and `to`.
    pub fn between(&self, from: Instant, to: Instant) -> CpuSample {
        let s = self.samples.lock().unwrap_or_else(|e| e.into_inner());
        let at = |t: Instant| {
            s.iter()
                .min_by_key(|(i, _)| if *i > t { *i - t } else { t - *i })
                .map_or(CpuSample::default(), |x| x.1)
        };
        let (a, b) = (at(from), at(to));
        CpuSample {
            master_s: (b.master_s - a.master_s).max(0.0),
            own_s: (b.own_s - a.own_s).max(0.0),
            this_process_s: (b.this_process_s - a.this_process_s).max(0.0),
            machine_s: (b.machine_s - a.machine_s).max(0.0),
        }
    }
}

impl Drop for CpuSampler {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_cpu_grows_while_this_process_works() {
        let s = CpuSampler::start();
        let t0 = Instant::now();
        let mut x = 0u64;
        while t0.elapsed() < Duration::from_millis(200) {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        std::thread::sleep(PERIOD * 2);
        let d = s.between(t0, Instant::now());
        if cfg!(target_os = "linux") {
            assert!(d.own_s > 0.0 && d.machine_s > 0.0, "{d:?}");
        }
    }

    #[test]
    fn a_master_thread_and_a_child_started_after_the_sampler_are_counted_at_once() {
        let s = CpuSampler::start();
        std::thread::sleep(PERIOD);
        let t0 = Instant::now();
        // Fixed work, not fixed time: on a loaded machine a thread gets a share of a core.
        let spin = || {
            let mut x = 0u64;
            for _ in 0..50_000_000u64 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
        };
        let master = std::thread::Builder::new()
            .name(MASTER_THREAD.into())
            .spawn(spin)
            .expect("a thread");
        // A child that burns CPU for a while (a shell loop, about 0.2 s), as a worker process
        // does. A quarter of that once measured 0.020 s on a loaded machine: the bound's edge.
        let child = std::process::Command::new("sh")
            .args(["-c", "i=0; while [ $i -lt 200000 ]; do i=$((i+1)); done"])
            .spawn();
        let Ok(mut child) = child else { return }; // no shell: nothing to count
        let _ = master.join();
        let _ = child.wait();
        std::thread::sleep(PERIOD * 2);
        let d = s.between(t0, Instant::now());
        if cfg!(target_os = "linux") {
            assert!(d.master_s > 0.02, "master thread CPU {:.3} s", d.master_s);
            assert!(
                d.own_s - d.this_process_s > 0.02,
                "child CPU {:.3} s",
                d.own_s - d.this_process_s
            );
        }
    }
}
