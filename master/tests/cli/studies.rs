//! The bench studies end to end through the real binary: `parrt bench efficiency` writes its
//! tables and plots, and `parrt bench simulate` replays a render's tile costs (and refuses tiles
//! that are not a multiple of the recorded ones).

use crate::{parrt, spd, stderr};

/// `--frames N`: every run is the orbit of N frames as one job, on threads and through
/// workers; each CSV row says how many frames; `--frames 0` and a bad orbit are usage errors.
#[test]
fn efficiency_of_a_sequence_has_a_frames_column() {
    let dir = tempfile::tempdir().unwrap();
    let eff = dir.path().join("eff");
    let o = parrt(&[
        "bench",
        "efficiency",
        &spd("tetra-4.nff"),
        "--frames",
        "3",
        "--orbit",
        "60",
        "--sizes",
        "32",
        "--tiles",
        "16",
        "--threads",
        "1,2",
        "--accel",
        "bvh",
        "--executors",
        "queue",
        "--mode",
        "smp,distributed",
        "--repeat",
        "1",
        "--out",
        eff.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(eff.join("efficiency.md")).unwrap();
    assert_eq!(md.matches(", 3 frames: tracing**").count(), 2, "{md}");
    let csv = std::fs::read_to_string(eff.join("efficiency.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("table,threads,tile,tn_s,cost_s,efficiency,oversubscribed,frames")
    );
    // Two modes × (tracing + whole) × two thread counts, every one of 3 frames.
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 2 * 2 * 2, "{csv}");
    assert!(rows.iter().all(|r| r.ends_with(",3")), "{csv}");
    for (flag, value) in [("--frames", "0"), ("--orbit", "inf")] {
        let mut args = vec![
            "bench",
            "efficiency",
            "tetra:1",
            "--sizes",
            "8",
            "--tiles",
            "8",
        ];
        args.extend([
            "--threads",
            "1",
            "--repeat",
            "1",
            "--frames",
            "2",
            flag,
            value,
        ]);
        let out = dir.path().join("bad");
        args.extend(["--out", out.to_str().unwrap()]);
        let o = parrt(&args);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {}", stderr(&o));
        assert!(stderr(&o).contains(flag), "{flag}: {}", stderr(&o));
    }
}

#[test]
fn efficiency_and_simulate_write_tables_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let eff = dir.path().join("eff");
    let o = parrt(&[
        "bench",
        "efficiency",
        &spd("tetra-4.nff"),
        "--sizes",
        "32",
        "--tiles",
        "8,16",
        "--threads",
        "1,2",
        "--accel",
        "bvh",
        "--executors",
        "queue,guided",
        "--repeat",
        "1",
        "--out",
        eff.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(eff.join("efficiency.md")).unwrap();
    // Two executors × (tracing + whole) tables, each with a header and two thread rows.
    assert_eq!(
        md.matches("| threads | tile 8 | tile 16 |").count(),
        4,
        "{md}"
    );
    let csv = std::fs::read_to_string(eff.join("efficiency.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 2 * 2 * 2, "{csv}");
    for f in ["efficiency-32-bvh.svg", "efficiency-32-bvh.png"] {
        assert!(eff.join(f).is_file(), "{f}");
    }
    // Tile costs at tile 8 → the simulator.
    let costs = dir.path().join("costs.csv");
    let png = dir.path().join("t.png");
    let o = parrt(&[
        "render",
        &spd("tetra-4.nff"),
        "-o",
        png.to_str().unwrap(),
        "--width",
        "32",
        "--height",
        "32",
        "--tile",
        "8",
        "--threads",
        "1",
        "--tile-costs",
        costs.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let sim = dir.path().join("sim");
    let o = parrt(&[
        "bench",
        "simulate",
        "--tile-costs",
        costs.to_str().unwrap(),
        "--tiles",
        "8,16,32",
        "--workers",
        "1,2,64",
        "--out",
        sim.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(sim.join("simulate.md")).unwrap();
    assert_eq!(
        md.lines()
            .filter(|l| l.starts_with("| ") && !l.starts_with("| workers"))
            .count(),
        3,
        "{md}"
    );
    assert!(sim.join("simulate.png").is_file());
    let o = parrt(&[
        "bench",
        "simulate",
        "--tile-costs",
        costs.to_str().unwrap(),
        "--tiles",
        "12",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not a multiple"));
}
