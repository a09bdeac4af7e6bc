//! Axis-parallel rays: along ±x, ±y, ±z, in the planes of the accelerators' boxes and through
//! polygon edges, every accelerator finds the known hit.

use crate::setup::{f32_resolves, unlit_scene, Direct, Placement, PLACEMENTS};
use crate::support::scene::{prim, v};
use parrt_render::description::{ConeShape, SceneDescription, Shape};
use parrt_render::real::Real;
use parrt_render::settings::AccelKind;
use parrt_render::vec3::Vec3d;

/// Rays along ±x, ±y, ±z, including rays lying exactly in the planes of the accelerator's boxes
/// (0·∞ in the slab test) and through polygon edges: every accelerator finds the same hit as
/// the known answer.
#[test]
fn axis_parallel_rays() {
    let square = |z: f64| {
        Shape::Polygon(
            vec![
                v(-1.0, -1.0, z),
                v(1.0, -1.0, z),
                v(1.0, 1.0, z),
                v(-1.0, 1.0, z),
            ]
            .into(),
        )
    };
    let desc = unlit_scene(
        v(0.0, 0.0, 10.0),
        vec![
            prim(square(0.0), 0),  // triangles 0, 1
            prim(square(-4.0), 0), // triangles 2, 3
            prim(
                Shape::Sphere {
                    center: v(5.0, 0.0, 0.0),
                    radius: 1.0,
                },
                0,
            ), // 4
            prim(
                Shape::Cone(ConeShape {
                    base: v(0.0, 5.0, -1.0),
                    base_radius: 1.0,
                    apex: v(0.0, 5.0, 1.0),
                    apex_radius: 1.0,
                }),
                0,
            ), // 5
        ],
    );
    // (origin, direction, expected distance)
    let cases: &[(Vec3d, Vec3d, Option<f64>)] = &[
        (v(0.3, 0.2, 5.0), v(0.0, 0.0, -1.0), Some(5.0)),
        (v(0.3, 0.2, -9.0), v(0.0, 0.0, 1.0), Some(5.0)),
        // Negative zeros (what `-n` gives for n = (0, 0, 1)): 1/−0 = −∞, so the slab test must
        // take the sign from the reciprocal, not from `d < 0`.
        (v(0.3, 0.2, 5.0), v(-0.0, -0.0, -1.0), Some(5.0)),
        (v(0.3, 0.2, -9.0), v(-0.0, 0.0, 1.0), Some(5.0)),
        (v(0.0, 0.0, 0.0), v(1.0, -0.0, -0.0), Some(4.0)),
        // On the polygon's edge x = -1 and corner: inside the box's face plane.
        (v(-1.0, 0.0, 5.0), v(0.0, 0.0, -1.0), Some(5.0)),
        (v(1.0, 1.0, 5.0), v(0.0, 0.0, -1.0), Some(5.0)),
        (v(1.0, -1.0, -6.0), v(0.0, 0.0, 1.0), Some(2.0)),
        // Along the shared diagonal of the two triangles.
        (v(0.5, 0.5, 3.0), v(0.0, 0.0, -1.0), Some(3.0)),
        // Just outside the square (two f32 ulps of 1, so that the scaled copies stay outside).
        (v(1.0000002, 0.0, 5.0), v(0.0, 0.0, -1.0), None),
        // Sphere along ±x, and tangent along y (a grazing touch at x = 5, z = 1).
        (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), Some(4.0)),
        (v(9.0, 0.0, 0.0), v(-1.0, 0.0, 0.0), Some(3.0)),
        // Cylinder across (along ±x) and down its open axis (no hit).
        (v(-3.0, 5.0, 0.5), v(1.0, 0.0, 0.0), Some(2.0)),
        (v(0.0, 5.0, 9.0), v(0.0, 0.0, -1.0), None),
        (v(0.0, -9.0, 0.0), v(0.0, 1.0, 0.0), Some(13.0)),
    ];
    fn run<R: Real>(
        desc: &SceneDescription,
        place: Placement,
        cases: &[(Vec3d, Vec3d, Option<f64>)],
    ) {
        let desc = place.scene(desc);
        for accel in [AccelKind::Bvh, AccelKind::Grid, AccelKind::Brute] {
            let d = Direct::<R>::new(&desc, accel, 8);
            for &(o, dir, want) in cases {
                let got = d.hit(place.point(o), dir).map(|h| h.1);
                let at = place.name;
                match (got, want.map(|w| w * place.s)) {
                    (Some(g), Some(w)) => assert!(
                        (g - w).abs() < 1e-5 * w.max(place.s),
                        "{} {at} {accel:?} {o:?} {dir:?}: t = {g}, want {w}",
                        R::NAME
                    ),
                    (None, None) => {}
                    _ => panic!(
                        "{} {at} {accel:?} {o:?} {dir:?}: {got:?}, want {want:?}",
                        R::NAME
                    ),
                }
            }
        }
    }
    for place in PLACEMENTS {
        if f32_resolves(&place.scene(&desc)) {
            run::<f32>(&desc, place, cases);
        }
        run::<f64>(&desc, place, cases);
    }
}
