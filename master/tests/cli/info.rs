//! `parrt info` end to end, through the real binary: every SPD scene gives exactly the counts of
//! `data/spd/README.md`'s first table (read from the Markdown itself), and malformed inputs
//! exit 2 with the right `file:line:column` and message.

use crate::parrt;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

fn info_json(path: &Path) -> Value {
    let p = path.to_str().expect("UTF-8 path");
    let out = parrt(&["info", "--json", p]);
    assert!(
        out.status.success(),
        "parrt info --json {p} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("info --json prints one JSON object")
}

// ---------------------------------------------------------------------------------------------
// The SPD table.

/// One row of the README's first table, as the Markdown says it.
#[derive(Debug)]
struct Row {
    file: String,
    spheres: u64,
    cylinders: u64,
    cones: u64,
    polygons: BTreeMap<u64, u64>,
    patches: BTreeMap<u64, u64>,
    total: u64,
    materials: u64,
    lights: u64,
    width: u64,
    height: u64,
    angle: f64,
    bytes: u64,
}

fn int(s: &str) -> u64 {
    s.trim()
        .parse()
        .unwrap_or_else(|e| panic!("README table: '{s}' is not an integer: {e}"))
}

/// `"0"` or `"4200 (4200 cyl, 0 cone)"` → (cylinders, cones).
fn cones_cell(s: &str) -> (u64, u64) {
    let s = s.trim();
    let Some((total, rest)) = s.split_once('(') else {
        assert_eq!(
            int(s),
            0,
            "README table: a c cell without a split must be 0: '{s}'"
        );
        return (0, 0);
    };
    let rest = rest.trim_end_matches(')');
    let mut cyl = None;
    let mut cone = None;
    for part in rest.split(',') {
        let mut it = part.split_whitespace();
        let n = int(it.next().unwrap_or(""));
        match it.next() {
            Some("cyl") => cyl = Some(n),
            Some("cone") => cone = Some(n),
            other => panic!("README table: unexpected c part {other:?} in '{s}'"),
        }
    }
    let (cyl, cone) = (cyl.expect("cyl count"), cone.expect("cone count"));
    assert_eq!(int(total), cyl + cone, "README table: c total in '{s}'");
    (cyl, cone)
}

/// `"0"` or `"9217×p4, 128×p144"` (prefix `p` or `pp`) → vertex count → number.
fn groups_cell(s: &str, prefix: &str) -> BTreeMap<u64, u64> {
    let s = s.trim();
    let mut m = BTreeMap::new();
    if s == "0" {
        return m;
    }
    for part in s.split(',') {
        let (n, k) = part
            .trim()
            .split_once('×')
            .unwrap_or_else(|| panic!("README table: '{part}' is not N×{prefix}K"));
        let k = k
            .strip_prefix(prefix)
            .unwrap_or_else(|| panic!("README table: '{part}' lacks '{prefix}'"));
        m.insert(int(k), int(n));
    }
    m
}

/// Reads the first Markdown table of the SPD README, finding columns by their header names.
fn spd_table() -> Vec<Row> {
    let readme = crate::support::spd_dir().join("README.md");
    let text = std::fs::read_to_string(&readme)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", readme.display()));
    let cells = |line: &str| -> Vec<String> {
        line.trim()
            .trim_matches('|')
            .split('|')
            .map(|c| c.trim().to_string())
            .collect()
    };
    let mut lines = text
        .lines()
        .skip_while(|l| !l.trim_start().starts_with('|'));
    let header = cells(lines.next().expect("README has a table"));
    let col = |name: &str| -> usize {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("README table has no column '{name}': {header:?}"))
    };
    let (file, s, c, p, pp, total, f, l, res, angle, bytes) = (
        col("file"),
        col("s"),
        col("c"),
        col("p (by vertex count)"),
        col("pp"),
        col("total prims"),
        col("f"),
        col("l"),
        col("resolution"),
        col("angle"),
        col("bytes"),
    );
    let mut rows = Vec::new();
    for line in lines.take_while(|l| l.trim_start().starts_with('|')) {
        let r = cells(line);
        if r.iter()
            .all(|c| c.chars().all(|ch| matches!(ch, '-' | ':')))
        {
            continue; // the |---| separator
        }
        assert_eq!(r.len(), header.len(), "README table row: {line}");
        let (cylinders, cones) = cones_cell(&r[c]);
        let mut wh = r[res].split_whitespace().map(int);
        rows.push(Row {
            file: r[file].clone(),
            spheres: int(&r[s]),
            cylinders,
            cones,
            polygons: groups_cell(&r[p], "p"),
            patches: groups_cell(&r[pp], "pp"),
            total: int(&r[total]),
            materials: int(&r[f]),
            lights: int(&r[l]),
            width: wh.next().expect("width"),
            height: wh.next().expect("height"),
            angle: r[angle].parse().expect("angle"),
            bytes: int(&r[bytes]),
        });
    }
    assert!(rows.len() >= 20, "README table: only {} rows", rows.len());
    rows
}

