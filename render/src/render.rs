//! The renderer facade: builds a render-ready scene and accelerator from a description and
//! settings once, then renders any tile on any thread. Every pixel depends only on the scene,
//! the settings and its own coordinates, so tiles can be rendered in any order, anywhere, and
//! the image is the same bits.

use crate::accel::bvh::packet::PACKET;
use crate::accel::{Accel, AccelStats};
use crate::camera::Camera;
use crate::description::{Bounds, SceneDescription, View};
use crate::film::Rgb;
use crate::packet::buffers::PacketBuffers;
use crate::real::Real;
use crate::scene::{Scene, SceneError};
use crate::settings::{Precision, RenderSettings, MAX_GRID_DENSITY};
use crate::shade::{Integrator, RayKind, ShadeOptions};
use crate::stats::RayStats;
use crate::tile::Tile;
use crate::vec3::V3;
use std::sync::Arc;
use std::time::Instant;
use thiserror::Error;

/// Deepest recursion a render may ask for (the tracer recurses on the stack).
pub const MAX_DEPTH_LIMIT: u32 = 64;
/// Most samples per pixel a render may ask for.
pub const MAX_SPP: u32 = 4096;

/// Errors building a renderer.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The image has no pixels.
    #[error("image size {0}x{1} has no pixels")]
    EmptyImage(u32, u32),
    /// A setting is out of range.
    #[error("bad setting: {0}")]
    BadSetting(String),
    /// The scene cannot be rendered.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A view asked of a built renderer ([`Renderer::with_view`]) is not a camera.
    #[error("bad view: {0}")]
    BadView(String),
    /// A built renderer cannot serve another view without a build of its own
    /// ([`Renderer::with_view`]): the build would differ.
    #[error("the built scene cannot be reused: {0}")]
    OtherBuild(String),
}

/// Preprocessing figures of a built renderer.
#[derive(Clone, Debug, Default)]
pub struct BuildInfo {
    /// Seconds spent building the render-ready scene and the accelerator.
    pub build_s: f64,
    /// Primitives after triangulation.
    pub primitives: usize,
    /// Bytes of the render-ready scene's arrays ([`Scene::bytes`]).
    pub scene_bytes: u64,
    /// Accelerator statistics.
    pub accel: AccelStats,
    /// World position of the frame's origin the scene was built in ([`crate::frame`]).
    pub origin: [f64; 3],
}

struct Core<R> {
    /// The scene and accelerator: shared by every renderer of the same build that only moves
    /// the camera ([`Renderer::with_view`]).
    integrator: Arc<Integrator<R>>,
    camera: Camera<R>,
}

enum Inner {
    F32(Core<f32>),
    F64(Core<f64>),
}

/// A scene ready to trace, with its settings.
pub struct Renderer {
    settings: RenderSettings,
    inner: Inner,
    info: BuildInfo,
    packets: bool,
    /// The sampled bounds the frame's origin was chosen from ([`crate::frame::origin`]): what
    /// [`Renderer::with_view`] needs to tell whether another eye keeps the origin.
    bounds: Bounds,
}

/// Checks settings that come from the command line or the network.
pub fn validate_settings(s: &RenderSettings) -> Result<(), RenderError> {
    if s.width == 0 || s.height == 0 {
        return Err(RenderError::EmptyImage(s.width, s.height));
    }
    if s.max_depth == 0 || s.max_depth > MAX_DEPTH_LIMIT {
        return Err(RenderError::BadSetting(format!(
            "max depth {} is outside 1..={MAX_DEPTH_LIMIT}",
            s.max_depth
        )));
    }
    if s.spp == 0 || s.spp > MAX_SPP {
        return Err(RenderError::BadSetting(format!(
            "samples per pixel {} is outside 1..={MAX_SPP}",
            s.spp
        )));
    }
    if !s.cutoff.is_finite() || s.cutoff < 0.0 || s.cutoff > 1.0 {
        return Err(RenderError::BadSetting(format!(
            "cut-off {} is outside [0, 1]",
            s.cutoff
        )));
    }
    if !s.grid_density.is_finite() || s.grid_density <= 0.0 || s.grid_density > MAX_GRID_DENSITY {
        return Err(RenderError::BadSetting(format!(
            "grid density {:?} is outside (0, {MAX_GRID_DENSITY}]",
            s.grid_density
        )));
    }
    Ok(())
}

