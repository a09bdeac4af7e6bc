//! `jacks`: recursive jacks. A jack is three axis-aligned cylinders with a sphere at each of
//! their six ends; it recurses into its eight octants at half scale. The whole set is turned
//! −20° about y and then −30° about x. Size N gives Σ_{k<N} 8^k jacks of 9 primitives each.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder};
use crate::matrix::Mat4;
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "jacks";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 1;

/// Half-length of a top-level arm.
const ARM: f64 = 0.75;
/// Arm (cylinder) radius of the top-level jack.
const ARM_RADIUS: f64 = 0.075;
/// Radius of the top-level knob spheres.
const KNOB_RADIUS: f64 = 0.15;

fn jack_count(n: u32) -> Option<u64> {
    let mut total: u64 = 0;
    let mut level: u64 = 1;
    for _ in 0..n {
        total = total.checked_add(level)?;
        level = level.saturating_mul(8);
    }
    Some(total)
}

fn jack(b: &mut SceneBuilder, m: &Mat4, center: Vec3d, scale: f64, levels: u32) {
    let axes = [v3(1.0, 0.0, 0.0), v3(0.0, 1.0, 0.0), v3(0.0, 0.0, 1.0)];
    let end = |a: Vec3d, sign: f64| m.point(center + a * (sign * ARM * scale));
    for a in axes {
        b.cone(
            end(a, -1.0),
            ARM_RADIUS * scale,
            end(a, 1.0),
            ARM_RADIUS * scale,
        );
    }
    for sign in [1.0, -1.0] {
        for a in axes {
            b.sphere(end(a, sign), KNOB_RADIUS * scale);
        }
    }
    if levels <= 1 {
        return;
    }
    let h = scale / 2.0;
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                jack(b, m, center + v3(sx, sy, sz) * h, h, levels - 1);
            }
        }
    }
}

/// Generates the jacks at size factor `size` (levels of recursion, 1 = a single jack).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let count = check_size(NAME, size, jack_count(size).and_then(|j| j.checked_mul(9)))?;
    let mut b = SceneBuilder::new(
        v3(0.2, 0.05, 0.2),
        view(
            v3(0.0, 0.0, -8.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 1.0, 0.0),
            25.0,
            0.001,
            256,
        ),
        vec![light(-10.0, 3.0, -20.0)],
        count,
    );
    b.material(material(0.737, 0.561, 0.561, 0.7, 0.7, 11.1434, 0.0, 1.0));
    let m = Mat4::rotate(1, -20.0).then(&Mat4::rotate(0, -30.0));
    jack(&mut b, &m, Vec3d::zero(), 1.0, size);
    Ok(b.finish())
}
