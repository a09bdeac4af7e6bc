//! Accelerator agreement (docs/design-rendering.md, *Acceleration*): on every small SPD scene and
//! on seeded random scenes, the BVH, the uniform grid and the brute-force scan give every ray the
//! same closest hit (primitive and distance, bit for bit) and the same occlusion answer — for the
//! camera's eye rays, seeded random rays, shadow-like segments and rays leaving surfaces — and
//! render bit-identical images. The Goldsmith–Salmon BVH (the quality baseline, `--accel bvh-gs`)
//! is held to the same rule.

use crate::support::scene::{scene_of, v};
use crate::support::spd::{load, Trio, TrioStats, SMALL_SCENES};
use parrt_render::accel::Accel;
use parrt_render::camera::Camera;
use parrt_render::description::{ConeShape, SceneDescription, Shape, View};
use parrt_render::geometry::{Aabb, PreparedRay, PrimHit, Ray};
use parrt_render::real::Real;
use parrt_render::render::Renderer;
use parrt_render::settings::{AccelKind, Precision, RenderSettings, DEFAULT_GRID_DENSITY};
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_render::stats::RayStats;
use parrt_render::vec3::V3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

type Rv = V3<f64>;

/// A uniform point in the cube [-1, 1)³.
fn in_cube(rng: &mut StdRng) -> Rv {
    v(
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
    )
}

/// A uniform direction (a point of the unit ball, away from its centre, scaled to length 1).
fn unit_dir(rng: &mut StdRng) -> Rv {
    loop {
        let d = in_cube(rng);
        let l = d.length();
        if l > 1e-3 && l <= 1.0 {
            return d / l;
        }
    }
}

fn ray<R: Real>(o: Rv, d: Rv, t_min: f64, t_max: f64) -> Ray<R> {
    Ray {
        o: V3::from_f64(o),
        d: V3::from_f64(d),
        t_min: R::from_f64(t_min),
        t_max: R::from_f64(t_max),
    }
}

fn scene_box<R: Real>(t: &Trio<R>) -> (Rv, Rv) {
    let b = t
        .scene
        .all_bounds()
        .iter()
        .fold(Aabb::EMPTY, |acc, b| acc.union(b));
    let lo = v(b.min[0] as f64, b.min[1] as f64, b.min[2] as f64);
    let hi = v(b.max[0] as f64, b.max[1] as f64, b.max[2] as f64);
    (lo, hi)
}

fn point_in(rng: &mut StdRng, lo: Rv, hi: Rv, grow: f64) -> Rv {
    let pad = (hi - lo) * grow;
    let (lo, hi) = (lo - pad, hi + pad);
    let pick = |rng: &mut StdRng, a: f64, b: f64| {
        if b > a {
            rng.gen_range(a..b)
        } else {
            a
        }
    };
    v(
        pick(rng, lo.x, hi.x),
        pick(rng, lo.y, hi.y),
        pick(rng, lo.z, hi.z),
    )
}

/// Seeded random rays around the scene: full lines from inside and outside the box, rays from
/// `eye` at random points, finite shadow-like segments, and axis-parallel rays.
fn random_rays<R: Real>(t: &Trio<R>, eye: Rv, n: usize, seed: u64) -> Vec<Ray<R>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let (lo, hi) = scene_box(t);
    let mut rays = Vec::with_capacity(n);
    for i in 0..n {
        let r = match i % 5 {
            0 => ray(
                point_in(&mut rng, lo, hi, 0.25),
                unit_dir(&mut rng),
                0.0,
                f64::INFINITY,
            ),
            1 => {
                let p = point_in(&mut rng, lo, hi, 0.0);
                ray(eye, (p - eye).normalize(), 0.0, f64::INFINITY)
            }
            2 => {
                let o = point_in(&mut rng, lo, hi, 0.1);
                let p = point_in(&mut rng, lo, hi, 0.1);
                let len = (p - o).length();
                if len == 0.0 {
                    continue;
                }
                ray(o, (p - o) / len, 0.0, len)
            }
            3 => {
                let mut d = v(0.0, 0.0, 0.0);
                let a = rng.gen_range(0..3);
                let s = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
                match a {
                    0 => d.x = s,
                    1 => d.y = s,
                    _ => d.z = s,
                }
                ray(point_in(&mut rng, lo, hi, 0.1), d, 0.0, f64::INFINITY)
            }
            _ => {
                // A far origin looking back at the scene.
                let c = (lo + hi) * 0.5;
                let o = c + unit_dir(&mut rng) * ((hi - lo).length() * 3.0);
                let p = point_in(&mut rng, lo, hi, 0.0);
                ray(o, (p - o).normalize(), 0.0, f64::INFINITY)
            }
        };
        rays.push(r);
    }
    rays
}

