//! Render flags shared by every command that renders (`render`, `master`, `cluster`, the
//! benches): image size, depth, cut-off, samples, SPD mode, accelerator, precision; and the
//! accelerator and executor choices the benches list. Turned into the library's
//! [`RenderSettings`] here, once, so that every command renders the same bits from the same
//! flags; a bad value is bad input (exit 2).

use super::ArgError;
use clap::{Args, ValueEnum};
use parrt_render::description::SceneDescription;
use parrt_render::precision::Choice;
use parrt_render::settings::{AccelKind, Precision, RenderSettings};
use parrt_render::smp::Executor;

/// Acceleration structure choices.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum AccelArg {
    /// Bounding volume hierarchy (binned SAH).
    Bvh,
    /// Uniform voxel grid with 3D-DDA.
    Grid,
    /// No acceleration: every primitive for every ray (the test oracle; slow).
    Brute,
    /// BVH built by Goldsmith–Salmon incremental insertion (the quality baseline for `bvh`).
    BvhGs,
}

impl AccelArg {
    /// The library's accelerator kind.
    pub fn kind(self) -> AccelKind {
        match self {
            AccelArg::Bvh => AccelKind::Bvh,
            AccelArg::Grid => AccelKind::Grid,
            AccelArg::Brute => AccelKind::Brute,
            AccelArg::BvhGs => AccelKind::BvhGoldsmithSalmon,
        }
    }
}

/// Tile executor choices.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ExecutorArg {
    /// The paper's design: N threads take the next tile from a locked queue.
    Queue,
    /// rayon's work-stealing pool.
    Rayon,
    /// Tiles in Morton (Z) order from an atomic counter.
    Morton,
    /// Runs of Morton-ordered tiles that shrink as work runs out (large first).
    Guided,
}

impl ExecutorArg {
    /// The library's executor.
    pub fn executor(self) -> Executor {
        match self {
            ExecutorArg::Queue => Executor::Queue,
            ExecutorArg::Rayon => Executor::Rayon,
            ExecutorArg::Morton => Executor::Morton,
            ExecutorArg::Guided => Executor::Guided,
        }
    }
}

/// Precision choices.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum PrecisionArg {
    /// Whichever the scene needs: f32 unless its extent over its smallest feature is too large
    /// for f32 to resolve (see --stats).
    Auto,
    /// Single precision (fast).
    F32,
    /// Double precision (reference).
    F64,
}

/// Settings shared by every command that renders (render, master, bench).
#[derive(Debug, Clone, Args)]
pub struct RenderFlags {
    /// Image size in pixels, WxH (or N for NxN); the same as --width W --height H (default:
    /// the scene's resolution; 512x512 with --spd-standard).
    #[arg(long, value_name = "WxH", conflicts_with_all = ["width", "height"])]
    pub size: Option<String>,
    /// Image width in pixels (default: the scene's resolution; 512 with --spd-standard).
    #[arg(long, value_name = "W")]
    pub width: Option<u32>,
    /// Image height in pixels (default: the scene's resolution; 512 with --spd-standard).
    #[arg(long, value_name = "H")]
    pub height: Option<u32>,
    /// Maximum ray depth; the eye ray is depth 1.
    #[arg(long, value_name = "D", default_value_t = parrt_render::settings::DEFAULT_MAX_DEPTH)]
    pub max_depth: u32,
    /// Adaptive cut-off: a reflected/refracted ray is not traced when the product of weights
    /// along its path falls below X (0 disables; ignored with --spd-standard).
    #[arg(long, value_name = "X", default_value_t = parrt_render::settings::DEFAULT_CUTOFF)]
    pub cutoff: f64,
    /// Samples per pixel (1: one ray through each pixel centre; square numbers are stratified).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub spp: u32,
    /// Haines' SPD testing procedure: 513×513 corner rays averaged per pixel, depth 5, no
    /// cut-off, one-sided opaque primitives.
    #[arg(long)]
    pub spd_standard: bool,
    /// With --spd-standard: treat every primitive as two-sided (SPD asks this for the teapot).
    #[arg(long)]
    pub two_sided: bool,
    /// Acceleration structure.
    #[arg(long, value_enum, default_value_t = AccelArg::Bvh)]
    pub accel: AccelArg,
    /// Uniform grid density: about cbrt(density × primitives) cells along the longest axis.
    #[arg(long, value_name = "X", default_value_t = parrt_render::settings::DEFAULT_GRID_DENSITY)]
    pub grid_density: f64,
    /// Geometric precision: auto (f32 when it resolves the scene, else f64), f32 (fast path)
    /// or f64 (reference path).
    #[arg(long, value_enum, default_value_t = PrecisionArg::Auto)]
    pub precision: PrecisionArg,
}

