//! Polygon meshes: watertight jittered meshes and many triangles at one vertex let no eye ray
//! through, and a concave 144-vertex gear polygon is hit in its teeth and hub, missed in its
//! notches — at every placement and precision.

use crate::setup::{
    f32_resolves, perpendiculars, precisions, render, settings, Direct, Placement, PLACEMENTS,
};
use crate::support::scene::{mat, prim, tri, v, view};
use parrt_render::description::{Light, SceneDescription, Shape};
use parrt_render::real::Real;
use parrt_render::render::Renderer;
use parrt_render::settings::AccelKind;
use parrt_render::vec3::Vec3d;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

// ---------------------------------------------------------------------------------------------
// Watertight meshes
// ---------------------------------------------------------------------------------------------

/// A 70×70-cell grid of jittered vertices (9,800 triangles sharing every edge) filling the view:
/// no eye ray may slip between neighbours, looked at straight on and at a slant.
#[test]
fn jittered_mesh_has_no_leaks() {
    let n = 70usize;
    let mut rng = StdRng::seed_from_u64(6);
    let mut grid = vec![v(0.0, 0.0, 0.0); (n + 1) * (n + 1)];
    for j in 0..=n {
        for i in 0..=n {
            let interior = i > 0 && i < n && j > 0 && j < n;
            let (jx, jy, jz) = if interior {
                (
                    rng.gen_range(-0.4..0.4),
                    rng.gen_range(-0.4..0.4),
                    rng.gen_range(-0.3..0.3),
                )
            } else {
                (0.0, 0.0, 0.0)
            };
            grid[j * (n + 1) + i] = v(
                (i as f64 + jx) * 0.1 - 3.5,
                (j as f64 + jy) * 0.1 - 3.5,
                jz * 0.05,
            );
        }
    }
    let mut prims = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = grid[j * (n + 1) + i];
            let b = grid[j * (n + 1) + i + 1];
            let c = grid[(j + 1) * (n + 1) + i + 1];
            let d = grid[(j + 1) * (n + 1) + i];
            // Alternate the diagonal so vertices have 4 to 8 triangles around them.
            if (i + j) % 2 == 0 {
                prims.push(prim(tri(a, b, c), 0));
                prims.push(prim(tri(a, c, d), 0));
            } else {
                prims.push(prim(tri(a, b, d), 0));
                prims.push(prim(tri(b, c, d), 0));
            }
        }
    }
    for (from, angle) in [(v(0.0, 0.0, 4.0), 60.0), (v(0.3, -1.0, 2.5), 40.0)] {
        let written = SceneDescription {
            background: v(1.0, 0.0, 0.0),
            view: view(from, v(0.0, 0.5, 0.0), v(0.0, 1.0, 0.0), angle, 96),
            lights: vec![Light {
                position: v(0.0, 0.0, 10.0),
                color: None,
            }],
            materials: vec![mat([0.0, 1.0, 0.0], 0.8, 0.0, 0.0, 1.0)],
            primitives: prims.clone(),
        };
        for place in PLACEMENTS {
            let desc = place.scene(&written);
            let at = place.name;
            for precision in precisions(&desc) {
                for spd in [false, true] {
                    let mut s = settings(96, precision);
                    s.spd_standard = spd;
                    s.two_sided = true;
                    let (film, st) = render(&desc, &s);
                    assert_eq!(
                        st.eye_hits, st.eye_rays,
                        "{from:?} {at} {precision:?} spd={spd}: eye rays leaked through the mesh"
                    );
                    let background = film.pixels.iter().filter(|p| p[0] > 0.5).count();
                    assert_eq!(
                        background, 0,
                        "{from:?} {at} {precision:?}: background pixels"
                    );
                }
            }
        }
    }
}

