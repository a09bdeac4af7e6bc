//! `parrt bench accuracy`: speed against error (docs/design-measures.md, *Accuracy*). Renders a
//! reference (f64, no cut-off, depth 16, 16 samples per pixel) and a grid of configurations per
//! scene, and writes the tables (Markdown, CSV) and Pareto plots (SVG, PNG) to an output directory.
//! The pieces live in [`crate::studies::accuracy`]; this file only parses arguments and writes
//! files.

use crate::cli_args::size::parse_size;
use crate::cli_args::{LimitArgs, SceneSpec};
use crate::exit::input_error;
use crate::studies::accuracy::configs::{grid, Config};
use crate::studies::accuracy::plot::{self, PlotPoint, Series};
use crate::studies::accuracy::report;
use crate::studies::accuracy::study::{self, StudyOptions};
use anyhow::Context;
use clap::Args;
use parrt_render::settings::Precision;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `parrt bench accuracy`.
#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Scenes: NFF files or generated scenes as NAME[:SIZE].
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE", required_unless_present = "replot")]
    pub scenes: Vec<String>,
    /// Image size in pixels of the reference and every configuration: WxH, or N for NxN.
    #[arg(long, value_name = "WxH", default_value = "256x256")]
    pub size: String,
    /// Output directory for accuracy.md (with a page per scene, accuracy-SCENE.md),
    /// accuracy.csv and the plots.
    #[arg(long, value_name = "DIR", default_value = "accuracy-out")]
    pub out: PathBuf,
    /// Render threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Renders per configuration; the median trace time is reported.
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub repeat: usize,
    /// Measure the full cross product (160 configurations per scene) instead of the pruned grid.
    #[arg(long)]
    pub full: bool,
    /// Render nothing: draw the Pareto plots again from an `accuracy.csv` this command wrote
    /// (into --out; --size and --machine name the run in the titles).
    #[arg(long, value_name = "CSV")]
    pub replot: Option<PathBuf>,
    /// With --replot: the machine the CSV was measured on, for the titles (default: this one).
    #[arg(long, value_name = "TEXT", requires = "replot")]
    pub machine: Option<String>,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// The title of a scene's Pareto plot.
fn pareto_title(label: &str, width: u32, height: u32, machine: &str) -> String {
    format!("{label} {width}×{height}: trace time vs RMSE on {machine}")
}

