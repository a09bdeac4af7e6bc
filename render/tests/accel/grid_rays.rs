//! The grid on the rays that trouble a 3D-DDA, each checked against the BVH and brute force:
//! axis-parallel rays, rays starting inside, outside and on the grid box, rays lying in a cell
//! plane or grazing it, rays through cell edges and exact cell corners; and degenerate scenes
//! (empty, one primitive, everything in one plane). Also: a primitive spanning many cells is
//! tested at most once per ray (mailbox), and the walk counts its cells.

use crate::support::scene::{scene_of, tri, v};
use crate::support::spd::Trio;
use parrt_render::accel::{Accel, Grid};
use parrt_render::description::{ConeShape, SceneDescription, Shape, View};
use parrt_render::geometry::{PreparedRay, Ray};
use parrt_render::real::Real;
use parrt_render::stats::RayStats;
use parrt_render::vec3::V3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

type Rv = V3<f64>;

fn describe(primitives: Vec<Shape>) -> SceneDescription {
    scene_of(
        primitives,
        View {
            from: v(3.0, -4.0, 2.0),
            at: v(0.0, 0.0, 0.0),
            up: v(0.0, 0.0, 1.0),
            angle: 45.0,
            hither: 0.0,
            width: 32,
            height: 32,
        },
    )
}

/// A scene whose box is exactly [-1, 1]³ (the unit sphere) with geometry around the point `o`:
/// triangles lying in the planes x = o.x, y = o.y, z = o.z and meeting at `o`; spheres beside it;
/// a cylinder through it along z. With `o` on an interior cell corner of the grid (see
/// [`corner_trio`]) the triangles lie in cell planes, meet at a corner shared by eight cells, and
/// the cylinder runs along a line shared by four.
fn corner_scene(o: Rv) -> SceneDescription {
    let mut p = vec![Shape::Sphere {
        center: v(0.0, 0.0, 0.0),
        radius: 1.0,
    }];
    let h = 0.5;
    let at = |x: f64, y: f64, z: f64| o + v(x, y, z);
    for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
        p.push(tri(
            at(0.0, 0.0, 0.0),
            at(sx * h, 0.0, 0.0),
            at(0.0, sy * h, 0.0),
        ));
        p.push(tri(
            at(0.0, 0.0, 0.0),
            at(0.0, sx * h, 0.0),
            at(0.0, 0.0, sy * h),
        ));
        p.push(tri(
            at(0.0, 0.0, 0.0),
            at(0.0, 0.0, sx * h),
            at(sy * h, 0.0, 0.0),
        ));
    }
    for c in [
        at(0.4, 0.4, 0.4),
        at(-0.5, 0.5, 0.0),
        at(0.0, -0.5, -0.5),
        at(0.5, 0.0, 0.0),
    ] {
        p.push(Shape::Sphere {
            center: c,
            radius: 0.125,
        });
    }
    p.push(Shape::Cone(ConeShape {
        base: at(0.0, 0.0, -0.8),
        base_radius: 0.05,
        apex: at(0.0, 0.0, 0.8),
        apex_radius: 0.05,
    }));
    // A duplicate of the first triangle: ties everywhere on it.
    p.push(tri(at(0.0, 0.0, 0.0), at(h, 0.0, 0.0), at(0.0, h, 0.0)));
    describe(p)
}

fn grid_of<R>(t: &Trio<R>) -> &Grid {
    match &t.grid {
        Accel::Grid(g) => g,
        other => panic!("expected a grid, got {other:?}"),
    }
}

/// The corner scene with exactly 4 cells per axis, its geometry around the interior cell corner
/// (plane 2, plane 2, plane 2). Built twice: the first build finds the planes (the box is the
/// unit sphere's either way, so the second build has the same grid).
fn corner_trio<R: Real>() -> (Trio<R>, Rv) {
    let probe = corner_scene(v(0.0, 0.0, 0.0));
    let density = 64.0 / probe.primitives.len() as f64;
    let t = Trio::<R>::new(&probe, density);
    let g = grid_of(&t);
    assert_eq!(g.res, [4, 4, 4]);
    let o = v(planes(g, 0)[2], planes(g, 1)[2], planes(g, 2)[2]);
    let t2 = Trio::<R>::new(&corner_scene(o), density);
    let g2 = grid_of(&t2);
    assert_eq!(
        (g2.res, g2.min, g2.cell),
        (g.res, g.min, g.cell),
        "same grid"
    );
    (t2, o)
}

fn ray<R: Real>(o: Rv, d: Rv) -> Ray<R> {
    Ray {
        o: V3::from_f64(o),
        d: V3::from_f64(d),
        t_min: R::ZERO,
        t_max: R::INFINITY,
    }
}