/// The camera's eye rays on a `n × n` image: through pixel corners (SPD procedure) and centres.
fn eye_rays<R: Real>(view: &View, n: u32) -> Vec<Ray<R>> {
    let cam = Camera::<R>::new(view, n, n);
    let mut rays = Vec::new();
    for y in 0..=n {
        for x in 0..=n {
            rays.push(cam.ray(R::from_u32(x), R::from_u32(y)));
            if x < n && y < n {
                let h = R::HALF;
                rays.push(cam.ray(R::from_u32(x) + h, R::from_u32(y) + h));
            }
        }
    }
    rays
}

/// Rays leaving the surfaces the given rays hit: from the exact computed hit point, in seeded
/// random directions, with `t_min = 0` (so self-hits happen, and must agree too).
fn rays_from_hits<R: Real>(t: &Trio<R>, from: &[Ray<R>], seed: u64) -> Vec<Ray<R>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut st = TrioStats::default();
    let mut out = Vec::new();
    for r in from.iter().step_by(3) {
        let pr = parrt_render::geometry::PreparedRay::new(*r);
        let hit = t.brute.intersect(&pr, &mut st.brute, |i, tm| {
            t.scene.intersect_prim(i, &pr, tm)
        });
        if let Some(h) = hit {
            let p = r.o + r.d * h.t;
            let d = unit_dir(&mut rng);
            out.push(Ray {
                o: p,
                d: V3::from_f64(d),
                t_min: R::ZERO,
                t_max: R::INFINITY,
            });
        }
    }
    out
}

/// Everything for one scene in precision `R`.
fn agree<R: Real>(name: &str, desc: &SceneDescription, density: f64, seed: u64) -> TrioStats {
    let trio = Trio::<R>::new(desc, density);
    let what = format!("{name} ({}, density {density})", R::NAME);
    let eye = eye_rays::<R>(&desc.view, 24);
    let mut st = trio.check_all(&format!("{what} eye rays"), &eye);
    let random = random_rays(&trio, desc.view.from, 1500, seed);
    let s2 = trio.check_all(&format!("{what} random rays"), &random);
    let secondary = rays_from_hits(&trio, &eye, seed ^ 0x5eed);
    let s3 = trio.check_all(&format!("{what} rays from hits"), &secondary);
    for s in [s2, s3] {
        st.rays += s.rays;
        st.hits += s.hits;
        st.occluded += s.occluded;
        st.bvh += s.bvh;
        st.grid += s.grid;
        st.brute += s.brute;
    }
    st
}

#[test]
fn spd_small_scenes_agree_f32() {
    for (i, name) in SMALL_SCENES.iter().enumerate() {
        let desc = load(name);
        let st = agree::<f32>(name, &desc, DEFAULT_GRID_DENSITY, 1000 + i as u64);
        assert!(
            st.hits > st.rays / 10,
            "{name}: too few hits to mean anything"
        );
        assert!(
            st.grid.primitive_tests < st.brute.primitive_tests,
            "{name}: the grid should cull: {} tests against brute {}",
            st.grid.primitive_tests,
            st.brute.primitive_tests
        );
        assert!(st.grid.cell_steps > 0 && st.bvh.cell_steps == 0);
    }
}

