//! Packet traversal: every ray of a packet gets exactly the answer brute force gives
//! it alone — the same closest hit bit for bit and the same occlusion — for the camera's eye
//! rays in 4×4 blocks, the shadow rays of their hits, coherent bundles with one origin or a
//! patch of origins, and incoherent packets (which go one by one). Renders with and without
//! packets are the same bits on any tiling and thread count.

use crate::support::film::assert_same_bits;
use crate::support::spd::{key, load, Trio, SMALL_SCENES};
use parrt_render::accel::bvh::packet::PACKET;
use parrt_render::accel::Accel;
use parrt_render::camera::Camera;
use parrt_render::description::SceneDescription;
use parrt_render::geometry::{offset_ray_origin, PreparedRay, Ray};
use parrt_render::real::Real;
use parrt_render::render::Renderer;
use parrt_render::settings::{Precision, RenderSettings, DEFAULT_GRID_DENSITY};
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_render::stats::RayStats;
use parrt_render::vec3::V3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Counts of what one scene's checks covered.
#[derive(Default, Debug)]
struct Covered {
    packets: usize,
    as_packet: usize,
    rays: usize,
    hits: usize,
    blocked: usize,
}

/// Checks one packet against brute force ray by ray; `Err` names the first disagreement.
fn check_packet<R: Real>(
    t: &Trio<R>,
    rays: &[Ray<R>],
    cov: &mut Covered,
    what: &str,
) -> Result<(), String> {
    let prs: Vec<_> = rays.iter().map(|r| PreparedRay::new(*r)).collect();
    let Accel::Bvh(bvh) = &t.bvh else {
        panic!("Trio's bvh is a BVH")
    };
    cov.packets += 1;
    cov.as_packet += bvh.takes_as_packet(&prs) as usize;
    let mut hits = [None; PACKET];
    let mut occ = [false; PACKET];
    let mut st = RayStats::default();
    let test = |pr: &PreparedRay<R>, p: u32, tm: R| t.scene.intersect_prim(p, pr, tm);
    t.bvh
        .intersect_packet(&prs, &mut hits[..prs.len()], &mut st, test);
    t.bvh
        .occluded_packet(&prs, &mut occ[..prs.len()], &mut st, test);
    for (i, pr) in prs.iter().enumerate() {
        let single = |p: u32, tm: R| t.scene.intersect_prim(p, pr, tm);
        let want = t.brute.intersect(pr, &mut st, single);
        let occ_want = t.brute.occluded(pr, &mut st, single);
        cov.rays += 1;
        cov.hits += want.is_some() as usize;
        cov.blocked += occ_want as usize;
        if key(&hits[i]) != key(&want) || occ[i] != occ_want {
            return Err(format!(
                "{what}: ray {i} of {}: packet {:?} / occluded {}, alone {want:?} / {occ_want}; {:?}",
                prs.len(),
                hits[i],
                occ[i],
                pr.ray
            ));
        }
    }
    Ok(())
}

/// Eye rays through the pixel centres of an `n × n` image in 4×4 blocks (narrower at the
/// edges when `n` is not a multiple of 4), and for each block the shadow rays of its hits to
/// each light, built as the renderer builds them.
fn eye_and_shadow_packets<R: Real>(
    t: &Trio<R>,
    desc: &SceneDescription,
    n: u32,
    cov: &mut Covered,
) -> Result<(), String> {
    let cam = Camera::<R>::new(&desc.view, n, n);
    for by in (0..n).step_by(4) {
        for bx in (0..n).step_by(4) {
            let mut eye = Vec::new();
            for y in by..(by + 4).min(n) {
                for x in bx..(bx + 4).min(n) {
                    eye.push(cam.ray(R::from_u32(x) + R::HALF, R::from_u32(y) + R::HALF));
                }
            }
            check_packet(t, &eye, cov, &format!("eye block ({bx}, {by})"))?;
            for (li, light) in t.scene.lights.iter().enumerate() {
                let mut shadow = Vec::new();
                for r in &eye {
                    let pr = PreparedRay::new(*r);
                    let mut st = RayStats::default();
                    let Some(h) = t
                        .brute
                        .intersect(&pr, &mut st, |p, tm| t.scene.intersect_prim(p, &pr, tm))
                    else {
                        continue;
                    };
                    let s = t.scene.surface(r, &h);
                    let to = light.position - s.p;
                    let dist = to.length();
                    let o = offset_ray_origin(s.p, s.p_err, s.ng, to / dist);
                    let d = light.position - o;
                    let len = d.length();
                    shadow.push(Ray {
                        o,
                        d: d / len,
                        t_min: R::ZERO,
                        t_max: len,
                    });
                }
                if !shadow.is_empty() {
                    check_packet(t, &shadow, cov, &format!("shadow ({bx}, {by}) light {li}"))?;
                }
            }
        }
    }
    Ok(())
}

