//! `gears`: an N × N × N grid of 36-tooth gears whose teeth mesh with their neighbours', over a
//! reflective ground square. Each gear is a prism: a concave 144-vertex top face, 144 side quads
//! and the bottom face. Some gears are transparent. Size N gives 146·N³ + 1 polygons.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "gears";

/// SPD's compiled-in size factor.
pub const DEFAULT_SIZE: u32 = 4;

/// Teeth per gear.
const TEETH: usize = 36;
/// Outline radius at the tooth tips, as a fraction of the outer radius.
const TIP: f64 = 0.995;
/// Outline radius at the tooth roots.
const ROOT: f64 = 0.9;
/// Angular positions of a tooth's four outline points, in tooth pitches: two at the tip, then
/// two at the root.
const TOOTH_POINTS: [(f64, f64); 4] = [(-0.19, TIP), (0.19, TIP), (0.3, ROOT), (0.7, ROOT)];
/// Centre spacing of neighbouring gears, in outer radii (less than 2, so the teeth interlock).
const SPACING: f64 = 1.9;

/// A gear's colour: per channel, an integer linear form in the grid indices taken mod 7 (plus a
/// small offset so no channel is zero), rescaled so the largest channel is 1. The forms are
/// chosen to reproduce SPD's gear colours.
fn gear_colour(ix: u32, iy: u32, iz: u32) -> Vec3d {
    // (constant, ix, iy, iz) coefficients per channel.
    const FORMS: [[u64; 4]; 3] = [[5, 1, 3, 5], [3, 3, 2, 6], [2, 4, 2, 6]];
    let [r, g, b] = FORMS.map(|f| {
        let k = (f[0] + f[1] * u64::from(ix) + f[2] * u64::from(iy) + f[3] * u64::from(iz)) % 7;
        k as f64 + 0.07
    });
    let m = r.max(g).max(b);
    v3(r / m, g / m, b / m)
}

/// The gear outline around the origin, counter-clockwise from +x, turned by `phase` radians.
fn outline(radius: f64, phase: f64) -> Vec<(f64, f64)> {
    let pitch = 2.0 * std::f64::consts::PI / TEETH as f64;
    let mut pts = Vec::with_capacity(TEETH * TOOTH_POINTS.len());
    for t in 0..TEETH {
        for (frac, r) in TOOTH_POINTS {
            let a = phase + pitch * (t as f64 + frac);
            pts.push((radius * r * a.cos(), radius * r * a.sin()));
        }
    }
    pts
}

/// Generates the gears at size factor `size` (gears along each axis).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let per_gear = (2 + TEETH * TOOTH_POINTS.len()) as u64;
    let count = u64::from(size)
        .checked_pow(3)
        .and_then(|g| g.checked_mul(per_gear)?.checked_add(1));
    let count = check_size(NAME, size, count)?;
    let n = f64::from(size);
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(-1.1, -2.1, 2.6),
            v3(0.0, 0.0, 0.0),
            v3(0.0, 0.0, 1.0),
            45.0,
            1.0,
            512,
        ),
        vec![
            light(2.0, 4.0, 4.0),
            light(-2.0, 4.0, 3.0),
            light(2.0, -2.5, 2.5),
            light(-1.0, -4.0, 2.0),
            light(-1.111, -2.121, 2.626),
        ],
        count,
    );
    b.material(material(1.0, 0.85, 0.7, 0.3, 0.6, 3.0827, 0.0, 0.0));
    b.polygon(vec![
        v3(2.0, 2.0, 0.0),
        v3(-2.0, 2.0, 0.0),
        v3(-2.0, -2.0, 0.0),
        v3(2.0, -2.0, 0.0),
    ]);
    let radius = 1.0 / (n - (n - 1.0) * 0.05);
    let thickness = (1.0 / (2.0 * n)).min(0.1);
    let half_tooth = std::f64::consts::PI / TEETH as f64;
    let shapes = [outline(radius, 0.0), outline(radius, half_tooth)];
    for iz in 0..size {
        let top = 1.0 - f64::from(iz) / n;
        let bottom = top - thickness;
        for iy in 0..size {
            for ix in 0..size {
                let cx = -1.0 + radius + SPACING * radius * f64::from(ix);
                let cy = -1.0 + radius + SPACING * radius * f64::from(iy);
                let c = gear_colour(ix, iy, iz);
                if (4 * u64::from(ix) + 2 * u64::from(iy) + u64::from(iz)) % 5 == 0 {
                    b.material(material(c.x, c.y, c.z, 0.2, 0.0, 100000.0, 0.8, 1.1));
                } else {
                    b.material(material(c.x, c.y, c.z, 1.0, 0.0, 100000.0, 0.0, 0.0));
                }
                let shape = &shapes[((ix + iy + iz) % 2) as usize];
                let at = |i: usize, z: f64| -> Vec3d {
                    let (x, y) = shape[i % shape.len()];
                    v3(cx + x, cy + y, z)
                };
                let m = shape.len();
                b.polygon((0..m).map(|i| at(i, top)).collect());
                for i in 0..m {
                    b.polygon(vec![
                        at(i, top),
                        at(i, bottom),
                        at(i + 1, bottom),
                        at(i + 1, top),
                    ]);
                }
                // The same outline backwards (starting at point 1), so the bottom faces down.
                b.polygon((0..m).map(|k| at(1 + m - k, bottom)).collect());
            }
        }
    }
    Ok(b.finish())
}