/// Checks a job before it is handed out: the settings ([`validate_settings`]) and the scene, by
/// building the render-ready scene exactly as [`Renderer::new`] would (bad material indices, values
/// that are not finite, degenerate primitives) and dropping it. The accelerator is not built. A
/// master calls this before it listens, so a job no worker could build is refused up front.
pub fn validate_job(desc: &SceneDescription, s: &RenderSettings) -> Result<(), RenderError> {
    validate_settings(s)?;
    // In the frame the renderer builds in: rounding to f32 far from the world origin could make
    // a primitive degenerate that the rebased scene renders.
    let origin = crate::frame::origin(desc);
    match resolved(s.precision, desc) {
        Precision::F64 => drop(Scene::<f64>::build_in(desc, origin)?),
        _ => drop(Scene::<f32>::build_in(desc, origin)?),
    }
    Ok(())
}

/// Checks a view that arrives apart from a scene ([`Renderer::with_view`]) as the reader checks
/// the `v` block: a camera frame (`from` ≠ `at`, `up` not zero nor parallel to the view), an
/// angle strictly between 0 and 180 degrees, a hither that is finite and not negative.
pub fn validate_view(v: &View) -> Result<(), RenderError> {
    use crate::nff::checks::{camera, CameraProblem};
    if !(v.from.is_finite() && v.at.is_finite() && v.up.is_finite()) {
        return Err(RenderError::BadView(
            "from, at and up must be finite".into(),
        ));
    }
    match camera(v.from, v.at, v.up) {
        Ok(()) => {}
        Err(CameraProblem::NoViewDirection) => {
            return Err(RenderError::BadView(
                "'from' and 'at' are the same point, so there is no view direction".into(),
            ))
        }
        Err(CameraProblem::ZeroUp) => {
            return Err(RenderError::BadView("the 'up' vector is zero".into()))
        }
        Err(CameraProblem::UpParallel) => {
            return Err(RenderError::BadView(
                "'up' is parallel to the view direction".into(),
            ))
        }
    }
    if !(v.angle > 0.0 && v.angle < 180.0) {
        return Err(RenderError::BadView(format!(
            "the view angle {} must lie strictly between 0 and 180 degrees",
            v.angle
        )));
    }
    if !(v.hither >= 0.0 && v.hither.is_finite()) {
        return Err(RenderError::BadView(format!(
            "the hither distance {} must be finite and not negative",
            v.hither
        )));
    }
    Ok(())
}

/// `F32` or `F64`: `Auto` resolved from the description ([`crate::precision::resolve`]).
fn resolved(p: Precision, desc: &SceneDescription) -> Precision {
    match p {
        Precision::Auto => crate::precision::resolve(p, desc).precision,
        p => p,
    }
}

/// The first half of a build: the render-ready scene and the camera, all a build needs from the
/// description.
fn prepare<R: Real>(
    desc: &SceneDescription,
    s: &RenderSettings,
) -> Result<(Scene<R>, Camera<R>), RenderError> {
    let origin = crate::frame::origin(desc);
    let scene = Scene::<R>::build_in(desc, origin)?;
    let camera = Camera::in_frame(&desc.view, s.width, s.height, origin);
    Ok((scene, camera))
}

/// The second half: the accelerator over the scene (its primitive bounds are dropped as soon as
/// the accelerator's build no longer needs them).
fn finish<R: Real>(scene: Scene<R>, camera: Camera<R>, s: &RenderSettings) -> (Core<R>, BuildInfo) {
    let bounds = scene.all_bounds();
    let t0 = Instant::now();
    let accel = Accel::build_owned(s.accel, bounds, s.grid_density);
    let accel_build_s = t0.elapsed().as_secs_f64();
    let info = BuildInfo {
        build_s: 0.0,
        primitives: scene.len(),
        scene_bytes: scene.bytes(),
        origin: scene.origin.to_array(),
        accel: AccelStats {
            build_s: accel_build_s,
            ..accel.stats()
        },
    };
    let opts = ShadeOptions {
        max_depth: s.max_depth,
        cutoff: if s.spd_standard {
            R::ZERO
        } else {
            R::from_f64(s.cutoff)
        },
        spd: s.spd_standard,
        two_sided: s.two_sided,
    };
    (
        Core {
            integrator: Arc::new(Integrator { scene, accel, opts }),
            camera,
        },
        info,
    )
}