/// Planes of axis `a` of the grid, as `f64`.
fn planes(g: &Grid, a: usize) -> Vec<f64> {
    (0..=g.res[a])
        .map(|k| g.min[a] + k as f64 * g.cell[a])
        .collect()
}

fn axis_rays<R: Real>(g: &Grid) -> Vec<Ray<R>> {
    let mut rays = Vec::new();
    let px = planes(g, 0);
    let py = planes(g, 1);
    let pz = planes(g, 2);
    // Along z through every cell edge line (x, y on planes), through cell centres, and along
    // lines in one plane only; from outside below, from outside above, and from inside.
    let mut xs = px.clone();
    xs.extend(px.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    let mut ys = py.clone();
    ys.extend(py.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    for &x in &xs {
        for &y in &ys {
            for (oz, dz) in [(-3.0, 1.0), (3.0, -1.0), (0.1, 1.0), (0.0, -1.0)] {
                rays.push(ray(v(x, y, oz), v(0.0, 0.0, dz)));
                rays.push(ray(v(oz, x, y), v(dz, 0.0, 0.0)));
                rays.push(ray(v(y, oz, x), v(0.0, dz, 0.0)));
            }
        }
    }
    // Starting exactly on the grid box faces and corners, pointing in and out.
    for &z in &[pz[0], pz[pz.len() - 1]] {
        rays.push(ray(v(0.1, 0.2, z), v(0.0, 0.0, 1.0)));
        rays.push(ray(v(0.1, 0.2, z), v(0.0, 0.0, -1.0)));
        rays.push(ray(v(px[0], py[0], z), v(1.0, 1.0, 1.0).normalize()));
    }
    rays
}

fn corner_rays<R: Real>(g: &Grid, seed: u64) -> Vec<Ray<R>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let px = planes(g, 0);
    let py = planes(g, 1);
    let pz = planes(g, 2);
    let mut rays = Vec::new();
    for _ in 0..3000 {
        // Through an exact cell corner (f64 plane intersection), from inside or outside.
        let c = v(
            px[rng.gen_range(0..px.len())],
            py[rng.gen_range(0..py.len())],
            pz[rng.gen_range(0..pz.len())],
        );
        let d = loop {
            let d = v(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            if d.length() > 0.1 {
                break d.normalize();
            }
        };
        let back = rng.gen_range(0.0..4.0);
        rays.push(ray(c - d * back, d));
        // Diagonals through corners: equal components cross planes simultaneously.
        let diag = v(
            if rng.gen_bool(0.5) { 1.0 } else { -1.0 },
            if rng.gen_bool(0.5) { 1.0 } else { -1.0 },
            if rng.gen_bool(0.5) { 1.0 } else { -1.0 },
        )
        .normalize();
        rays.push(ray(c - diag * back, diag));
    }
    rays
}

fn plane_rays<R: Real>(o: Rv, seed: u64) -> Vec<Ray<R>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut rays = Vec::new();
    for _ in 0..2000 {
        let a = rng.gen_range(-1.5..1.5);
        let b = rng.gen_range(-1.5..1.5);
        let th = rng.gen_range(0.0..std::f64::consts::TAU);
        let (c, s) = (th.cos(), th.sin());
        // Lying in the cell planes through `o` (which hold triangles).
        rays.push(ray(v(o.x, a, b), v(0.0, c, s)));
        rays.push(ray(v(a, o.y, b), v(c, 0.0, s)));
        rays.push(ray(v(a, b, o.z), v(c, s, 0.0)));
        // Grazing: almost in the plane, crossing it far away or just here.
        let eps = [1e-7, -1e-7, 1e-4, 1e-12][rng.gen_range(0..4)];
        rays.push(ray(v(o.x, a, b), v(eps, c, s).normalize()));
        rays.push(ray(v(a, b, o.z), v(c, s, eps).normalize()));
    }
    rays
}

fn random_rays<R: Real>(seed: u64, t_min: f64) -> Vec<Ray<R>> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..3000)
        .map(|_| {
            let o = v(
                rng.gen_range(-2.0..2.0),
                rng.gen_range(-2.0..2.0),
                rng.gen_range(-2.0..2.0),
            );
            let p = v(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            );
            let mut r = ray::<R>(o, (p - o).normalize());
            r.t_min = R::from_f64(t_min);
            r
        })
        .collect()
}

