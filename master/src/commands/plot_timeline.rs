//! `parrt plot-timeline`: draws a timeline written by `--timeline` as SVG or PNG.

use crate::exit::input_error;
use crate::timeline::{plot, Timeline};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `parrt plot-timeline`.
#[derive(Debug, Args)]
pub struct PlotTimelineArgs {
    /// A timeline written by `--timeline` (.json or .csv).
    #[arg(value_name = "TIMELINE")]
    pub file: PathBuf,
    /// The plot: .svg or .png.
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Title (default: scene, size, mode and machine from the timeline).
    #[arg(long, value_name = "TEXT")]
    pub title: Option<String>,
}

/// Runs `parrt plot-timeline`.
pub fn run(args: PlotTimelineArgs) -> anyhow::Result<ExitCode> {
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("svg" | "png")) {
        return Err(input_error(anyhow::anyhow!(
            "-o {}: the plot is written as .svg or .png",
            args.output.display()
        )));
    }
    crate::cli_args::output::check_file_output(&args.output)?;
    // The timeline is the user's input: one that is missing, unreadable or not a timeline is
    // bad input (exit 2), as a scene file that cannot be read is.
    let t = Timeline::read(&args.file).map_err(input_error)?;
    let title = args.title.unwrap_or_else(|| plot::title(&t));
    plot::save(&t, &args.output, &title)?;
    crate::errln!(
        "parrt: drew {} ({} tiles, {} events)",
        args.output.display(),
        t.tiles.len(),
        t.events.len()
    );
    Ok(ExitCode::SUCCESS)
}
