//! Parse throughput of the NFF reader on the largest SPD scenes (teapot-12: 1.5 MB of mostly
//! `pp 3`; mount-6: 0.6 MB of `p 3`). Reports bytes per second. Finds the scenes like the tests
//! do: `$PARRT_SPD_DIR`, else `shared/spd` above this crate.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::{Path, PathBuf};

fn spd_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("PARRT_SPD_DIR") {
        return PathBuf::from(d);
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .map(|d| d.join("shared").join("spd"))
        .find(|d| d.is_dir())
        .unwrap_or_else(|| panic!("cannot find shared/spd: set PARRT_SPD_DIR"))
}

fn parse(c: &mut Criterion) {
    let dir = spd_dir();
    let limits = parrt::nff::Limits::default();
    let mut group = c.benchmark_group("nff_parse");
    for name in ["teapot-12.nff", "mount-6.nff"] {
        let path = dir.join(name);
        let src = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
        group.throughput(Throughput::Bytes(src.len() as u64));
        group.bench_function(name, |b| {
            b.iter(|| {
                let d = parrt::nff::parse(std::hint::black_box(&src), name, &limits);
                std::hint::black_box(d.map(|d| d.primitives.len()).unwrap_or(0))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, parse);
criterion_main!(benches);
