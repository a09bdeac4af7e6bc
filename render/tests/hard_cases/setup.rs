//! What the hard cases share: the placements every scene-level case runs at (as written, moved
//! far, tiny, huge), the precisions it runs in, a two-thread render, and an integrator and camera
//! built directly to see radiance and hits before the film cleans them.

use crate::support::render::render_with;
use parrt_render::accel::Accel;
use parrt_render::camera::Camera;
use parrt_render::description::{Primitive, SceneDescription};
use parrt_render::film::Film;
use parrt_render::geometry::cone::Cone;
use parrt_render::geometry::Ray;
use parrt_render::real::Real;
use parrt_render::render::Renderer;
use parrt_render::scene::Scene;
use parrt_render::settings::{AccelKind, Precision, RenderSettings};
use parrt_render::shade::{Integrator, RayKind, ShadeOptions};
use parrt_render::smp::Executor;
use parrt_render::stats::RayStats;
use parrt_render::vec3::{Vec3d, V3};

pub use crate::support::film::compare;
use crate::support::scene::{mat, v, view};

pub fn render(desc: &SceneDescription, s: &RenderSettings) -> (Film, RayStats) {
    let r = Renderer::new(desc, s).expect("scene builds");
    let res = render_with(&r, 2, 16, Executor::Queue);
    (res.film, res.stats)
}

/// `primitives` on a black background with no lights, material 0 white and diffuse, seen from
/// `from` towards the origin (y up) through an 8×8 view of 45°.
pub fn unlit_scene(from: Vec3d, primitives: Vec<Primitive>) -> SceneDescription {
    SceneDescription {
        background: v(0.0, 0.0, 0.0),
        view: view(from, v(0.0, 0.0, 0.0), v(0.0, 1.0, 0.0), 45.0, 8),
        lights: vec![],
        materials: vec![mat([1.0, 1.0, 1.0], 1.0, 0.0, 0.0, 1.0)],
        primitives,
    }
}

/// Two unit vectors that make a right-handed orthonormal basis with the unit vector `n`.
pub fn perpendiculars(n: Vec3d) -> (Vec3d, Vec3d) {
    let helper = if n.x.abs() < 0.5 {
        v(1.0, 0.0, 0.0)
    } else {
        v(0.0, 1.0, 0.0)
    };
    let e1 = n.cross(helper).normalize();
    (e1, n.cross(e1))
}

/// The cone from `base` (radius `r0`) to `apex` (radius `r1`), given in `f64`, built in `R`;
/// `None` when it is degenerate.
pub fn cone_in<R: Real>(base: Vec3d, r0: f64, apex: Vec3d, r1: f64) -> Option<Cone<R>> {
    Cone::new(
        V3::from_f64(base),
        R::from_f64(r0),
        V3::from_f64(apex),
        R::from_f64(r1),
    )
}

/// Where a hard case is placed: x ↦ s·x + t.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    pub name: &'static str,
    pub s: f64,
    pub t: Vec3d,
}

/// As written, moved far in a mixed direction, tiny and huge.
pub const PLACEMENTS: [Placement; 4] = [
    Placement {
        name: "as written",
        s: 1.0,
        t: V3::new(0.0, 0.0, 0.0),
    },
    Placement {
        name: "moved 1e7",
        s: 1.0,
        t: V3::new(1e7, -1e7, 3e6),
    },
    Placement {
        name: "scaled 1e-6",
        s: 1e-6,
        t: V3::new(0.0, 0.0, 0.0),
    },
    Placement {
        name: "scaled 1e6",
        s: 1e6,
        t: V3::new(0.0, 0.0, 0.0),
    },
];

impl Placement {
    pub fn point(&self, p: Vec3d) -> Vec3d {
        p * self.s + self.t
    }

    pub fn scene(&self, d: &SceneDescription) -> SceneDescription {
        transform(d, self.s, self.t)
    }
}

/// Every precision a rendered hard case runs in: f32, f64 and auto — except f32 where auto finds
/// the scene outside what f32 resolves (a 2e4 ground scaled by 1e6 squares past f32's range):
/// there auto's choice of f64 is the answer, and forcing f32 is the user's risk.
pub fn precisions(desc: &SceneDescription) -> Vec<Precision> {
    let auto = parrt_render::precision::resolve(Precision::Auto, desc).precision;
    let mut all = vec![Precision::F64, Precision::Auto];
    if auto == Precision::F32 {
        all.insert(0, Precision::F32);
    }
    all
}

/// Whether auto picks f32 for `desc` (the Direct cases then test f32 as well as f64).
pub fn f32_resolves(desc: &SceneDescription) -> bool {
    parrt_render::precision::resolve(Precision::Auto, desc).precision == Precision::F32
}

pub fn settings(size: u32, precision: Precision) -> RenderSettings {
    let mut s = RenderSettings::new(size, size);
    s.precision = precision;
    s
}

/// An integrator and camera built directly, to see radiance before the film cleans it, in the
/// scene's own frame as the renderer builds it.
pub struct Direct<R> {
    integ: Integrator<R>,
    cam: Camera<R>,
    origin: Vec3d,
}

impl<R: Real> Direct<R> {
    pub fn new(desc: &SceneDescription, accel: AccelKind, size: u32) -> Self {
        let origin = parrt_render::frame::origin(desc);
        let scene = Scene::<R>::build_in(desc, origin).expect("scene builds");
        let accel = Accel::build(accel, &scene.all_bounds(), 3.0);
        Direct {
            integ: Integrator {
                scene,
                accel,
                opts: ShadeOptions {
                    max_depth: 8,
                    cutoff: R::ZERO,
                    spd: false,
                    two_sided: false,
                },
            },
            cam: Camera::in_frame(&desc.view, size, size, origin),
            origin,
        }
    }

    /// Radiance through every pixel centre, unclamped and uncleaned, as f64 RGB.
    pub fn radiance(&self, size: u32) -> Vec<[f64; 3]> {
        let mut st = RayStats::default();
        let mut out = Vec::with_capacity((size * size) as usize);
        for y in 0..size {
            for x in 0..size {
                let ray = self
                    .cam
                    .ray(R::from_f64(x as f64 + 0.5), R::from_f64(y as f64 + 0.5));
                let c = self
                    .integ
                    .trace(&ray, 1, R::ONE, RayKind::Eye, &mut st)
                    .to_f64();
                out.push([c.x, c.y, c.z]);
            }
        }
        out
    }

    /// The closest hit of the ray from world point `o` along `d`.
    pub fn hit(&self, o: Vec3d, d: Vec3d) -> Option<(u32, f64)> {
        let ray = Ray {
            o: V3::from_f64(o - self.origin),
            d: V3::from_f64(d),
            t_min: R::ZERO,
            t_max: R::INFINITY,
        };
        self.integ
            .intersect(&ray, &mut RayStats::default())
            .map(|h| (h.prim, h.t.to_f64()))
    }
}

/// Applies `x ↦ s·x + t` to every position of a scene ([`SceneDescription::transformed`]).
pub fn transform(desc: &SceneDescription, s: f64, t: Vec3d) -> SceneDescription {
    desc.transformed(s, t)
}
