//! Whitted shading (docs/design-rendering.md, *Shading*): ambient, diffuse and Phong highlight from
//! every light a shadow ray finds unblocked, mirror reflection weighted by Ks, Snell refraction
//! weighted by T with total internal reflection, recursion ended by the depth limit and the
//! adaptive cut-off. Spawns no ray the material does not need, and allocates nothing.

use crate::accel::Accel;
use crate::geometry::{offset_ray_origin, PreparedRay, PrimHit, Ray};
use crate::packet::scene_leaf::SceneLeaf;
use crate::real::Real;
use crate::scene::Scene;
use crate::scene::{Mat, Surface};
use crate::stats::RayStats;
use crate::vec3::V3;

/// What a traced ray is, for the statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// From the camera.
    Eye,
    /// Mirror reflection (also total internal reflection).
    Reflection,
    /// Refraction.
    Refraction,
}

/// A hit made ready for shading ([`Integrator::lit`]).
#[derive(Clone, Copy, Debug)]
pub struct Lit<R> {
    /// The surface at the hit.
    pub s: Surface<R>,
    /// Its material.
    pub m: Mat<R>,
    /// The shading normal the lights are tested against.
    pub ns: V3<R>,
    /// The ray arrived at the primitive's front.
    pub arrives_front: bool,
}

/// The secondary rays of a hit ([`Integrator::spawn`]), each with its weight.
#[derive(Clone, Copy, Debug)]
pub struct Spawned<R> {
    /// Mirror reflection (also total internal reflection).
    pub reflection: Option<(Ray<R>, R)>,
    /// Refraction.
    pub refraction: Option<(Ray<R>, R)>,
}

/// Shading switches derived from the render settings.
#[derive(Clone, Copy, Debug)]
pub struct ShadeOptions<R> {
    /// Maximum depth (eye ray = 1).
    pub max_depth: u32,
    /// Adaptive cut-off on the path weight; 0 disables.
    pub cutoff: R,
    /// SPD testing procedure.
    pub spd: bool,
    /// Every primitive two-sided in the SPD procedure.
    pub two_sided: bool,
}

/// A scene, its accelerator and the shading options: everything a ray needs.
#[derive(Debug)]
pub struct Integrator<R> {
    /// The scene.
    pub scene: Scene<R>,
    /// Its accelerator.
    pub accel: Accel,
    /// Shading options.
    pub opts: ShadeOptions<R>,
}

impl<R: Real> Integrator<R> {
    /// Closest hit along `ray`.
    #[inline]
    pub fn intersect(
        &self,
        ray: &Ray<R>,
        stats: &mut RayStats,
    ) -> Option<crate::geometry::PrimHit<R>> {
        let pr = PreparedRay::new(*ray);
        self.accel
            .intersect(&pr, stats, SceneLeaf::new(&self.scene).ray(&pr))
    }

    /// True when anything blocks `ray` within its range.
    #[inline]
    pub fn occluded(&self, ray: &Ray<R>, stats: &mut RayStats) -> bool {
        let pr = PreparedRay::new(*ray);
        self.accel
            .occluded(&pr, stats, SceneLeaf::new(&self.scene).ray(&pr))
    }

    /// Radiance along `ray`. `weight` is the product of reflect/transmit weights so far.
    pub fn trace(
        &self,
        ray: &Ray<R>,
        depth: u32,
        weight: R,
        kind: RayKind,
        stats: &mut RayStats,
    ) -> V3<R> {
        match kind {
            RayKind::Eye => stats.eye_rays += 1,
            RayKind::Reflection => stats.reflection_rays += 1,
            RayKind::Refraction => stats.refraction_rays += 1,
        }
        let Some(hit) = self.intersect(ray, stats) else {
            return self.scene.background;
        };
        match kind {
            RayKind::Eye => stats.eye_hits += 1,
            RayKind::Reflection => stats.reflection_hits += 1,
            RayKind::Refraction => stats.refraction_hits += 1,
        }
        let lit = self.lit(ray, &hit);
        self.shade(ray, &lit, depth, weight, stats, |_, shadow, st| {
            self.occluded(shadow, st)
        })
    }

