//! `parrt info`: reads one NFF file with the strict parser and prints what it contains — counts,
//! bounds, camera, resolution, parse time — as an aligned summary or as one JSON object whose
//! integer keys are a stable contract (docs/design.md, *Command line contract*). It never renders
//! or modifies anything.

use crate::cli_args::LimitArgs;
use crate::exit::input_error;
use clap::Args;
use parrt_render::description::{Bounds, SceneDescription};
use parrt_render::nff::{self, NffErrorKind, ParsedNff, Summary};
use parrt_render::precision::Choice;
use parrt_render::settings::Precision;
use parrt_render::vec3::Vec3d;
use serde_json::{json, Map, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Arguments of `parrt info`.
#[derive(Debug, Args)]
#[command(after_help = "\
Exit status: 0 the file is valid NFF; 2 bad input: the file is malformed (the message is \
'parrt: FILE:LINE:COLUMN: what was expected'), exceeds a limit, or cannot be read (missing, \
unreadable: the message names the path); 1 any other failure (e.g. stdout closed).

With --json, the keys spheres, cones (radii differ), cylinders (equal radii), polygons (p), \
patches (pp), lights, materials (f lines), width, height (integers) and bounds \
({\"min\":[x,y,z],\"max\":[x,y,z]}, null for a scene without primitives) are stable; \
polygons_by_vertices, patches_by_vertices, primitives, default_material_inserted, camera, \
background, file, bytes, parse_s, precision (what --precision auto would render with: f32 or \
f64), precision_reason and precision_s (seconds the estimate took) are extra.")]
pub struct InfoArgs {
    /// The NFF file to read (Eric Haines' Neutral File Format, as the SPD generators write it).
    #[arg(value_name = "SCENE.nff")]
    pub scene: PathBuf,
    /// Print one JSON object (machine-readable, stable keys) instead of the readable summary.
    #[arg(long)]
    pub json: bool,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// Runs `parrt info`.
pub fn run(args: InfoArgs) -> anyhow::Result<ExitCode> {
    let name = args.scene.display().to_string();
    // A file named on the command line that cannot be read is bad input too (exit 2).
    let bytes = args.limits.read_file(&args.scene)?;
    let t0 = Instant::now();
    let parsed = nff::parse_bytes(&bytes, &name, &args.limits.limits()).map_err(|e| {
        if e.kind == NffErrorKind::Io {
            input_error(anyhow::anyhow!("{}: {}", e.file, e.message))
        } else {
            input_error(e)
        }
    })?;
    let parse_s = t0.elapsed().as_secs_f64();
    let summary = Summary::of(&parsed);
    let t1 = Instant::now();
    let choice = parrt_render::precision::resolve(Precision::Auto, &parsed.description);
    let precision = (choice, t1.elapsed().as_secs_f64());
    let text = if args.json {
        let mut s = serde_json::to_string_pretty(&to_json(
            &name,
            bytes.len(),
            &parsed,
            &summary,
            parse_s,
            &precision,
        ))?;
        s.push('\n');
        s
    } else {
        human(&name, bytes.len(), &parsed, &summary, parse_s, &precision)
    };
    std::io::stdout().lock().write_all(text.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

fn arr(v: Vec3d) -> Value {
    json!([v.x, v.y, v.z])
}

fn by_vertices(m: &BTreeMap<usize, usize>) -> Value {
    Value::Object(
        m.iter()
            .map(|(k, v)| (k.to_string(), json!(v)))
            .collect::<Map<String, Value>>(),
    )
}

fn bounds_json(b: &Bounds) -> Value {
    if b.is_empty() {
        Value::Null
    } else {
        json!({"min": arr(b.min), "max": arr(b.max)})
    }
}

/// The `--json` object. The first keys are a stable contract (docs/design.md, *Command line
/// contract*): never rename them.
fn to_json(
    file: &str,
    bytes: usize,
    parsed: &ParsedNff,
    s: &Summary,
    parse_s: f64,
    (choice, precision_s): &(Choice, f64),
) -> Value {
    let d: &SceneDescription = &parsed.description;
    let v = &d.view;
    json!({
        "spheres": s.spheres,
        "cones": s.cones,
        "cylinders": s.cylinders,
        "polygons": s.polygons,
        "patches": s.patches,
        "lights": s.lights,
        "materials": s.materials,
        "width": v.width,
        "height": v.height,
        "bounds": bounds_json(&s.bounds),
        "polygons_by_vertices": by_vertices(&s.polygons_by_vertices),
        "patches_by_vertices": by_vertices(&s.patches_by_vertices),
        "primitives": s.primitives(),
        "default_material_inserted": parsed.default_material_inserted,
        "camera": {
            "from": arr(v.from),
            "at": arr(v.at),
            "up": arr(v.up),
            "angle": v.angle,
            "hither": v.hither,
        },
        "background": arr(d.background),
        "file": file,
        "bytes": bytes,
        "parse_s": parse_s,
        "precision": parrt_render::precision::name(choice.precision),
        "precision_reason": choice.reason,
        "precision_s": precision_s,
        "isa": parrt_render::isa::current(),
    })
}

fn v3(v: Vec3d) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

fn groups(m: &BTreeMap<usize, usize>, prefix: &str) -> String {
    m.iter()
        .map(|(k, n)| format!("{n}×{prefix}{k}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The readable summary: one aligned `label  value` line per fact.
fn human(
    file: &str,
    bytes: usize,
    parsed: &ParsedNff,
    s: &Summary,
    parse_s: f64,
    (choice, precision_s): &(Choice, f64),
) -> String {
    let d = &parsed.description;
    let v = &d.view;
    let mut rows: Vec<(&str, String)> = vec![
        ("file", format!("{file} ({bytes} bytes)")),
        ("spheres", s.spheres.to_string()),
        ("cones", s.cones.to_string()),
        ("cylinders", s.cylinders.to_string()),
    ];
    let with_groups = |n: usize, m: &BTreeMap<usize, usize>, prefix: &str| {
        if n == 0 {
            "0".to_string()
        } else {
            format!("{n}  ({})", groups(m, prefix))
        }
    };
    rows.push((
        "polygons",
        with_groups(s.polygons, &s.polygons_by_vertices, "p"),
    ));
    rows.push((
        "patches",
        with_groups(s.patches, &s.patches_by_vertices, "pp"),
    ));
    rows.push(("primitives", s.primitives().to_string()));
    rows.push(("lights", s.lights.to_string()));
    let mut materials = s.materials.to_string();
    if parsed.default_material_inserted {
        materials.push_str("  (+ a default white material for primitives before the first f)");
    }
    rows.push(("materials", materials));
    rows.push((
        "bounds",
        if s.bounds.is_empty() {
            "empty (no primitives)".to_string()
        } else {
            format!("min {}  max {}", v3(s.bounds.min), v3(s.bounds.max))
        },
    ));
    rows.push(("from", v3(v.from)));
    rows.push(("at", v3(v.at)));
    rows.push(("up", v3(v.up)));
    rows.push(("angle", format!("{}°", v.angle)));
    rows.push(("hither", v.hither.to_string()));
    rows.push(("resolution", format!("{} × {}", v.width, v.height)));
    rows.push(("background", v3(d.background)));
    let mbps = if parse_s > 0.0 {
        format!("  ({:.0} MB/s)", bytes as f64 / parse_s / 1e6)
    } else {
        String::new()
    };
    rows.push(("parse time", format!("{:.3} ms{mbps}", parse_s * 1e3)));
    rows.push((
        "precision",
        format!(
            "{} ({}; estimated in {:.3} ms)",
            parrt_render::precision::name(choice.precision),
            choice.reason,
            precision_s * 1e3
        ),
    ));
    rows.push(("isa", parrt_render::isa::current().to_string()));
    let width = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    let mut out = String::new();
    for (label, value) in rows {
        let _ = writeln!(out, "{label:<width$}  {value}");
    }
    out
}
