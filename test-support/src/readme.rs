//! The two Markdown tables of the SPD directory's README (per-file counts, default-scene
//! cameras), read so the tests compare our generators and our parser against the numbers SPD's
//! own outputs have. Never generates anything itself.

use parrt_render::description::{SceneDescription, Shape};
use std::collections::BTreeMap;

/// Primitive counts of a scene, keyed as the README keys them.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counts {
    /// Spheres.
    pub spheres: u64,
    /// Cones with equal radii.
    pub cylinders: u64,
    /// Cones with different radii.
    pub cones: u64,
    /// Polygons by vertex count.
    pub polygons: BTreeMap<usize, u64>,
    /// Patches by vertex count.
    pub patches: BTreeMap<usize, u64>,
}

impl Counts {
    /// Counts the primitives of a description.
    pub fn of(desc: &SceneDescription) -> Counts {
        let mut c = Counts::default();
        for p in &desc.primitives {
            match &p.shape {
                Shape::Sphere { .. } => c.spheres += 1,
                Shape::Cone(cone) if cone.is_cylinder() => c.cylinders += 1,
                Shape::Cone(_) => c.cones += 1,
                Shape::Polygon(v) => *c.polygons.entry(v.len()).or_default() += 1,
                Shape::Patch(v) => *c.patches.entry(v.len()).or_default() += 1,
            }
        }
        c
    }

    /// Total primitives.
    pub fn total(&self) -> u64 {
        self.spheres
            + self.cylinders
            + self.cones
            + self.polygons.values().sum::<u64>()
            + self.patches.values().sum::<u64>()
    }
}

/// One row of the README's file table.
#[derive(Debug, Clone)]
pub struct FileRow {
    /// File name (`balls-4.nff`).
    pub file: String,
    /// Generator name.
    pub generator: String,
    /// Size factor.
    pub size: u32,
    /// Role (`compiled default`, `small`, ...).
    pub role: String,
    /// Counts by kind.
    pub counts: Counts,
    /// Total primitives as the table states it.
    pub total: u64,
    /// `f` lines.
    pub materials: u64,
    /// `l` lines.
    pub lights: u64,
    /// Resolution.
    pub resolution: (u32, u32),
    /// Field of view.
    pub angle: f64,
}

/// One row of the README's camera table.
#[derive(Debug, Clone)]
pub struct CameraRow {
    /// Generator name.
    pub scene: String,
    /// Background colour.
    pub background: [f64; 3],
    /// Eye.
    pub from: [f64; 3],
    /// Look-at point.
    pub at: [f64; 3],
    /// Up vector.
    pub up: [f64; 3],
    /// Field of view.
    pub angle: f64,
    /// Hither distance.
    pub hither: f64,
    /// Number of lights.
    pub lights: u64,
}

/// The README's tables.
#[derive(Debug)]
pub struct Readme {
    /// The file table.
    pub files: Vec<FileRow>,
    /// The camera table (default-size scenes).
    pub cameras: Vec<CameraRow>,
}

fn cells(line: &str) -> Vec<String> {
    let t = line.trim();
    let t = t.strip_prefix('|').unwrap_or(t);
    let t = t.strip_suffix('|').unwrap_or(t);
    t.split('|').map(|c| c.trim().replace("**", "")).collect()
}

/// Every Markdown table in `text` as (header, rows).
fn tables(text: &str) -> Vec<(Vec<String>, Vec<Vec<String>>)> {
    let mut out = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    while i + 1 < lines.len() {
        let is_sep =
            |l: &str| l.trim_start().starts_with("|---") || l.trim_start().starts_with("| ---");
        if lines[i].trim_start().starts_with('|') && is_sep(lines[i + 1]) {
            let header = cells(lines[i]);
            let mut rows = Vec::new();
            i += 2;
            while i < lines.len() && lines[i].trim_start().starts_with('|') {
                rows.push(cells(lines[i]));
                i += 1;
            }
            out.push((header, rows));
        } else {
            i += 1;
        }
    }
    out
}

fn int(s: &str, what: &str) -> u64 {
    s.trim()
        .parse()
        .unwrap_or_else(|_| panic!("README: {what} '{s}' is not an integer"))
}

fn float(s: &str, what: &str) -> f64 {
    s.trim()
        .parse()
        .unwrap_or_else(|_| panic!("README: {what} '{s}' is not a number"))
}

/// The first three numbers of a cell such as `-0.816497 -0.816497 0.816497 (not ⟂ view)`.
fn triple(s: &str, what: &str) -> [f64; 3] {
    let v: Vec<f64> = s
        .split_whitespace()
        .map_while(|t| t.parse::<f64>().ok())
        .collect();
    assert!(
        v.len() >= 3,
        "README: {what} '{s}' does not start with 3 numbers"
    );
    [v[0], v[1], v[2]]
}

