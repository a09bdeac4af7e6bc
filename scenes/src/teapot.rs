//! `teapot`: Newell's teapot on a checkerboard. Each of the 32 bicubic Bézier patches (see
//! [`crate::teapot_data`]) is sampled on an N × N grid of (u, v) cells, each cell split into two
//! triangles with per-vertex normals (`pp 3`). Triangles with two or more vertices on the z axis
//! (where the lid and bottom patches collapse to a point) are dropped; a kept triangle's vertex on
//! the axis gets the normal (0, 0, +1) on the lid and (0, 0, −1) on the bottom. Size N gives
//! 64N² − 8N patches and N × N squares. SPD's compiled default is 6; the "standard" teapot of
//! SPD's statistics is size 12. Size 1 is refused, as SPD flags it unsupported.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::teapot_data::{PATCHES, VERTICES};
use crate::GenError;
use parrt_render::description::{PatchVertex, SceneDescription};
use parrt_render::vec3::Vec3d;

const NAME: &str = "teapot";

/// SPD's compiled-in size factor (the standard benchmark uses 12).
pub const DEFAULT_SIZE: u32 = 6;

/// Half-width of the checkerboard.
const BOARD: f64 = 4.0;
/// Points this close to the z axis count as on it.
const AXIS_EPS: f64 = 1e-9;
/// Height separating the bottom (below) from the lid (above), for the forced axis normals.
const MID_HEIGHT: f64 = 1.5;

/// The cubic Bernstein polynomials at `t` and their derivatives.
fn bernstein(t: f64) -> ([f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    (
        [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t],
        [
            -3.0 * s * s,
            3.0 * s * s - 6.0 * t * s,
            6.0 * t * s - 3.0 * t * t,
            3.0 * t * t,
        ],
    )
}

fn on_axis(p: Vec3d) -> bool {
    p.x.abs() < AXIS_EPS && p.y.abs() < AXIS_EPS
}

/// Samples patch `k` on an (n+1)² grid: position and unit normal (v-derivative × u-derivative),
/// row-major with v fastest.
fn sample_patch(k: usize, n: u32) -> Vec<PatchVertex> {
    let cp: [Vec3d; 16] = std::array::from_fn(|i| {
        let [x, y, z] = VERTICES[PATCHES[k][i] as usize];
        v3(x, y, z)
    });
    let basis: Vec<([f64; 4], [f64; 4])> = (0..=n)
        .map(|i| bernstein(f64::from(i) / f64::from(n)))
        .collect();
    let mut out = Vec::with_capacity(basis.len() * basis.len());
    for (bu, dbu) in &basis {
        for (bv, dbv) in &basis {
            let (mut p, mut du, mut dv) = (Vec3d::zero(), Vec3d::zero(), Vec3d::zero());
            for r in 0..4 {
                for c in 0..4 {
                    let q = cp[4 * r + c];
                    p += q * (bu[r] * bv[c]);
                    du += q * (dbu[r] * bv[c]);
                    dv += q * (bu[r] * dbv[c]);
                }
            }
            let normal = if on_axis(p) {
                v3(0.0, 0.0, if p.z > MID_HEIGHT { 1.0 } else { -1.0 })
            } else {
                let nrm = dv.cross(du);
                let len = nrm.length();
                if len > 0.0 {
                    nrm * (1.0 / len)
                } else {
                    nrm
                }
            };
            out.push(PatchVertex {
                position: p,
                normal,
            });
        }
    }
    out
}

/// Generates the teapot at size factor `size` (cells per patch side and squares per board side).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    if size == 1 {
        return Err(GenError::BadSize {
            name: NAME.to_string(),
            size,
            why: "SPD does not support teapot size 1 (use 2 or more)".to_string(),
        });
    }
    let n64 = u64::from(size);
    let count = n64
        .checked_mul(n64)
        .and_then(|sq| sq.checked_mul(64)?.checked_sub(8 * n64)?.checked_add(sq));
    let count = check_size(NAME, size, count)?;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(4.86, 7.2, 5.4),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 1.0),
            45.0,
            1.0,
            512,
        ),
        vec![light(-3.1, 9.8, 12.1), light(11.3, 5.1, 8.8)],
        count,
    );
    // Checkerboard: all white squares, then all grey ones; x outer, y inner.
    let step = 2.0 * BOARD / f64::from(size);
    for (shade, parity) in [(1.0, 1), (0.5, 0)] {
        b.material(material(shade, shade, shade, 0.5, 0.5, 4.81884, 0.0, 0.0));
        for i in 0..size {
            for j in 0..size {
                if (i + j) % 2 != parity {
                    continue;
                }
                let edge = |k: u32| -BOARD + step * f64::from(k);
                let (x0, y0, x1, y1) = (edge(i), edge(j), edge(i + 1), edge(j + 1));
                b.polygon(vec![
                    v3(x0, y0, 0.0),
                    v3(x1, y0, 0.0),
                    v3(x1, y1, 0.0),
                    v3(x0, y1, 0.0),
                ]);
            }
        }
    }
    b.material(material(1.0, 0.5, 0.1, 0.75, 0.25, 3.0827, 0.0, 0.0));
    let side = size as usize + 1;
    for k in 0..PATCHES.len() {
        let grid = sample_patch(k, size);
        let at = |i: usize, j: usize| grid[i * side + j];
        for i in 0..side - 1 {
            for j in 0..side - 1 {
                let (a, bb, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
                for tri in [[a, bb, c], [c, d, a]] {
                    if tri.iter().filter(|v| on_axis(v.position)).count() < 2 {
                        b.patch(tri.to_vec());
                    }
                }
            }
        }
    }
    Ok(b.finish())
}