/// Seeded bundles: one origin and directions in a narrow cone (coherent, finite or infinite),
/// origins on a small patch aimed at one point (shadow-like), and rays in any directions (which
/// the BVH must take one by one).
fn random_packets<R: Real>(t: &Trio<R>, seed: u64, cov: &mut Covered) -> Result<(), String> {
    let mut rng = StdRng::seed_from_u64(seed);
    let b = t
        .scene
        .all_bounds()
        .iter()
        .fold(parrt_render::geometry::Aabb::EMPTY, |a, b| a.union(b));
    let lo = V3::new(b.min[0] as f64, b.min[1] as f64, b.min[2] as f64);
    let hi = V3::new(b.max[0] as f64, b.max[1] as f64, b.max[2] as f64);
    let size = (hi - lo).length();
    let point = |rng: &mut StdRng, grow: f64| {
        let f = |a: f64, b: f64, rng: &mut StdRng| {
            let pad = (b - a) * grow;
            if b > a {
                rng.gen_range(a - pad..b + pad)
            } else {
                a
            }
        };
        V3::new(f(lo.x, hi.x, rng), f(lo.y, hi.y, rng), f(lo.z, hi.z, rng))
    };
    let mk = |o: V3<f64>, d: V3<f64>, t_max: f64| Ray {
        o: V3::<R>::from_f64(o),
        d: V3::<R>::from_f64(d.normalize()),
        t_min: R::ZERO,
        t_max: R::from_f64(t_max),
    };
    for k in 0..120 {
        let n = 2 + k % (PACKET - 1);
        let o = point(&mut rng, 0.3);
        let target = point(&mut rng, 0.0);
        let spread = [0.001, 0.01, 0.05][k % 3] * size;
        let mut rays = Vec::new();
        for _ in 0..n {
            let jitter = V3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            ) * spread;
            rays.push(match k % 4 {
                0 => mk(o, target + jitter - o, f64::INFINITY),
                1 => mk(o, target + jitter - o, (target - o).length()),
                2 => {
                    // A patch of origins towards one point, like shadow rays to a light.
                    let from = target + jitter * 0.5;
                    mk(from, o - from, (o - from).length())
                }
                _ => mk(
                    point(&mut rng, 0.2),
                    point(&mut rng, 0.2) - o,
                    f64::INFINITY,
                ),
            });
        }
        rays.retain(|r| r.d.is_finite());
        if !rays.is_empty() {
            check_packet(t, &rays, cov, &format!("random packet {k}"))?;
        }
    }
    Ok(())
}

fn packets_agree<R: Real>(name: &str, seed: u64) -> Covered {
    let desc = load(name);
    let t = Trio::<R>::new(&desc, DEFAULT_GRID_DENSITY);
    let mut cov = Covered::default();
    let what = format!("{name} ({})", R::NAME);
    if let Err(e) = eye_and_shadow_packets(&t, &desc, 30, &mut cov) {
        panic!("{what}: {e}");
    }
    if let Err(e) = random_packets(&t, seed, &mut cov) {
        panic!("{what}: {e}");
    }
    assert!(cov.hits > cov.rays / 10, "{what}: too few hits: {cov:?}");
    // Eye blocks straddling the view's axis planes, shadow packets across silhouettes and the
    // incoherent random packets go one by one; a fair share must still be traced together.
    assert!(
        cov.as_packet * 4 > cov.packets,
        "{what}: too few packets traced together: {cov:?}"
    );
    cov
}

#[test]
fn packets_agree_with_brute_force_f32() {
    let mut blocked = 0;
    for (i, name) in SMALL_SCENES.iter().enumerate() {
        blocked += packets_agree::<f32>(name, 100 + i as u64).blocked;
    }
    assert!(
        blocked > 0,
        "no ray was ever blocked: the occlusion check means nothing"
    );
}

#[test]
fn packets_agree_with_brute_force_f64() {
    for (i, name) in ["teapot-2", "tetra-4", "balls-3", "gears-1"]
        .iter()
        .enumerate()
    {
        packets_agree::<f64>(name, 200 + i as u64);
    }
}

