//! The bench studies end to end through the real binary: `parrt bench efficiency` writes its
//! tables and plots, and `parrt bench simulate` replays a render's tile costs (and refuses tiles
//! that are not a multiple of the recorded ones).

use crate::{parrt, spd, stderr};

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
