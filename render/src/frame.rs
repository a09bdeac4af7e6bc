//! The rendering frame: the origin, chosen in `f64` from the description, that the render-ready
//! scene, its lights and the camera are expressed relative to, so that `f32` carries only the
//! scene's *relative* extent and a scene placed far from the world origin (survey, CAD or
//! astronomy coordinates) renders as if it sat at the origin.
//!
//! Per axis, the origin is 0 when the eye lies within twice the scene's extent (primitives and
//! eye, rounded up to a power of two) of the world origin — every SPD scene: an exact no-op, its
//! images keep their bits — and otherwise the eye rounded to a power-of-two grid 1/256 of that
//! extent, so the rebased eye sits within 1/512 of the extent of the origin. Every coordinate is
//! then `c − origin`, subtracted in `f64` before rounding to the renderer's precision; the
//! origin has few significant bits, so the subtraction is exact for coordinates near the eye.
//!
//! The extent comes from the bounds of at most [`SAMPLE_LIMIT`] primitives, evenly strided
//! ([`sampled_bounds`]): every primitive of a scene up to that size, a deterministic sample of a
//! larger one (the origin only has to be near the eye; a full pass over millions of polygons
//! costs more than the rest of the precision estimate together).

use crate::description::{Bounds, SceneDescription};
use crate::vec3::Vec3d;

/// An eye coordinate within 2^ZERO_LOG2 · 2^⌈log₂ extent⌉ of 0 keeps origin 0 on that axis.
const ZERO_LOG2: i32 = 1;
/// Otherwise it is rounded to multiples of 2^⌈log₂ extent⌉ / 2^FINE_LOG2.
const FINE_LOG2: i32 = 8;

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
    let k = (extent.log2().ceil() as i32).clamp(-900, 900);
    let near = 2f64.powi(k + ZERO_LOG2);
    let cell = 2f64.powi(k - FINE_LOG2);
    if !(cell > 0.0) || !near.is_finite() {
        return Vec3d::zero();
    }
    // c / cell and the product are exact (power-of-two scaling); round() is exact.
    let snap = |c: f64| {
        if c.abs() < near {
            0.0
        } else {
            (c / cell).round() * cell
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
        // Extent 4: the eye within 4/512 of the origin, a multiple of 4/256.
        assert!(rel.abs().max_component() <= 4.0 / 512.0, "{o:?}");
        assert_eq!(o.x % (4.0 / 256.0), 0.0);
        assert_ne!(o.z, 0.0);
        // Only the far axes move.
        let mixed = origin_for(&b, Vec3d::new(1e7, 2.0, 0.5));
        assert_eq!((mixed.y, mixed.z), (0.0, 0.0));
    }

    #[test]
    fn non_finite_eye_gives_zero() {
        assert_eq!(
            origin_for(&unit_box(), Vec3d::splat(f64::NAN)),
            Vec3d::zero()
        );
    }
}
