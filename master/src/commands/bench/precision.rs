//! `parrt bench precision`: renders each scene moved by 1e0 … 1e8 (the direction turning through
//! positive, negative and mixed signs) and scaled by 1e-6 … 1e6, in f32 (rebased into the
//! camera-relative frame), f64 and auto, against the f64 render of the untransformed scene:
//! share of pixels off by more than 1/255, the largest error, the precision auto chose, trace
//! time (the errors by [`crate::studies::accuracy::metrics`], as the accuracy study measures them).
//! Writes precision.md, precision.csv and two plots (translation, scale) as SVG and PNG.

use crate::cli_args::size::parse_size;
use crate::cli_args::{LimitArgs, SceneSpec};
use crate::exit::input_error;
use crate::machine::machine;
use crate::plot::{save_chart, Chart, Series};
use crate::studies::accuracy::metrics::{compare, ImageError};
use anyhow::Context;
use clap::Args;
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::render::Renderer;
use parrt_render::settings::{Precision, RenderSettings};
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_render::vec3::Vec3d;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `parrt bench precision`.
#[derive(Debug, Args)]
pub struct PrecisionArgs {
    /// Scenes: NFF files, generated scenes as NAME[:SIZE], or soup[:SIZE] (the sliver soup).
    /// Default: mount:6, gears:2, teapot:6 and soup:2.
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE")]
    pub scenes: Vec<String>,
    /// Image size in pixels of every render: WxH, or N for NxN.
    #[arg(long, value_name = "WxH", default_value = "128x128")]
    pub size: String,
    /// Output directory for precision.md, precision.csv and the plots.
    #[arg(long, value_name = "DIR", default_value = "precision-out")]
    pub out: PathBuf,
    /// Render threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// One transformed copy: `x ↦ scale·x + shift`.
#[derive(Clone, Copy, Debug)]
struct Placement {
    /// `"move"` or `"scale"`.
    kind: &'static str,
    /// The magnitude plotted: |shift| per axis, or the scale.
    magnitude: f64,
    scale: f64,
    shift: Vec3d,
}

/// Translations by 10^k, k = 0…8, turning through (+,+,+), (−,−,−) and (+,−,+½); scales
/// 10^k, k = −6…6 in steps of 2 (1 is the reference itself).
fn placements() -> Vec<Placement> {
    let dirs = [
        Vec3d::new(1.0, 1.0, 1.0),
        Vec3d::new(-1.0, -1.0, -1.0),
        Vec3d::new(1.0, -1.0, 0.5),
    ];
    let mut out: Vec<Placement> = (0..=8)
        .map(|k| {
            let m = 10f64.powi(k);
            Placement {
                kind: "move",
                magnitude: m,
                scale: 1.0,
                shift: dirs[k as usize % 3] * m,
            }
        })
        .collect();
    out.extend([-6, -4, -2, 2, 4, 6].map(|k| {
        let m = 10f64.powi(k);
        Placement {
            kind: "scale",
            magnitude: m,
            scale: m,
            shift: Vec3d::zero(),
        }
    }));
    out
}

/// One measured render.
struct Row {
    scene: String,
    place: Placement,
    mode: Precision,
    used: Precision,
    off: f64,
    max_err: f64,
    trace_s: f64,
}

fn render(
    desc: &SceneDescription,
    s: &RenderSettings,
    threads: usize,
) -> anyhow::Result<(Film, Precision, f64)> {
    let r = Renderer::new(desc, s).map_err(input_error)?;
    let used = r.settings().precision;
    let res = render_smp(
        &r,
        &SmpOptions {
            threads,
            tile: 16,
            executor: Executor::Queue,
        },
        &|_, _| {},
    );
    Ok((res.film, used, res.trace_s))
}

/// Loads a scene argument (the one scene parser's); `soup[:N]` is the sliver soup, not in the
/// generator list. Returns the label the files use (`mount-6`, `soup-2`) with the scene.
fn load(arg: &str, limits: &LimitArgs) -> anyhow::Result<(String, SceneDescription)> {
    let spec = SceneSpec::parse(arg)?;
    if let SceneSpec::Generated { name, size } = &spec {
        if name == "soup" {
            let size = size.unwrap_or(parrt_scenes::soup::DEFAULT_SIZE);
            let desc = parrt_scenes::soup::generate(size).map_err(input_error)?;
            return Ok((format!("soup-{size}"), desc));
        }
    }
    let (desc, _) = spec.load(&limits.limits())?;
    Ok((arg.replace(':', "-"), desc))
}

fn name(p: Precision) -> &'static str {
    parrt_render::precision::name(p)
}