/// 64 thin triangles meeting at one vertex; the central eye ray passes exactly through it (and
/// rays a hair beside it, in every direction) and must hit one of them.
#[test]
fn many_triangles_meeting_at_a_vertex() {
    let cases = [
        (v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), v(0.0, 0.0, 5.0)),
        (v(0.1, 0.2, 0.3), v(0.3, -0.5, 0.8), v(1.3, -0.7, 2.9)),
        (
            v(1e3, -2e3, 5e2),
            v(1.0, 1.0, 1.0),
            v(1e3 + 3.0, -2e3 + 4.0, 5e2 + 5.0),
        ),
    ];
    for (hub, normal, from) in cases {
        let n = normal.normalize();
        let (e1, e2) = perpendiculars(n);
        let k = 64;
        let rim = |i: usize| {
            let a = i as f64 / k as f64 * std::f64::consts::TAU;
            hub + (e1 * a.cos() + e2 * a.sin()) * 2.0
        };
        let primitives = (0..k)
            .map(|i| prim(tri(hub, rim(i), rim((i + 1) % k)), 0))
            .collect();
        let written = SceneDescription {
            background: v(0.0, 0.0, 0.0),
            view: view(from, hub, e2, 30.0, 65),
            lights: vec![],
            materials: vec![mat([1.0, 1.0, 1.0], 1.0, 0.0, 0.0, 1.0)],
            primitives,
        };
        for place in PLACEMENTS {
            let desc = place.scene(&written);
            let at = place.name;
            for precision in precisions(&desc) {
                for accel in [AccelKind::Bvh, AccelKind::Grid, AccelKind::Brute] {
                    let mut s = settings(65, precision);
                    s.accel = accel;
                    let r = Renderer::new(&desc, &s).expect("builds");
                    let centre = 32.5;
                    assert!(
                        r.probe(centre, centre).is_some(),
                        "{hub:?} {at} {precision:?} {accel:?}: ray through the shared vertex missed"
                    );
                    for i in 0..32 {
                        let a = i as f64 / 32.0 * std::f64::consts::TAU;
                        for eps in [1e-7, 1e-5, 1e-3] {
                            let (x, y) = (centre + eps * a.cos(), centre + eps * a.sin());
                            assert!(
                                r.probe(x, y).is_some(),
                                "{hub:?} {at} {precision:?} {accel:?}: ray beside the vertex missed"
                            );
                        }
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Concave polygons
// ---------------------------------------------------------------------------------------------

/// A gear outline of 144 vertices (36 teeth of 4 vertices, like SPD's gears), flat and tilted:
/// rays through the notches miss, rays through the teeth and the hub hit.
#[test]
fn concave_gear_polygon_inside_and_outside() {
    let (inner, outer) = (0.8, 1.0);
    let deg = |d: f64| d.to_radians();
    let mut outline = Vec::new();
    for k in 0..36 {
        let a0 = k as f64 * 10.0;
        for (da, r) in [(0.0, inner), (1.0, outer), (4.0, outer), (5.0, inner)] {
            let a = deg(a0 + da);
            outline.push((r * a.cos(), r * a.sin()));
        }
    }
    assert_eq!(outline.len(), 144);
    let frames = [
        (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)),
        (
            v(3.0, -2.0, 7.0),
            v(0.6, 0.8, 0.0),
            v(-0.8 * 0.6, 0.6 * 0.6, 0.8),
        ),
    ];
    for (origin, ex, ey) in frames {
        let ex = ex.normalize();
        let ey = ey.normalize();
        let n = ex.cross(ey);
        let at = |x: f64, y: f64| origin + ex * x + ey * y;
        let desc = SceneDescription {
            background: v(0.0, 0.0, 0.0),
            view: view(origin + n * 5.0, origin, ey, 45.0, 8),
            lights: vec![],
            materials: vec![mat([1.0, 1.0, 1.0], 1.0, 0.0, 0.0, 1.0)],
            primitives: vec![prim(
                Shape::Polygon(outline.iter().map(|&(x, y)| at(x, y)).collect()),
                0,
            )],
        };
        // Through the NFF text as well: the parser's checks must accept the concave 144-gon.
        let text = parrt_render::nff::to_nff(&desc);
        let parsed =
            parrt_render::nff::parse(&text, "gear.nff", &Default::default()).expect("parses");
        fn check<R: Real>(
            d: &SceneDescription,
            place: Placement,
            at: &dyn Fn(f64, f64) -> Vec3d,
            n: Vec3d,
        ) {
            let d = place.scene(d);
            let name = format!("{} {}", R::NAME, place.name);
            for accel in [AccelKind::Bvh, AccelKind::Brute] {
                let t = Direct::<R>::new(&d, accel, 8);
                let probe = |r: f64, a_deg: f64| {
                    let a = a_deg.to_radians();
                    let p = at(r * a.cos(), r * a.sin());
                    t.hit(place.point(p + n * 3.0), n * -1.0).is_some()
                };
                for k in 0..36 {
                    let a0 = k as f64 * 10.0;
                    for r in [0.82, 0.9, 0.98] {
                        assert!(probe(r, a0 + 2.5), "{}: tooth {k} at r = {r} missed", name);
                        assert!(!probe(r, a0 + 7.5), "{}: notch {k} at r = {r} hit", name);
                    }
                    assert!(probe(0.5, a0 + 7.5), "{}: hub missed", name);
                    assert!(probe(0.0, 0.0), "{}: centre missed", name);
                    assert!(!probe(1.02, a0 + 2.5), "{}: outside tooth {k} hit", name);
                }
            }
        }
        for place in PLACEMENTS {
            if f32_resolves(&place.scene(&parsed)) {
                check::<f32>(&parsed, place, &at, n);
            }
            check::<f64>(&parsed, place, &at, n);
        }
    }
}
