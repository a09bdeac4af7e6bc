//! The scene's primitive test as the accelerators call it ([`crate::accel::RayPrimTest`]): one
//! primitive at a time through [`Scene::intersect_prim`], except that a BVH leaf of two or more
//! triangles, of two or more spheres, or of two or more cones in `f32` goes to a four-at-a-time
//! SIMD kernel ([`crate::geometry::triangle4`], [`crate::geometry::sphere4`],
//! [`crate::geometry::cone4`]), which gives each primitive
//! exactly the scalar test's answer. The choice of precision is by
//! type and folds away at compile time; the kernel is chosen at run time by CPU features.

use std::any::Any;

use crate::accel::{OneRay, RayPrimTest};
use crate::geometry::cone::Cone;
use crate::geometry::cone4::{self, Cones4};
use crate::geometry::sphere::Sphere;
use crate::geometry::sphere4::{self, Spheres4};
use crate::geometry::triangle4::{self, Tris4, LANES};
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::scene::{Prim, Scene};

/// The primitive test of a scene's primitives.
#[derive(Clone, Copy, Debug)]
pub struct SceneLeaf<'a, R> {
    scene: &'a Scene<R>,
    simd: bool,
}

impl<'a, R: Real> SceneLeaf<'a, R> {
    /// Tests `scene`'s primitives, leaves of triangles four at a time.
    #[inline(always)]
    pub fn new(scene: &'a Scene<R>) -> Self {
        SceneLeaf { scene, simd: true }
    }

    /// Tests `scene`'s primitives one at a time only (the portable path, for comparisons).
    #[inline(always)]
    pub fn scalar(scene: &'a Scene<R>) -> Self {
        SceneLeaf { scene, simd: false }
    }

    /// This test for one ray ([`crate::accel::PrimTest`]).
    #[inline(always)]
    pub fn ray<'b>(&'b mut self, pr: &'b PreparedRay<R>) -> OneRay<'b, R, Self> {
        OneRay { test: self, pr }
    }

    /// The `f32` scene, ray and hit record when `R` is `f32` and leaves go to the kernel.
    #[inline(always)]
    fn as_f32<'b>(&self, pr: &'b PreparedRay<R>) -> Option<(&'a Scene<f32>, &'b PreparedRay<f32>)> {
        if !self.simd {
            return None;
        }
        let scene = (self.scene as &dyn Any).downcast_ref::<Scene<f32>>()?;
        let pr = (pr as &dyn Any).downcast_ref::<PreparedRay<f32>>()?;
        Some((scene, pr))
    }
}

/// A leaf the SIMD kernels take: 2..=4 triangles, 2..=4 spheres or 2..=4 cones.
enum Simd<'a> {
    Triangles(Tris4<'a, f32>),
    Spheres(Spheres4<'a, f32>),
    Cones(Cones4<'a, f32>),
}

/// The kernel input of a leaf, or `None` when it is shorter, longer or mixed.
#[inline(always)]
fn simd_leaf<'a>(prims: &'a [Prim<f32>], leaf: &[u32]) -> Option<Simd<'a>> {
    if leaf.len() < 2 || leaf.len() > LANES {
        return None;
    }
    match prims.get(leaf[0] as usize)? {
        Prim::Triangle(first) => {
            let mut tris = [first; LANES];
            for (slot, &p) in tris.iter_mut().zip(leaf).skip(1) {
                let Prim::Triangle(v) = prims.get(p as usize)? else {
                    return None;
                };
                *slot = v;
            }
            Some(Simd::Triangles(tris))
        }
        Prim::Sphere(first) => {
            let mut spheres: [&Sphere<f32>; LANES] = [first; LANES];
            for (slot, &p) in spheres.iter_mut().zip(leaf).skip(1) {
                let Prim::Sphere(s) = prims.get(p as usize)? else {
                    return None;
                };
                *slot = s;
            }
            Some(Simd::Spheres(spheres))
        }
        Prim::Cone(first) => {
            let mut cones: [&Cone<f32>; LANES] = [first; LANES];
            for (slot, &p) in cones.iter_mut().zip(leaf).skip(1) {
                let Prim::Cone(c) = prims.get(p as usize)? else {
                    return None;
                };
                *slot = c;
            }
            Some(Simd::Cones(cones))
        }
    }
}

/// Bit `i` set when lane `i` is hit, and lane `i`'s `(t, u, v)`.
#[inline(always)]
fn run(pr: &PreparedRay<f32>, leaf: &Simd<'_>, used: usize, t_max: f32) -> (u32, Lanes) {
    match leaf {
        Simd::Triangles(tris) => {
            let h = triangle4::intersect4(pr, tris, used, t_max);
            (h.mask, (h.t, h.b1, h.b2))
        }
        Simd::Spheres(spheres) => {
            let h = sphere4::intersect4(&pr.ray, spheres, used, t_max);
            (h.mask, (h.t, [0.0; LANES], [0.0; LANES]))
        }
        Simd::Cones(cones) => {
            let h = cone4::intersect4(&pr.ray, cones, used, t_max);
            (h.mask, (h.t, [0.0; LANES], [0.0; LANES]))
        }
    }
}

/// Per lane: distance and the two surface parameters.
type Lanes = ([f32; LANES], [f32; LANES], [f32; LANES]);

impl<R: Real> RayPrimTest<R> for SceneLeaf<'_, R> {
    #[inline(always)]
    fn test(&mut self, pr: &PreparedRay<R>, prim: u32, t_max: R) -> Option<PrimHit<R>> {
        self.scene.intersect_prim(prim, pr, t_max)
    }

    #[inline(always)]
    fn closest(&mut self, pr: &PreparedRay<R>, leaf: &[u32], best: &mut Nearest<R>) {
        if let Some((scene, pr32)) = self.as_f32(pr) {
            if let Some(simd) = simd_leaf(&scene.prims, leaf) {
                // Every lane with the bound the leaf is entered with: a hit beyond the best so
                // far never beats it, so offering the hits in order picks what the one-at-a-time
                // loop picks.
                let (mut m, (t, u, v)) = run(pr32, &simd, leaf.len(), best.t.to_f32());
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    best.offer(Some(PrimHit {
                        t: R::from_f32(t[i]),
                        prim: leaf[i],
                        u: R::from_f32(u[i]),
                        v: R::from_f32(v[i]),
                    }));
                }
                return;
            }
        }
        for &p in leaf {
            best.offer(self.test(pr, p, best.t));
        }
    }

    #[inline(always)]
    fn any(&mut self, pr: &PreparedRay<R>, leaf: &[u32], t_max: R) -> Option<usize> {
        if let Some((scene, pr32)) = self.as_f32(pr) {
            if let Some(simd) = simd_leaf(&scene.prims, leaf) {
                let (m, _) = run(pr32, &simd, leaf.len(), t_max.to_f32());
                return (m != 0).then(|| m.trailing_zeros() as usize);
            }
        }
        leaf.iter().position(|&p| self.test(pr, p, t_max).is_some())
    }
}
