//! `--timeline FILE`: every tile once, on a thread or worker that exists, inside the trace
//! phase; JSON and CSV agree with what the render did; the image does not change.

use crate::EXE;
use std::process::Command;

fn render(dir: &std::path::Path, out: &str, extra: &[&str]) {
    let o = Command::new(EXE)
        .args([
            "render", "--scene", "balls:2", "--width", "96", "--height", "64",
        ])
        .args(["--tile", "16", "--threads", "2", "-o"])
        .arg(dir.join(out))
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn smp_timeline_has_every_tile_once_on_a_thread() {
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), "plain.png", &[]);
    let tl = dir.path().join("t.json");
    render(
        dir.path(),
        "timed.png",
        &["--timeline", tl.to_str().unwrap()],
    );
    assert_eq!(
        std::fs::read(dir.path().join("plain.png")).unwrap(),
        std::fs::read(dir.path().join("timed.png")).unwrap(),
        "the timeline must not change the image"
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&tl).unwrap()).unwrap();
    assert_eq!(v["mode"], "smp");
    assert_eq!(
        (v["width"].as_u64(), v["tile_size"].as_u64()),
        (Some(96), Some(16))
    );
    let trace = v["trace_s"].as_f64().unwrap();
    assert_eq!(v["rows"].as_array().unwrap().len(), 2);
    let tiles = v["tiles"].as_array().unwrap();
    let mut ids: Vec<u64> = tiles.iter().map(|t| t["tile"].as_u64().unwrap()).collect();
    ids.sort_unstable();
    assert_eq!(ids, (0..24).collect::<Vec<u64>>());
    // No two tiles overlap on one thread; every span lies in the trace phase.
    let mut spans: Vec<(u64, f64, f64)> = Vec::new();
    for t in tiles {
        let th = t["thread"].as_u64().expect("SMP tiles name their thread");
        assert!(th < 2);
        assert_eq!(t["worker"], format!("thread {th}"));
        assert_eq!(t["attempt"], "first");
        let (s, e) = (t["start_s"].as_f64().unwrap(), t["end_s"].as_f64().unwrap());
        assert!(
            0.0 <= s && s <= e && e <= trace + 1e-6,
            "{t} (trace {trace})"
        );
        spans.push((th, s, e));
    }
    spans.sort_by(|a, b| (a.0, a.1).partial_cmp(&(b.0, b.1)).unwrap());
    for w in spans.windows(2) {
        if w[0].0 == w[1].0 {
            assert!(
                w[0].2 <= w[1].1 + 1e-9,
                "overlap on thread {}: {w:?}",
                w[0].0
            );
        }
    }
}

#[test]
fn distributed_timeline_csv_names_the_workers_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    render(dir.path(), "smp.png", &[]);
    let tl = dir.path().join("t.csv");
    render(
        dir.path(),
        "dist.png",
        &["--workers", "2", "--timeline", tl.to_str().unwrap()],
    );
    assert_eq!(
        std::fs::read(dir.path().join("smp.png")).unwrap(),
        std::fs::read(dir.path().join("dist.png")).unwrap()
    );
    let text = std::fs::read_to_string(&tl).unwrap();
    assert!(text.starts_with("# mode=distributed"), "{text}");
    assert!(text.contains("\nrecord,tile,worker,thread,assigned_s,start_s,end_s,attempt,detail\n"));
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("# row=")).collect();
    assert_eq!(rows.len(), 2, "{text}");
    let mut accepted = Vec::new();
    for l in text.lines().filter(|l| l.starts_with("tile,")) {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 9, "{l}");
        assert!(
            rows.iter().any(|r| r.contains(&format!("row={} ", f[2]))),
            "{l}"
        );
        let (a, s, e): (f64, f64, f64) = (
            f[4].parse().unwrap(),
            f[5].parse().unwrap(),
            f[6].parse().unwrap(),
        );
        assert!(a <= s + 1e-9 && s <= e, "{l}");
        if f[7] != "duplicate-ignored" {
            accepted.push(f[1].parse::<u32>().unwrap());
        }
    }
    accepted.sort_unstable();
    assert_eq!(
        accepted,
        (0..24).collect::<Vec<u32>>(),
        "each tile in the image once"
    );
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with("worker-ready,"))
            .count(),
        2
    );

    // The standalone plot reads it back.
    for ext in ["svg", "png"] {
        let out = dir.path().join(format!("t.{ext}"));
        let o = Command::new(EXE)
            .arg("plot-timeline")
            .arg(&tl)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(std::fs::metadata(&out).unwrap().len() > 1000);
    }
    let o = Command::new(EXE)
        .args(["plot-timeline"])
        .arg(dir.path().join("smp.png"))
        .args(["-o"])
        .arg(dir.path().join("x.svg"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "not a timeline is bad input");
}

/// The (frame, tile) of every tile record of `v` that is in the image (not an ignored
/// duplicate), sorted.
fn frame_tiles(v: &serde_json::Value) -> Vec<(u64, u64)> {
    let mut got: Vec<(u64, u64)> = v["tiles"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|t| t["attempt"] != "duplicate-ignored")
        .map(|t| {
            let frame = t["frame"]
                .as_u64()
                .unwrap_or_else(|| panic!("no frame: {t}"));
            (frame, t["tile"].as_u64().unwrap())
        })
        .collect();
    got.sort_unstable();
    got
}

/// The timeline of a 3-frame sequence, on this machine's threads and through two workers (in
/// CSV, read back by `plot-timeline`'s reader): every tile of every frame once, with its
/// frame; the frames are the same bytes as without a timeline.
#[test]
fn a_sequences_timeline_has_every_tile_of_every_frame_once_with_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    let want: Vec<(u64, u64)> = (0..3).flat_map(|f| (0..24).map(move |t| (f, t))).collect();
    let seq = |out: &str, extra: &[&str]| {
        let o = Command::new(EXE)
            .args([
                "render", "--scene", "balls:2", "--orbit", "90", "--frames", "3",
            ])
            .args([
                "--width",
                "96",
                "--height",
                "64",
                "--tile",
                "16",
                "--threads",
                "2",
            ])
            .arg("-o")
            .arg(dir.path().join(out).join("f-%d.png"))
            .args(extra)
            .env_remove("PARRT_WORKER_TILE_DELAY_MS")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    seq("plain", &[]);
    let smp = dir.path().join("smp.json");
    seq("smp", &["--timeline", smp.to_str().unwrap()]);
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&smp).unwrap()).unwrap();
    assert_eq!(v["mode"], "smp");
    assert_eq!(frame_tiles(&v), want);
    let csv = dir.path().join("dist.csv");
    seq(
        "dist",
        &["--workers", "2", "--timeline", csv.to_str().unwrap()],
    );
    let t = parrt_master::timeline::Timeline::read(&csv).unwrap();
    assert_eq!(t.mode, "distributed");
    let v = serde_json::to_value(&t).unwrap();
    assert_eq!(frame_tiles(&v), want);
    for k in 0..3 {
        let plain = std::fs::read(dir.path().join(format!("plain/f-{k}.png"))).unwrap();
        for out in ["smp", "dist"] {
            let p = dir.path().join(format!("{out}/f-{k}.png"));
            assert_eq!(std::fs::read(p).unwrap(), plain, "{out} frame {k}");
        }
    }
    // The plot marks where each frame was complete: three frame lines.
    assert_eq!(parrt_master::timeline::plot::frame_ends(&t).len(), 3);
}
