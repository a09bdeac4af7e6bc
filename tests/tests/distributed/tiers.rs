//! A heterogeneous farm in one test (docs/design-rendering.md, *Instruction sets*): two worker
//! processes on different instruction-set tiers (`PARRT_ISA=scalar` and the widest this CPU runs)
//! render one image that equals the SMP render bit for bit, with the same ray statistics, and the
//! master's report names each worker's tier as its Hello said. A worker asked for an unknown tier
//! refuses to start.

use crate::EXE;
use parrt_render::isa::Isa;
use parrt_tests::*;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Milliseconds each worker sleeps before a tile: the 64 tiles then take a worker alone at
/// least 0.6 s, so the other is ready long before they run out even on a loaded machine (a
/// 6 ms render once went whole to the worker that was ready first).
const TILE_DELAY_MS: u64 = 10;

/// `EXE worker` dialling `addr` with one thread on `tier`.
fn worker_on(addr: std::net::SocketAddr, tier: Isa) -> ChildGuard {
    let child = Command::new(EXE)
        .args(["worker", "--connect", &addr.to_string(), "--threads", "1"])
        .env("PARRT_TOKEN", TEST_TOKEN)
        .env("PARRT_LOG", "warn")
        .env(parrt_render::isa::ENV, tier.name())
        .env(
            parrt_worker::options::TILE_DELAY_ENV,
            TILE_DELAY_MS.to_string(),
        )
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn worker process");
    ChildGuard(child)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workers_on_different_tiers_render_the_smp_image() {
    let best = Isa::best();
    assert!(best > Isa::Scalar, "this CPU runs only the scalar tier");
    // Triangles and spheres (mount), cones, cylinders and spheres (jacks).
    for scene in ["mount-4", "jacks-3"] {
        let path = crate::support::spd_dir().join(format!("{scene}.nff"));
        let desc = parrt_render::nff::parse_file(&path, &Default::default()).unwrap();
        let settings = parrt_render::settings::RenderSettings::new(64, 64);
        let (reference, ref_stats) = smp_reference(&desc, &settings, 8);
        let mut opts = test_options(8);
        opts.schedule.min_workers = 2;
        let m = start_master(&desc, &settings, &opts).await;
        let _w = [worker_on(m.addr, Isa::Scalar), worker_on(m.addr, best)];
        let r = tokio::time::timeout(Duration::from_secs(120), m.handle)
            .await
            .expect("render finishes")
            .unwrap()
            .unwrap();
        let what = format!("{scene}: workers on scalar and {best}");
        assert_same_bits(&r.film, &reference, &what);
        assert_eq!(r.stats, ref_stats, "{what}: ray statistics");
        let mut tiers: Vec<Isa> = r.per_worker.iter().map(|w| w.isa).collect();
        tiers.sort();
        assert_eq!(
            tiers,
            [Isa::Scalar, best],
            "{what}: the tiers the workers said"
        );
        assert!(
            r.per_worker.iter().all(|w| w.tiles > 0),
            "{what}: each worker rendered tiles: {:?}",
            r.per_worker
        );
    }
}

#[test]
fn a_worker_asked_for_an_unknown_tier_exits_2_naming_it() {
    let out = Command::new(EXE)
        .args(["worker", "--connect", "127.0.0.1:9"])
        .env("PARRT_TOKEN", TEST_TOKEN)
        .env(parrt_render::isa::ENV, "avx1024")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("PARRT_ISA") && err.contains("avx1024"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