#[test]
fn incoherent_packets_go_one_by_one() {
    let desc = load("balls-3");
    let t = Trio::<f32>::new(&desc, DEFAULT_GRID_DENSITY);
    let Accel::Bvh(bvh) = &t.bvh else {
        panic!("a BVH")
    };
    let ray = |o: [f32; 3], d: [f32; 3]| {
        PreparedRay::new(Ray {
            o: V3::from_array(o),
            d: V3::from_array(d),
            t_min: 0.0,
            t_max: f32::INFINITY,
        })
    };
    let same = [ray([3.0, 3.0, 3.0], [-1.0, -1.0, -0.5]); 4];
    assert!(bvh.takes_as_packet(&same));
    let mixed = [
        ray([3.0, 3.0, 3.0], [-1.0, -1.0, -0.5]),
        ray([3.0, 3.0, 3.0], [1.0, -1.0, -0.5]),
    ];
    assert!(!bvh.takes_as_packet(&mixed), "mixed direction signs");
    let axis = [
        ray([3.0, 3.0, 3.0], [-1.0, -1.0, -0.5]),
        ray([3.0, 3.0, 3.0], [-1.0, 0.0, -0.5]),
    ];
    assert!(!bvh.takes_as_packet(&axis), "a zero direction component");
    let mut far_apart = same;
    far_apart[1].ray.o = V3::new(-3.0, 3.0, 3.0);
    far_apart[1].ray.t_max = 1.0;
    far_apart[0].ray.t_max = 1.0;
    assert!(!bvh.takes_as_packet(&far_apart), "origins spread wide");
    assert!(!bvh.takes_as_packet(&same[..1]), "a single ray");
}

/// Renders with and without packets on tilings that cut 4×4 blocks (1, 7, 13, 32) and on one
/// and two threads: the same bits, and the same ray counts.
fn renders_match(name: &str, precision: Precision, w: u32, h: u32) {
    let desc = load(name);
    let mut s = RenderSettings::new(w, h);
    s.precision = precision;
    let mut single = Renderer::new(&desc, &s).expect("scene builds");
    single.set_packets(false);
    let opts = |tile, threads| SmpOptions {
        threads,
        tile,
        executor: Executor::Queue,
    };
    let want = render_smp(&single, &opts(16, 1), &|_, _| {});
    let mut packed = Renderer::new(&desc, &s).expect("scene builds");
    packed.set_packets(true);
    for (tile, threads) in [(1, 1), (7, 2), (13, 1), (32, 2)] {
        let got = render_smp(&packed, &opts(tile, threads), &|_, _| {});
        assert_same_bits(
            &got.film,
            &want.film,
            &format!("{name}: packets (tile {tile}, {threads} threads) against one by one"),
        );
        let rays = |st: &RayStats| {
            [
                st.eye_rays,
                st.eye_hits,
                st.shadow_rays,
                st.shadow_hits,
                st.reflection_rays,
                st.reflection_hits,
                st.refraction_rays,
                st.refraction_hits,
            ]
        };
        assert_eq!(rays(&got.stats), rays(&want.stats), "{name}: ray counts");
    }
    // Tile sizes that are multiples of 4 form the same packets: all counts agree.
    let a = render_smp(&packed, &opts(8, 1), &|_, _| {});
    let b = render_smp(&packed, &opts(32, 2), &|_, _| {});
    assert_eq!(
        a.stats, b.stats,
        "{name}: tiles 8 and 32 count the same tests"
    );
}

#[test]
fn renders_are_the_same_bits_with_and_without_packets() {
    for name in [
        "mount-4", "balls-3", "teapot-2", "gears-1", "tetra-4", "shells-1",
    ] {
        renders_match(name, Precision::F32, 45, 38);
    }
    renders_match("balls-3", Precision::F64, 30, 30);
}

/// The integrator `parrt render` builds for `desc` at `w`×`h` (BVH, default settings but
/// `max_depth`), with its camera.
fn integrator<R: Real>(
    desc: &SceneDescription,
    w: u32,
    h: u32,
    max_depth: u32,
) -> (parrt_render::shade::Integrator<R>, Camera<R>) {
    let s = RenderSettings::new(w, h);
    let scene = parrt_render::scene::Scene::<R>::build(desc).expect("scene builds");
    let accel = Accel::build(s.accel, &scene.all_bounds(), DEFAULT_GRID_DENSITY);
    let opts = parrt_render::shade::ShadeOptions {
        max_depth,
        cutoff: R::from_f64(s.cutoff),
        spd: false,
        two_sided: false,
    };
    (
        parrt_render::shade::Integrator { scene, accel, opts },
        Camera::new(&desc.view, w, h),
    )
}