/// `--replot`: the Pareto plots of every scene in an `accuracy.csv`.
fn replot(
    args: &AccuracyArgs,
    csv: &std::path::Path,
    width: u32,
    height: u32,
) -> anyhow::Result<ExitCode> {
    let text =
        std::fs::read_to_string(csv).with_context(|| format!("cannot read {}", csv.display()))?;
    let machine = args.machine.clone().unwrap_or_else(crate::machine::machine);
    let scenes = read_points(csv, &text)?;
    crate::cli_args::output::prepare_out_dir(&args.out)?;
    for (label, points) in &scenes {
        plot::write(
            &args.out.join(format!("pareto-{}", stem(label))),
            &pareto_title(label, width, height, &machine),
            points,
        )?;
    }
    crate::errln!(
        "parrt: drew {} Pareto plots in {}",
        scenes.len(),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The points of every scene in an `accuracy.csv` read from `path` (named in errors, with the
/// line).
fn read_points(
    path: &std::path::Path,
    text: &str,
) -> anyhow::Result<Vec<(String, Vec<PlotPoint>)>> {
    let mut scenes: Vec<(String, Vec<PlotPoint>)> = Vec::new();
    let bad = |line: u64, what: &str| {
        input_error(anyhow::anyhow!("{} line {line}: {what}", path.display()))
    };
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_reader(text.as_bytes());
    let line_of = |e: &csv::Error| e.position().map_or(1, csv::Position::line);
    let header = reader
        .headers()
        .map_err(|e| bad(line_of(&e), &e.to_string()))?;
    if header.iter().ne(report::CSV_HEADER) {
        return Err(bad(1, "not the header of accuracy.csv"));
    }
    for record in reader.records() {
        let f = record.map_err(|e| bad(line_of(&e), &e.to_string()))?;
        let n = f.position().map_or(0, csv::Position::line);
        let row = || bad(n, "not a row of accuracy.csv");
        if f.len() != report::CSV_HEADER.len() {
            return Err(row());
        }
        let num = |i: usize| f[i].parse::<f64>().map_err(|_| row());
        let config = Config {
            cutoff: num(1)?,
            depth: f[2].parse().map_err(|_| row())?,
            precision: if &f[3] == "f64" {
                Precision::F64
            } else {
                Precision::F32
            },
            spp: f[4].parse().map_err(|_| row())?,
        };
        let point = PlotPoint {
            time: num(5)?,
            rmse: num(7)?,
            series: series(&config),
            is_default: config.is_default(),
            on_front: &f[15] == "true",
        };
        match scenes.iter_mut().find(|s| s.0 == f[0]) {
            Some(s) => s.1.push(point),
            None => scenes.push((f[0].to_string(), vec![point])),
        }
    }
    Ok(scenes)
}

fn series(c: &Config) -> Series {
    if c.spp > 1 {
        Series::FourSamples
    } else if c.precision == Precision::F64 {
        Series::F64OneSample
    } else {
        Series::F32OneSample
    }
}

/// A file-name-safe stem for a scene label.
fn stem(label: &str) -> String {
    let base = std::path::Path::new(label)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| label.to_string());
    base.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Runs `parrt bench accuracy`.
pub fn run(args: AccuracyArgs) -> anyhow::Result<ExitCode> {
    let (width, height) = parse_size(&args.size)?;
    // The studies render in tiles of 32; the image is checked against the pixel limit before
    // anything is allocated, as in every bench.
    args.limits.check_image(width, height, 32)?;
    if let Some(csv) = &args.replot {
        return replot(&args, csv, width, height);
    }
    if args.threads == Some(0) || args.repeat == 0 {
        return Err(input_error(anyhow::anyhow!(
            "--threads and --repeat must be at least 1"
        )));
    }
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let opts = StudyOptions {
        width,
        height,
        threads,
        repeat: args.repeat,
    };
    let specs = args
        .scenes
        .iter()
        .map(|s| SceneSpec::parse(s))
        .collect::<anyhow::Result<Vec<_>>>()?;
    crate::cli_args::output::prepare_out_dir(&args.out)?;
    let configs = grid(args.full);
    let mut studies = Vec::new();
    for spec in &specs {
        let (desc, _) = spec.load(&args.limits.limits())?;
        let label = stem(&spec.label());
        let st = study::run(&label, &desc, &configs, &opts, &|line| {
            crate::errln!("{line}")
        })?;
        let front = report::front_of(&st);
        let points: Vec<PlotPoint> = st
            .rows
            .iter()
            .enumerate()
            .map(|(i, r)| PlotPoint {
                time: r.time,
                rmse: r.error.rmse,
                series: series(&r.config),
                is_default: r.config.is_default(),
                on_front: front.contains(&i),
            })
            .collect();
        plot::write(
            &args.out.join(format!("pareto-{label}")),
            &pareto_title(&label, width, height, &crate::machine::machine()),
            &points,
        )?;
        studies.push(st);
    }
    let md = report::markdown(&studies, width, height, threads);
    let mut pages = vec![("accuracy.md".to_string(), md.clone())];
    for st in &studies {
        pages.push((report::page_name(st), report::scene_page(st, width, height)));
    }
    for (name, text) in pages {
        let path = args.out.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let csv_path = args.out.join("accuracy.csv");
    std::fs::write(&csv_path, report::csv(&studies)?)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    crate::outln!("{md}");
    crate::errln!("parrt: wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replot_reads_what_the_study_wrote_and_names_bad_lines() {
        use crate::studies::accuracy::metrics::ImageError;
        use crate::studies::accuracy::study::{Row, SceneStudy};
        let e = ImageError {
            rmse: 0.01,
            psnr: 40.0,
            max: 0.1,
            off: 0.0,
        };
        let row = |cutoff, spp| Row {
            config: Config {
                cutoff,
                depth: 5,
                precision: Precision::F32,
                spp,
            },
            time: 0.5,
            rays: 10,
            error: e,
            truncation: e,
        };
        let study = SceneStudy {
            scene: "a, \"b\"".into(),
            reference_time: 1.0,
            reference_rays: 100,
            rows: vec![row(0.001, 1), row(0.01, 4)],
        };
        let text = report::csv(&[study]).expect("writes");
        let path = std::path::Path::new("acc.csv");
        let scenes = read_points(path, &text).expect("reads");
        assert_eq!(scenes.len(), 1);
        assert_eq!(scenes[0].0, "a, \"b\"");
        assert_eq!(scenes[0].1.len(), 2);
        assert_eq!(scenes[0].1[1].series, Series::FourSamples);
        let err = |t: &str| read_points(path, t).expect_err("bad input").to_string();
        let mut lines: Vec<&str> = text.lines().collect();
        assert_eq!(err(""), "acc.csv line 1: not the header of accuracy.csv");
        assert_eq!(
            err("scene,cutoff\n"),
            "acc.csv line 1: not the header of accuracy.csv"
        );
        lines.push("s,1,2");
        assert_eq!(
            err(&lines.join("\n")),
            "acc.csv line 4: not a row of accuracy.csv"
        );
        lines.pop();
        let broken = lines[2].replacen(",5,", ",five,", 1);
        lines[2] = &broken;
        assert_eq!(
            err(&lines.join("\n")),
            "acc.csv line 3: not a row of accuracy.csv"
        );
    }

    #[test]
    fn stems_are_file_names() {
        assert_eq!(stem("data/spd/mount-6.nff"), "mount-6");
        assert_eq!(stem("mount:6"), "mount_6");
    }
}