/// The modes measured for every placement, in the order of the report's columns.
const MODES: [Precision; 3] = [Precision::F32, Precision::F64, Precision::Auto];

/// Renders every scene in every placement and mode, and compares each image with the
/// untransformed scene's f64 render.
fn measure(
    scenes: &[(String, SceneDescription)],
    width: u32,
    height: u32,
    threads: usize,
) -> anyhow::Result<Vec<Row>> {
    let mut rows = Vec::new();
    for (scene, desc) in scenes {
        let mut s = RenderSettings::new(width, height);
        s.precision = Precision::F64;
        let (reference, _, _) = render(desc, &s, threads)?;
        for place in placements() {
            let moved = desc.transformed(place.scale, place.shift);
            for mode in MODES {
                s.precision = mode;
                let (film, used, trace_s) = render(&moved, &s, threads)?;
                // Share of pixels off by more than 1/255 and the largest channel error, by the
                // accuracy study's rule (channels clamped to [0, 1], NaN read as 0).
                let ImageError {
                    off, max: max_err, ..
                } = compare(&film.pixels, &reference.pixels);
                crate::errln!(
                    "{scene} {} {:e} {}: {} off {:.4}% max {max_err:.4} trace {trace_s:.3}s",
                    place.kind,
                    place.magnitude,
                    name(mode),
                    name(used),
                    off * 100.0
                );
                rows.push(Row {
                    scene: scene.clone(),
                    place,
                    mode,
                    used,
                    off,
                    max_err,
                    trace_s,
                });
            }
        }
    }
    Ok(rows)
}

/// The plots of pixels off against the translation and against the scale, f32 and auto.
fn plots(
    args: &PrecisionArgs,
    scenes: &[(String, SceneDescription)],
    rows: &[Row],
    (width, height): (u32, u32),
    machine: &str,
) -> anyhow::Result<()> {
    let labels: Vec<&str> = scenes.iter().map(|s| s.0.as_str()).collect();
    let title_scenes = labels.join(", ");
    for (kind, file, x_label) in [
        (
            "move",
            "precision",
            "log10 of the translation per axis (scene units)",
        ),
        ("scale", "precision-scale", "log10 of the scale factor"),
    ] {
        let mut series = Vec::new();
        for (scene, _) in scenes {
            for mode in [Precision::F32, Precision::Auto] {
                let points = rows
                    .iter()
                    .filter(|r| &r.scene == scene && r.mode == mode && r.place.kind == kind)
                    .map(|r| (r.place.magnitude.log10(), r.off * 100.0))
                    .collect();
                series.push(Series {
                    label: format!("{scene} {}", name(mode)),
                    points,
                    line: true,
                });
            }
        }
        let chart = Chart {
            title: format!("{title_scenes}: {width}x{height}, {machine}"),
            x_label: x_label.to_string(),
            y_label: "pixels off by more than 1/255 (%; goal: at most 0.1)".to_string(),
            series,
            log_x: false,
            y_range: Some((-0.005, 0.1)),
            reference: None,
        };
        save_chart(
            &chart,
            &args.out.join(format!("{file}.svg")),
            &args.out.join(format!("{file}.png")),
        )?;
    }
    Ok(())
}

