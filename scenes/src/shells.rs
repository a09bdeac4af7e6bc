//! `shells`: Pickover's seashell, a logarithmic spiral of S + 1 overlapping spheres
//! (S = 180·2^N) growing from tiny to large; a deliberately pathological scene. SPD's header
//! mentions a square, but SPD writes none, and neither do we.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use std::f64::consts::PI;

const NAME: &str = "shells";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 5;

/// Growth rate of the spiral: radius = e^(GROWTH·θ).
const GROWTH: f64 = 0.15;
/// Turns of the whole spiral, in units of π (θ spans 18π).
const SPAN: f64 = 18.0;

/// Generates the seashell at size factor `size`.
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let steps = 2u64.checked_pow(size).and_then(|p| p.checked_mul(180));
    let count = check_size(NAME, size, steps.and_then(|s| s.checked_add(1)))?;
    // count ≤ MAX_PRIMITIVES, so the step count fits an i64 comfortably.
    let s = (count - 1) as i64;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(-6.0, -60.0, 35.0),
            v3(0.0, 8.0, -15.0),
            v3(0.0, 0.0, 1.0),
            45.0,
            0.5,
            512,
        ),
        vec![light(-100.0, -100.0, 100.0)],
        count,
    );
    b.material(material(1.0, 0.8, 0.4, 0.8, 0.2, 45.2776, 0.0, 1.0));
    let sf = s as f64;
    for i in (-2 * s / 3)..=(s / 3) {
        let theta = SPAN * PI * i as f64 / sf;
        let r = (GROWTH * theta).exp();
        b.sphere(v3(r * theta.sin(), r * theta.cos(), -2.0 * r), r);
    }
    Ok(b.finish())
}
