//! `--costly-first FILE`: the master hands tiles out in the order a previous render's
//! `--tile-costs` ranks them, costliest first, and the image stays the SMP image bit for bit; a
//! file of another tiling is refused (exit 2) before anyone waits for workers.

use crate::identical::run_master_with_workers;
use crate::EXE;
use parrt_tests::*;

#[test]
fn the_costliest_tile_goes_out_first_and_the_image_is_the_smp_image() {
    let dir = tempfile::tempdir().unwrap();
    let desc = test_scene(64, 48);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, serde_json::to_string(&desc).unwrap()).unwrap();
    // Costs a previous frame might have measured: the last tile (raster order would hand it
    // out last) is the costliest, then the first; the rest cheap.
    let tiles = parrt_render::tile::tiles(64, 48, 8);
    let last = tiles.len() - 1;
    let mut secs = vec![0.001; tiles.len()];
    secs[last] = 0.5;
    secs[0] = 0.2;
    let costs = dir.path().join("costs.csv");
    parrt_master::studies::efficiency::write_tile_costs(&costs, &tiles, &secs).unwrap();
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, format!("{TEST_TOKEN}\n")).unwrap();
    let out = dir.path().join("out.png");
    let timeline = dir.path().join("timeline.json");
    let mut master = master_command(&scene, &costs);
    master
        .args(["--max-batch", "1", "--window", "1"])
        .arg("--token-file")
        .arg(&token_file)
        .arg("--timeline")
        .arg(&timeline)
        .arg("-o")
        .arg(&out)
        .env_remove("PARRT_TOKEN");
    let (status, log) = run_master_with_workers(&mut master, &[1]);
    assert!(status.success(), "master failed: {log}");
    assert_eq!(
        image::open(&out).unwrap().into_rgb8().into_raw(),
        reference.to_rgb8(),
        "the image does not depend on the order"
    );
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&timeline).unwrap()).unwrap();
    let mut handed: Vec<(f64, u64)> = t["tiles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["assigned_s"].as_f64().unwrap(),
                r["tile"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(handed.len(), tiles.len());
    handed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let first: Vec<u64> = handed.iter().take(2).map(|h| h.1).collect();
    assert_eq!(first, vec![last as u64, 0], "handed out first: {handed:?}");
}

#[test]
fn a_cost_file_of_another_tiling_is_refused_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let desc = test_scene(64, 48);
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, serde_json::to_string(&desc).unwrap()).unwrap();
    let tiles = parrt_render::tile::tiles(64, 48, 16);
    let costs = dir.path().join("costs.csv");
    parrt_master::studies::efficiency::write_tile_costs(&costs, &tiles, &vec![0.01; tiles.len()])
        .unwrap();
    let out = master_command(&scene, &costs)
        .arg("-o")
        .arg(dir.path().join("out.png"))
        .env("PARRT_TOKEN", TEST_TOKEN)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("costs.csv") && err.contains("12 tiles") && err.contains("48 tiles"),
        "{err}"
    );
}

/// `parrt master` on `scene`, tiles of 8, on a free loopback port, ordered by `costs`.
fn master_command(scene: &std::path::Path, costs: &std::path::Path) -> std::process::Command {
    let mut c = std::process::Command::new(EXE);
    c.args(["master", "--scene-json"])
        .arg(scene)
        .args([
            "--listen",
            "127.0.0.1:0",
            "--tile",
            "8",
            "--wait-workers",
            "30",
        ])
        .arg("--costly-first")
        .arg(costs);
    c
}
