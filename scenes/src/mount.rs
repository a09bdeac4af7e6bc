//! `mount`: the fractal mountain of the PARRT paper's test scene, with four glass spheres
//! floating above it. The mountain is a 2^N × 2^N grid over [−1, 1]² whose heights come from
//! recursive midpoint displacement (a variant of Carpenter's method); each cell is two triangles.
//! Size N gives 2·4^N triangles + 4 spheres.
//!
//! ## Heights
//! Every displacement is `rise·g(i, j)`, where `g` is a Gaussian drawn from a small LCG seeded by a
//! hash of the new point's integer grid coordinates, so the height of a point does not depend on
//! which square computed it (shared edges agree, no cracks) nor on the order of computation. The
//! hash is SPD's default ("old") one, which makes sizes up to 7 reproduce SPD's mountains:
//! `seed = 21 + (((i << (23−N)) + (j << (15−N)) + (i << (7−N))) & 0xFFFF)`.
//!
//! **Sizes above 7.** There the C original shifts by a negative amount, which is undefined. We
//! define a shift by a negative amount `−s` as a right shift by `s` (the integer part of
//! `v·2^(−s)`, continuing the same formula); the same rule would apply to the other two shifts
//! beyond N = 15 and 23, which the primitive limit never reaches. Note that the hash has only
//! 2^16 values, so from N = 8 on (more than 2^16 grid points) seeds necessarily repeat, as they
//! would in any extension of it.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "mount";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 6;

/// Fractal dimension of the surface.
const FRACTAL_DIMENSION: f64 = 2.2;
/// Modulus, multiplier and increment of the LCG behind the Gaussian.
const LCG_M: u64 = 134_456;
const LCG_A: u64 = 8121;
const LCG_C: u64 = 28_411;
/// Radius of the glass spheres.
const SPHERE_RADIUS: f64 = 0.17;

/// Shifts left by `s` bits, or right by `−s` bits when `s` is negative (our definition of the
/// negative shifts SPD's hash makes for N > 7).
fn shift(v: u64, s: i64) -> u64 {
    if s >= 0 {
        v << s
    } else {
        v >> (-s)
    }
}

/// SPD's default ("old") hash of grid point (i, j) at size `n` into an LCG seed.
pub fn seed(i: u64, j: u64, n: u32) -> u64 {
    let n = i64::from(n);
    let h = shift(i, 23 - n)
        .wrapping_add(shift(j, 15 - n))
        .wrapping_add(shift(i, 7 - n));
    21 + (h & 0xFFFF)
}

/// A standard normal deviate from the polar Box–Muller method, driven by the LCG
/// x ← (28411 + 8121·x) mod 134456 started at `seed`: pairs of successive values mapped to
/// [−1, 1) are drawn until one falls strictly inside the unit circle.
pub fn gaussian(seed: u64) -> f64 {
    let mut x = seed % LCG_M;
    let mut next = || {
        x = (LCG_C + LCG_A * x) % LCG_M;
        2.0 * x as f64 / LCG_M as f64 - 1.0
    };
    // The LCG has full period, so a pair inside the circle comes within a few draws; the bound
    // only guards the loop.
    for _ in 0..LCG_M {
        let v1 = next();
        let v2 = next();
        let r = v1 * v1 + v2 * v2;
        if r > 0.0 && r < 1.0 {
            return v1 * (-2.0 * r.ln() / r).sqrt();
        }
    }
    0.0
}

/// The (2^n + 1)² grid of heights, row-major with `i` (along x) fastest.
pub fn heights(n: u32) -> Vec<f64> {
    let cells = 1usize << n;
    let side = cells + 1;
    let mut h = vec![0.0f64; side * side];
    let ratio = 2.0 / 2f64.powf(1.0 / (FRACTAL_DIMENSION - 1.0));
    let roughness = (ratio * ratio - 1.0).sqrt();
    let g = |i: usize, j: usize| gaussian(seed(i as u64, j as u64, n));
    // Level by level, coarse to fine. A point's height depends only on its square's corners and
    // on g(i, j), so this gives the same heights as SPD's depth-first recursion.
    let mut w = cells;
    while w >= 2 {
        let half = w / 2;
        // Half the square's width in world units, times the roughness.
        let rise = (w as f64 / cells as f64) * roughness;
        let mut j0 = 0;
        while j0 < cells {
            let mut i0 = 0;
            while i0 < cells {
                let at = |i: usize, j: usize| j * side + i;
                let (ll, lr) = (h[at(i0, j0)], h[at(i0 + w, j0)]);
                let (ur, ul) = (h[at(i0 + w, j0 + w)], h[at(i0, j0 + w)]);
                let (im, jm) = (i0 + half, j0 + half);
                // Edge midpoints (the ones shared with a neighbour get the same value twice).
                h[at(im, j0)] = (ll + lr) / 2.0 + rise * g(im, j0);
                h[at(i0 + w, jm)] = (lr + ur) / 2.0 + rise * g(i0 + w, jm);
                h[at(im, j0 + w)] = (ur + ul) / 2.0 + rise * g(im, j0 + w);
                h[at(i0, jm)] = (ul + ll) / 2.0 + rise * g(i0, jm);
                h[at(im, jm)] =
                    (ll + lr + ur + ul) / 4.0 + std::f64::consts::SQRT_2 * rise * g(im, jm);
                i0 += w;
            }
            j0 += w;
        }
        w = half;
    }
    h
}