fn by_vertices(v: &Value) -> BTreeMap<u64, u64> {
    v.as_object()
        .expect("an object")
        .iter()
        .map(|(k, n)| {
            (
                k.parse().expect("vertex count key"),
                n.as_u64().expect("count"),
            )
        })
        .collect()
}

#[test]
fn info_json_matches_the_spd_readme_table_for_every_file() {
    let dir = crate::support::spd_dir();
    let rows = spd_table();
    // The table and the directory list the same files.
    let listed: Vec<String> = rows.iter().map(|r| r.file.clone()).collect();
    let mut present: Vec<String> = crate::support::spd_files()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let mut sorted = listed.clone();
    sorted.sort();
    present.sort();
    assert_eq!(sorted, present, "README table vs the .nff files present");

    for row in &rows {
        let j = info_json(&dir.join(&row.file));
        let get = |k: &str| {
            j[k].as_u64()
                .unwrap_or_else(|| panic!("{}: key '{k}' is not an integer: {}", row.file, j[k]))
        };
        let f = &row.file;
        let polygons: u64 = row.polygons.values().sum();
        let patches: u64 = row.patches.values().sum();
        assert_eq!(get("spheres"), row.spheres, "{f}: spheres");
        assert_eq!(get("cylinders"), row.cylinders, "{f}: cylinders");
        assert_eq!(get("cones"), row.cones, "{f}: cones");
        assert_eq!(get("polygons"), polygons, "{f}: polygons");
        assert_eq!(get("patches"), patches, "{f}: patches");
        assert_eq!(get("lights"), row.lights, "{f}: lights");
        assert_eq!(get("materials"), row.materials, "{f}: materials");
        assert_eq!(get("width"), row.width, "{f}: width");
        assert_eq!(get("height"), row.height, "{f}: height");
        assert_eq!(get("bytes"), row.bytes, "{f}: bytes");
        assert_eq!(get("primitives"), row.total, "{f}: total primitives");
        assert_eq!(
            row.spheres + row.cylinders + row.cones + polygons + patches,
            row.total,
            "{f}: the README row adds up"
        );
        assert_eq!(
            by_vertices(&j["polygons_by_vertices"]),
            row.polygons,
            "{f}: p by vertices"
        );
        assert_eq!(
            by_vertices(&j["patches_by_vertices"]),
            row.patches,
            "{f}: pp by vertices"
        );
        assert_eq!(j["camera"]["angle"].as_f64(), Some(row.angle), "{f}: angle");
        // Bounds: two finite 3-vectors, min ≤ max.
        let corner = |k: &str| -> Vec<f64> {
            j["bounds"][k]
                .as_array()
                .unwrap_or_else(|| panic!("{f}: bounds.{k}"))
                .iter()
                .map(|x| x.as_f64().expect("finite bound"))
                .collect()
        };
        let (lo, hi) = (corner("min"), corner("max"));
        assert_eq!((lo.len(), hi.len()), (3, 3), "{f}: bounds");
        assert!(
            lo.iter().zip(&hi).all(|(a, b)| a <= b),
            "{f}: bounds min ≤ max"
        );
    }
}