/// A description, borrowed or owned (then consumed while the scene is built).
enum Desc<'a> {
    Borrowed(&'a SceneDescription),
    Owned(SceneDescription),
}

fn build_core<R: Real>(
    desc: Desc<'_>,
    s: &RenderSettings,
) -> Result<(Core<R>, BuildInfo), RenderError> {
    let (scene, camera) = match desc {
        Desc::Borrowed(d) => prepare::<R>(d, s)?,
        Desc::Owned(d) => {
            // The description (f64, a vector per polygon) is far larger than the scene: it is
            // freed while the scene is built, before the accelerator's memory is taken.
            // Built in the same frame as a borrowed description would be (crate::frame).
            let origin = crate::frame::origin(&d);
            let camera = Camera::in_frame(&d.view, s.width, s.height, origin);
            (Scene::<R>::build_owned_in(d, origin)?, camera)
        }
    };
    Ok(finish(scene, camera, s))
}

/// A 64-bit mix (splitmix64's finaliser): the per-pixel sample sequence is a pure function of
/// the pixel, so it does not depend on which thread or node renders it.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) from a hash.
#[inline]
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Offset in [0,1)² of sample `i` of `spp` in pixel (x, y): the centre for one sample, jittered
/// strata for a square count, hashed points otherwise.
pub fn sample_offset(x: u32, y: u32, i: u32, spp: u32) -> (f64, f64) {
    if spp == 1 {
        return (0.5, 0.5);
    }
    let h = mix(((y as u64) << 32 | x as u64) ^ mix(i as u64 + 1));
    let (jx, jy) = (unit(h), unit(mix(h)));
    let k = (spp as f64).sqrt() as u32;
    if k * k == spp {
        let (sx, sy) = (i % k, i / k);
        ((sx as f64 + jx) / k as f64, (sy as f64 + jy) / k as f64)
    } else {
        (jx, jy)
    }
}

impl<R: Real> Core<R> {
    fn eye(&self, sx: f64, sy: f64, stats: &mut RayStats) -> V3<R> {
        let ray = self.camera.ray(R::from_f64(sx), R::from_f64(sy));
        self.integrator.trace(&ray, 1, R::ONE, RayKind::Eye, stats)
    }

