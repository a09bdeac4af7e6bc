//! The scene's primitive test as the accelerators call it ([`crate::accel::RayPrimTest`]): one
//! primitive at a time through [`Scene::intersect_prim`], except that a BVH leaf of two or more
//! triangles, or of two or more spheres, in `f32` goes to a four-at-a-time SIMD kernel
//! ([`crate::geometry::triangle4`], [`crate::geometry::sphere4`]), which gives each primitive
//! exactly the scalar test's answer. A packet's rays entering such a leaf share one gather of
//! its primitives into the kernel's lanes ([`RayPrimTest::closest_many`]). The choice of
//! precision is by type and folds away at compile time; the kernel is chosen at run time by
//! CPU features.

use std::any::Any;

use crate::accel::{OneRay, RayPrimTest};
use crate::geometry::sphere::Sphere;
use crate::geometry::sphere4::{self, SphereLanes, Spheres4};
use crate::geometry::triangle4::{self, TriLanes, Tris4, LANES};
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

    /// The `f32` scene and ray when `R` is `f32` and leaves go to the kernel.
    #[inline(always)]
    fn as_f32<'b>(&self, pr: &'b PreparedRay<R>) -> Option<(&'a Scene<f32>, &'b PreparedRay<f32>)> {
        Some((self.scene_f32()?, f32_ray(pr)?))
    }

    /// The `f32` scene when `R` is `f32` and leaves go to the kernel.
    #[inline(always)]
    fn scene_f32(&self) -> Option<&'a Scene<f32>> {
        if !self.simd {
            return None;
        }
        (self.scene as &dyn Any).downcast_ref::<Scene<f32>>()
    }
}

/// `pr` as an `f32` ray when `R` is `f32`.
#[inline(always)]
fn f32_ray<R: Real>(pr: &PreparedRay<R>) -> Option<&PreparedRay<f32>> {
    (pr as &dyn Any).downcast_ref::<PreparedRay<f32>>()
}

/// A leaf the kernels take, gathered into lanes once for several rays.
enum Gathered {
    Triangles(TriLanes),
    Spheres(SphereLanes),
}

impl Gathered {
    #[inline(always)]
    fn new(leaf: &Simd<'_>) -> Self {
        match leaf {
            Simd::Triangles(t) => Gathered::Triangles(TriLanes::gather(t)),
            Simd::Spheres(s) => Gathered::Spheres(SphereLanes::gather(s)),
        }
    }

    /// [`run`] on the gathered lanes: the same answer.
    #[inline(always)]
    fn run(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> (u32, Lanes) {
        match self {
            Gathered::Triangles(tris) => {
                let h = triangle4::intersect4_gathered(pr, tris, used, t_max);
                (h.mask, (h.t, h.b1, h.b2))
            }
            Gathered::Spheres(spheres) => {
                let h = sphere4::intersect4_gathered(&pr.ray, spheres, used, t_max);
                (h.mask, (h.t, [0.0; LANES], [0.0; LANES]))
            }
        }
    }
}

/// Offers lane hits `m` of `leaf` to `best`, in lane order.
#[inline(always)]
fn offer<R: Real>(best: &mut Nearest<R>, leaf: &[u32], mut m: u32, (t, u, v): Lanes) {
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
}

/// A leaf the SIMD kernels take: 2..=4 triangles or 2..=4 spheres.
enum Simd<'a> {
    Triangles(Tris4<'a, f32>),
    Spheres(Spheres4<'a, f32>),
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
        Prim::Cone(_) => None,
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
                let (m, lanes) = run(pr32, &simd, leaf.len(), best.t.to_f32());
                offer(best, leaf, m, lanes);
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

    #[inline(always)]
    fn closest_many(
        &mut self,
        rays: &[PreparedRay<R>],
        mask: u32,
        leaf: &[u32],
        best: &mut [Nearest<R>],
    ) {
        let mut m = mask;
        if m & (m.wrapping_sub(1)) != 0 {
            // Two rays or more: gather once.
            if let Some(simd) = self.scene_f32().and_then(|s| simd_leaf(&s.prims, leaf)) {
                let g = Gathered::new(&simd);
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    let Some(pr32) = f32_ray(&rays[i]) else {
                        break;
                    };
                    m &= m - 1;
                    let (hit, lanes) = g.run(pr32, leaf.len(), best[i].t.to_f32());
                    offer(&mut best[i], leaf, hit, lanes);
                }
            }
        }
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            self.closest(&rays[i], leaf, &mut best[i]);
        }
    }

    #[inline(always)]
    fn any_many(
        &mut self,
        rays: &[PreparedRay<R>],
        mask: u32,
        leaf: &[u32],
        first: &mut [usize],
    ) -> u32 {
        let mut m = mask;
        let mut blocked = 0;
        if m & (m.wrapping_sub(1)) != 0 {
            if let Some(simd) = self.scene_f32().and_then(|s| simd_leaf(&s.prims, leaf)) {
                let g = Gathered::new(&simd);
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    let Some(pr32) = f32_ray(&rays[i]) else {
                        break;
                    };
                    m &= m - 1;
                    let (hit, _) = g.run(pr32, leaf.len(), pr32.ray.t_max);
                    if hit != 0 {
                        first[i] = hit.trailing_zeros() as usize;
                        blocked |= 1 << i;
                    }
                }
            }
        }
        while m != 0 {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            let pr = &rays[i];
            if let Some(k) = self.any(pr, leaf, pr.ray.t_max) {
                first[i] = k;
                blocked |= 1 << i;
            }
        }
        blocked
    }
}