/// The ray families of the corner scene. `with_bvh`: compare the BVH too (see
/// [`bvh_on_plane_and_edge_rays`]); the grid is always compared with brute force.
fn corner_scene_agrees<R: Real>(with_bvh: bool) {
    let (t, o) = corner_trio::<R>();
    let g = grid_of(&t);
    let check = |what: &str, rays: &[Ray<R>]| {
        if with_bvh {
            t.check_all(what, rays)
        } else {
            t.check_grid(what, rays)
        }
    };
    let st = check("axis rays", &axis_rays::<R>(g));
    assert!(st.hits > 0);
    let st = check("corner rays", &corner_rays::<R>(g, 7));
    assert!(st.hits > st.rays / 5, "{} hits of {}", st.hits, st.rays);
    check("in-plane and grazing rays", &plane_rays::<R>(o, 8));
    check("rays from inside and outside", &random_rays::<R>(9, 0.0));
    check("rays with t_min > 0", &random_rays::<R>(10, 0.7));
}

// Also the regression for the BVH pruning bug the grid's agreement tests found: nodes were pruned when
// the slab test's (rounded) entry distance exceeded the best hit so far, so a primitive hit at
// the best `t` or a few ulps below it — an edge or vertex shared with the current best, a ray
// lying in a box face — was skipped and a larger-index or farther primitive returned. Fixed by
// building the BVH over boxes widened by `parrt_render::accel::margin`.
#[test]
fn corner_scene_agrees_f32() {
    corner_scene_agrees::<f32>(true);
}

#[test]
fn corner_scene_agrees_f64() {
    corner_scene_agrees::<f64>(true);
}

#[test]
fn mailbox_tests_each_primitive_once() {
    let (t, _) = corner_trio::<f32>();
    assert!(t.scene.len() < parrt_render::accel::grid::mailbox::MAILBOX_SLOTS);
    for r in corner_rays::<f32>(grid_of(&t), 11) {
        let pr = PreparedRay::new(r);
        let mut seen = Vec::new();
        let mut st = RayStats::default();
        t.grid.intersect(&pr, &mut st, |i, tm| {
            seen.push(i);
            t.scene.intersect_prim(i, &pr, tm)
        });
        let n = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), n, "a primitive was tested twice");
        assert_eq!(st.primitive_tests, n as u64);
        assert!(st.box_tests <= 1);
        assert!(st.cell_steps >= 1 || st.box_tests == 0 || st.primitive_tests == 0);
    }
}

#[test]
fn walk_counts_cells() {
    let (t, _) = corner_trio::<f32>();
    // Straight up the z axis through all 4 layers of cells.
    let pr = PreparedRay::new(ray::<f32>(v(0.3, 0.3, -5.0), v(0.0, 0.0, 1.0)));
    let mut st = RayStats::default();
    let hit = t
        .grid
        .occluded(&pr, &mut st, |i, tm| t.scene.intersect_prim(i, &pr, tm));
    assert!(hit);
    let mut st = RayStats::default();
    let far = Ray {
        t_max: 0.1,
        ..pr.ray
    };
    let pr = PreparedRay::new(far);
    assert!(!t
        .grid
        .occluded(&pr, &mut st, |i, tm| t.scene.intersect_prim(i, &pr, tm)));
    assert_eq!((st.box_tests, st.cell_steps, st.primitive_tests), (1, 0, 0));
    // A miss that crosses the grid: 4 cells along z, no primitive in reach of x = y = 0.97.
    let pr = PreparedRay::new(ray::<f32>(v(0.97, 0.97, -5.0), v(0.0, 0.0, 1.0)));
    let mut st = RayStats::default();
    assert!(t
        .grid
        .intersect(&pr, &mut st, |i, tm| t.scene.intersect_prim(i, &pr, tm))
        .is_none());
    assert_eq!((st.box_tests, st.cell_steps), (1, 4));
}

// ---- degenerate scenes ----

fn everywhere_rays<R: Real>(seed: u64) -> Vec<Ray<R>> {
    let mut rays = random_rays::<R>(seed, 0.0);
    rays.extend(plane_rays::<R>(v(0.0, 0.0, 0.0), seed + 1));
    rays
}

#[test]
fn empty_scene() {
    let desc = describe(Vec::new());
    let t = Trio::<f32>::new(&desc, 8.0);
    assert!(grid_of(&t).is_empty());
    let st = t.check_all("empty scene", &everywhere_rays::<f32>(20));
    assert_eq!(st.hits, 0);
    assert_eq!(st.grid.primitive_tests + st.grid.cell_steps, 0);
}

