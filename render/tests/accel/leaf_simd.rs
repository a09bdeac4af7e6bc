//! Leaves tested four triangles, four spheres or four cones at a time: the BVH with the SIMD
//! leaf test the renderer uses (`SceneLeaf::new`) and with the portable one-at-a-time test
//! (`SceneLeaf::scalar`, and the plain closure) gives every ray the same closest hit —
//! primitive, `t`, `u`, `v` bit for bit —, the same occlusion answer and the same
//! primitive-test count, one ray at a time and in packets: on the SPD scenes (triangle and
//! sphere leaves, edge and vertex hits, the kernel's `f64` redo of zero edge functions), and on
//! a mesh with exact integer vertices and duplicated triangles (ties decided by the primitive
//! index), and on bundles of cones with rays along their axes, along generator lines, grazing
//! and just missing. In `f64` leaves go one at a time, and the test holds there too.

use crate::packet_leaf::triangle_targets;
use crate::support::scene::{doubled_grid, scene_of};
use crate::support::spd::{key, load, SMALL_SCENES};
use parrt_render::accel::bvh::packet::PACKET;
use parrt_render::accel::Accel;
use parrt_render::camera::Camera;
use parrt_render::description::{ConeShape, SceneDescription, Shape, View};
use parrt_render::geometry::{PreparedRay, Ray};
use parrt_render::packet::scene_leaf::SceneLeaf;
use parrt_render::real::Real;
use parrt_render::scene::{Prim, Scene};
use parrt_render::settings::{AccelKind, DEFAULT_GRID_DENSITY};
use parrt_render::stats::RayStats;
use parrt_render::vec3::V3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// What a scene's comparison covered.
#[derive(Default, Debug)]
struct Covered {
    rays: u64,
    hits: u64,
    /// Hits on an edge or a vertex (a barycentric exactly 0, or `u + v` exactly 1).
    edge_hits: u64,
    occluded: u64,
}

/// Rays at the scene's triangles: from `eye` to each vertex, each edge's midpoint and each
/// centroid (every `step`-th triangle), as full rays and as segments ending exactly there.
fn rays_at_triangles<R: Real>(scene: &Scene<R>, eye: V3<R>, step: usize) -> Vec<Ray<R>> {
    let mut out = Vec::new();
    for p in scene.prims.iter().step_by(step) {
        let Prim::Triangle(v) = p else { continue };
        for t in triangle_targets(v) {
            let d = t - eye;
            let len = d.length();
            if len.partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let d = d / len;
            out.push(Ray {
                o: eye,
                d,
                t_min: R::ZERO,
                t_max: R::INFINITY,
            });
            out.push(Ray {
                o: eye,
                d,
                t_min: R::ZERO,
                t_max: len,
            });
        }
    }
    out
}

/// Eye rays through pixel corners and centres of an `n × n` image.
fn eye_rays<R: Real>(view: &View, n: u32) -> Vec<Ray<R>> {
    let cam = Camera::<R>::new(view, n, n);
    let mut rays = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let h = R::HALF;
            rays.push(cam.ray(R::from_u32(x), R::from_u32(y)));
            rays.push(cam.ray(R::from_u32(x) + h, R::from_u32(y) + h));
        }
    }
    rays
}

/// Rays leaving the hits of `from` in seeded random directions, from the exact hit point with
/// `t_min = 0` (self-hits included).
fn rays_from_hits<R: Real>(scene: &Scene<R>, bvh: &Accel, from: &[Ray<R>]) -> Vec<Ray<R>> {
    let mut rng = StdRng::seed_from_u64(18);
    let mut st = RayStats::default();
    let mut out = Vec::new();
    for r in from.iter().step_by(2) {
        let pr = PreparedRay::new(*r);
        if let Some(h) = bvh.intersect(&pr, &mut st, |i, t| scene.intersect_prim(i, &pr, t)) {
            let d = V3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0f64),
            );
            if d.length() > 1e-3 {
                out.push(Ray {
                    o: r.o + r.d * h.t,
                    d: V3::from_f64(d.normalize()),
                    t_min: R::ZERO,
                    t_max: R::INFINITY,
                });
            }
        }
    }
    out
}