    /// A hit made ready for shading: its surface, material and the normal the lights are
    /// tested against.
    #[inline]
    pub fn lit(&self, ray: &Ray<R>, hit: &PrimHit<R>) -> Lit<R> {
        let s = self.scene.surface(ray, hit);
        let m = self.scene.materials[s.material as usize];
        let arrives_front = ray.d.dot(s.ng) < R::ZERO;
        // Normals facing the viewer, except SPD's one-sided opaque primitives, which keep their
        // front normal for the light test.
        let one_sided = self.opts.spd && !self.opts.two_sided && m.t == R::ZERO;
        let ns = if arrives_front || one_sided {
            s.ns
        } else {
            -s.ns
        };
        Lit {
            s,
            m,
            ns,
            arrives_front,
        }
    }

    /// The shadow ray from a lit hit to light `light`, with `n·l` before normalising and the
    /// distance to the light; `None` when the surface faces away from the light (no shadow ray
    /// is cast then).
    #[inline]
    pub fn shadow_ray(&self, lit: &Lit<R>, light: usize) -> Option<(Ray<R>, R, R)> {
        let s = &lit.s;
        let position = self.scene.lights[light].position;
        let to_light = position - s.p;
        let n_dot_l_raw = lit.ns.dot(to_light);
        if n_dot_l_raw <= R::ZERO {
            return None; // faces away: no shadow ray
        }
        let dist = to_light.length();
        if !(dist > R::ZERO) {
            return None;
        }
        let l = to_light / dist;
        let origin = offset_ray_origin(s.p, s.p_err, s.ng, l);
        let to_light_o = position - origin;
        let dist_o = to_light_o.length();
        let shadow = Ray {
            o: origin,
            d: to_light_o / dist_o,
            t_min: R::ZERO,
            t_max: dist_o,
        };
        Some((shadow, n_dot_l_raw, dist))
    }

    /// Radiance leaving a lit hit back along `ray`: `occluded(light, shadow ray, stats)`
    /// answers the shadow rays (traced on the spot, or looked up from a packet traced before).
    pub fn shade<O>(
        &self,
        ray: &Ray<R>,
        lit: &Lit<R>,
        depth: u32,
        weight: R,
        stats: &mut RayStats,
        occluded: O,
    ) -> V3<R>
    where
        O: FnMut(usize, &Ray<R>, &mut RayStats) -> bool,
    {
        let mut color = self.direct(ray, lit, stats, occluded);
        let spawned = self.spawn(ray, lit, depth, weight);
        if let Some((refl, w)) = spawned.reflection {
            let c = self.trace(&refl, depth + 1, weight * w, RayKind::Reflection, stats);
            color += c * w;
        }
        if let Some((refr, w)) = spawned.refraction {
            let c = self.trace(&refr, depth + 1, weight * w, RayKind::Refraction, stats);
            color += c * w;
        }
        color
    }

    /// The light a lit hit sends back along `ray` directly: ambient, and diffuse and highlight
    /// from every light whose shadow ray `occluded` says is free.
    pub fn direct<O>(
        &self,
        ray: &Ray<R>,
        lit: &Lit<R>,
        stats: &mut RayStats,
        mut occluded: O,
    ) -> V3<R>
    where
        O: FnMut(usize, &Ray<R>, &mut RayStats) -> bool,
    {
        let mut color = self.ambient(lit);
        for li in 0..self.scene.lights.len() {
            let Some((shadow, n_dot_l_raw, dist)) = self.shadow_ray(lit, li) else {
                continue;
            };
            stats.shadow_rays += 1;
            if occluded(li, &shadow, stats) {
                stats.shadow_hits += 1;
                continue;
            }
            color += self.from_light(ray, lit, li, n_dot_l_raw, dist);
        }
        color
    }

