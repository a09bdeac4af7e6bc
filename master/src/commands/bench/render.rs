//! `parrt bench render`: times full renders (parse or generate, build, trace) of one or more
//! scenes, K times each, and prints the medians with Mrays/s as a Markdown table.

use crate::cli_args::{LimitArgs, RenderFlags, SceneSpec};
use crate::exit::input_error;
use crate::studies::efficiency::median;
use clap::Args;
use parrt_render::render::Renderer;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use std::process::ExitCode;

/// Arguments of `parrt bench render`.
#[derive(Debug, Args)]
pub struct BenchRenderArgs {
    /// Scenes: NFF files or generated scenes as NAME[:SIZE] (default: mount:6 and balls:4).
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE")]
    pub scenes: Vec<String>,
    /// Render threads.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub threads: usize,
    /// Tile edge in pixels.
    #[arg(long, value_name = "S", default_value_t = 32)]
    pub tile: u32,
    /// Runs per scene; the median is reported.
    #[arg(long, value_name = "K", default_value_t = 3)]
    pub repeat: usize,
    /// Render settings (use --width/--height 512 for the paper's size).
    #[command(flatten)]
    pub render: RenderFlags,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// Runs `parrt bench render`.
pub fn run(args: BenchRenderArgs) -> anyhow::Result<ExitCode> {
    if args.repeat == 0 || args.threads == 0 || args.tile == 0 {
        return Err(input_error(anyhow::anyhow!(
            "--repeat, --threads and --tile must be at least 1"
        )));
    }
    let names = if args.scenes.is_empty() {
        vec!["mount:6".to_string(), "balls:4".to_string()]
    } else {
        args.scenes.clone()
    };
    crate::outln!(
        "| scene | size | prims | parse s | build s | trace s | total s | rays | Mrays/s |"
    );
    crate::outln!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for name in &names {
        let spec = SceneSpec::parse(name)?;
        let (mut parse, mut build, mut trace) = (Vec::new(), Vec::new(), Vec::new());
        let mut rays = 0;
        let mut prims = 0;
        let mut size = (0, 0);
        for _ in 0..args.repeat {
            let (desc, parse_s) = spec.load(&args.limits.limits())?;
            let settings = args.render.settings(&desc)?;
            args.limits
                .check_image(settings.width, settings.height, args.tile)?;
            size = (settings.width, settings.height);
            let r = Renderer::new(&desc, &settings).map_err(input_error)?;
            prims = r.build_info().primitives;
            let res = render_smp(
                &r,
                &SmpOptions {
                    threads: args.threads,
                    tile: args.tile,
                    executor: Executor::Queue,
                },
                &|_, _| {},
            );
            parse.push(parse_s);
            build.push(r.build_info().build_s);
            trace.push(res.trace_s);
            rays = res.stats.total_rays();
        }
        let (p, b, t) = (median(&parse), median(&build), median(&trace));
        crate::outln!(
            "| {} | {}x{} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {} | {:.2} |",
            spec.label(),
            size.0,
            size.1,
            prims,
            p,
            b,
            t,
            p + b + t,
            rays,
            rays as f64 / t / 1e6
        );
    }
    Ok(ExitCode::SUCCESS)
}