/// Compares the SIMD leaf with the portable ones on `rays`, one by one and in packets of
/// [`PACKET`] consecutive rays.
fn compare<R: Real>(what: &str, scene: &Scene<R>, rays: &[Ray<R>]) -> Covered {
    let bvh = Accel::build(AccelKind::Bvh, &scene.all_bounds(), DEFAULT_GRID_DENSITY);
    let mut c = Covered::default();
    for r in rays {
        let pr = PreparedRay::new(*r);
        let (mut s_simd, mut s_scalar, mut s_closure) = Default::default();
        let simd = bvh.intersect(&pr, &mut s_simd, SceneLeaf::new(scene).ray(&pr));
        let scalar = bvh.intersect(&pr, &mut s_scalar, SceneLeaf::scalar(scene).ray(&pr));
        let closure = bvh.intersect(&pr, &mut s_closure, |i, t| scene.intersect_prim(i, &pr, t));
        assert_eq!(key(&simd), key(&scalar), "{what}: closest hit of {r:?}");
        assert_eq!(key(&simd), key(&closure), "{what}: closest hit of {r:?}");
        let occ_simd = bvh.occluded(&pr, &mut s_simd, SceneLeaf::new(scene).ray(&pr));
        let occ_scalar = bvh.occluded(&pr, &mut s_scalar, SceneLeaf::scalar(scene).ray(&pr));
        let occ_closure = bvh.occluded(&pr, &mut s_closure, |i, t| scene.intersect_prim(i, &pr, t));
        assert_eq!(occ_simd, occ_scalar, "{what}: occlusion of {r:?}");
        assert_eq!(occ_simd, occ_closure, "{what}: occlusion of {r:?}");
        assert_eq!(
            s_simd.primitive_tests, s_scalar.primitive_tests,
            "{what}: primitive tests of {r:?}"
        );
        assert_eq!(s_simd.primitive_tests, s_closure.primitive_tests);
        c.rays += 1;
        c.occluded += occ_simd as u64;
        if let Some(h) = simd {
            c.hits += 1;
            if matches!(scene.prims[h.prim as usize], Prim::Triangle(_))
                && (h.u == R::ZERO || h.v == R::ZERO || h.u + h.v == R::ONE)
            {
                c.edge_hits += 1;
            }
        }
    }
    for chunk in rays.chunks(PACKET) {
        let prs: Vec<PreparedRay<R>> = chunk.iter().map(|r| PreparedRay::new(*r)).collect();
        let n = prs.len();
        let (mut a, mut b) = ([None; PACKET], [None; PACKET]);
        let (mut sa, mut sb) = (RayStats::default(), RayStats::default());
        bvh.intersect_packet(&prs, &mut a[..n], &mut sa, SceneLeaf::new(scene));
        bvh.intersect_packet(&prs, &mut b[..n], &mut sb, SceneLeaf::scalar(scene));
        for i in 0..n {
            assert_eq!(
                key(&a[i]),
                key(&b[i]),
                "{what}: packet hit of {:?}",
                chunk[i]
            );
        }
        let (mut oa, mut ob) = ([false; PACKET], [false; PACKET]);
        bvh.occluded_packet(&prs, &mut oa[..n], &mut sa, SceneLeaf::new(scene));
        bvh.occluded_packet(&prs, &mut ob[..n], &mut sb, SceneLeaf::scalar(scene));
        assert_eq!(oa, ob, "{what}: packet occlusion");
        assert_eq!(
            sa.primitive_tests, sb.primitive_tests,
            "{what}: packet tests"
        );
    }
    c
}

fn scene_rays<R: Real>(name: &str, desc: &SceneDescription) -> Covered {
    let scene = Scene::<R>::build(desc).unwrap_or_else(|e| panic!("{name}: {e}"));
    let bvh = Accel::build(AccelKind::Bvh, &scene.all_bounds(), DEFAULT_GRID_DENSITY);
    let mut rays = eye_rays::<R>(&desc.view, 48);
    let from = V3::from_f64(desc.view.from) - V3::from_f64(scene.origin);
    let step = (scene.prims.len() / 400).max(1);
    rays.extend(rays_at_triangles(&scene, from, step));
    let secondary = rays_from_hits(&scene, &bvh, &rays);
    rays.extend(secondary);
    compare(&format!("{name} ({})", R::NAME), &scene, &rays)
}