/// Secondary rays in packets: the reflection and refraction rays of each 4×4 block's eye hits,
/// traced together with `trace_packet`, get the colour `trace` gives each alone, bit for bit;
/// returns how many of those packets were coherent enough to go through the packet code.
fn secondary_packets_match<R: Real>(name: &str, w: u32, h: u32, max_depth: u32) -> usize {
    use parrt_render::packet::trace::directions_close;
    use parrt_render::shade::RayKind;
    let desc = load(name);
    let (integ, camera) = integrator::<R>(&desc, w, h, max_depth);
    let Accel::Bvh(bvh) = &integ.accel else {
        panic!("BVH expected");
    };
    let mut stats = RayStats::default();
    let mut coherent = 0;
    for by in (0..h).step_by(4) {
        for bx in (0..w).step_by(4) {
            let mut next = Vec::new();
            let mut kinds = Vec::new();
            for y in by..(by + 4).min(h) {
                for x in bx..(bx + 4).min(w) {
                    let eye = camera.ray(R::from_f64(x as f64 + 0.5), R::from_f64(y as f64 + 0.5));
                    let Some(hit) = integ.intersect(&eye, &mut stats) else {
                        continue;
                    };
                    let lit = integ.lit(&eye, &hit);
                    let sp = integ.spawn(&eye, &lit, 1, R::ONE);
                    if let Some(r) = sp.reflection {
                        next.push(r);
                        kinds.push(RayKind::Reflection);
                    }
                    if let Some(r) = sp.refraction {
                        next.push(r);
                        kinds.push(RayKind::Refraction);
                    }
                }
            }
            for kind in [RayKind::Reflection, RayKind::Refraction] {
                let group: Vec<(Ray<R>, R)> = next
                    .iter()
                    .zip(&kinds)
                    .filter(|(_, k)| **k == kind)
                    .map(|(r, _)| *r)
                    .collect();
                if group.is_empty() {
                    continue;
                }
                let rays: Vec<Ray<R>> = group.iter().map(|(r, _)| *r).collect();
                let weights: Vec<R> = group.iter().map(|(_, w)| *w).collect();
                let prs: Vec<PreparedRay<R>> = rays.iter().map(|r| PreparedRay::new(*r)).collect();
                if rays.len() > 1 && directions_close(&rays) && bvh.takes_as_packet(&prs) {
                    coherent += 1;
                }
                let mut got = vec![V3::zero(); rays.len()];
                integ.trace_packet(&rays, 2, &weights, kind, &mut got, &mut stats);
                for (i, r) in rays.iter().enumerate() {
                    let want = integ.trace(r, 2, weights[i], kind, &mut stats);
                    let bits = |c: V3<R>| [c.x, c.y, c.z].map(|v| v.to_f64().to_bits());
                    assert_eq!(
                        bits(got[i]),
                        bits(want),
                        "{name}: {kind:?} ray {i} of block ({bx}, {by}) differs in a packet"
                    );
                }
            }
        }
    }
    coherent
}

#[test]
fn secondary_ray_packets_give_every_ray_its_single_ray_colour() {
    // gears: a mirror floor and glass gears; teapot: a mirror floor and a curved teapot; balls:
    // mirror spheres (incoherent); mount: glass spheres; rings: mirror cylinders.
    let mut coherent = 0;
    for name in ["gears-1", "teapot-2", "balls-3", "mount-4", "rings-2"] {
        coherent += secondary_packets_match::<f32>(name, 64, 64, 5);
    }
    // Deeper than PACKET_DEPTH, where the packets hand over to single rays.
    coherent += secondary_packets_match::<f32>("gears-1", 32, 32, 12);
    coherent += secondary_packets_match::<f64>("teapot-2", 32, 32, 5);
    assert!(
        coherent > 50,
        "only {coherent} secondary packets went through the packet code"
    );
}

#[test]
fn deep_renders_are_the_same_bits_with_and_without_secondary_packets() {
    // Mirror floors at a depth limit beyond PACKET_DEPTH, so reflections bounce in packets, then
    // one by one.
    for name in ["gears-1", "teapot-2", "rings-2"] {
        let desc = load(name);
        let mut s = RenderSettings::new(64, 48);
        s.max_depth = 12;
        let mut single = Renderer::new(&desc, &s).expect("scene builds");
        single.set_packets(false);
        let opts = SmpOptions {
            threads: 1,
            tile: 16,
            executor: Executor::Queue,
        };
        let want = render_smp(&single, &opts, &|_, _| {});
        let mut packed = Renderer::new(&desc, &s).expect("scene builds");
        packed.set_packets(true);
        let got = render_smp(&packed, &opts, &|_, _| {});
        assert_same_bits(&got.film, &want.film, &format!("{name} at depth 12"));
        assert_eq!(
            (
                got.stats.reflection_rays,
                got.stats.refraction_rays,
                got.stats.shadow_rays
            ),
            (
                want.stats.reflection_rays,
                want.stats.refraction_rays,
                want.stats.shadow_rays
            ),
            "{name}: ray counts"
        );
    }
}