#[test]
fn info_human_output_is_an_aligned_summary() {
    let path = crate::support::spd_dir().join("gears-1.nff");
    let out = parrt(&["info", path.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "polygons    147  (145×p4, 2×p144)",
        "lights      5",
        "materials   2",
        "resolution  512 × 512",
        "parse time",
    ] {
        assert!(text.contains(needle), "missing '{needle}' in:\n{text}");
    }
    // Every value starts in the same column.
    let cols: Vec<usize> = text
        .lines()
        .map(|l| l.find("  ").unwrap() + l[l.find("  ").unwrap()..].find(|c| c != ' ').unwrap())
        .collect();
    assert!(cols.windows(2).all(|w| w[0] == w[1]), "{text}");
}

#[test]
fn info_help_explains_every_flag() {
    let out = parrt(&["info", "--help"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for flag in [
        "--json",
        "--max-vertices",
        "--max-pixels",
        "--max-primitives",
        "Exit status",
    ] {
        assert!(text.contains(flag), "--help lacks {flag}:\n{text}");
    }
}

// ---------------------------------------------------------------------------------------------
// Malformed inputs.

/// A valid view block on one line. Columns: from 3, at 14, up 23, angle 32 (value 38),
/// hither 41 (value 48), resolution 53 (width 64, height 67).
const V: &str = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 64 48\n";
const F: &str = "f 1 1 1 1 0 0 0 0\n";

/// Writes `content` to a temporary `name`, runs `parrt info` on it with `extra` flags, and checks
/// exit status 2 and `parrt: <path>:<line>:<col>: ...<phrase>...` on stderr.
fn bad(name: &str, content: &[u8], extra: &[&str], line: u32, col: u32, phrase: &str) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, content).unwrap();
    let p = path.to_str().unwrap();
    let mut args = vec!["info", p];
    args.extend_from_slice(extra);
    let out = parrt(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{name}: exit status; stderr: {err}"
    );
    let prefix = format!("parrt: {p}:{line}:{col}: ");
    assert!(
        err.starts_with(&prefix),
        "{name}: expected '{prefix}…', got: {err}"
    );
    assert!(
        err.contains(phrase),
        "{name}: expected '{phrase}' in: {err}"
    );
    assert!(out.stdout.is_empty(), "{name}: nothing on stdout");
}

fn s(parts: &[&str]) -> Vec<u8> {
    parts.concat().into_bytes()
}

#[test]
fn unknown_keyword() {
    bad(
        "kw.nff",
        &s(&[V, F, "q 1 2 3\n"]),
        &[],
        3,
        1,
        "unknown keyword 'q'",
    );
}

#[test]
fn sense8_header() {
    bad("sense8.nff", b"nff\nversion 2.0\n", &[], 1, 1, "Sense8");
}

#[test]
fn missing_view() {
    bad(
        "noview.nff",
        &s(&[F, "s 0 0 0 1\n"]),
        &[],
        3,
        1,
        "no view block",
    );
}

#[test]
fn empty_file_has_no_view() {
    bad("empty.nff", b"", &[], 1, 1, "no view block");
}

#[test]
fn second_view() {
    bad("twoviews.nff", &s(&[V, V]), &[], 2, 1, "second view block");
}

#[test]
fn truncated_in_a_vertex_list() {
    let src = s(&[V, F, "p 3\n0.5 0.5 0.5\n1.5 0.5 0.5\n0.5 1"]);
    bad("trunc.nff", &src, &[], 6, 6, "the z of polygon vertex 3");
    bad("trunc.nff", &src, &[], 6, 6, "end of the file");
}

#[test]
fn count_larger_than_the_vertices_that_follow() {
    let src = s(&[V, F, "p 4\n0 0 0\n1 0 0\n0 1 0\ns 0 0 0 1\n"]);
    bad(
        "mismatch.nff",
        &src,
        &[],
        7,
        1,
        "a number for the x of polygon vertex 4",
    );
}

#[test]
fn extra_field() {
    bad(
        "extra.nff",
        &s(&[V, F, "s 0 0 0 1 7\n"]),
        &[],
        3,
        11,
        "unexpected number '7' after the sphere",
    );
}

#[test]
fn nan() {
    bad(
        "nan.nff",
        &s(&[V, F, "s 0 0 0 nan\n"]),
        &[],
        3,
        9,
        "NaN and infinity are not allowed",
    );
}

#[test]
fn inf() {
    bad(
        "inf.nff",
        &s(&[V, F, "s 0 -inf 0 1\n"]),
        &[],
        3,
        5,
        "a finite number for the sphere centre's y",
    );
}

#[test]
fn overflowing_number() {
    bad(
        "big.nff",
        &s(&[V, F, "s 0 0 0 1e999\n"]),
        &[],
        3,
        9,
        "out of range",
    );
}

#[test]
fn bad_number() {
    bad(
        "123.nff",
        &s(&[V, F, "s 1.2.3 0 0 1\n"]),
        &[],
        3,
        3,
        "expected a number for the sphere centre's x, found '1.2.3'",
    );
}

#[test]
fn angle_zero_and_180() {
    let v0 = V.replace("angle 45", "angle 0");
    bad(
        "a0.nff",
        v0.as_bytes(),
        &[],
        1,
        38,
        "strictly between 0 and 180",
    );
    let v180 = V.replace("angle 45", "angle 180");
    bad(
        "a180.nff",
        v180.as_bytes(),
        &[],
        1,
        38,
        "strictly between 0 and 180",
    );
}

#[test]
fn from_equals_at() {
    let v = V.replace("from 0 0 5", "from 0 0 0");
    bad("fromat.nff", v.as_bytes(), &[], 1, 14, "same point");
}

#[test]
fn zero_up() {
    let v = V.replace("up 0 1 0", "up 0 0 0");
    bad(
        "zeroup.nff",
        v.as_bytes(),
        &[],
        1,
        23,
        "'up' vector is zero",
    );
}

#[test]
fn up_parallel_to_view() {
    let v = V.replace("up 0 1 0", "up 0 0 7");
    bad(
        "parallel.nff",
        v.as_bytes(),
        &[],
        1,
        23,
        "parallel to the view direction",
    );
}

#[test]
fn view_out_of_order() {
    let v = "v from 0 0 5 up 0 1 0 at 0 0 0 angle 45 hither 0.01 resolution 64 48\n";
    bad(
        "order.nff",
        v.as_bytes(),
        &[],
        1,
        14,
        "expected 'at' in the view block",
    );
}

#[test]
fn view_without_hither() {
    let v = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 resolution 64 48\n";
    bad(
        "nohither.nff",
        v.as_bytes(),
        &[],
        1,
        41,
        "expected 'hither'",
    );
}

#[test]
fn resolution_zero_and_negative() {
    let v = V.replace("resolution 64 48", "resolution 0 48");
    bad(
        "res0.nff",
        v.as_bytes(),
        &[],
        1,
        64,
        "resolution width must be at least 1",
    );
    let v = V.replace("resolution 64 48", "resolution 64 -48");
    bad(
        "resneg.nff",
        v.as_bytes(),
        &[],
        1,
        67,
        "a whole number (digits only) for the resolution height",
    );
}

#[test]
fn resolution_over_the_pixel_limit() {
    bad(
        "pixels.nff",
        V.as_bytes(),
        &["--max-pixels", "3000"],
        1,
        64,
        "--max-pixels",
    );
}

#[test]
fn polygon_with_two_vertices() {
    bad(
        "p2.nff",
        &s(&[V, F, "p 2\n0 0 0\n1 1 1\n"]),
        &[],
        3,
        3,
        "at least 3 vertices",
    );
}

/// Polygons and patches of zero area (a triangle of three equal vertices; collinear patches, as
/// SPD's teapot generator writes at size 1) are dropped with one warning that counts them and
/// names the first one's line; the rest of the file is read and rendered.
#[test]
fn polygons_of_zero_area_are_dropped_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flat.nff");
    let collinear_pp = "pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n2 0 0 0 0 1\n";
    let content = s(&[
        V,
        F,
        "s 0 0 0 1\n",                // line 3
        "p 3\n1 1 1\n1 1 1\n1 1 1\n", // line 4: three equal vertices
        "p 3\n0 0 0\n1 0 0\n0 1 0\n", // line 8: a real triangle
        collinear_pp,                 // line 12
        collinear_pp,                 // line 16
    ]);
    std::fs::write(&path, content).unwrap();
    let p = path.to_str().unwrap();
    let out = parrt(&["info", p, "--json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert_eq!(err.matches("of zero area").count(), 1, "one warning: {err}");
    assert!(
        err.contains(&format!(
            "parrt: warning: {p}:4:1: 3 polygons and patches of zero area dropped (the vertices \
             coincide or are collinear); the first is this polygon\n"
        )),
        "a line for people: {err}"
    );
    assert!(!err.contains("WARN"), "no log line by default: {err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(v["primitives"], 2, "{v}");
    assert_eq!(v["polygons"], 1, "{v}");
    assert_eq!(v["spheres"], 1, "{v}");
    // What is left renders.
    let img = dir.path().join("flat.png");
    let o = parrt(&["render", p, "-o", img.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn collinear_polygon() {
    bad(
        "line.nff",
        &s(&[V, F, "p 3\n0 0 0\n1 1 1\n2 2 2\n"]),
        &[],
        3,
        1,
        "zero area",
    );
}

#[test]
fn zero_area_patch() {
    let pp = "pp 3\n1 1 1 0 0 1\n1 1 1 0 0 1\n1 1 1 0 0 1\n";
    bad("pp.nff", &s(&[V, F, pp]), &[], 3, 1, "degenerate patch");
}

#[test]
fn cone_with_one_negative_radius() {
    bad(
        "cneg.nff",
        &s(&[V, F, "c 0 0 0 1 0 0 1 -0.5\n"]),
        &[],
        3,
        17,
        "exactly one negative radius",
    );
}

#[test]
fn cone_base_equals_apex() {
    bad(
        "caxis.nff",
        &s(&[V, F, "c 1 2 3 1 1 2 3 0.5\n"]),
        &[],
        3,
        1,
        "same point",
    );
}

#[test]
fn cone_with_zero_radii() {
    bad(
        "c00.nff",
        &s(&[V, F, "c 0 0 0 0\n0 0 1 0\n"]),
        &[],
        3,
        1,
        "both radii are zero",
    );
}

#[test]
fn sphere_radius_zero() {
    bad(
        "s0.nff",
        &s(&[V, F, "s 0 0 0 -0\n"]),
        &[],
        3,
        9,
        "sphere radius must not be zero",
    );
}

#[test]
fn huge_count_in_a_tiny_file_fails_on_the_count() {
    let src = s(&[V, F, "p 4000000000\n0 0 0\n"]);
    // Even with the vertex limit raised out of the way, the bytes left refuse the count.
    bad(
        "huge.nff",
        &src,
        &["--max-vertices", "4294967295"],
        3,
        3,
        "the count disagrees with the file",
    );
    bad(
        "huge.nff",
        &src,
        &[],
        3,
        3,
        "the count disagrees with the file",
    );
}

#[test]
fn count_over_the_vertex_limit() {
    let src = s(&[V, F, "p 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"]);
    bad(
        "maxv.nff",
        &src,
        &["--max-vertices", "3"],
        3,
        3,
        "--max-vertices",
    );
}

#[test]
fn too_many_primitives() {
    let src = s(&[V, F, "s 0 0 0 1\ns 0 0 3 1\n"]);
    bad(
        "maxp.nff",
        &src,
        &["--max-primitives", "1"],
        4,
        1,
        "--max-primitives",
    );
}

#[test]
fn non_integer_count() {
    bad(
        "p30.nff",
        &s(&[V, F, "p 3.0\n0 0 0\n1 0 0\n0 1 0\n"]),
        &[],
        3,
        3,
        "whole number",
    );
}

#[test]
fn light_with_four_or_five_numbers() {
    bad(
        "l4.nff",
        &s(&[V, "l 1 2 3 4\n", F]),
        &[],
        3,
        1,
        "a number for the light's green",
    );
    bad(
        "l5.nff",
        &s(&[V, "l 1 2 3 4 5\n", F]),
        &[],
        3,
        1,
        "a number for the light's blue",
    );
}

#[test]
fn material_with_seven_numbers() {
    bad(
        "f7.nff",
        &s(&[V, "f 1 1 1 1 0 0 0\ns 0 0 0 1\n"]),
        &[],
        3,
        1,
        "a number for the material's ior",
    );
}

#[test]
fn crlf_tabs_and_comments_keep_positions_right() {
    let src = "# a comment, s 0 0 0 1\r\nb 0 0 0\r\nv\r\nfrom 0 0 5\r\nat 0 0 0\r\nup 0 1 0\r\n\
               angle 45\r\nhither 1\r\nresolution 8 8\r\n\ts 0 0 0 x # trailing\r\n";
    bad(
        "crlf.nff",
        src.as_bytes(),
        &[],
        10,
        10,
        "the sphere radius, found 'x'",
    );
}

#[test]
fn non_utf8_bytes() {
    let mut src = s(&[V, F]);
    src.extend_from_slice(b"s 0 0 0 1\n\xff\xfe 1\n");
    bad("bin.nff", &src, &[], 4, 1, "unknown keyword");
}

#[test]
fn missing_file_exits_2_and_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no-such-scene.nff");
    let p = path.to_str().unwrap();
    let out = parrt(&["info", p]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.starts_with(&format!("parrt: {p}: cannot read the file")),
        "{err}"
    );
}

/// `info --json` says which precision `render --precision auto` would use and why.
#[test]
fn info_says_which_precision_auto_picks() {
    let v = info_json(&crate::support::spd_dir().join("mount-4.nff"));
    assert_eq!(v["precision"], "f32", "{v}");
    let why = v["precision_reason"].as_str().unwrap_or_default();
    assert!(why.contains("origin (0, 0, 0)"), "{why}");
    assert!(v["precision_s"].is_f64());
}