#[test]
fn spd_scenes_simd_leaves_agree_with_scalar() {
    let mut total = Covered::default();
    for name in SMALL_SCENES {
        let desc = load(name);
        let c = scene_rays::<f32>(name, &desc);
        total.rays += c.rays;
        total.hits += c.hits;
        total.edge_hits += c.edge_hits;
        total.occluded += c.occluded;
    }
    for name in ["teapot-2", "tetra-4"] {
        scene_rays::<f64>(name, &load(name));
    }
    assert!(total.hits > 20_000 && total.occluded > 20_000, "{total:?}");
    assert!(total.edge_hits > 100, "{total:?}");
}

/// A flat mesh on integer vertices (two triangles per unit square, every one twice: once as
/// is, once wound the other way, so every hit is a tie the primitive index decides), and rays
/// through the integer grid: exactly on edges and vertices, where edge functions are exactly 0
/// (in `f32` and in the `f64` redo) and the sign rule and the tie rule decide.
#[test]
fn exact_edges_vertices_and_ties_agree() {
    let n = 8;
    let desc = doubled_grid(n);
    let scene = Scene::<f32>::build(&desc).expect("scene");
    let mut rays = Vec::new();
    // Straight down and slanted onto every half-integer point: vertices, edges, diagonals,
    // with ranges ending before, exactly at and after the plane.
    for i in 0..=2 * n {
        for j in 0..=2 * n {
            let (x, y) = (i as f64 * 0.5, j as f64 * 0.5);
            for (dx, dy, h) in [(0.0, 0.0, 2.0), (0.5, 0.0, 1.0), (0.25, -0.5, 4.0)] {
                // Relative to the scene's origin, in f64 (exact here), then rounded.
                let o = V3::<f32>::from_f64(V3::new(x - dx * h, y - dy * h, h) - scene.origin);
                let d = V3::<f32>::from_f64(V3::new(dx * h, dy * h, -h));
                let len = d.length();
                for t_max in [f32::INFINITY, len, len * 0.5] {
                    rays.push(Ray {
                        o,
                        d: d / len,
                        t_min: 0.0,
                        t_max,
                    });
                }
            }
        }
    }
    let c = compare("integer mesh", &scene, &rays);
    assert!(c.edge_hits > 200, "{c:?}");
}

/// How many BVH leaves of `scene` hold two or more primitives, all cones (the cone kernel's
/// leaves).
fn cone_leaves<R: Real>(scene: &Scene<R>) -> usize {
    use parrt_render::accel::bvh::wide::{is_leaf, leaf_range, EMPTY};
    let Accel::Bvh(bvh) = Accel::build(AccelKind::Bvh, &scene.all_bounds(), DEFAULT_GRID_DENSITY)
    else {
        panic!("not a BVH");
    };
    let mut n = 0;
    for node in &bvh.nodes {
        for &c in node.child.iter().filter(|&&c| c != EMPTY && is_leaf(c)) {
            let (first, count) = leaf_range(c);
            let prims = &bvh.order[first..first + count];
            if count >= 2
                && prims
                    .iter()
                    .all(|&p| matches!(scene.prims[p as usize], Prim::Cone(_)))
            {
                n += 1;
            }
        }
    }
    n
}