#[test]
fn spd_small_scenes_agree_f64() {
    for (i, name) in ["teapot-2", "rings-2", "tetra-4", "balls-3", "gears-1"]
        .iter()
        .enumerate()
    {
        agree::<f64>(name, &load(name), DEFAULT_GRID_DENSITY, 2000 + i as u64);
    }
}

#[test]
fn grid_density_does_not_change_answers() {
    for name in ["mount-4", "lattice-4", "jacks-3"] {
        let desc = load(name);
        for density in [0.05, 1.0, 8.0, 100.0] {
            agree::<f32>(name, &desc, density, 3000);
        }
    }
}

// ---- the Goldsmith–Salmon hierarchy ----

/// The Goldsmith–Salmon BVH against brute force on the eye, random and secondary rays of
/// [`agree`]: the same closest hit bit for bit and the same occlusion answer. Returns (rays,
/// hits).
fn goldsmith_salmon_agrees<R: Real>(name: &str, desc: &SceneDescription, seed: u64) -> (u64, u64) {
    let trio = Trio::<R>::new(desc, DEFAULT_GRID_DENSITY);
    let gs = Accel::build(
        AccelKind::BvhGoldsmithSalmon,
        &trio.scene.all_bounds(),
        DEFAULT_GRID_DENSITY,
    );
    let eye = eye_rays::<R>(&desc.view, 24);
    let mut rays = random_rays(&trio, desc.view.from, 1500, seed);
    rays.extend(rays_from_hits(&trio, &eye, seed ^ 0x5eed));
    rays.extend(eye);
    let key = |h: &Option<PrimHit<R>>| {
        h.map(|h| {
            let bits = |x: R| x.to_f64().to_bits();
            (h.prim, bits(h.t), bits(h.u), bits(h.v))
        })
    };
    let (mut st_gs, mut st_brute) = (RayStats::default(), RayStats::default());
    let mut hits = 0;
    let mut bad = Vec::new();
    for r in &rays {
        let pr = PreparedRay::new(*r);
        let test = |i: u32, t: R| trio.scene.intersect_prim(i, &pr, t);
        let want = trio.brute.intersect(&pr, &mut st_brute, test);
        let got = gs.intersect(&pr, &mut st_gs, test);
        let occ_want = trio.brute.occluded(&pr, &mut st_brute, test);
        let occ = gs.occluded(&pr, &mut st_gs, test);
        hits += want.is_some() as u64;
        if key(&got) != key(&want) || occ != occ_want {
            bad.push(format!(
                "closest {got:?} (brute {want:?}), occluded {occ} (brute {occ_want}), ray {r:?}"
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "{name} ({}): Goldsmith–Salmon BVH disagrees with brute force on {} of {} rays; first: {}",
        R::NAME,
        bad.len(),
        rays.len(),
        bad.iter().take(3).cloned().collect::<Vec<_>>().join("\n")
    );
    assert!(
        st_gs.primitive_tests < st_brute.primitive_tests,
        "{name}: the Goldsmith–Salmon BVH should cull"
    );
    (rays.len() as u64, hits)
}

#[test]
fn goldsmith_salmon_agrees_with_brute_force() {
    for (i, name) in SMALL_SCENES.iter().enumerate() {
        let (rays, hits) = goldsmith_salmon_agrees::<f32>(name, &load(name), 6000 + i as u64);
        assert!(hits > rays / 10, "{name}: too few hits to mean anything");
    }
    for (i, name) in ["teapot-2", "tetra-4", "balls-3"].iter().enumerate() {
        goldsmith_salmon_agrees::<f64>(name, &load(name), 7000 + i as u64);
    }
    let makers = RANDOM_SCENES;
    for (name, make) in makers {
        let (_, hits) = goldsmith_salmon_agrees::<f32>(name, &make(0), 8000);
        assert!(hits > 0, "{name}: nothing hit");
    }
}

// ---- seeded random scenes ----

fn describe(primitives: Vec<Shape>, from: Rv) -> SceneDescription {
    scene_of(
        primitives,
        View {
            from,
            at: v(0.0, 0.0, 0.0),
            up: v(0.0, 0.0, 1.0),
            angle: 50.0,
            hither: 0.001,
            width: 64,
            height: 64,
        },
    )
}

/// A jittered height-field mesh (every inner edge shared by two triangles, every inner vertex by
/// six), a fan around one vertex, and exact duplicates (equal distances: the tie rule decides).
fn triangle_soup(seed: u64) -> SceneDescription {
    let mut rng = StdRng::seed_from_u64(seed);
    let n = 12;
    let mut h = vec![vec![0.0f64; n + 1]; n + 1];
    for row in h.iter_mut() {
        for z in row.iter_mut() {
            *z = rng.gen_range(-0.3..0.3);
        }
    }
    let p = |i: usize, j: usize| {
        v(
            i as f64 / n as f64 * 2.0 - 1.0,
            j as f64 / n as f64 * 2.0 - 1.0,
            h[i][j],
        )
    };
    let mut prims = Vec::new();
    for i in 0..n {
        for j in 0..n {
            prims.push(Shape::Polygon(
                vec![p(i, j), p(i + 1, j), p(i + 1, j + 1)].into(),
            ));
            prims.push(Shape::Polygon(
                vec![p(i, j), p(i + 1, j + 1), p(i, j + 1)].into(),
            ));
        }
    }
    let c = v(0.1, 0.2, 0.8);
    for k in 0..10 {
        let a0 = k as f64 / 10.0 * std::f64::consts::TAU;
        let a1 = (k + 1) as f64 / 10.0 * std::f64::consts::TAU;
        prims.push(Shape::Polygon(
            vec![
                c,
                c + v(a0.cos(), a0.sin(), 0.2) * 0.5,
                c + v(a1.cos(), a1.sin(), 0.2) * 0.5,
            ]
            .into(),
        ));
    }
    for k in 0..20 {
        let dup = prims[rng.gen_range(0..prims.len())].clone();
        prims.push(dup);
        if k % 2 == 0 {
            // Also the same triangle in the other winding: same plane, same distance.
            if let Some(Shape::Polygon(mut vs)) = prims.last().cloned() {
                vs.reverse();
                prims.push(Shape::Polygon(vs));
            }
        }
    }
    describe(prims, v(2.5, -3.0, 2.0))
}

/// Overlapping spheres of very different sizes, some duplicated, some nested.
fn overlapping_spheres(seed: u64) -> SceneDescription {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut prims = Vec::new();
    for _ in 0..150 {
        let c = in_cube(&mut rng);
        let r = if rng.gen_bool(0.1) {
            rng.gen_range(0.3..0.8)
        } else {
            rng.gen_range(0.01..0.2)
        };
        prims.push(Shape::Sphere {
            center: c,
            radius: r,
        });
        if rng.gen_bool(0.1) {
            prims.push(Shape::Sphere {
                center: c,
                radius: r,
            });
            prims.push(Shape::Sphere {
                center: c,
                radius: r * 0.5,
            });
        }
    }
    describe(prims, v(0.3, -4.0, 1.0))
}

/// Cones and cylinders in random directions, some closed to a point, plus a few spheres.
fn cones(seed: u64) -> SceneDescription {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut prims = Vec::new();
    for i in 0..120 {
        let base = in_cube(&mut rng);
        let apex = base + unit_dir(&mut rng) * rng.gen_range(0.05..0.6);
        let r0 = rng.gen_range(0.01..0.2);
        let r1 = match i % 3 {
            0 => r0,
            1 => 0.0,
            _ => rng.gen_range(0.01..0.2),
        };
        prims.push(Shape::Cone(ConeShape {
            base,
            base_radius: r0,
            apex,
            apex_radius: r1,
        }));
        if i % 10 == 0 {
            prims.push(Shape::Sphere {
                center: apex,
                radius: r1.max(0.05),
            });
        }
    }
    describe(prims, v(-3.0, -2.0, 2.5))
}

/// Small objects over huge background polygons: most of the grid is empty and every cell holds
/// the floor and the wall.
fn huge_background(seed: u64) -> SceneDescription {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut prims = vec![
        Shape::Polygon(
            vec![
                v(-1000.0, -1000.0, -0.5),
                v(1000.0, -1000.0, -0.5),
                v(1000.0, 1000.0, -0.5),
                v(-1000.0, 1000.0, -0.5),
            ]
            .into(),
        ),
        Shape::Polygon(
            vec![
                v(-1000.0, 3.0, -0.5),
                v(1000.0, 3.0, -0.5),
                v(1000.0, 3.0, 500.0),
                v(-1000.0, 3.0, 500.0),
            ]
            .into(),
        ),
    ];
    for _ in 0..100 {
        let c = v(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-0.5..1.0),
        );
        prims.push(Shape::Sphere {
            center: c,
            radius: rng.gen_range(0.02..0.15),
        });
        let a = c + unit_dir(&mut rng) * 0.2;
        let b = c + unit_dir(&mut rng) * 0.2;
        if (a - c).cross(b - c).length() > 1e-4 {
            prims.push(Shape::Polygon(vec![c, a, b].into()));
        }
    }
    describe(prims, v(2.0, -4.0, 1.5))
}

/// A named generator of seeded random scenes.
type SceneMaker = (&'static str, fn(u64) -> SceneDescription);

/// The seeded random scenes every accelerator is checked on.
const RANDOM_SCENES: [SceneMaker; 4] = [
    ("triangle soup", triangle_soup),
    ("overlapping spheres", overlapping_spheres),
    ("cones", cones),
    ("huge background", huge_background),
];

#[test]
fn random_scenes_agree() {
    let makers = RANDOM_SCENES;
    for (name, make) in makers {
        for seed in 0..3u64 {
            let desc = make(seed);
            let what = format!("{name} #{seed}");
            let st = agree::<f32>(&what, &desc, DEFAULT_GRID_DENSITY, 4000 + seed);
            assert!(st.hits > 0 && st.occluded > 0, "{what}: nothing hit");
            if seed == 0 {
                agree::<f64>(&what, &desc, DEFAULT_GRID_DENSITY, 5000 + seed);
            }
        }
    }
}

// ---- whole images ----

fn render(desc: &SceneDescription, accel: AccelKind, precision: Precision) -> Vec<u32> {
    let mut s = RenderSettings::new(64, 64);
    s.accel = accel;
    s.precision = precision;
    let r = Renderer::new(desc, &s).unwrap_or_else(|e| panic!("renderer: {e}"));
    let opts = SmpOptions {
        threads: 1,
        tile: 16,
        executor: Executor::Queue,
    };
    let out = render_smp(&r, &opts, &|_, _| {});
    out.film
        .pixels
        .iter()
        .flat_map(|p| p.iter().map(|c| c.to_bits()))
        .collect()
}

#[test]
fn images_identical_across_accelerators() {
    let cases = [
        ("balls-3", Precision::F32),
        ("gears-1", Precision::F32),
        ("teapot-2", Precision::F32),
        ("rings-2", Precision::F32),
        ("tetra-4", Precision::F64),
    ];
    for (name, precision) in cases {
        let desc = load(name);
        let brute = render(&desc, AccelKind::Brute, precision);
        for accel in [
            AccelKind::Bvh,
            AccelKind::Grid,
            AccelKind::BvhGoldsmithSalmon,
        ] {
            let img = render(&desc, accel, precision);
            let differ = img.iter().zip(&brute).filter(|(a, b)| a != b).count();
            assert_eq!(
                differ, 0,
                "{name} {precision:?}: {accel:?} differs from brute in {differ} channels"
            );
        }
    }
}