/// Writes the cells of the square at (i0, j0) of width `w` in SPD's order: quarters lower-left,
/// lower-right, upper-right, upper-left; each cell as (ll, lr, ur) and (ur, ul, ll).
fn emit(
    b: &mut SceneBuilder,
    point: &dyn Fn(usize, usize) -> Vec3d,
    i0: usize,
    j0: usize,
    w: usize,
) {
    if w == 1 {
        let (ll, lr) = (point(i0, j0), point(i0 + 1, j0));
        let (ur, ul) = (point(i0 + 1, j0 + 1), point(i0, j0 + 1));
        b.polygon(vec![ll, lr, ur]);
        b.polygon(vec![ur, ul, ll]);
        return;
    }
    let h = w / 2;
    for (di, dj) in [(0, 0), (h, 0), (h, h), (0, h)] {
        emit(b, point, i0 + di, j0 + dj, h);
    }
}

/// Generates the mountain at size factor `size` (2^size cells along each side).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let tris = 4u64.checked_pow(size).and_then(|c| c.checked_mul(2));
    let count = check_size(NAME, size, tris.and_then(|t| t.checked_add(4)))?;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(-1.6, 1.6, 1.7),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 1.0),
            45.0,
            0.01,
            512,
        ),
        vec![light(-100.0, -100.0, 100.0)],
        count,
    );
    // Four touching glass spheres at the corners of a regular tetrahedron standing on one face,
    // centred at (−0.8, 0.8, 1): the top one, then three at 120° steps from −45°.
    b.material(material(1.0, 1.0, 1.0, 0.1, 0.1, 101.148, 0.9, 1.5));
    let centre = v3(-0.8, 0.8, 1.0);
    let r = SPHERE_RADIUS;
    b.sphere(centre + v3(0.0, 0.0, r * 1.5f64.sqrt()), r);
    let ring = 2.0 * r / 3f64.sqrt();
    for k in 0..3 {
        let a = (-45.0 + 120.0 * f64::from(k)).to_radians();
        b.sphere(
            centre + v3(ring * a.cos(), ring * a.sin(), -r * 1.5f64.sqrt() / 3.0),
            r,
        );
    }
    b.material(material(0.5, 0.45, 0.35, 1.0, 0.0, 100000.0, 0.0, 0.0));
    let cells = 1usize << size;
    let side = cells + 1;
    let h = heights(size);
    let step = 2.0 / cells as f64;
    let point = |i: usize, j: usize| {
        v3(
            -1.0 + step * i as f64,
            -1.0 + step * j as f64,
            h[j * side + i],
        )
    };
    emit(&mut b, &point, 0, 0, cells);
    Ok(b.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_shift_is_a_right_shift() {
        assert_eq!(shift(0b1011_0000, -4), 0b1011);
        assert_eq!(shift(3, 2), 12);
        // N = 10: i << 13, j << 5, i >> 3.
        assert_eq!(
            seed(9, 2, 10),
            21 + (((9u64 << 13) + (2 << 5) + (9 >> 3)) & 0xFFFF)
        );
    }

    #[test]
    fn gaussian_is_deterministic_and_sane() {
        let a: Vec<f64> = (0..1000).map(|s| gaussian(s * 37)).collect();
        let b: Vec<f64> = (0..1000).map(|s| gaussian(s * 37)).collect();
        assert_eq!(a, b);
        let mean = a.iter().sum::<f64>() / a.len() as f64;
        let var = a.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / a.len() as f64;
        assert!(mean.abs() < 0.15, "mean {mean}");
        assert!((var - 1.0).abs() < 0.25, "variance {var}");
    }

    #[test]
    fn corners_stay_at_zero() {
        let h = heights(3);
        let side = 9;
        for idx in [0, side - 1, side * (side - 1), side * side - 1] {
            assert_eq!(h[idx], 0.0);
        }
    }
}