/// `precision.csv`: a record per scene, placement and mode.
fn csv_of(rows: &[Row]) -> anyhow::Result<Vec<u8>> {
    let mut csv = csv::Writer::from_writer(Vec::new());
    csv.write_record([
        "scene",
        "kind",
        "magnitude",
        "shift_x",
        "shift_y",
        "shift_z",
        "scale",
        "mode",
        "used",
        "off",
        "max_err",
        "trace_s",
    ])?;
    for r in rows {
        csv.write_record([
            r.scene.clone(),
            r.place.kind.to_string(),
            format!("{:e}", r.place.magnitude),
            r.place.shift.x.to_string(),
            r.place.shift.y.to_string(),
            r.place.shift.z.to_string(),
            format!("{:e}", r.place.scale),
            name(r.mode).to_string(),
            name(r.used).to_string(),
            format!("{:.6}", r.off),
            format!("{:.6}", r.max_err),
            format!("{:.4}", r.trace_s),
        ])?;
    }
    Ok(csv.into_inner()?)
}

/// `precision.md`: a row per scene and placement, the three modes side by side.
fn markdown(rows: &[Row], (width, height): (u32, u32), threads: usize, machine: &str) -> String {
    let mut md = format!(
        "Pixels off by more than 1/255 against the untransformed scene's f64 render, largest channel \
         error, and trace seconds; {width}×{height}, {threads} threads, {machine}. `used` is what auto \
         chose.\n\n| scene | transform | f32 off | f32 max | f64 off | f64 max | auto (used) off | auto max | f32 s | f64 s | auto s |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for group in rows.chunks(MODES.len()) {
        let [a, b, c] = group else { continue };
        let t = &a.place;
        let how = if t.kind == "move" {
            format!("move ({:e}, {:e}, {:e})", t.shift.x, t.shift.y, t.shift.z)
        } else {
            format!("scale {:e}", t.scale)
        };
        let _ = writeln!(
            md,
            "| {} | {how} | {:.2}% | {:.3} | {:.2}% | {:.3} | {:.2}% ({}) | {:.3} | {:.3} | {:.3} | {:.3} |",
            a.scene,
            a.off * 100.0,
            a.max_err,
            b.off * 100.0,
            b.max_err,
            c.off * 100.0,
            name(c.used),
            c.max_err,
            a.trace_s,
            b.trace_s,
            c.trace_s
        );
    }
    md
}

/// Runs `parrt bench precision`.
pub fn run(args: PrecisionArgs) -> anyhow::Result<ExitCode> {
    let (width, height) = parse_size(&args.size)?;
    // Rendered in tiles of 16; the image is checked against the pixel limit before anything is
    // allocated, as in every bench.
    args.limits.check_image(width, height, 16)?;
    if args.threads == Some(0) {
        return Err(input_error(anyhow::anyhow!("--threads must be at least 1")));
    }
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let names = if args.scenes.is_empty() {
        ["mount:6", "gears:2", "teapot:6", "soup:2"]
            .map(String::from)
            .to_vec()
    } else {
        args.scenes.clone()
    };
    let scenes = names
        .iter()
        .map(|n| load(n, &args.limits))
        .collect::<anyhow::Result<Vec<_>>>()?;
    crate::cli_args::output::prepare_out_dir(&args.out)?;
    let rows = measure(&scenes, width, height, threads)?;
    let machine = machine();
    plots(&args, &scenes, &rows, (width, height), &machine)?;
    let md = markdown(&rows, (width, height), threads, &machine);
    let md_path = args.out.join("precision.md");
    std::fs::write(&md_path, &md).with_context(|| format!("cannot write {}", md_path.display()))?;
    let csv_path = args.out.join("precision.csv");
    std::fs::write(&csv_path, csv_of(&rows)?)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    crate::outln!("{md}");
    crate::errln!("parrt: wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placements_cover_both_signs_and_every_magnitude() {
        let p = placements();
        let moves: Vec<_> = p.iter().filter(|p| p.kind == "move").collect();
        assert_eq!(moves.len(), 9);
        assert!(moves.iter().any(|m| m.shift.x < 0.0));
        assert!(moves.iter().any(|m| m.shift.x > 0.0 && m.shift.y < 0.0));
        assert_eq!(moves.last().map(|m| m.magnitude), Some(1e8));
        let scales: Vec<f64> = p
            .iter()
            .filter(|p| p.kind == "scale")
            .map(|p| p.scale)
            .collect();
        assert_eq!(scales, vec![1e-6, 1e-4, 1e-2, 1e2, 1e4, 1e6]);
    }
}
