//! Parse throughput of the NFF reader on the largest SPD scenes (teapot-12: 1.5 MB of mostly
//! `pp 3`; mount-6: 0.6 MB of `p 3`), in bytes per second. Finds the scenes like the tests do
//! (`parrt_test_support::spd_dir`: `$PARRT_SPD_DIR`, else the repository's `data/spd`).
//!
//! Two groups: `nff_parse` measures wall-clock time (criterion's default), `nff_parse_cpu` the
//! time the benchmarking thread spent on a CPU (Linux `/proc/thread-self/schedstat`), which stays
//! meaningful on a shared, oversubscribed machine where wall-clock time includes waiting for a
//! core. The second group is skipped where that file cannot be read.

use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion, Throughput};

const FILES: [&str; 2] = ["teapot-12.nff", "mount-6.nff"];

/// Nanoseconds this thread has run on a CPU, from Linux's `/proc/thread-self/schedstat`, or
/// `None` elsewhere. The kernel updates it at scheduler ticks (a few ms), so each reading can be
/// a tick stale; over criterion's samples (tens of ms each, 100 of them) that error is small and
/// has no bias.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// On-CPU time of the measuring thread, in nanoseconds.
struct CpuTime;

/// Formats [`CpuTime`] values like criterion formats durations.
struct CpuFormatter;

impl ValueFormatter for CpuFormatter {
    fn scale_values(&self, typical_ns: f64, values: &mut [f64]) -> &'static str {
        let (factor, unit) = if typical_ns < 1e3 {
            (1.0, "ns")
        } else if typical_ns < 1e6 {
            (1e-3, "µs")
        } else if typical_ns < 1e9 {
            (1e-6, "ms")
        } else {
            (1e-9, "s")
        };
        values.iter_mut().for_each(|v| *v *= factor);
        unit
    }

    fn scale_throughputs(&self, _typical: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        let (amount, denominator, unit) = match *t {
            Throughput::Bytes(b) => (b as f64, 1024.0 * 1024.0, "MiB/s"),
            Throughput::BytesDecimal(b) => (b as f64, 1e6, "MB/s"),
            Throughput::Elements(e) => (e as f64, 1e6, "Melem/s"),
        };
        values
            .iter_mut()
            .for_each(|v| *v = amount * (1e9 / *v) / denominator);
        unit
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

impl Measurement for CpuTime {
    type Intermediate = u64;
    type Value = u64;

    fn start(&self) -> u64 {
        thread_cpu_ns().unwrap_or(0)
    }
    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns().unwrap_or(0).saturating_sub(start)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuFormatter
    }
}

fn run_group<M: Measurement>(mut group: BenchmarkGroup<'_, M>) {
    let dir = parrt_test_support::spd_dir();
    let limits = parrt_render::nff::Limits::default();
    for name in FILES {
        let path = dir.join(name);
        let src = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
        group.throughput(Throughput::Bytes(src.len() as u64));
        group.bench_function(name, |b| {
            b.iter(|| {
                let d = parrt_render::nff::parse(std::hint::black_box(&src), name, &limits);
                std::hint::black_box(d.map(|d| d.primitives.len()).unwrap_or(0))
            })
        });
    }
    group.finish();
}

fn wall(c: &mut Criterion) {
    run_group(c.benchmark_group("nff_parse"));
}

fn cpu(c: &mut Criterion<CpuTime>) {
    if thread_cpu_ns().is_none() {
        eprintln!("nff_parse_cpu: no per-thread CPU clock here; skipped");
        return;
    }
    run_group(c.benchmark_group("nff_parse_cpu"));
}

criterion_group!(wall_clock, wall);
criterion_group! {
    name = cpu_time;
    config = Criterion::default().with_measurement(CpuTime);
    targets = cpu
}
criterion_main!(wall_clock, cpu_time);
