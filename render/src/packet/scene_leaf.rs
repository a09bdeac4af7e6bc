//! The scene's primitive test as the accelerators call it ([`crate::accel::RayPrimTest`]): one
//! primitive at a time through [`Scene::intersect_prim`], except that a BVH leaf of two or more
//! triangles, of two or more spheres, or of two or more cones in `f32` goes to a four-at-a-time
//! SIMD kernel ([`crate::geometry::leaf_triangles`], [`crate::geometry::leaf_spheres`],
//! [`crate::geometry::cone::lanes`]), which gives each primitive exactly the scalar test's answer. A
//! packet's rays entering a leaf of triangles or spheres share one gather of its primitives
//! into the kernel's lanes ([`RayPrimTest::closest_many`]); those entering a leaf with a cone
//! meet each of its cones four rays at a time ([`cone_lanes::intersect_rays4`]; where the tier
//! runs AVX, [`crate::packet::leaf::PacketLeaf`] takes a leaf of cones before this, each cone
//! against all the rays in AVX lanes). The choice of
//! precision is by type and folds away at compile time; the kernel is chosen at run time by
//! CPU features.

use crate::bits::SetBits;
use std::any::Any;

use crate::accel::{OneRay, RayPrimTest};
use crate::geometry::cone::lanes::{self as cone_lanes, Cones4};
use crate::geometry::four_lanes;
use crate::geometry::leaf_spheres::{LeafSpheres, Spheres4};
use crate::geometry::leaf_triangles::{LeafTriangles, Tris4, LANES};
use crate::geometry::{Nearest, PreparedRay, PrimHit, Ray};
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

    /// The `f32` scene when `R` is `f32`, leaves go to the kernels, two or more of a packet's
    /// rays (`which`) enter `leaf` and it holds a cone.
    #[inline(always)]
    fn cone_packet(&self, which: u32, leaf: &[u32]) -> Option<&'a Scene<f32>> {
        if which & which.wrapping_sub(1) == 0 {
            return None;
        }
        let scene = self.scene_f32()?;
        leaf.iter()
            .any(|&p| matches!(scene.prims.get(p as usize), Some(Prim::Cone(_))))
            .then_some(scene)
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
    Triangles(LeafTriangles),
    Spheres(LeafSpheres),
}

impl Gathered {
    /// `None` for cones (a packet meets them ray-per-lane, [`cone_lanes::intersect_rays4`]).
    #[inline(always)]
    fn new(leaf: &Simd<'_>) -> Option<Self> {
        match leaf {
            Simd::Triangles(t) => Some(Gathered::Triangles(LeafTriangles::gather(t))),
            Simd::Spheres(s) => Some(Gathered::Spheres(LeafSpheres::gather(s))),
            Simd::Cones(_) => None,
        }
    }