    fn render_tile(
        &self,
        s: &RenderSettings,
        packets: bool,
        tile: &Tile,
        out: &mut Vec<Rgb>,
        stats: &mut RayStats,
    ) {
        let finish = |c: V3<R>| -> Rgb {
            let f = c.to_f32();
            let clean = |v: f32| if v.is_finite() { v } else { 0.0 };
            [clean(f.x), clean(f.y), clean(f.z)]
        };
        if s.spd_standard {
            out.clear();
            out.reserve(tile.pixel_count());
            // Corner rays: (w+1)×(h+1) per tile; a corner shared with the next tile is traced
            // again there but counted only by the tile that owns it, so totals are exact.
            let cw = tile.w as usize + 1;
            let mut corners: Vec<V3<R>> = Vec::with_capacity(cw * (tile.h as usize + 1));
            let mut scratch = RayStats::default();
            for cy in tile.y..=tile.y + tile.h {
                let own_y = cy < tile.y + tile.h || cy == s.height;
                for cx in tile.x..=tile.x + tile.w {
                    let own = own_y && (cx < tile.x + tile.w || cx == s.width);
                    let st = if own { &mut *stats } else { &mut scratch };
                    corners.push(self.eye(cx as f64, cy as f64, st));
                }
            }
            let quarter = R::from_f64(0.25);
            for y in 0..tile.h as usize {
                for x in 0..tile.w as usize {
                    let c = corners[y * cw + x]
                        + corners[y * cw + x + 1]
                        + corners[(y + 1) * cw + x]
                        + corners[(y + 1) * cw + x + 1];
                    out.push(finish(c * quarter));
                }
            }
            return;
        }
        if packets && s.spp == 1 {
            // The tile's parts of the image's 4 × 4 blocks, a packet each.
            let w = tile.w as usize;
            // The blocks write every pixel: a buffer already the tile's size is not zeroed.
            out.resize(tile.pixel_count(), [0.0; 3]);
            let mut colors = [V3::zero(); PACKET];
            let mut buffers = PacketBuffers::new();
            for (bx, by, bw, bh) in tile.blocks() {
                self.integrator.trace_eye_block(
                    &self.camera,
                    (bx, by, bw, bh),
                    &mut colors,
                    &mut buffers,
                    stats,
                );
                let mut k = 0;
                for y in by..by + bh {
                    for x in bx..bx + bw {
                        out[(y - tile.y) as usize * w + (x - tile.x) as usize] = finish(colors[k]);
                        k += 1;
                    }
                }
            }
            return;
        }
        out.clear();
        out.reserve(tile.pixel_count());
        let inv = R::ONE / R::from_u32(s.spp);
        for y in tile.y..tile.y + tile.h {
            for x in tile.x..tile.x + tile.w {
                let mut c = V3::zero();
                for i in 0..s.spp {
                    let (ox, oy) = sample_offset(x, y, i, s.spp);
                    c += self.eye(x as f64 + ox, y as f64 + oy, stats);
                }
                out.push(finish(if s.spp == 1 { c } else { c * inv }));
            }
        }
    }
}

impl Renderer {
    /// Builds the render-ready scene and accelerator.
    pub fn new(desc: &SceneDescription, settings: &RenderSettings) -> Result<Self, RenderError> {
        Self::build(Desc::Borrowed(desc), settings)
    }

    /// Like [`Renderer::new`], but takes the description and frees it piece by piece while the
    /// scene is built ([`Scene::build_owned`]), before the accelerator: peak memory is then about
    /// the larger of the description and scene plus accelerator build, not their sum.
    pub fn from_description(
        desc: SceneDescription,
        settings: &RenderSettings,
    ) -> Result<Self, RenderError> {
        Self::build(Desc::Owned(desc), settings)
    }

    fn build(desc: Desc<'_>, settings: &RenderSettings) -> Result<Self, RenderError> {
        validate_settings(settings)?;
        let t0 = Instant::now();
        // Auto normally arrives resolved (the master resolves it once for every worker);
        // resolving here is the same pure function of the description.
        let d = match &desc {
            Desc::Borrowed(d) => *d,
            Desc::Owned(d) => d,
        };
        let mut settings = settings.clone();
        settings.precision = resolved(settings.precision, d);
        let bounds = crate::frame::sampled_bounds(d);
        let (inner, mut info) = match settings.precision {
            Precision::F64 => {
                let (c, i) = build_core::<f64>(desc, &settings)?;
                (Inner::F64(c), i)
            }
            _ => {
                let (c, i) = build_core::<f32>(desc, &settings)?;
                (Inner::F32(c), i)
            }
        };
        info.build_s = t0.elapsed().as_secs_f64();
        Ok(Renderer {
            settings,
            inner,
            info,
            packets: true,
            bounds,
        })
    }

