//! The geometric validity rules of the reader: what makes a camera, cone, sphere or polygon
//! degenerate. Pure functions on values; the parser attaches file positions to their verdicts.
//! Kept apart so tests and generators can apply exactly the rules the reader applies.

use crate::vec3::Vec3d;

/// Smallest sine of the angle between `up` and the view direction that is accepted
/// (about 0.00006°). Anything closer is "up parallel to the view". SPD's sombrero has 32°.
pub const MIN_UP_SINE: f64 = 1e-6;

/// `v` scaled to unit length without overflow or underflow, or `None` for a zero or non-finite
/// vector.
pub fn unit(v: Vec3d) -> Option<Vec3d> {
    let m = v.abs().max_component();
    if m == 0.0 || !m.is_finite() {
        return None;
    }
    let s = v * (1.0 / m);
    if !s.is_finite() {
        // 1/m overflowed (m subnormal): divide instead.
        let s = Vec3d::new(v.x / m, v.y / m, v.z / m);
        return Some(s * (1.0 / s.length()));
    }
    Some(s * (1.0 / s.length()))
}

/// What is wrong with a camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraProblem {
    /// `from` and `at` coincide (or their difference overflows).
    NoViewDirection,
    /// `up` is zero.
    ZeroUp,
    /// `up` is parallel to the view direction.
    UpParallel,
}

/// Checks that `from`, `at` and `up` define a camera frame.
pub fn camera(from: Vec3d, at: Vec3d, up: Vec3d) -> Result<(), CameraProblem> {
    let w = unit(at - from).ok_or(CameraProblem::NoViewDirection)?;
    let u = unit(up).ok_or(CameraProblem::ZeroUp)?;
    if w.cross(u).length() < MIN_UP_SINE {
        return Err(CameraProblem::UpParallel);
    }
    Ok(())
}

/// Newell's normal of a polygon (twice the area vector; exact for planar polygons, robust to
/// concave outlines and to rounding noise).
pub fn newell_normal<I: IntoIterator<Item = Vec3d>>(points: I) -> Vec3d {
    let it = points.into_iter();
    let mut first = None;
    let mut prev: Option<Vec3d> = None;
    let mut n = Vec3d::zero();
    let mut add = |a: Vec3d, b: Vec3d| {
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    };
    for p in it {
        if first.is_none() {
            first = Some(p);
        }
        if let Some(q) = prev {
            add(q, p);
        }
        prev = Some(p);
    }
    if let (Some(a), Some(b)) = (prev, first) {
        add(a, b);
    }
    n
}

/// What is wrong with a polygon's shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PolygonProblem {
    /// The Newell normal is zero: coincident or collinear vertices, zero area.
    ZeroArea,
    /// The Newell normal overflows: coordinates too large to compute with.
    Overflow,
}

/// Checks that a polygon has a usable plane.
pub fn polygon<I: IntoIterator<Item = Vec3d>>(points: I) -> Result<(), PolygonProblem> {
    let n = newell_normal(points);
    if !n.is_finite() {
        Err(PolygonProblem::Overflow)
    } else if n == Vec3d::zero() {
        Err(PolygonProblem::ZeroArea)
    } else {
        Ok(())
    }
}

/// What is wrong with a cone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConeProblem {
    /// Base and apex centres coincide (or their difference overflows).
    NoAxis,
    /// One radius is negative and the other is not (inside-only needs both negative).
    MixedSigns,
    /// Both radii are zero.
    ZeroRadii,
}

/// Checks a cone: an axis, radii of one sign (`-0` counts as non-negative), not both zero.
pub fn cone(
    base: Vec3d,
    base_radius: f64,
    apex: Vec3d,
    apex_radius: f64,
) -> Result<(), ConeProblem> {
    if unit(apex - base).is_none() {
        return Err(ConeProblem::NoAxis);
    }
    if (base_radius < 0.0) != (apex_radius < 0.0) {
        return Err(ConeProblem::MixedSigns);
    }
    if base_radius == 0.0 && apex_radius == 0.0 {
        return Err(ConeProblem::ZeroRadii);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vec3d {
        Vec3d::new(x, y, z)
    }

    #[test]
    fn cameras() {
        let o = v(0.0, 0.0, 0.0);
        let up = v(0.0, 0.0, 1.0);
        assert_eq!(camera(v(1.0, 0.0, 0.0), o, up), Ok(()));
        assert_eq!(camera(o, o, up), Err(CameraProblem::NoViewDirection));
        assert_eq!(camera(v(1.0, 0.0, 0.0), o, o), Err(CameraProblem::ZeroUp));
        assert_eq!(
            camera(v(0.0, 0.0, 5.0), o, v(0.0, 0.0, -3.0)),
            Err(CameraProblem::UpParallel)
        );
        // sombrero: up 32° from the view direction.
        assert_eq!(camera(v(0.0, 5.0, -8.0), o, up), Ok(()));
        // Huge and tiny coordinates still work.
        assert_eq!(camera(v(1e300, 0.0, 0.0), v(-1e300, 0.0, 0.0), up), Ok(()));
        assert_eq!(camera(v(1e-310, 0.0, 0.0), o, v(0.0, 1e-310, 0.0)), Ok(()));
        assert_eq!(
            camera(v(f64::MAX, 0.0, 0.0), v(-f64::MAX, 0.0, 0.0), up),
            Err(CameraProblem::NoViewDirection)
        );
    }

    #[test]
    fn polygons() {
        let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        assert_eq!(newell_normal(tri), v(0.0, 0.0, 1.0));
        assert_eq!(polygon(tri), Ok(()));
        let line = [v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), v(2.0, 2.0, 2.0)];
        assert_eq!(polygon(line), Err(PolygonProblem::ZeroArea));
        let huge = [
            v(0.0, 0.0, 0.0),
            v(f64::MAX, 0.0, 0.0),
            v(0.0, f64::MAX, 0.0),
        ];
        assert_eq!(polygon(huge), Err(PolygonProblem::Overflow));
    }

    #[test]
    fn cones() {
        let (a, b) = (v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0));
        assert_eq!(cone(a, 1.0, b, 0.5), Ok(()));
        assert_eq!(cone(a, -1.0, b, -0.5), Ok(()));
        assert_eq!(cone(a, 1.0, b, 0.0), Ok(()));
        assert_eq!(cone(a, 1.0, b, -0.0), Ok(()));
        assert_eq!(cone(a, 1.0, a, 0.5), Err(ConeProblem::NoAxis));
        assert_eq!(cone(a, -1.0, b, 0.5), Err(ConeProblem::MixedSigns));
        assert_eq!(cone(a, 1.0, b, -0.5), Err(ConeProblem::MixedSigns));
        assert_eq!(cone(a, 0.0, b, 0.0), Err(ConeProblem::ZeroRadii));
    }
}
