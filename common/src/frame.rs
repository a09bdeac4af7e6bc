//! The rendering frame: the origin, chosen in `f64` from the description, that the render-ready
//! scene, its lights and the camera are expressed relative to, so that `f32` carries only the
//! scene's *relative* extent and a scene placed far from the world origin (survey, CAD or
//! astronomy coordinates) renders as if it sat at the origin.
//!
//! The origin is the eye rounded to a power-of-two grid four times coarser than the scene's
//! extent (primitives and eye). A scene whose eye lies within its own extent of the world origin
//! (every SPD scene) therefore gets origin 0, an exact no-op: its images keep their bits. For the
//! others every coordinate is `c − origin`, subtracted in `f64` before rounding to the renderer's
//! precision; the grid's coarseness keeps the origin's bits few, so the subtraction is exact for
//! coordinates near the eye.
//!
//! The extent comes from the bounds of at most [`SAMPLE_LIMIT`] primitives, evenly strided
//! ([`sampled_bounds`]): every primitive of a scene up to that size, a deterministic sample of a
//! larger one (the origin only has to be near the eye; a full pass over millions of polygons
//! costs more than the rest of the precision estimate together).

use crate::description::{Bounds, SceneDescription};
use crate::vec3::Vec3d;

/// Grid cells per scene extent (rounded up to a power of two): the eye is rounded to multiples
/// of `GRID_FACTOR · 2^⌈log₂ extent⌉`, so an eye within twice the extent of the origin per axis
/// keeps origin 0, and the rebased eye is never further than that from the new origin.
const GRID_FACTOR_LOG2: i32 = 2;

/// The origin for a scene whose primitives span `bounds` (may be empty) seen from `eye`.
pub fn origin_for(bounds: &Bounds, eye: Vec3d) -> Vec3d {
    if !eye.is_finite() {
        return Vec3d::zero();
    }
    let mut b = *bounds;
    b.add_point(eye);
    let extent = (b.max - b.min).max_component();
    if !(extent > 0.0) || !extent.is_finite() {
        return Vec3d::zero();
    }
    // 2^k ≥ extent, built exactly (powi of 2 is a product of powers of two).
    let k = (extent.log2().ceil() as i32).clamp(-1000, 1000) + GRID_FACTOR_LOG2;
    let cell = 2f64.powi(k);
    if !(cell > 0.0) || !cell.is_finite() {
        return Vec3d::zero();
    }
    // eye / cell and the product are exact (power-of-two scaling); round() is exact.
    let snap = |c: f64| {
        let n = (c / cell).round();
        if n == 0.0 {
            0.0
        } else {
            n * cell
        }
    };
    Vec3d::new(snap(eye.x), snap(eye.y), snap(eye.z))
}

/// Most primitives whose bounds the origin (and [`crate::precision`]'s estimate) looks at.
pub const SAMPLE_LIMIT: usize = 1 << 16;

/// The step between sampled primitives: 1 up to [`SAMPLE_LIMIT`] primitives.
pub fn sample_stride(n: usize) -> usize {
    n.div_ceil(SAMPLE_LIMIT).max(1)
}

/// Bounds of every [`sample_stride`]-th primitive and of the last one.
pub fn sampled_bounds(desc: &SceneDescription) -> Bounds {
    let n = desc.primitives.len();
    let mut b = Bounds::empty();
    for p in desc.primitives.iter().step_by(sample_stride(n)) {
        b.union(&p.shape.bounds());
    }
    if let Some(p) = desc.primitives.last() {
        b.union(&p.shape.bounds());
    }
    b
}

/// The origin of `desc`'s rendering frame.
pub fn origin(desc: &SceneDescription) -> Vec3d {
    origin_for(&sampled_bounds(desc), desc.view.from)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Bounds {
        Bounds {
            min: Vec3d::new(-1.0, -1.0, -1.0),
            max: Vec3d::new(1.0, 1.0, 1.0),
        }
    }

    #[test]
    fn near_origin_is_zero() {
        assert_eq!(
            origin_for(&unit_box(), Vec3d::new(3.0, -4.0, 0.5)),
            Vec3d::zero()
        );
        assert_eq!(
            origin_for(&Bounds::empty(), Vec3d::new(3.0, 4.0, 5.0)),
            Vec3d::zero()
        );
    }

    #[test]
    fn far_scene_gets_an_origin_near_its_eye() {
        let t = Vec3d::new(1e7, -3.3e7, 1e5);
        let b = Bounds {
            min: unit_box().min + t,
            max: unit_box().max + t,
        };
        let eye = t + Vec3d::new(2.0, 3.0, -1.0);
        let o = origin_for(&b, eye);
        let rel = eye - o;
        assert!(rel.abs().max_component() <= 32.0, "{o:?}");
        // Origin is a multiple of a power of two: exactly representable, few bits.
        assert_eq!(o.x % 16.0, 0.0);
    }

    #[test]
    fn non_finite_eye_gives_zero() {
        assert_eq!(
            origin_for(&unit_box(), Vec3d::splat(f64::NAN)),
            Vec3d::zero()
        );
    }
}
