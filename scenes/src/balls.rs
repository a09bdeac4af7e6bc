//! `balls`: Haines' sphereflake. A sphere carries nine spheres a third its size, touching it, in a
//! fixed pattern around its growth direction; each of them does the same, N levels deep. One
//! matte floor square sits under the flake. Size N gives Σ_{k=0..N} 9^k spheres + 1 polygon.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "balls";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 4;

/// Number of spheres at size `n`: Σ_{k=0..n} 9^k, `None` on overflow.
fn sphere_count(n: u32) -> Option<u64> {
    let mut total: u64 = 0;
    let mut level: u64 = 1;
    for k in 0..=n {
        total = total.checked_add(level)?;
        if k < n {
            level = level.checked_mul(9)?;
        }
    }
    Some(total)
}

/// The nine child directions in the local frame whose +z is the growth direction, in SPD's
/// output order: three groups g = 0, 1, 2, each one sphere above the equator at elevation
/// asin(√(2/3)) and azimuth 45° + 120°g, then two on the equator at 15° + 120°g and 75° + 120°g.
fn child_directions() -> [Vec3d; 9] {
    let mut dirs = [Vec3d::zero(); 9];
    let elev = (2.0f64 / 3.0).sqrt().asin();
    let (se, ce) = elev.sin_cos();
    for g in 0..3 {
        let base = 120.0 * g as f64;
        let up = (45.0 + base).to_radians();
        dirs[3 * g] = v3(ce * up.cos(), ce * up.sin(), se);
        for (k, az) in [15.0, 75.0].into_iter().enumerate() {
            let a = (az + base).to_radians();
            dirs[3 * g + 1 + k] = v3(a.cos(), a.sin(), 0.0);
        }
    }
    dirs
}

/// Maps local vector `v` (frame with +z along unit `d`) to world: the rotation that takes +z to
/// `d` about the axis z × d; d ≈ +z is the identity and d ≈ −z a half turn about y.
fn to_world(d: Vec3d, v: Vec3d) -> Vec3d {
    let c = d.z;
    if c > 1.0 - 1e-12 {
        return v;
    }
    if c < -1.0 + 1e-12 {
        return v3(-v.x, v.y, -v.z);
    }
    // Rodrigues with unit axis k = (z × d)/|z × d| and sin θ = |z × d|.
    let axis = v3(-d.y, d.x, 0.0);
    let s = axis.length();
    let k = axis * (1.0 / s);
    v * c + k.cross(v) * s + k * (k.dot(v) * (1.0 - c))
}

fn flake(
    b: &mut SceneBuilder,
    dirs: &[Vec3d; 9],
    center: Vec3d,
    radius: f64,
    dir: Vec3d,
    depth: u32,
) {
    b.sphere(center, radius);
    if depth == 0 {
        return;
    }
    let child_r = radius / 3.0;
    for local in dirs {
        let d = to_world(dir, *local);
        flake(
            b,
            dirs,
            center + d * (radius + child_r),
            child_r,
            d,
            depth - 1,
        );
    }
}

/// Generates the sphereflake at size factor `size` (recursion depth).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let spheres = check_size(
        NAME,
        size,
        sphere_count(size).and_then(|n| n.checked_add(1)),
    )?;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(2.1, 1.3, 1.7),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 1.0),
            45.0,
            0.01,
            512,
        ),
        vec![
            light(4.0, 3.0, 2.0),
            light(1.0, -4.0, 4.0),
            light(-3.0, 1.0, 5.0),
        ],
        spheres,
    );
    b.material(material(1.0, 0.75, 0.33, 0.8, 0.0, 100000.0, 0.0, 1.0));
    let z = -0.5;
    b.polygon(vec![
        v3(12.0, 12.0, z),
        v3(-12.0, 12.0, z),
        v3(-12.0, -12.0, z),
        v3(12.0, -12.0, z),
    ]);
    b.material(material(1.0, 0.9, 0.7, 0.5, 0.5, 3.0827, 0.0, 1.0));
    flake(
        &mut b,
        &child_directions(),
        Vec3d::zero(),
        0.5,
        v3(0.0, 0.0, 1.0),
        size,
    );
    Ok(b.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts() {
        assert_eq!(sphere_count(4), Some(7381));
        assert_eq!(sphere_count(3), Some(820));
        assert!(generate(9).is_err());
    }
}
