//! `lattice`: an (N+1)³ grid of shiny spheres on the unit cube, neighbours joined along x, y and
//! z by red, green and blue matte cylinders. SPD writes an `f` before every primitive, and so do
//! we (a stress test for material switching). The camera sits on the cube's top-back edge.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::{Material, SceneDescription};

const NAME: &str = "lattice";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 12;

/// Sphere radius times N.
const SPHERE_RADIUS: f64 = 0.25;
/// Cylinder radius times N.
const CYLINDER_RADIUS: f64 = 1.0 / 16.0;
/// How far each cylinder end sits from its sphere's centre, times N (inside the sphere).
const INSET: f64 = 0.12375;

/// Generates the lattice at size factor `size` (cells along each edge).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let n = u64::from(size);
    let count = (n + 1)
        .checked_pow(3)
        .and_then(|s| s.checked_add(3u64.checked_mul(n)?.checked_mul((n + 1).checked_pow(2)?)?));
    let count = check_size(NAME, size, count)?;
    let nf = f64::from(size);
    let eye = v3(0.5 + 0.5 / nf, 1.0, 1.0 - 0.5 / nf);
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            eye,
            eye + v3(0.0, -2.0, -2.0),
            v3(0.2, 1.0, 0.0),
            60.0,
            0.0,
            512,
        ),
        vec![
            light(2.0, 0.5, 0.5),
            light(-1.0, 0.5, 0.5),
            light(0.5, 2.0, 0.5),
            light(0.5, -1.0, 0.5),
            light(0.5, 0.5, 2.0),
            light(0.5, 0.5, -1.0),
        ],
        count,
    );
    let ball = material(0.9, 0.9, 0.9, 0.5, 0.5, 3.0827, 0.0, 0.0);
    let rod =
        |r: f64, g: f64, bl: f64| -> Material { material(r, g, bl, 0.99, 0.0, 100000.0, 0.0, 0.0) };
    let rods = [rod(0.9, 0.1, 0.1), rod(0.1, 0.9, 0.1), rod(0.1, 0.1, 0.9)];
    let axes = [v3(1.0, 0.0, 0.0), v3(0.0, 1.0, 0.0), v3(0.0, 0.0, 1.0)];
    let (r_ball, r_rod, inset, step) = (
        SPHERE_RADIUS / nf,
        CYLINDER_RADIUS / nf,
        INSET / nf,
        1.0 / nf,
    );
    for i in 0..=size {
        for j in 0..=size {
            for k in 0..=size {
                let idx = [i, j, k];
                let p = v3(f64::from(i), f64::from(j), f64::from(k)) * step;
                b.material(ball.clone());
                b.sphere(p, r_ball);
                for axis in 0..3 {
                    if idx[axis] < size {
                        b.material(rods[axis].clone());
                        let a = axes[axis];
                        b.cone(p + a * inset, r_rod, p + a * (step - inset), r_rod);
                    }
                }
            }
        }
    }
    Ok(b.finish())
}