    /// A renderer of this one's built scene and accelerator (shared, not copied) seen from
    /// `view` with `settings`: the same bits as [`Renderer::new`] of the description with its
    /// view replaced by `view`, at the cost of a camera. The build must be the one that
    /// description would get, so this refuses ([`RenderError::OtherBuild`]) when it would not:
    /// another precision (`settings` must name `F32` or `F64`, resolved for the new view, as a
    /// master and a sequence do), another accelerator, grid density, depth, cut-off or SPD
    /// procedure, or an eye that moves the rendering frame's origin ([`crate::frame`]). The
    /// size and the samples per pixel may differ. A view that is no camera (not finite, `from`
    /// = `at`, `up` zero or parallel to the view, an angle outside (0, 180), a negative hither)
    /// is refused ([`RenderError::BadView`]), as the reader refuses it.
    pub fn with_view(&self, view: &View, settings: &RenderSettings) -> Result<Self, RenderError> {
        let t0 = Instant::now();
        validate_settings(settings)?;
        validate_view(view)?;
        let mut same = settings.clone();
        same.width = self.settings.width;
        same.height = self.settings.height;
        same.spp = self.settings.spp;
        if same != self.settings {
            return Err(RenderError::OtherBuild(format!(
                "the settings differ in more than the size and samples ({:?} against {:?})",
                settings, self.settings
            )));
        }
        let origin = crate::frame::origin_for(&self.bounds, view.from).to_array();
        if origin != self.info.origin {
            return Err(RenderError::OtherBuild(format!(
                "the eye {:?} moves the rendering frame's origin from {:?} to {origin:?}",
                view.from.to_array(),
                self.info.origin
            )));
        }
        let o = crate::vec3::Vec3d::new(origin[0], origin[1], origin[2]);
        let (w, h) = (settings.width, settings.height);
        let inner = match &self.inner {
            Inner::F32(c) => Inner::F32(Core {
                integrator: c.integrator.clone(),
                camera: Camera::in_frame(view, w, h, o),
            }),
            Inner::F64(c) => Inner::F64(Core {
                integrator: c.integrator.clone(),
                camera: Camera::in_frame(view, w, h, o),
            }),
        };
        let mut info = self.info.clone();
        info.build_s = t0.elapsed().as_secs_f64();
        info.accel.build_s = 0.0;
        Ok(Renderer {
            settings: settings.clone(),
            inner,
            info,
            packets: self.packets,
            bounds: self.bounds,
        })
    }

    /// The settings this renderer was built with.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Preprocessing figures.
    pub fn build_info(&self) -> &BuildInfo {
        &self.info
    }

    /// Traces eye rays (with one sample per pixel), their shadow rays and their coherent
    /// reflection and refraction rays in 4 × 4 packets ([`crate::packet::trace`]; the default),
    /// or each ray on its own. The pixels are the same
    /// bits either way; the box and primitive test counts differ.
    pub fn set_packets(&mut self, on: bool) {
        self.packets = on;
    }

    /// Whether eye rays go in packets ([`Renderer::set_packets`]).
    pub fn packets(&self) -> bool {
        self.packets
    }

    /// Renders one tile into `out` (its old contents replaced; row-major within the tile),
    /// adding to `stats`.
    pub fn render_tile(&self, tile: &Tile, out: &mut Vec<Rgb>, stats: &mut RayStats) {
        let p = self.packets;
        match &self.inner {
            Inner::F32(c) => c.render_tile(&self.settings, p, tile, out, stats),
            Inner::F64(c) => c.render_tile(&self.settings, p, tile, out, stats),
        }
    }

    /// Casts eye and shadow rays only (no shading) for one tile: see [`crate::cast`].
    pub fn cast_tile(&self, tile: &Tile, cull: bool, stats: &mut RayStats) {
        let p = self.packets;
        match &self.inner {
            Inner::F32(c) => crate::cast::cast_tile(&c.integrator, &c.camera, tile, cull, p, stats),
            Inner::F64(c) => crate::cast::cast_tile(&c.integrator, &c.camera, tile, cull, p, stats),
        }
    }

    /// The closest hit of an eye ray through continuous image position `(sx, sy)`: the
    /// primitive index and distance, for tests and tools.
    pub fn probe(&self, sx: f64, sy: f64) -> Option<(u32, f64)> {
        let mut st = RayStats::default();
        match &self.inner {
            Inner::F32(c) => {
                let ray = c.camera.ray(sx as f32, sy as f32);
                c.integrator
                    .intersect(&ray, &mut st)
                    .map(|h| (h.prim, h.t as f64))
            }
            Inner::F64(c) => {
                let ray = c.camera.ray(sx, sy);
                c.integrator.intersect(&ray, &mut st).map(|h| (h.prim, h.t))
            }
        }
    }
}