/// Rays at every cone of `scene`: down the axis and just beside it, along a generator line
/// (the quadratic's parallel-ray branch) and just inside and outside it, grazing the side at
/// mid-height, just beyond either end, and outward from inside.
fn rays_at_cones(scene: &Scene<f32>) -> Vec<Ray<f32>> {
    let mut out = Vec::new();
    let ray = |o: V3<f32>, d: V3<f32>, t_max: f32| Ray {
        o,
        d: d.normalize(),
        t_min: 0.0,
        t_max,
    };
    for p in &scene.prims {
        let Prim::Cone(c) = p else { continue };
        let (a, h) = (c.axis, c.height);
        let r1 = c.r0 + c.slope * h;
        let apex = c.base + a * h;
        let helper = if a.x.abs() < 0.5 {
            V3::new(1.0, 0.0, 0.0)
        } else {
            V3::new(0.0, 1.0, 0.0)
        };
        let s1 = a.cross(helper).normalize();
        let s2 = a.cross(s1);
        let size = h + c.r0 + r1;
        for s in [s1, s2, -s1, (s1 + s2).normalize()] {
            // Axis and near-axis rays, from both ends.
            for off in [0.0, 1.0e-3, 0.5] {
                let o = c.base - a * size + s * (off * c.r0);
                out.push(ray(o, a, f32::INFINITY));
                out.push(ray(apex + a * size + s * (off * r1), -a, f32::INFINITY));
            }
            // Along a generator line, on it and a little inside and outside.
            for scale in [1.0f32, 0.999, 1.001, 0.5, 1.5] {
                let (p0, p1) = (c.base + s * (c.r0 * scale), apex + s * (r1 * scale));
                let g = p1 - p0;
                if g.length() > 0.0 {
                    out.push(ray(p0 - g, g, f32::INFINITY));
                    out.push(ray(p1 + g, -g, f32::INFINITY));
                }
            }
            // Grazing the silhouette at mid-height, and beyond either end.
            let tangent = a.cross(s);
            let r_mid = c.r0 + c.slope * (h * 0.5);
            for (z, r) in [(h * 0.5, r_mid), (-0.01 * h, c.r0), (1.01 * h, r1)] {
                for scale in [1.0f32, 0.9999, 1.0001, 0.9] {
                    let p = c.base + a * z + s * (r * scale);
                    out.push(ray(p - tangent * size, tangent, f32::INFINITY));
                    out.push(ray(p - tangent * size, tangent, size));
                }
            }
            // From inside, outward and slanted.
            let inside = c.base + a * (h * 0.5);
            out.push(ray(inside, s, f32::INFINITY));
            out.push(ray(inside, s + a, f32::INFINITY));
            out.push(ray(inside, s + a, 1.0e-3));
        }
    }
    out
}

/// Leaves of two to four cones (bundles of concentric cylinders, nested cones, true cones and
/// crossing cylinders, in every orientation, one bundle far from the rest) tested four at a
/// time give every ray the scalar test's hit bit for bit, the same occlusion answer and the
/// same test count, including grazing, axis-parallel and generator-parallel rays and misses.
#[test]
fn cone_leaves_agree_with_scalar() {
    let mut shapes = Vec::new();
    let cone = |b: V3<f64>, r0: f64, a: V3<f64>, r1: f64| {
        Shape::Cone(ConeShape {
            base: b,
            base_radius: r0,
            apex: a,
            apex_radius: r1,
        })
    };
    let axes = [
        V3::new(1.0, 0.0, 0.0),
        V3::new(0.0, 1.0, 0.0),
        V3::new(0.0, 0.0, 1.0),
        V3::new(1.0, 1.0, 1.0).normalize(),
        V3::new(0.3, -0.8, 0.5).normalize(),
    ];
    let centres = [
        V3::new(0.0, 0.0, 0.0),
        V3::new(4.0, 0.0, 0.0),
        V3::new(0.0, 4.0, 0.0),
        V3::new(-4.0, -2.0, 1.0),
        V3::new(2.0e4, 1.0e4, -3.0e4),
    ];
    for (k, &c) in centres.iter().enumerate() {
        for (j, &a) in axes.iter().enumerate() {
            let c = c + V3::new(0.0, 0.0, 1.5 * j as f64) * if k == 4 { 1.0 } else { 3.0 };
            let (b, e) = (c - a, c + a);
            // Concentric cylinders, nested cones and a true cone on one axis: one leaf.
            shapes.push(cone(b, 0.3, e, 0.3));
            shapes.push(cone(b, 0.25, e, 0.25));
            shapes.push(cone(b, 0.3, e, 0.1));
            shapes.push(cone(b, 0.2, e, 0.0));
        }
    }
    let desc = scene_of(
        shapes,
        View {
            from: V3::new(2.0, -12.0, 6.0),
            at: V3::new(0.0, 0.0, 4.0),
            up: V3::new(0.0, 0.0, 1.0),
            angle: 60.0,
            hither: 0.001,
            width: 64,
            height: 64,
        },
    );
    let scene = Scene::<f32>::build(&desc).expect("scene");
    assert!(cone_leaves(&scene) >= 15, "{}", cone_leaves(&scene));
    let mut rays = eye_rays::<f32>(&desc.view, 64);
    rays.extend(rays_at_cones(&scene));
    let bvh = Accel::build(AccelKind::Bvh, &scene.all_bounds(), DEFAULT_GRID_DENSITY);
    let secondary = rays_from_hits(&scene, &bvh, &rays);
    rays.extend(secondary);
    let c = compare("cones", &scene, &rays);
    assert!(c.hits > 5_000 && c.occluded > 5_000, "{c:?}");
}
