//! `parrt bench cast`: ray-casting throughput on the rays Embree's `nffcast` harness casts (eye
//! rays through pixel centres, one shadow ray per light per hit, no shading), repeated for at
//! least `--mintime` seconds, reported as Mrays/s.

use crate::cli_args::{AccelArg, LimitArgs, SceneSpec};
use crate::exit::input_error;
use clap::Args;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use std::process::ExitCode;
use std::time::Instant;

/// Arguments of `parrt bench cast`.
#[derive(Debug, Args)]
pub struct CastArgs {
    /// Scenes: NFF files or NAME[:SIZE].
    // `NAME[:SIZE]` is usage notation in clap's help text (printed verbatim), not a link.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(value_name = "SCENE", required = true)]
    pub scenes: Vec<String>,
    /// Image size in pixels, WxH or N for NxN (default: the scene's resolution).
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Skip shadow rays to lights behind the surface (Embree harness: -cull).
    #[arg(long)]
    pub cull: bool,
    /// Cast each ray on its own instead of eye rays in 4×4 packets with their shadow rays.
    #[arg(long)]
    pub no_packets: bool,
    /// Repeat frames until at least this many seconds were timed.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub mintime: f64,
    /// Acceleration structure.
    #[arg(long, value_enum, default_value_t = AccelArg::Bvh)]
    pub accel: AccelArg,
    /// Parser limits.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// Runs `parrt bench cast` (one thread).
pub fn run(args: CastArgs) -> anyhow::Result<ExitCode> {
    if !args.mintime.is_finite() || args.mintime < 0.0 {
        return Err(input_error(anyhow::anyhow!(
            "--mintime must be a non-negative number"
        )));
    }
    crate::outln!(
        "| scene | prims | build s | rays/frame | eye hits | shadow rays | frames | Mrays/s | Mrays/CPU-s |"
    );
    crate::outln!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for name in &args.scenes {
        let spec = SceneSpec::parse(name)?;
        let (desc, _) = spec.load(&args.limits.limits())?;
        let (w, h) = match &args.size {
            Some(s) => crate::cli_args::size::parse_size(s)?,
            None => (desc.view.width, desc.view.height),
        };
        args.limits.check_image(w, h, 32)?;
        let mut settings = RenderSettings::new(w, h);
        settings.accel = args.accel.kind();
        let mut r = Renderer::new(&desc, &settings).map_err(input_error)?;
        r.set_packets(!args.no_packets);
        let tiles = parrt_render::tile::tiles(w, h, 32);
        let mut frames = 0u64;
        let t0 = Instant::now();
        let c0 = parrt_runtime::cpu_time::thread_cpu_s();
        let per_frame = loop {
            let mut st = RayStats::default();
            for t in &tiles {
                r.cast_tile(t, args.cull, &mut st);
            }
            frames += 1;
            if t0.elapsed().as_secs_f64() >= args.mintime {
                break st;
            }
        };
        let secs = t0.elapsed().as_secs_f64();
        let cpu = parrt_runtime::cpu_time::thread_cpu_s() - c0;
        let rays = per_frame.eye_rays + per_frame.shadow_rays;
        crate::outln!(
            "| {} | {} | {:.4} | {} | {} | {} | {} | {:.2} | {:.2} |",
            spec.label(),
            r.build_info().primitives,
            r.build_info().build_s,
            rays,
            per_frame.eye_hits,
            per_frame.shadow_rays,
            frames,
            rays as f64 * frames as f64 / secs / 1e6,
            rays as f64 * frames as f64 / cpu / 1e6
        );
    }
    Ok(ExitCode::SUCCESS)
}
