//! The emulated cluster of `parrt bench cluster` at a small N: real worker processes
//! replaying a recorded render through the emulated LAN relay assemble exactly the SMP image,
//! with every tile delivered once; and the command line writes the promised JSON rows.

use crate::EXE;
use parrt_master::studies::cluster::emulate::{self, EmulatedRun};
use parrt_master::studies::cluster::link::LinkParams;
use parrt_render::render::Renderer;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_tests::*;
use std::process::Command;
use std::time::Duration;

#[test]
fn four_replaying_workers_of_two_threads_assemble_the_smp_image_once_per_tile() {
    let desc = test_scene(72, 56);
    let settings = settings_for(&desc);
    let tile = 8;
    // The recording: a one-thread render at the run's tile size.
    let renderer = Renderer::new(&desc, &settings).unwrap();
    let recorded = render_smp(
        &renderer,
        &SmpOptions {
            threads: 1,
            tile,
            executor: Executor::Queue,
        },
        &|_, _| {},
    );
    let dir = tempfile::tempdir().unwrap();
    let replay = dir.path().join("test.replay");
    parrt_worker::replay::write(&replay, tile, &recorded.tile_seconds, &recorded.film).unwrap();
    // The reference is an independent SMP render (other threads, other tile size).
    let (reference, _) = smp_reference(&desc, &settings, 16);

    let m = emulate::run(
        &desc,
        &settings,
        &EmulatedRun {
            workers: 4,
            threads: 2,
            tile,
            window: parrt_runtime::window::Window::default(),
            max_batch: 8,
            pixel_format: parrt_protocol::PixelFormat::F32,
            link: LinkParams {
                latency: Duration::from_micros(500),
                worker_bps: 100e6 / 8.0,
                master_bps: 100e6 / 8.0,
            },
            replay,
            cost_scale: 1.0,
            worker_exe: EXE.into(),
            worker_prefix: vec!["worker".into()],
            timeout: Duration::from_secs(60),
            observers: Default::default(),
        },
    )
    .unwrap();
    assert_same_bits(&m.film, &reference, "emulated 4 × 2");
    assert_eq!(m.tiles, 63);
    assert_eq!(
        m.delivered, m.tiles as u64,
        "every tile delivered exactly once"
    );
    assert_eq!(m.rejected, 0);
    assert!(m.trace_s > 0.0);
    assert!(
        m.bytes_received as usize >= 72 * 56 * 3,
        "pixels crossed the relay"
    );
}

#[test]
fn bench_cluster_command_writes_json_rows() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("rows.json");
    let out = Command::new(EXE)
        .args([
            "bench", "cluster", "balls:1", "--size", "48", "--tile", "16",
        ])
        .args([
            "--workers",
            "1,2",
            "--threads",
            "2",
            "--work-seconds",
            "0.2",
        ])
        .args(["--latency-ms", "0.1", "--run-timeout", "60"])
        // The round-trip-sized window, end to end: still every tile once, the same image.
        .args(["--window", "auto"])
        .arg("--out")
        .arg(dir.path())
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for (row, workers) in rows.iter().zip([1, 2]) {
        assert_eq!(row["workers"], workers);
        assert_eq!(row["threads"], 2);
        assert_eq!(row["tile"], 16);
        assert_eq!(row["identical"], true);
        for key in ["efficiency", "predicted", "limit"] {
            let v = row[key].as_f64().unwrap();
            assert!(v > 0.0 && v <= 1.0 + 1e-9, "{key} = {v}");
        }
    }
    for f in ["cluster.md", "cluster.csv", "cluster.svg", "cluster.png"] {
        assert!(dir.path().join(f).is_file(), "{f}");
    }
}

#[test]
fn bad_cluster_flags_are_usage_errors() {
    for args in [
        &["--workers", "0"][..],
        &["--threads", "0"],
        &["--cost-scale", "-1"],
        &["--latency-ms", "nan"],
        &["--window", "0"],
        &["--window", "many"],
    ] {
        let out = Command::new(EXE)
            .args(["bench", "cluster", "balls:1", "--size", "16"])
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}