#[test]
fn one_primitive() {
    for (i, shape) in [
        Shape::Sphere {
            center: v(0.2, -0.1, 0.3),
            radius: 0.7,
        },
        tri(v(-1.0, -1.0, 0.0), v(1.0, -1.0, 0.2), v(0.0, 1.0, -0.1)),
        Shape::Cone(ConeShape {
            base: v(0.0, 0.0, -1.0),
            base_radius: 0.5,
            apex: v(0.0, 0.0, 1.0),
            apex_radius: 0.0,
        }),
    ]
    .into_iter()
    .enumerate()
    {
        let desc = describe(vec![shape]);
        for density in [1.0, 8.0, 1000.0] {
            let t = Trio::<f32>::new(&desc, density);
            let st = t.check_all("one primitive", &everywhere_rays::<f32>(30 + i as u64));
            assert!(st.hits > 0);
            Trio::<f64>::new(&desc, density)
                .check_all("one primitive f64", &everywhere_rays::<f64>(40 + i as u64));
        }
    }
}

#[test]
fn all_primitives_in_one_plane() {
    flat_scene(true);
}

fn flat_scene(with_bvh: bool) {
    // A triangulated square in z = 0 with shared edges, plus a concave polygon, all flat.
    let mut rng = StdRng::seed_from_u64(50);
    let n = 10;
    let mut p = Vec::new();
    let q = |i: usize, j: usize| {
        v(
            i as f64 / n as f64 * 2.0 - 1.0,
            j as f64 / n as f64 * 2.0 - 1.0,
            0.0,
        )
    };
    for i in 0..n {
        for j in 0..n {
            p.push(tri(q(i, j), q(i + 1, j), q(i + 1, j + 1)));
            p.push(tri(q(i, j), q(i + 1, j + 1), q(i, j + 1)));
        }
    }
    p.push(Shape::Polygon(
        vec![
            v(-0.5, -0.5, 0.0),
            v(0.5, -0.5, 0.0),
            v(0.0, 0.0, 0.0),
            v(0.5, 0.5, 0.0),
            v(-0.5, 0.5, 0.0),
        ]
        .into(),
    ));
    let desc = describe(p);
    let t = Trio::<f32>::new(&desc, 8.0);
    let g = grid_of(&t);
    assert_eq!(g.res[2], 1, "a flat scene has one layer of cells");
    let mut rays = everywhere_rays::<f32>(51);
    for _ in 0..2000 {
        // Straight down onto vertices and edges of the mesh (shared by two to six triangles).
        let i = rng.gen_range(0..=2 * n) as f64 / (2 * n) as f64 * 2.0 - 1.0;
        let j = rng.gen_range(0..=2 * n) as f64 / (2 * n) as f64 * 2.0 - 1.0;
        rays.push(ray(v(i, j, 1.0), v(0.0, 0.0, -1.0)));
        rays.push(ray(v(i, j, -1.0), v(0.1, 0.0, 1.0).normalize()));
    }
    let st = if with_bvh {
        t.check_all("flat scene", &rays)
    } else {
        t.check_grid("flat scene", &rays)
    };
    assert!(st.hits > 1000);
    let t64 = Trio::<f64>::new(&desc, 8.0);
    let rays64 = everywhere_rays::<f64>(52);
    if with_bvh {
        t64.check_all("flat scene f64", &rays64);
    } else {
        t64.check_grid("flat scene f64", &rays64);
    }
}

#[test]
fn scene_far_from_origin_and_tiny_scene() {
    // Far from the origin and tiny (docs/design-rendering.md, *Numeric robustness*): offset by
    // 1e5 and scaled by 1e-3; the answers must still agree.
    let base = corner_scene(v(0.0, 0.0, 0.0));
    for (shift, scale) in [(1e5, 1.0), (0.0, 1e-3), (-3e3, 10.0)] {
        let mut desc = base.clone();
        let tr = |p: Rv| p * scale + V3::splat(shift);
        for prim in &mut desc.primitives {
            prim.shape = match &prim.shape {
                Shape::Sphere { center, radius } => Shape::Sphere {
                    center: tr(*center),
                    radius: radius * scale,
                },
                Shape::Cone(c) => Shape::Cone(c.transformed(scale, V3::splat(shift))),
                Shape::Polygon(vs) => Shape::Polygon(vs.iter().map(|&p| tr(p)).collect()),
                Shape::Patch(_) => unreachable!("the corner scene has no patches"),
            };
        }
        let rays: Vec<Ray<f64>> = random_rays::<f64>(60, 0.0)
            .into_iter()
            .map(|r| Ray { o: tr(r.o), ..r })
            .collect();
        let what = format!("shift {shift}, scale {scale}");
        Trio::<f64>::new(&desc, 8.0).check_all(&what, &rays);
        let rays32: Vec<Ray<f32>> = rays.iter().map(|r| ray::<f32>(r.o, r.d)).collect();
        Trio::<f32>::new(&desc, 8.0).check_all(&what, &rays32);
    }
}