    /// The ambient term of a lit hit, the first of [`Self::direct`]'s sum.
    #[inline]
    pub fn ambient(&self, lit: &Lit<R>) -> V3<R> {
        lit.m.color * (self.scene.ambient * lit.m.kd)
    }

    /// Diffuse and highlight from light `light` whose shadow ray ([`Self::shadow_ray`], which
    /// gave `n_dot_l_raw` and `dist`) is free: the term [`Self::direct`] adds for it.
    #[inline]
    pub fn from_light(
        &self,
        ray: &Ray<R>,
        lit: &Lit<R>,
        light: usize,
        n_dot_l_raw: R,
        dist: R,
    ) -> V3<R> {
        let (s, m, ns) = (&lit.s, lit.m, lit.ns);
        let light = &self.scene.lights[light];
        let l = (light.position - s.p) / dist;
        let n_dot_l = n_dot_l_raw / dist;
        let mut c = m.color * (m.kd * n_dot_l);
        if m.ks > R::ZERO {
            let r = ns * (R::TWO * n_dot_l) - l;
            let rv = r.dot(-ray.d);
            if rv > R::ZERO {
                c += V3::splat(m.ks * rv.powf(m.shine));
            }
        }
        c.mul_elem(light.intensity)
    }

    /// The reflection and refraction rays a lit hit at `depth` spawns, each with the weight its
    /// radiance is added with (none past the depth limit, or below the cut-off).
    pub fn spawn(&self, ray: &Ray<R>, lit: &Lit<R>, depth: u32, weight: R) -> Spawned<R> {
        let mut out = Spawned {
            reflection: None,
            refraction: None,
        };
        if depth >= self.opts.max_depth {
            return out;
        }
        let (s, m, arrives_front) = (&lit.s, lit.m, lit.arrives_front);
        let d = ray.d;
        let cutoff = self.opts.cutoff;
        let wants = |w: R| -> bool {
            if self.opts.spd {
                true
            } else {
                w > R::ZERO && weight * w >= cutoff
            }
        };
        // Refraction geometry from the geometric normal: entering when arriving at the front.
        let (n_in, eta) = if arrives_front {
            (s.ng, R::ONE / m.ior)
        } else {
            (-s.ng, m.ior)
        };
        let cos_i = -d.dot(n_in);
        let sin2_t = eta * eta * (R::ONE - cos_i * cos_i).max(R::ZERO);
        let transmits = m.t > R::ZERO;
        let tir = transmits && sin2_t >= R::ONE;
        let refl_w = m.ks + if tir { m.t } else { R::ZERO };
        let spawn_reflection = if self.opts.spd {
            m.ks > R::ZERO || transmits
        } else {
            wants(refl_w)
        };
        if spawn_reflection {
            let nf = if arrives_front { s.ns } else { -s.ns };
            let mut r = d - nf * (R::TWO * d.dot(nf));
            let ng_f = if arrives_front { s.ng } else { -s.ng };
            if r.dot(ng_f) <= R::ZERO {
                // An interpolated normal bent the mirror ray into the surface: use the true one.
                r = d - ng_f * (R::TWO * d.dot(ng_f));
            }
            let r = r.normalize();
            let o = offset_ray_origin(s.p, s.p_err, s.ng, r);
            let refl = Ray {
                o,
                d: r,
                t_min: R::ZERO,
                t_max: R::INFINITY,
            };
            out.reflection = Some((refl, refl_w));
        }
        if transmits && !tir && wants(m.t) {
            let cos_t = (R::ONE - sin2_t).sqrt();
            let t_dir = (d * eta + n_in * (eta * cos_i - cos_t)).normalize();
            let o = offset_ray_origin(s.p, s.p_err, s.ng, t_dir);
            let refr = Ray {
                o,
                d: t_dir,
                t_min: R::ZERO,
                t_max: R::INFINITY,
            };
            out.refraction = Some((refr, m.t));
        }
        out
    }
}