    /// [`run`] on the gathered lanes: the same answer.
    #[inline(always)]
    fn run(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> (u32, Lanes) {
        match self {
            Gathered::Triangles(tris) => {
                let h = four_lanes::intersect4(pr, tris, used, t_max);
                (h.mask, (h.t, h.b1, h.b2))
            }
            Gathered::Spheres(spheres) => {
                let h = four_lanes::intersect4(&pr.ray, spheres, used, t_max);
                (h.mask, (h.t, [0.0; LANES], [0.0; LANES]))
            }
        }
    }
}

/// Offers lane hits `m` of `leaf` to `best`, in lane order.
#[inline(always)]
fn offer<R: Real>(best: &mut Nearest<R>, leaf: &[u32], m: u32, (t, u, v): Lanes) {
    for i in SetBits(m) {
        best.offer(Some(PrimHit {
            t: R::from_f32(t[i]),
            prim: leaf[i],
            u: R::from_f32(u[i]),
            v: R::from_f32(v[i]),
        }));
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
        Prim::Triangle(first) => all_like(first, prims, leaf, |p| match p {
            Prim::Triangle(v) => Some(v),
            _ => None,
        })
        .map(Simd::Triangles),
        Prim::Sphere(first) => all_like(first, prims, leaf, |p| match p {
            Prim::Sphere(s) => Some(s),
            _ => None,
        })
        .map(Simd::Spheres),
        Prim::Cone(first) => all_like(first, prims, leaf, |p| match p {
            Prim::Cone(c) => Some(c),
            _ => None,
        })
        .map(Simd::Cones),
    }
}

/// The lanes of a leaf whose first primitive is `first`, when `kind` takes every one of its
/// primitives (unused lanes repeat the first).
#[inline(always)]
fn all_like<'a, T>(
    first: &'a T,
    prims: &'a [Prim<f32>],
    leaf: &[u32],
    kind: impl Fn(&'a Prim<f32>) -> Option<&'a T>,
) -> Option<[&'a T; LANES]> {
    let mut lanes = [first; LANES];
    for (slot, &p) in lanes.iter_mut().zip(leaf).skip(1) {
        *slot = kind(prims.get(p as usize)?)?;
    }
    Some(lanes)
}

/// The rays named by the bits of `which`, in order, in groups of up to four: calls
/// `f(indices, rays, used)` per group (unused lanes repeat the group's first ray).
#[inline(always)]
fn ray_groups<R: Real>(
    rays: &[PreparedRay<R>],
    which: u32,
    mut f: impl FnMut(&[usize; LANES], &[&Ray<f32>; LANES], usize),
) {
    let mut m = which;
    while m != 0 {
        let first = m.trailing_zeros() as usize;
        let Some(r0) = f32_ray(&rays[first]).map(|p| &p.ray) else {
            return;
        };
        let mut idx = [first; LANES];
        let mut group = [r0; LANES];
        let mut used = 0;
        while m != 0 && used < LANES {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            idx[used] = i;
            if let Some(r) = f32_ray(&rays[i]).map(|p| &p.ray) {
                group[used] = r;
            }
            used += 1;
        }
        f(&idx, &group, used);
    }
}

/// Bit `i` set when lane `i` is hit, and lane `i`'s `(t, u, v)`.
#[inline(always)]
fn run(pr: &PreparedRay<f32>, leaf: &Simd<'_>, used: usize, t_max: f32) -> (u32, Lanes) {
    match leaf {
        Simd::Triangles(tris) => {
            let h = four_lanes::intersect4(pr, tris, used, t_max);
            (h.mask, (h.t, h.b1, h.b2))
        }
        Simd::Spheres(spheres) => {
            let h = four_lanes::intersect4(&pr.ray, spheres, used, t_max);
            (h.mask, (h.t, [0.0; LANES], [0.0; LANES]))
        }
        Simd::Cones(cones) => {
            let h = four_lanes::intersect4(&pr.ray, cones, used, t_max);
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
        if let Some(scene) = self.cone_packet(mask, leaf) {
            return self.closest_many_cones(scene, rays, mask, leaf, best);
        }
        let mut m = mask;
        if m & (m.wrapping_sub(1)) != 0 {
            // Two rays or more: gather once.
            let simd = self.scene_f32().and_then(|s| simd_leaf(&s.prims, leaf));
            if let Some(g) = simd.as_ref().and_then(Gathered::new) {
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
        for i in SetBits(m) {
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
        if let Some(scene) = self.cone_packet(mask, leaf) {
            return self.any_many_cones(scene, rays, mask, leaf, first);
        }
        let mut m = mask;
        let mut blocked = 0;
        if m & (m.wrapping_sub(1)) != 0 {
            let simd = self.scene_f32().and_then(|s| simd_leaf(&s.prims, leaf));
            if let Some(g) = simd.as_ref().and_then(Gathered::new) {
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
        for i in SetBits(m) {
            let pr = &rays[i];
            if let Some(k) = self.any(pr, leaf, pr.ray.t_max) {
                first[i] = k;
                blocked |= 1 << i;
            }
        }
        blocked
    }
}

impl<R: Real> SceneLeaf<'_, R> {
    /// [`RayPrimTest::closest_many`] of a leaf with a cone (kept out of line: the packet
    /// traversal of scenes without cones stays as small as it was).
    #[inline(never)]
    fn closest_many_cones(
        &mut self,
        scene: &Scene<f32>,
        rays: &[PreparedRay<R>],
        which: u32,
        leaf: &[u32],
        best: &mut [Nearest<R>],
    ) {
        // Primitive by primitive, each ray with its own best so far: every ray meets the
        // leaf's primitives in order with the bounds the one-at-a-time loop gives it.
        for &p in leaf {
            let Some(Prim::Cone(cone)) = scene.prims.get(p as usize) else {
                for i in SetBits(which) {
                    best[i].offer(self.test(&rays[i], p, best[i].t));
                }
                continue;
            };
            ray_groups(rays, which, |idx, group, used| {
                let t_max = idx.map(|i| best[i].t.to_f32());
                let h = cone_lanes::intersect_rays4(cone, group, used, t_max);
                for l in SetBits(h.mask) {
                    best[idx[l]].offer(Some(PrimHit {
                        t: R::from_f32(h.t[l]),
                        prim: p,
                        u: R::ZERO,
                        v: R::ZERO,
                    }));
                }
            });
        }
    }

    /// [`RayPrimTest::any_many`] of a leaf with a cone (out of line as above).
    #[inline(never)]
    fn any_many_cones(
        &mut self,
        scene: &Scene<f32>,
        rays: &[PreparedRay<R>],
        which: u32,
        leaf: &[u32],
        first: &mut [usize],
    ) -> u32 {
        let mut hit = 0;
        // Primitive by primitive over the rays not yet hit: each ray stops at its first hit,
        // having been tested against the primitives up to it.
        for (k, &p) in leaf.iter().enumerate() {
            let open = which & !hit;
            if open == 0 {
                break;
            }
            let Some(Prim::Cone(cone)) = scene.prims.get(p as usize) else {
                for i in SetBits(open) {
                    if self.test(&rays[i], p, rays[i].ray.t_max).is_some() {
                        hit |= 1 << i;
                        first[i] = k;
                    }
                }
                continue;
            };
            ray_groups(rays, open, |idx, group, used| {
                let t_max = idx.map(|i| rays[i].ray.t_max.to_f32());
                let h = cone_lanes::intersect_rays4(cone, group, used, t_max);
                for l in SetBits(h.mask) {
                    hit |= 1 << idx[l];
                    first[idx[l]] = k;
                }
            });
        }
        hit
    }
}