/// `1×p4, 128×p144` (or `0`) → {4: 1, 144: 128}; `prefix` is `p` or `pp`.
fn by_vertices(s: &str, prefix: &str, what: &str) -> BTreeMap<usize, u64> {
    let mut m = BTreeMap::new();
    if s.trim() == "0" {
        return m;
    }
    for part in s.split(',') {
        let (n, kind) = part
            .split_once('×')
            .unwrap_or_else(|| panic!("README: {what} part '{part}' is not N×{prefix}V"));
        let v = kind
            .trim()
            .strip_prefix(prefix)
            .unwrap_or_else(|| panic!("README: {what} part '{part}' does not say {prefix}"));
        m.insert(int(v, what) as usize, int(n, what));
    }
    m
}

/// `4200 (4200 cyl, 0 cone)` or `0` → (cylinders, cones).
fn cones(s: &str) -> (u64, u64) {
    let s = s.trim();
    let Some((total, rest)) = s.split_once('(') else {
        assert_eq!(
            int(s, "c"),
            0,
            "README: cone cell '{s}' has no cyl/cone split"
        );
        return (0, 0);
    };
    let mut cyl = None;
    let mut cone = None;
    for part in rest.trim_end_matches(')').split(',') {
        let mut it = part.split_whitespace();
        let n = int(it.next().unwrap_or(""), "c");
        match it.next() {
            Some("cyl") => cyl = Some(n),
            Some("cone") => cone = Some(n),
            other => panic!("README: unexpected cone part {other:?} in '{s}'"),
        }
    }
    let (cyl, cone) = (cyl.expect("cyl count"), cone.expect("cone count"));
    assert_eq!(
        cyl + cone,
        int(total, "c"),
        "README: cone cell '{s}' does not add up"
    );
    (cyl, cone)
}

/// Reads the README of the SPD directory.
pub fn readme() -> Readme {
    let path = crate::spd_dir().join("README.md");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut files = Vec::new();
    let mut cameras = Vec::new();
    for (header, rows) in tables(&text) {
        let col = |name: &str| {
            header
                .iter()
                .position(|h| h == name)
                .unwrap_or_else(|| panic!("README table lacks column '{name}': {header:?}"))
        };
        match header.first().map(String::as_str) {
            Some("file") => {
                let (cf, cg, cs, cr) = (col("file"), col("generator"), col("-s"), col("role"));
                let (c_s, c_c, c_p, c_pp) =
                    (col("s"), col("c"), col("p (by vertex count)"), col("pp"));
                let (ct, c_f, c_l, c_res, c_ang) = (
                    col("total prims"),
                    col("f"),
                    col("l"),
                    col("resolution"),
                    col("angle"),
                );
                for r in rows {
                    let (cyl, cone) = cones(&r[c_c]);
                    let res: Vec<u32> = r[c_res]
                        .split_whitespace()
                        .map(|t| int(t, "resolution") as u32)
                        .collect();
                    assert_eq!(res.len(), 2, "README: resolution '{}'", r[c_res]);
                    files.push(FileRow {
                        file: r[cf].clone(),
                        generator: r[cg].clone(),
                        size: int(&r[cs], "-s") as u32,
                        role: r[cr].clone(),
                        counts: Counts {
                            spheres: int(&r[c_s], "s"),
                            cylinders: cyl,
                            cones: cone,
                            polygons: by_vertices(&r[c_p], "p", "p"),
                            patches: by_vertices(&r[c_pp], "pp", "pp"),
                        },
                        total: int(&r[ct], "total prims"),
                        materials: int(&r[c_f], "f"),
                        lights: int(&r[c_l], "l"),
                        resolution: (res[0], res[1]),
                        angle: float(&r[c_ang], "angle"),
                    });
                }
            }
            Some("scene") => {
                let (cs, cb, cfr, cat, cup) =
                    (col("scene"), col("b"), col("from"), col("at"), col("up"));
                let (ca, ch, cl) = (col("angle"), col("hither"), col("lights"));
                let mut first_b: Option<[f64; 3]> = None;
                for r in rows {
                    let b = if r[cb] == "same" {
                        first_b.expect("README: 'same' background before any colour")
                    } else {
                        triple(&r[cb], "b")
                    };
                    first_b.get_or_insert(b);
                    cameras.push(CameraRow {
                        scene: r[cs].clone(),
                        background: b,
                        from: triple(&r[cfr], "from"),
                        at: triple(&r[cat], "at"),
                        up: triple(&r[cup], "up"),
                        angle: float(&r[ca], "angle"),
                        hither: float(&r[ch], "hither"),
                        lights: int(&r[cl], "lights"),
                    });
                }
            }
            _ => {}
        }
    }
    assert!(!files.is_empty(), "README: no file table found");
    assert!(!cameras.is_empty(), "README: no camera table found");
    Readme { files, cameras }
}

/// True when `a` and `b` agree to SPD's printing precision (`%g`, 6 significant digits).
pub fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 6e-6 * b.abs().max(a.abs()) + 1e-9
}

/// [`close`] for triples.
pub fn close3(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| close(*x, y))
}
