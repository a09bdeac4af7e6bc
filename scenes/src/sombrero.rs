//! `sombrero`: the height field f = cos(2π·r)·e^(−r), r = √(x² + z²), written as an n × n grid
//! of vertices over [−4, 4]² (n = 32·2^(N−1)), two flat triangles per cell facing +y, at height
//! y = −3 + f. As in SPD, sample i of the field is taken at −4 + 8i/n (the image-like spacing of a
//! height field) while the vertex is placed at −4 + 8i/(n−1), so the field is very slightly
//! stretched. (SPD's POV-Ray export scales the field differently; this is the NFF geometry.)

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;
use std::f64::consts::PI;

const NAME: &str = "sombrero";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 1;

/// Half-width of the sampled square.
const EXTENT: f64 = 4.0;
/// Height offset of the field in the NFF output.
const BASE: f64 = -3.0;

fn height(x: f64, z: f64) -> f64 {
    let r = (x * x + z * z).sqrt();
    BASE + (2.0 * PI * r).cos() * (-r).exp()
}

/// Generates the sombrero at size factor `size` (grid side 32·2^(size−1) samples).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let side = 2u64
        .checked_pow(size.saturating_sub(1))
        .and_then(|p| p.checked_mul(32));
    let tris = side.and_then(|n| (n - 1).checked_mul(n - 1)?.checked_mul(2));
    let count = check_size(NAME, size, tris)?;
    // count ≤ MAX_PRIMITIVES, so the side fits a u32.
    let n = side.unwrap_or(0) as u32;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(0.0, 5.0, -8.0),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 1.0),
            40.0,
            0.01,
            512,
        ),
        vec![light(10.0, 10.0, -10.0)],
        count,
    );
    b.material(material(1.0, 0.1, 0.1, 0.8, 0.0, 2.60078, 0.0, 1.0));
    let place = |i: u32| -EXTENT + 2.0 * EXTENT * f64::from(i) / f64::from(n - 1);
    let sample = |i: u32| -EXTENT + 2.0 * EXTENT * f64::from(i) / f64::from(n);
    let point = |i: u32, j: u32| -> Vec3d { v3(place(i), height(sample(i), sample(j)), place(j)) };
    for j in 0..n - 1 {
        // One row of samples is reused from the previous step to halve the evaluations.
        let mut lo0 = point(0, j);
        let mut hi0 = point(0, j + 1);
        for i in 0..n - 1 {
            let lo1 = point(i + 1, j);
            let hi1 = point(i + 1, j + 1);
            b.polygon(vec![lo0, hi1, lo1]);
            b.polygon(vec![lo0, hi0, hi1]);
            lo0 = lo1;
            hi0 = hi1;
        }
    }
    Ok(b.finish())
}