impl RenderFlags {
    /// The render settings for `desc`, with the precision resolved (auto decided once, here,
    /// from the description, so every worker is sent the same `f32` or `f64`).
    pub fn settings(&self, desc: &SceneDescription) -> anyhow::Result<RenderSettings> {
        Ok(self.settings_and_precision(desc)?.0)
    }

    /// [`RenderFlags::settings`] and why the precision is what it is.
    pub fn settings_and_precision(
        &self,
        desc: &SceneDescription,
    ) -> anyhow::Result<(RenderSettings, Choice)> {
        let (dw, dh) = if self.spd_standard {
            (512, 512)
        } else {
            (desc.view.width, desc.view.height)
        };
        let (w, h) = match &self.size {
            Some(size) => super::size::parse_size(size)?,
            None => (self.width.unwrap_or(dw), self.height.unwrap_or(dh)),
        };
        let mut s = RenderSettings::new(w, h);
        s.max_depth = self.max_depth;
        s.cutoff = self.cutoff;
        s.spp = self.spp;
        s.spd_standard = self.spd_standard;
        s.two_sided = self.two_sided;
        s.accel = self.accel.kind();
        s.grid_density = self.grid_density;
        let requested = match self.precision {
            PrecisionArg::Auto => Precision::Auto,
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F64 => Precision::F64,
        };
        parrt_render::render::validate_settings(&s).map_err(ArgError::refused)?;
        let choice = parrt_render::precision::resolve(requested, desc);
        s.precision = choice.precision;
        Ok((s, choice))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Flags {
        #[command(flatten)]
        render: RenderFlags,
    }

    fn settings(args: &[&str], desc: &SceneDescription) -> (RenderSettings, Choice) {
        let flags = Flags::try_parse_from(std::iter::once("parrt").chain(args.iter().copied()))
            .expect("flags parse");
        flags.render.settings_and_precision(desc).expect("settings")
    }

    /// What a master sends its workers is never `Auto`: auto is resolved here, once.
    #[test]
    fn auto_is_the_default_and_is_resolved_before_a_job_leaves() {
        let near = parrt_scenes::generate("tetra", Some(2)).expect("tetra");
        let (s, why) = settings(&[], &near);
        assert_eq!(s.precision, Precision::F32);
        assert!(why.reason.starts_with("auto: "), "{}", why.reason);
        // The eye 1e7 away from a small scene: f32 cannot resolve it.
        let mut far = near.clone();
        far.view.from = far.view.at + (far.view.from - far.view.at).normalize() * 1e7;
        let (s, why) = settings(&[], &far);
        assert_eq!(s.precision, Precision::F64, "{}", why.reason);
        let (s, why) = settings(&["--precision", "f32"], &far);
        assert_eq!(s.precision, Precision::F32);
        assert!(why.reason.starts_with("forced; auto would pick f64"));
    }

    /// `--size WxH` (or `N`) is `--width W --height H`, as on the benches.
    #[test]
    fn size_is_width_and_height() {
        let desc = parrt_scenes::generate("tetra", Some(1)).expect("tetra");
        let (s, _) = settings(&["--size", "64x48"], &desc);
        assert_eq!((s.width, s.height), (64, 48));
        let (s, _) = settings(&["--size", "40"], &desc);
        assert_eq!((s.width, s.height), (40, 40));
        let (s, _) = settings(&["--width", "64", "--height", "48"], &desc);
        assert_eq!((s.width, s.height), (64, 48));
        let both = Flags::try_parse_from(["parrt", "--size", "8x8", "--width", "9"]);
        assert!(both.is_err(), "--size and --width together are refused");
    }
}
