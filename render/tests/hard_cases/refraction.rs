//! Refraction: nested glass spheres, seen from outside, from inside the outer glass and from
//! inside the innermost sphere, give finite radiance and no black speckles.

use crate::setup::{f32_resolves, Direct, PLACEMENTS};
use crate::support::scene::{mat, prim, v, view};
use parrt_render::description::{Light, SceneDescription, Shape};
use parrt_render::settings::AccelKind;
use parrt_render::vec3::Vec3d;

fn glass_scene(from: Vec3d, at: Vec3d) -> SceneDescription {
    let mut prims = vec![
        prim(
            Shape::Sphere {
                center: v(0.0, 0.0, 0.0),
                radius: 2.0,
            },
            1,
        ),
        prim(
            Shape::Sphere {
                center: v(0.2, 0.0, 0.1),
                radius: 1.2,
            },
            2,
        ),
        prim(
            Shape::Sphere {
                center: v(0.3, 0.1, 0.1),
                radius: 0.5,
            },
            3,
        ),
    ];
    // A checkered room around it, so refracted rays see structure.
    for i in 0..8 {
        for j in 0..8 {
            let (x, y) = (i as f64 * 2.0 - 8.0, j as f64 * 2.0 - 8.0);
            let m = ((i + j) % 2) as u32 * 4;
            prims.push(prim(
                Shape::Polygon(
                    vec![
                        v(x, y, -3.0),
                        v(x + 2.0, y, -3.0),
                        v(x + 2.0, y + 2.0, -3.0),
                        v(x, y + 2.0, -3.0),
                    ]
                    .into(),
                ),
                m,
            ));
        }
    }
    SceneDescription {
        background: v(0.3, 0.4, 0.6),
        view: view(from, at, v(0.0, 0.0, 1.0), 60.0, 48),
        lights: vec![
            Light {
                position: v(5.0, -4.0, 6.0),
                color: None,
            },
            Light {
                position: v(0.1, 0.0, 0.2),
                color: None,
            },
        ],
        materials: vec![
            mat([0.9, 0.9, 0.9], 0.8, 0.0, 0.0, 1.0),
            mat([1.0, 1.0, 1.0], 0.1, 0.1, 0.9, 1.5),
            mat([0.8, 1.0, 0.8], 0.1, 0.2, 0.8, 1.33),
            mat([1.0, 0.8, 0.8], 0.1, 0.3, 0.7, 2.4),
            mat([0.2, 0.2, 0.9], 0.8, 0.0, 0.0, 1.0),
        ],
        primitives: prims,
    }
}

/// Nested glass spheres seen from outside, a camera inside the outer glass, and one inside the
/// innermost sphere: radiance is always finite (checked before the film could clean it), and no
/// pixel is an isolated black speckle among bright neighbours.
#[test]
fn nested_glass_and_camera_inside_glass() {
    let cases = [
        (v(0.5, -7.0, 2.0), v(0.0, 0.0, 0.0)),
        (v(-1.5, 0.3, 0.2), v(1.0, 0.0, -1.0)),
        (v(0.3, 0.1, 0.15), v(0.0, 1.0, -1.0)),
    ];
    for ((from, at), place) in cases.into_iter().flat_map(|c| PLACEMENTS.map(|p| (c, p))) {
        let desc = place.scene(&glass_scene(from, at));
        let from = (from, place.name);
        let size = 48;
        let check = |img: &[[f64; 3]], label: &str| {
            for (i, p) in img.iter().enumerate() {
                assert!(
                    p.iter().all(|c| c.is_finite() && *c >= 0.0),
                    "{from:?} {label}: pixel {i} = {p:?}"
                );
            }
            let lum = |x: usize, y: usize| {
                let p = img[y * size + x];
                p[0] + p[1] + p[2]
            };
            for y in 1..size - 1 {
                for x in 1..size - 1 {
                    let me = lum(x, y);
                    let mut neigh = f64::INFINITY;
                    for (dx, dy) in [(0, 1), (2, 1), (1, 0), (1, 2)] {
                        neigh = neigh.min(lum(x + dx - 1, y + dy - 1));
                    }
                    assert!(
                        !(me < 0.02 && neigh > 0.2),
                        "{from:?} {label}: black speckle at ({x},{y}): {me} among {neigh}"
                    );
                }
            }
        };
        if f32_resolves(&desc) {
            check(
                &Direct::<f32>::new(&desc, AccelKind::Bvh, size as u32).radiance(size as u32),
                "f32",
            );
        }
        check(
            &Direct::<f64>::new(&desc, AccelKind::Bvh, size as u32).radiance(size as u32),
            "f64",
        );
    }
}
