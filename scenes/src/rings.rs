//! `rings`: a pyramid of "objects", each six interlocking pentagonal rings (five cylinders and
//! five spheres per ring, one colour per ring), receding from the eye in N layers of
//! 1, 4, 9, … objects, in front of a white wall that just fills the view.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::matrix::Mat4;
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "rings";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 7;

/// Radius of every cylinder and sphere.
const TUBE: f64 = 0.07412;
/// Colours of the six rings of an object: red, green, blue, cyan, magenta, yellow.
const COLOURS: [[f64; 3]; 6] = [
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 0.0],
];
/// How much wider than the 45° view the wall is.
const WALL_MARGIN: f64 = 1.01;

/// Layer spacing along y: 1/sin 22.5°, so a layer's objects just fill the view's width.
fn layer_step() -> f64 {
    1.0 / 22.5f64.to_radians().sin()
}

fn count(n: u32) -> Option<u64> {
    // Σ_{d<n} (d+1)² objects of 30 spheres + 30 cylinders, plus the wall.
    let n = u64::from(n);
    let objects = n.checked_mul(n + 1)?.checked_mul(2 * n + 1)? / 6;
    objects.checked_mul(60)?.checked_add(1)
}

/// Generates the rings at size factor `size` (number of layers).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let total = check_size(NAME, size, count(size))?;
    let step = layer_step();
    let eye = v3(-1.0, -step, 0.5);
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            eye,
            eye + v3(0.0, 1.0, 0.0),
            v3(0.0, 0.0, 1.0),
            45.0,
            1.0,
            512,
        ),
        vec![
            light(3.0, -step, 3.0),
            light(-4.0, -step, 1.0),
            light(2.0, -step, -4.0),
        ],
        total,
    );
    // The wall, facing the eye.
    let wall_y = step * f64::from(size + 1);
    let half = WALL_MARGIN * (wall_y - eye.y) * 22.5f64.to_radians().tan();
    b.material(material(1.0, 1.0, 1.0, 1.0, 0.0, 100000.0, 0.0, 0.0));
    b.polygon(vec![
        v3(eye.x + half, wall_y, eye.z + half),
        v3(eye.x - half, wall_y, eye.z + half),
        v3(eye.x - half, wall_y, eye.z - half),
        v3(eye.x + half, wall_y, eye.z - half),
    ]);
    // One object, centred at the origin: ring k is the base pentagon (in the xy plane) turned
    // about x by the dihedral-like tilt and about z by 36°·(2k − 1).
    let radius = 1.0 / (1.0 + TUBE);
    let pentagon: [Vec3d; 5] = std::array::from_fn(|i| {
        let a = (72.0 * i as f64).to_radians();
        v3(radius * a.cos(), radius * a.sin(), 0.0)
    });
    let tilt = 2.0 * (60f64.to_radians().cos() / 36f64.to_radians().sin()).acos();
    let rings: Vec<[Vec3d; 5]> = (0..6)
        .map(|k| {
            if k == 0 {
                pentagon
            } else {
                let m = Mat4::rotate(0, tilt.to_degrees())
                    .then(&Mat4::rotate(2, 36.0 * f64::from(2 * k - 1)));
                pentagon.map(|p| m.point(p))
            }
        })
        .collect();
    for d in 0..size {
        let y = step * f64::from(d + 1);
        for iz in 0..=d {
            for ix in 0..=d {
                let centre = v3(
                    f64::from(2 * ix) - f64::from(d),
                    y,
                    f64::from(2 * iz) - f64::from(d),
                );
                for (ring, c) in rings.iter().zip(COLOURS) {
                    b.material(material(c[0], c[1], c[2], 0.5, 0.2, 3.0827, 0.0, 0.0));
                    for i in 0..5 {
                        let p = centre + ring[i];
                        let prev = centre + ring[(i + 4) % 5];
                        b.cone(p, TUBE, prev, TUBE);
                        b.sphere(p, TUBE);
                    }
                }
            }
        }
    }
    Ok(b.finish())
}
