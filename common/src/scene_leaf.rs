//! The scene's primitive test as the accelerators call it ([`crate::accel::RayPrimTest`]): one
//! primitive at a time through [`Scene::intersect_prim`], except that a BVH leaf of two or more
//! triangles in `f32` goes to the four-at-a-time SIMD kernel ([`crate::geometry::triangle4`]),
//! which gives each triangle exactly the scalar test's answer. The choice of precision is by
//! type and folds away at compile time; the kernel is chosen at run time by CPU features.

use std::any::Any;

use crate::accel::{OneRay, RayPrimTest};
use crate::geometry::triangle4::{intersect4, Tris4, LANES};
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::scene::{Prim, Scene};
use crate::vec3::V3;

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

/// The triangles of a leaf of 2..=4 primitives, or `None` when it is shorter, longer or holds
/// another kind of primitive.
#[inline(always)]
fn triangles<'a>(prims: &'a [Prim<f32>], leaf: &[u32]) -> Option<Tris4<'a, f32>> {
    if leaf.len() < 2 || leaf.len() > LANES {
        return None;
    }
    let tri = |p: u32| -> Option<&'a [V3<f32>; 3]> {
        match prims.get(p as usize)? {
            Prim::Triangle(v) => Some(v),
            _ => None,
        }
    };
    let first = tri(leaf[0])?;
    let mut tris = [first; LANES];
    for (slot, &p) in tris.iter_mut().zip(leaf).skip(1) {
        *slot = tri(p)?;
    }
    Some(tris)
}

impl<R: Real> RayPrimTest<R> for SceneLeaf<'_, R> {
    #[inline(always)]
    fn test(&mut self, pr: &PreparedRay<R>, prim: u32, t_max: R) -> Option<PrimHit<R>> {
        self.scene.intersect_prim(prim, pr, t_max)
    }

    #[inline(always)]
    fn closest(&mut self, pr: &PreparedRay<R>, leaf: &[u32], best: &mut Nearest<R>) {
        if let Some((scene, pr32)) = self.as_f32(pr) {
            if let Some(tris) = triangles(&scene.prims, leaf) {
                // Every lane with the bound the leaf is entered with: a hit beyond the best so
                // far never beats it, so offering the hits in order picks what the one-at-a-time
                // loop picks.
                let h = intersect4(pr32, &tris, leaf.len(), best.t.to_f32());
                let mut m = h.mask;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    best.offer(Some(PrimHit {
                        t: R::from_f32(h.t[i]),
                        prim: leaf[i],
                        u: R::from_f32(h.b1[i]),
                        v: R::from_f32(h.b2[i]),
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
            if let Some(tris) = triangles(&scene.prims, leaf) {
                let m = intersect4(pr32, &tris, leaf.len(), t_max.to_f32()).mask;
                return (m != 0).then(|| m.trailing_zeros() as usize);
            }
        }
        leaf.iter().position(|&p| self.test(pr, p, t_max).is_some())
    }
}
