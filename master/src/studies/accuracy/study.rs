//! Runs the study for one scene: the references, then every configuration, each rendered with
//! the same executor, thread count and tile size, timed (tracing only) and compared with the
//! references. Returns rows; printing and plotting live elsewhere.

use super::configs::{reference, Config, REF_SPP};
use super::metrics::{compare, ImageError};
use crate::studies::efficiency::median;
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::render::Renderer;
use parrt_render::smp::{render_smp, Executor, SmpOptions};

/// How the study renders.
#[derive(Clone, Copy, Debug)]
pub struct StudyOptions {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Render threads.
    pub threads: usize,
    /// Renders per configuration; the median trace time is reported (references render once).
    pub repeat: usize,
}

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct Row {
    /// The configuration.
    pub config: Config,
    /// Median trace seconds.
    pub time: f64,
    /// Rays cast (all kinds).
    pub rays: u64,
    /// Error against the reference (f64, no cut-off, depth 16, 16 samples).
    pub error: ImageError,
    /// Error against the reference with the configuration's own samples (f64, no cut-off, depth
    /// 16): what the cut-off, the depth limit and the precision cost, without sampling error.
    pub truncation: ImageError,
}

/// The result for one scene.
#[derive(Clone, Debug)]
pub struct SceneStudy {
    /// Scene label.
    pub scene: String,
    /// Trace seconds of the reference.
    pub reference_time: f64,
    /// Rays of the reference.
    pub reference_rays: u64,
    /// Measured configurations, in grid order.
    pub rows: Vec<Row>,
}

/// Renders `c` `repeat` times (at least once); returns the last film, the median trace seconds
/// and the rays of one render.
fn render(
    desc: &SceneDescription,
    c: &Config,
    o: &StudyOptions,
    repeat: usize,
) -> anyhow::Result<(Film, f64, u64)> {
    let r = Renderer::new(desc, &c.settings(o.width, o.height))?;
    let opts = SmpOptions {
        threads: o.threads,
        tile: 32,
        executor: Executor::Queue,
    };
    let mut times = Vec::with_capacity(repeat.max(1));
    let mut last = None;
    for _ in 0..repeat.max(1) {
        let res = render_smp(&r, &opts, &|_, _| {});
        times.push(res.trace_s);
        last = Some(res);
    }
    let res = last.ok_or_else(|| anyhow::anyhow!("no render ran"))?;
    Ok((res.film, median(&times), res.stats.total_rays()))
}

/// Measures every configuration of `grid` on one scene. `progress` receives a line per render.
pub fn run(
    scene: &str,
    desc: &SceneDescription,
    grid: &[Config],
    o: &StudyOptions,
    progress: &dyn Fn(&str),
) -> anyhow::Result<SceneStudy> {
    progress(&format!(
        "{scene}: reference ({REF_SPP} spp, f64, depth 16, no cut-off)"
    ));
    let (main_ref, reference_time, reference_rays) = render(desc, &reference(REF_SPP), o, 1)?;
    // Same-sampling references, one per sample count in the grid.
    let mut same: Vec<(u32, Film)> = Vec::new();
    for c in grid {
        if !same.iter().any(|(s, _)| *s == c.spp) {
            let film = if c.spp == REF_SPP {
                main_ref.clone()
            } else {
                progress(&format!("{scene}: reference at {} spp", c.spp));
                render(desc, &reference(c.spp), o, 1)?.0
            };
            same.push((c.spp, film));
        }
    }
    let mut rows = Vec::with_capacity(grid.len());
    for (i, c) in grid.iter().enumerate() {
        let (film, time, rays) = render(desc, c, o, o.repeat)?;
        let own = same
            .iter()
            .find(|(s, _)| *s == c.spp)
            .map(|(_, f)| f)
            .ok_or_else(|| anyhow::anyhow!("missing same-sampling reference"))?;
        let row = Row {
            config: *c,
            time,
            rays,
            error: compare(&film.pixels, &main_ref.pixels),
            truncation: compare(&film.pixels, &own.pixels),
        };
        progress(&format!(
            "{scene}: [{}/{}] {:<22} {:>8.3}s  RMSE {:.5}",
            i + 1,
            grid.len(),
            c.label(),
            time,
            row.error.rmse
        ));
        rows.push(row);
    }
    Ok(SceneStudy {
        scene: scene.to_string(),
        reference_time,
        reference_rays,
        rows,
    })
}
