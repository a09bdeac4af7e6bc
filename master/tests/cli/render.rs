//! `parrt render` end to end through the real binary: outputs, machine-readable statistics,
//! exit codes for bad input, the precision it picks, its help.

use crate::{parrt, spd, stderr};
use std::path::Path;

fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).expect("image written");
    assert_eq!(&bytes[1..4], b"PNG");
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (be(16), be(20))
}

#[test]
fn renders_png_and_writes_stats_json_and_tile_costs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.png");
    let json = dir.path().join("s.json");
    let costs = dir.path().join("c.csv");
    let o = parrt(&[
        "render",
        &spd("mount-4.nff"),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "48",
        "--height",
        "32",
        "--tile",
        "16",
        "--stats-json",
        json.to_str().unwrap(),
        "--tile-costs",
        costs.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(png_size(&out), (48, 32));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for key in [
        "eye_rays",
        "eye_hits",
        "shadow_rays",
        "shadow_hits",
        "reflection_rays",
        "reflection_hits",
        "refraction_rays",
        "refraction_hits",
        "box_tests",
        "primitive_tests",
    ] {
        assert!(v[key].is_u64(), "{key} missing or not an integer: {v}");
    }
    for key in ["parse_s", "build_s", "trace_s"] {
        assert!(v[key].is_f64(), "{key} missing: {v}");
    }
    assert_eq!(v["eye_rays"], 48 * 32);
    // auto is the default, and says what it chose and why.
    assert_eq!(v["precision"], "f32", "{v}");
    let why = v["precision_reason"].as_str().unwrap_or_default();
    assert!(why.starts_with("auto: f32 resolves it"), "{why}");
    // Mount's glass spheres refract.
    assert!(v["refraction_rays"].as_u64().unwrap() > 0);
    let csv = std::fs::read_to_string(&costs).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 * 2, "{csv}");
}

#[test]
fn writes_ppm_and_exr() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["ppm", "exr"] {
        let out = dir.path().join(format!("t.{ext}"));
        let o = parrt(&[
            "render",
            &spd("tetra-4.nff"),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "20",
            "--height",
            "20",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(std::fs::metadata(&out).unwrap().len() > 20 * 20);
    }
}

#[test]
fn bad_usage_exits_2_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("x.png");
    let png = png.to_str().unwrap();
    let scene = spd("tetra-4.nff");
    let ck = dir.path().join("render.ck");
    let ck = ck.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["render", &scene, "-o", png, "--tile", "0"], "--tile"),
        (
            vec!["render", &scene, "-o", png, "--threads", "0"],
            "--threads",
        ),
        (
            vec!["render", &scene, "-o", "out.gif"],
            "unknown image format",
        ),
        (
            vec!["render", &scene, "-o", png, "--max-depth", "0"],
            "max depth",
        ),
        (
            vec!["render", &scene, "-o", png, "--max-depth", "1000"],
            "max depth",
        ),
        (
            vec!["render", &scene, "-o", png, "--cutoff", "2"],
            "cut-off",
        ),
        (
            vec!["render", &scene, "-o", png, "--spp", "0"],
            "samples per pixel",
        ),
        (
            vec!["render", &scene, "-o", png, "--width", "0"],
            "no pixels",
        ),
        (
            vec!["render", &scene, "-o", png, "--accel", "octree"],
            "invalid value",
        ),
        (
            vec![
                "render", &scene, "-o", png, "--width", "100000", "--height", "100000",
            ],
            "over the limit",
        ),
        (
            vec!["render", &scene, "--scene", "mount", "-o", png],
            "not both",
        ),
        (
            vec!["render", "--scene", "mount:x", "-o", png],
            "not a whole number",
        ),
        (
            vec!["render", "/nonexistent/scene.nff", "-o", png],
            "cannot read",
        ),
        (vec!["render", "--bogus-flag"], "unexpected argument"),
        (
            vec!["render", &scene, "-o", png, "--checkpoint", ck],
            "--checkpoint records the tiles of a render through workers; add --workers N",
        ),
        (
            vec!["bench", "simulate", "--tile-costs", "/nonexistent.csv"],
            "cannot read",
        ),
    ];
    for (args, phrase) in cases {
        let o = parrt(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(phrase),
            "{args:?}: expected '{phrase}' in: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn precision_flag_forces_one_and_stats_say_why() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.png");
    let o = parrt(&[
        "render",
        &spd("mount-4.nff"),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--precision",
        "f64",
        "--stats",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("precision"))
        .unwrap_or_else(|| panic!("no precision line in --stats: {text}"));
    assert!(line.contains("f64 (forced; f32 resolves it"), "{line}");
    let bad = parrt(&["render", &spd("mount-4.nff"), "--precision", "f16"]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn help_explains_every_render_flag() {
    let o = parrt(&["render", "--help"]);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout);
    for flag in [
        "--threads",
        "--tile",
        "--accel",
        "--executor",
        "--width",
        "--height",
        "--max-depth",
        "--cutoff",
        "--spp",
        "--spd-standard",
        "--stats",
        "--stats-json",
        "--workers",
        "--tile-costs",
        "--precision",
    ] {
        assert!(help.contains(flag), "--help lacks {flag}");
    }
}

/// A write that fails part-way (the file-size limit reached: `ulimit -f`, SIGXFSZ ignored so
/// the write itself fails) exits 1 naming the image and leaves no partial file: the old image
/// at the path is as it was, and no temporary file is left beside it. Each format, and both
/// the 8-bit (PNG, PPM) and the linear (EXR) film.
#[test]
fn a_write_that_fails_part_way_leaves_no_partial_file() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["png", "ppm", "exr"] {
        let out = dir.path().join(format!("m.{ext}"));
        std::fs::write(&out, b"the old image").unwrap();
        let o = std::process::Command::new("sh")
            .args(["-c", "trap '' XFSZ; ulimit -f 2 && exec \"$0\" \"$@\""])
            .arg(env!("CARGO_BIN_EXE_parrt"))
            .args(["render", "--scene", "balls:2", "--size", "160x120", "-o"])
            .arg(&out)
            .env_remove("PARRT_LOG")
            .output()
            .expect("sh runs");
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{ext}: {err}");
        assert!(
            err.contains(&format!("cannot write image {}", out.display())),
            "{ext}: {err}"
        );
        assert_eq!(std::fs::read(&out).unwrap(), b"the old image", "{ext}");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.starts_with('.'))
            .collect();
        assert!(names.is_empty(), "{ext}: left behind: {names:?}");
    }
}
