//! Self-intersection: no shadow acne on a huge ground lit at grazing angles, and rays spawned
//! from spheres, cones and triangles never hit their own surface again (pbrt's Reintersect).

use crate::setup::{cone_in, perpendiculars, precisions, render, settings, PLACEMENTS};
use crate::support::scene::{mat, prim, v, view};
use parrt_render::description::{Light, SceneDescription, Shape};
use parrt_render::geometry::sphere::Sphere;
use parrt_render::geometry::triangle::{intersect_triangle, triangle_point};
use parrt_render::geometry::{offset_ray_origin, PreparedRay, Ray};
use parrt_render::real::Real;
use parrt_render::vec3::{Vec3d, V3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

// ---------------------------------------------------------------------------------------------
// Shadow acne
// ---------------------------------------------------------------------------------------------

/// A ground 2e4 units wide (one polygon, and a sphere of radius 1e4) seen and lit at grazing
/// angles. Nothing blocks the light, so every shadow ray blocked is self-intersection (acne).
#[test]
fn huge_grazing_ground_has_no_shadow_acne() {
    let polygon = Shape::Polygon(
        vec![
            v(-1e4, -1e4, 0.0),
            v(1e4, -1e4, 0.0),
            v(1e4, 1e4, 0.0),
            v(-1e4, 1e4, 0.0),
        ]
        .into(),
    );
    let ball = Shape::Sphere {
        center: v(0.0, 0.0, -1e4),
        radius: 1e4,
    };
    for (ground, place) in [polygon, ball]
        .into_iter()
        .flat_map(|g| PLACEMENTS.map(|p| (g.clone(), p)))
    {
        let written = SceneDescription {
            background: v(0.0, 0.0, 1.0),
            view: view(
                v(0.0, 0.0, 1.0),
                v(0.0, 60.0, 0.0),
                v(0.0, 0.0, 1.0),
                40.0,
                96,
            ),
            lights: vec![Light {
                position: v(3e3, 9e3, 40.0),
                color: None,
            }],
            materials: vec![mat([1.0, 1.0, 1.0], 0.9, 0.0, 0.0, 1.0)],
            primitives: vec![prim(ground.clone(), 0)],
        };
        let desc = place.scene(&written);
        let at = place.name;
        for precision in precisions(&desc) {
            let (film, st) = render(&desc, &settings(96, precision));
            assert!(st.shadow_rays > 1000, "{ground:?} {at}: the ground is lit");
            assert_eq!(st.shadow_hits, 0, "{ground:?} {at} {precision:?}: acne");
            // The lit ground is brighter than the ambient term everywhere.
            let ambient = 0.5 * 0.9;
            let dark = film
                .pixels
                .iter()
                .filter(|p| p[2] < 0.99 && p[0] <= ambient as f32 + 1e-6)
                .count();
            assert_eq!(
                dark, 0,
                "{ground:?} {at} {precision:?}: unlit ground pixels"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Reintersect (pbrt-v4's shapes_test idea): spawned rays never hit their own surface again
// ---------------------------------------------------------------------------------------------

fn rand_v(rng: &mut StdRng, r: f64) -> Vec3d {
    v(
        rng.gen_range(-r..r),
        rng.gen_range(-r..r),
        rng.gen_range(-r..r),
    )
}

fn rand_dir(rng: &mut StdRng) -> Vec3d {
    loop {
        let p = rand_v(rng, 1.0);
        let l = p.length();
        if l > 1e-3 && l <= 1.0 {
            return p / l;
        }
    }
}

/// A random direction on the side of `n` (dot > 0), including near-grazing ones.
fn rand_out(rng: &mut StdRng, n: Vec3d) -> Vec3d {
    let d = rand_dir(rng);
    if d.dot(n) > 0.0 {
        d
    } else {
        (d - n * (2.0 * d.dot(n))).normalize()
    }
}

fn ray<R: Real>(o: V3<R>, d: Vec3d) -> Ray<R> {
    Ray {
        o,
        d: V3::from_f64(d).normalize(),
        t_min: R::ZERO,
        t_max: R::INFINITY,
    }
}

const TRIALS: usize = 20_000;

/// Spawns four rays from a hit at `p` (error bound `err`, geometric normal `n`), towards
/// directions drawn by `towards`, each origin offset as the renderer offsets it, and asserts that
/// `rehit` (the primitive's own test, giving the distance of a hit) finds none of them hitting
/// again; `what` names the primitive. Returns how many rays it tested.
fn spawned_never_rehit<R: Real>(
    rng: &mut StdRng,
    (p, err, n): (V3<R>, V3<R>, V3<R>),
    towards: impl Fn(&mut StdRng) -> Vec3d,
    rehit: impl Fn(&Ray<R>) -> Option<R>,
    what: impl Fn() -> String,
) -> usize {
    const SPAWNED: usize = 4;
    for _ in 0..SPAWNED {
        let d = towards(rng);
        let spawned = ray(offset_ray_origin(p, err, n, V3::from_f64(d)), d);
        let again = rehit(&spawned);
        assert!(
            again.is_none(),
            "{}: {} re-hit at t = {again:?} from {p:?} towards {d:?}",
            R::NAME,
            what()
        );
    }
    SPAWNED
}

/// Runs the trials of one kind of primitive: `trial` draws a primitive and a primary ray aimed
/// at it and, when the ray hits, returns how many spawned rays it checked
/// ([`spawned_never_rehit`]). Most primary rays must hit.
fn reintersect<R: Real>(seed: u64, mut trial: impl FnMut(&mut StdRng) -> Option<usize>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let tested: usize = (0..TRIALS).filter_map(|_| trial(&mut rng)).sum();
    assert!(
        tested > TRIALS,
        "{}: most primary rays must hit ({tested})",
        R::NAME
    );
}

fn spheres_reintersect<R: Real>() {
    reintersect::<R>(1, |rng| {
        let scale = 10f64.powf(rng.gen_range(-3.0..3.0));
        let s = Sphere {
            center: V3::from_f64(rand_v(rng, 100.0 * scale)),
            radius: R::from_f64(rng.gen_range(0.01..10.0) * scale),
        };
        let target = s.center.to_f64() + rand_dir(rng) * (s.radius.to_f64() * 0.999);
        let o = target + rand_dir(rng) * (rng.gen_range(2.0..50.0) * s.radius.to_f64());
        let r0 = ray::<R>(V3::from_f64(o), target - o);
        let t = s.intersect(&r0, R::INFINITY)?;
        let hit = s.surface(&r0, t);
        Some(spawned_never_rehit(
            rng,
            hit,
            |rng| rand_out(rng, hit.2.to_f64()),
            |r| s.intersect(r, R::INFINITY),
            || format!("sphere {s:?}"),
        ))
    });
}

fn cones_reintersect<R: Real>() {
    reintersect::<R>(2, |rng| {
        let scale = 10f64.powf(rng.gen_range(-2.0..2.0));
        let base = rand_v(rng, 50.0 * scale);
        let apex = base + rand_dir(rng) * (rng.gen_range(0.1..10.0) * scale);
        let r0 = rng.gen_range(0.0..3.0) * scale;
        let r1 = if rng.gen_bool(0.3) {
            r0
        } else {
            rng.gen_range(0.0..3.0) * scale
        };
        let c = cone_in::<R>(base, r0, apex, r1)?;
        // Aim at a point on the surface, from outside the cone's box.
        let z = rng.gen_range(0.02..0.98);
        let axis = (apex - base).normalize();
        let (e1, e2) = perpendiculars(axis);
        let a = rng.gen_range(0.0..std::f64::consts::TAU);
        let radial = e1 * a.cos() + e2 * a.sin();
        let h = (apex - base).length();
        let target = base + axis * (z * h) + radial * ((r0 + (r1 - r0) * z) * 0.999);
        let o = target + rand_out(rng, radial) * (rng.gen_range(2.0..20.0) * (h + r0 + r1));
        let r = ray::<R>(V3::from_f64(o), target - o);
        let t = c.intersect(&r, R::INFINITY)?;
        let hit = c.surface(&r, t);
        Some(spawned_never_rehit(
            rng,
            hit,
            |rng| rand_out(rng, hit.2.to_f64()),
            |r| c.intersect(r, R::INFINITY),
            || format!("cone {c:?}"),
        ))
    });
}

fn triangles_reintersect<R: Real>() {
    reintersect::<R>(3, |rng| {
        let scale = 10f64.powf(rng.gen_range(-3.0..3.0));
        let centre = rand_v(rng, 100.0 * scale);
        let p = [0, 1, 2].map(|_| centre + rand_v(rng, 10.0 * scale));
        let pr = p.map(V3::<R>::from_f64);
        let ng = (pr[1] - pr[0]).cross(pr[2] - pr[0]);
        let area2 = ng.length_squared();
        if !area2.is_finite() || area2 <= R::ZERO {
            return None;
        }
        let ng = ng.normalize();
        let (mut b1, mut b2) = (rng.gen_range(0.0..1.0), rng.gen_range(0.0..1.0));
        if b1 + b2 > 1.0 {
            (b1, b2) = (1.0 - b1, 1.0 - b2);
        }
        let target = p[0] * (1.0 - b1 - b2) + p[1] * b1 + p[2] * b2;
        let o = target + rand_dir(rng) * (rng.gen_range(1.0..100.0) * scale);
        let r = PreparedRay::new(ray::<R>(V3::from_f64(o), target - o));
        let h = intersect_triangle(&r, pr[0], pr[1], pr[2], R::INFINITY)?;
        let (hp, err) = triangle_point(pr, h.b1, h.b2);
        Some(spawned_never_rehit(
            rng,
            (hp, err, ng),
            // Any direction: leaving to either side.
            rand_dir,
            |r| {
                intersect_triangle(&PreparedRay::new(*r), pr[0], pr[1], pr[2], R::INFINITY)
                    .map(|h| h.t)
            },
            || format!("triangle {p:?}"),
        ))
    });
}

#[test]
fn spawned_rays_never_rehit_spheres() {
    spheres_reintersect::<f32>();
    spheres_reintersect::<f64>();
}

#[test]
fn spawned_rays_never_rehit_cones() {
    cones_reintersect::<f32>();
    cones_reintersect::<f64>();
}

#[test]
fn spawned_rays_never_rehit_triangles() {
    triangles_reintersect::<f32>();
    triangles_reintersect::<f64>();
}
