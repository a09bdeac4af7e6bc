//! `parrt scene FILE --format pov` end to end: an SPD file becomes a POV-Ray scene with one
//! object per primitive (a polygon as its triangles, concave gears too), to stdout or to a file
//! named `*.pov`; the scene file itself as the output, `--factor` with a file and a malformed scene
//! exit 2.

use crate::{parrt, spd, stderr};

/// The text `parrt ARGS` printed, after checking it succeeded.
fn converted(args: &[&str]) -> String {
    let o = parrt(args);
    assert_eq!(o.status.code(), Some(0), "parrt {args:?}: {}", stderr(&o));
    String::from_utf8(o.stdout).expect("UTF-8 scene")
}

#[test]
fn an_spd_file_becomes_one_pov_object_per_primitive() {
    // balls-3: 820 spheres and one square floor, two materials, three lights.
    let pov = converted(&["scene", &spd("balls-3.nff"), "--format", "pov"]);
    assert_eq!(pov.matches("sphere {").count(), 820);
    assert_eq!(pov.matches("    triangle {").count(), 2);
    assert_eq!(pov.matches("light_source {").count(), 3);
    assert_eq!(pov.matches("#declare txt").count(), 2);
    assert_eq!(pov.matches("camera {").count(), 1);
    // gears-1: 145 quadrilaterals and two concave 144-gons, all as triangles (n - 2 each).
    let pov = converted(&["scene", &spd("gears-1.nff"), "--format", "pov"]);
    assert_eq!(pov.matches("    triangle {").count(), 145 * 2 + 2 * 142);
    assert_eq!(pov.matches("polygon {").count(), 0);
    // tree-6: 127 cones, open like Haines' cylinders and cones.
    let pov = converted(&["scene", &spd("tree-6.nff"), "--format", "pov"]);
    assert_eq!(pov.matches(" open\n").count(), 127);
    // teapot-2: 240 patches as smooth triangles.
    let pov = converted(&["scene", &spd("teapot-2.nff"), "--format", "pov"]);
    assert_eq!(pov.matches("smooth_triangle {").count(), 240);
}

#[test]
fn the_output_file_names_the_format() {
    let dir = tempfile::tempdir().unwrap();
    let pov = dir.path().join("balls.pov");
    let o = parrt(&["scene", &spd("balls-3.nff"), "-o", pov.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&pov)
        .unwrap()
        .starts_with("// POV-Ray"));
    // Any other name writes NFF, which reads back to the same scene.
    let nff = dir.path().join("balls.txt");
    let o = parrt(&["scene", &spd("balls-3.nff"), "-o", nff.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let limits = Default::default();
    assert_eq!(
        parrt_render::nff::parse_file(&nff, &limits).unwrap(),
        parrt_render::nff::parse_file(std::path::Path::new(&spd("balls-3.nff")), &limits).unwrap()
    );
    // A generated scene as POV-Ray: the same objects as its NFF.
    let pov = converted(&["scene", "tetra", "--factor", "2", "--format", "pov"]);
    assert_eq!(pov.matches("    triangle {").count(), 16);
}

#[test]
fn the_scene_is_never_overwritten_and_bad_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.nff");
    let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 8 8\n\
                f 1 0 0 1 0 0 0 0\ns 0 0 0 1\n";
    std::fs::write(&scene, text).unwrap();
    let s = scene.to_str().unwrap();
    let o = parrt(&["scene", s, "-o", s]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o),
        format!("parrt: the scene {s} and -o {s} are the same file; give each its own\n")
    );
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), text);
    let o = parrt(&["scene", s, "--factor", "2"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o),
        format!("parrt: --factor makes a generated scene; {s} is a file\n")
    );
    // A malformed scene: the file, line and column, exit 2.
    std::fs::write(&scene, "s 0 0 0\n").unwrap();
    let o = parrt(&["scene", s, "--format", "pov"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).starts_with(&format!("parrt: {}:", scene.display())),
        "{}",
        stderr(&o)
    );
    assert!(o.stdout.is_empty());
}
