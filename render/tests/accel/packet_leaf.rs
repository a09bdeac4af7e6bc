//! A packet's rays tested against a leaf together: `closest_many` and `any_many` of
//! `SceneLeaf` (which gathers a leaf of triangles or spheres into the four-lane kernel's lanes
//! once for all the rays that enter it) and of `PacketLeaf` (one primitive against all the
//! rays at once, a ray per AVX lane, where the CPU has it) give every ray of the mask
//! exactly what the one-ray-at-a-time scalar test gives it — primitive, `t`, `u`, `v` and the bound bit for bit,
//! the first blocking primitive's position — and leave the rays outside the mask alone. Leaves
//! of 2..=4 triangles, spheres and cones from SPD scenes and from a mesh on integer vertices (rays
//! exactly through edges and vertices, ties the primitive index decides), mixed leaves, rays
//! that miss, ranges ending before or exactly at a hit, and full, partial and single-ray masks.

use crate::support::scene::doubled_grid;
use crate::support::spd::{key, load};
use parrt_render::accel::RayPrimTest;
use parrt_render::geometry::{Nearest, PreparedRay, Ray};
use parrt_render::packet::leaf::PacketLeaf;
use parrt_render::packet::scene_leaf::SceneLeaf;
use parrt_render::real::Real;
use parrt_render::scene::{Prim, Scene};
use parrt_render::vec3::V3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Rays per packet.
const PACKET: usize = parrt_render::accel::bvh::packet::PACKET;

/// What the comparison covered.
#[derive(Default, Debug)]
struct Covered {
    leaves: u64,
    ray_tests: u64,
    hits: u64,
    /// Triangle hits on an edge or a vertex (a barycentric exactly 0, or `u + v` exactly 1).
    edge_hits: u64,
    misses: u64,
    blocked: u64,
    partial_masks: u64,
}

/// Points to aim at on the triangle `v`: its vertices, edge midpoints and centroid.
pub fn triangle_targets<R: Real>(v: &[V3<R>; 3]) -> [V3<R>; 7] {
    let half = R::HALF;
    let third = R::ONE / R::from_u32(3);
    [
        v[0],
        v[1],
        v[2],
        (v[0] + v[1]) * half,
        (v[1] + v[2]) * half,
        (v[2] + v[0]) * half,
        (v[0] + v[1] + v[2]) * third,
    ]
}

/// Points to aim at on primitive `p`: a triangle's vertices, edge midpoints and centroid; a
/// sphere's centre and points on its silhouette seen from `eye`; a cone's rims, a point on
/// its side half way up, and its axis there.
fn targets<R: Real>(p: &Prim<R>, eye: V3<R>) -> Vec<V3<R>> {
    match p {
        Prim::Triangle(v) => triangle_targets(v).to_vec(),
        Prim::Sphere(s) => {
            let view = (s.center - eye).normalize();
            let side = view.cross(V3::new(R::ZERO, R::ONE, R::ZERO));
            let side = if side.length() > R::from_f64(1e-3) {
                side.normalize()
            } else {
                view.cross(V3::new(R::ONE, R::ZERO, R::ZERO)).normalize()
            };
            vec![
                s.center,
                s.center + side * s.radius,
                s.center - side * (s.radius * R::HALF),
            ]
        }
        Prim::Cone(c) => {
            let side = c
                .axis
                .cross(V3::new(R::from_f64(0.3), R::HALF, R::from_f64(0.8)))
                .normalize();
            let r1 = c.r0 + c.slope * c.height;
            let mid = c.base + c.axis * (c.height * R::HALF);
            vec![
                c.base + side * c.r0,
                c.base + c.axis * c.height - side * r1,
                mid + side * ((c.r0 + r1) * R::HALF),
                mid,
            ]
        }
    }
}

/// Rays from `eye` at every target of `leaf`, as full rays, as segments ending exactly at the
/// target and at half way, and turned away (misses); and from a random point near each target
/// at it (so a packet mixes rays whose largest direction axes differ).
fn leaf_rays<R: Real>(
    scene: &Scene<R>,
    leaf: &[u32],
    eye: V3<R>,
    rng: &mut StdRng,
) -> Vec<PreparedRay<R>> {
    let mut out = Vec::new();
    for &p in leaf {
        for t in targets(&scene.prims[p as usize], eye) {
            let off = V3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0f64),
            );
            if off.length() > 1e-3 {
                let off = V3::from_f64(off * 4.0);
                out.push(PreparedRay::new(Ray {
                    o: t - off,
                    d: off.normalize(),
                    t_min: R::ZERO,
                    t_max: R::INFINITY,
                }));
            }
            let d = t - eye;
            let len = d.length();
            if len.partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let d = d / len;
            for (d, t_max) in [
                (d, R::INFINITY),
                (d, len),
                (d, len * R::HALF),
                (-d, R::INFINITY),
            ] {
                out.push(PreparedRay::new(Ray {
                    o: eye,
                    d,
                    t_min: R::ZERO,
                    t_max,
                }));
            }
        }
    }
    out
}

/// The masks each packet of `n` rays is tried with.
fn masks(n: usize, rng: &mut StdRng) -> Vec<u32> {
    let all = (1u32 << n) - 1;
    vec![
        all,
        all & 0x5555,
        all & 0xaaaa,
        1,
        1 << (n - 1),
        all & !1,
        rng.gen::<u32>() & all,
        rng.gen::<u32>() & all,
    ]
}

/// Compares the packet-leaf path with the scalar one-ray path on one leaf.
fn compare_leaf<R: Real>(
    what: &str,
    scene: &Scene<R>,
    leaf: &[u32],
    eye: V3<R>,
    rng: &mut StdRng,
    c: &mut Covered,
) {
    let rays = leaf_rays(scene, leaf, eye, rng);
    c.leaves += 1;
    for packet in rays.chunks(PACKET) {
        let n = packet.len();
        for mask in masks(n, rng) {
            if mask != (1 << n) - 1 {
                c.partial_masks += 1;
            }
            // Start some rays with a bound already lowered by an earlier leaf.
            let start: Vec<Nearest<R>> = packet
                .iter()
                .enumerate()
                .map(|(i, pr)| {
                    let t = if i % 3 == 2 {
                        pr.ray.t_max.min(R::from_f64(rng.gen_range(0.5..50.0)))
                    } else {
                        pr.ray.t_max
                    };
                    Nearest::new(t)
                })
                .collect();
            let mut many = start.clone();
            SceneLeaf::new(scene).closest_many(packet, mask, leaf, &mut many);
            let mut first = [usize::MAX; PACKET];
            let blocked = SceneLeaf::new(scene).any_many(packet, mask, leaf, &mut first);
            let mut lanes = start.clone();
            let mut slot = None;
            PacketLeaf::new(scene, &mut slot).closest_many(packet, mask, leaf, &mut lanes);
            let mut lanes_first = [usize::MAX; PACKET];
            let lanes_blocked =
                PacketLeaf::new(scene, &mut slot).any_many(packet, mask, leaf, &mut lanes_first);
            for (i, pr) in packet.iter().enumerate() {
                let mut want = start[i];
                let mut want_blocked = None;
                if mask & (1 << i) != 0 {
                    SceneLeaf::scalar(scene).closest(pr, leaf, &mut want);
                    want_blocked = SceneLeaf::scalar(scene).any(pr, leaf, pr.ray.t_max);
                    c.ray_tests += 1;
                }
                assert_eq!(
                    (key(&many[i].hit), many[i].t.to_f64().to_bits()),
                    (key(&want.hit), want.t.to_f64().to_bits()),
                    "{what}: leaf {leaf:?}, mask {mask:#x}, ray {i} {pr:?}"
                );
                assert_eq!(
                    (key(&lanes[i].hit), lanes[i].t.to_f64().to_bits()),
                    (key(&want.hit), want.t.to_f64().to_bits()),
                    "{what}: lanes, leaf {leaf:?}, mask {mask:#x}, ray {i} {pr:?}"
                );
                let got_blocked = (blocked & (1 << i) != 0).then_some(first[i]);
                assert_eq!(
                    got_blocked, want_blocked,
                    "{what}: blocked, leaf {leaf:?}, mask {mask:#x}, ray {i} {pr:?}"
                );
                let lanes_got = (lanes_blocked & (1 << i) != 0).then_some(lanes_first[i]);
                assert_eq!(
                    lanes_got, want_blocked,
                    "{what}: lanes blocked, leaf {leaf:?}, mask {mask:#x}, ray {i} {pr:?}"
                );
                if mask & (1 << i) == 0 {
                    continue;
                }
                c.blocked += u64::from(want_blocked.is_some());
                match want.hit {
                    None => c.misses += 1,
                    Some(h) => {
                        c.hits += 1;
                        if matches!(scene.prims[h.prim as usize], Prim::Triangle(_))
                            && (h.u == R::ZERO || h.v == R::ZERO || h.u + h.v == R::ONE)
                        {
                            c.edge_hits += 1;
                        }
                    }
                }
            }
        }
    }
}

/// Leaves of `k` = 1..=4 consecutive primitives (neighbours in a mesh share edges), every
/// `step`-th start, and a few leaves mixing a triangle or a cone with a sphere.
fn leaves<R: Real>(scene: &Scene<R>, step: usize) -> Vec<Vec<u32>> {
    let n = scene.prims.len() as u32;
    let mut out = Vec::new();
    for k in 1..=4u32 {
        let mut s = 0;
        while s + k <= n {
            out.push((s..s + k).collect());
            s += step as u32;
        }
    }
    let tri = (0..n).find(|&i| matches!(scene.prims[i as usize], Prim::Triangle(_)));
    let sph = (0..n).find(|&i| matches!(scene.prims[i as usize], Prim::Sphere(_)));
    if let (Some(t), Some(s)) = (tri, sph) {
        out.push(vec![t, s]);
        out.push(vec![s, t, s]);
    }
    let cone = (0..n).find(|&i| matches!(scene.prims[i as usize], Prim::Cone(_)));
    if let (Some(c), Some(s)) = (cone, sph) {
        out.push(vec![c, s]);
        out.push(vec![s, c, c + 1]);
    }
    out
}

fn spd_scene<R: Real>(name: &str, step: usize, rng: &mut StdRng, c: &mut Covered) {
    let desc = load(name);
    let scene = Scene::<R>::build(&desc).unwrap_or_else(|e| panic!("{name}: {e}"));
    let eye = V3::from_f64(desc.view.from) - V3::from_f64(scene.origin);
    for leaf in leaves(&scene, step) {
        compare_leaf(&format!("{name} ({})", R::NAME), &scene, &leaf, eye, rng, c);
    }
}

#[test]
fn packet_leaves_agree_with_one_ray_at_a_time_on_spd_scenes() {
    let mut rng = StdRng::seed_from_u64(18);
    let mut c = Covered::default();
    for (name, step) in [
        ("teapot-2", 7),
        ("tetra-4", 3),
        ("gears-1", 11),
        ("balls-3", 1),
        ("shells-1", 1),
        ("mount-4", 5),
    ] {
        spd_scene::<f32>(name, step, &mut rng, &mut c);
    }
    for name in ["balls-3", "tetra-4"] {
        spd_scene::<f64>(name, 5, &mut rng, &mut c);
    }
    assert!(
        c.hits > 20_000 && c.misses > 20_000 && c.blocked > 20_000,
        "{c:?}"
    );
    assert!(c.edge_hits > 500 && c.partial_masks > 5_000, "{c:?}");
}

/// Leaves of cones and cylinders (rings' rods, lattice's struts, tree's branches), alone and next to
/// spheres: the packet's rays meet each cone a ray per lane and get the one-ray answers.
#[test]
fn packet_leaves_of_cones_agree_with_one_ray_at_a_time() {
    let mut rng = StdRng::seed_from_u64(18);
    let mut c = Covered::default();
    for (name, step) in [("rings-2", 1), ("lattice-4", 2), ("tree-6", 3)] {
        spd_scene::<f32>(name, step, &mut rng, &mut c);
    }
    spd_scene::<f64>("rings-2", 5, &mut rng, &mut c);
    assert!(
        c.hits > 5_000 && c.misses > 5_000 && c.blocked > 5_000,
        "{c:?}"
    );
}

/// A flat mesh on integer vertices, every triangle twice (once wound the other way, so every
/// hit is a tie the primitive index decides), looked at from above and from the side: rays
/// exactly through edges and vertices, where edge functions are exactly 0 and the kernel
/// decides them again in `f64`.
#[test]
fn packet_leaves_agree_on_exact_edges_vertices_and_ties() {
    let desc = doubled_grid(4);
    let scene = Scene::<f32>::build(&desc).expect("scene");
    let mut rng = StdRng::seed_from_u64(18);
    let mut c = Covered::default();
    for eye in [
        V3::new(2.0, 2.0, 10.0),
        V3::new(0.0, 0.0, 3.0),
        V3::new(1.0, 3.0, 2.0),
        V3::new(-2.0, 0.5, 0.5),
    ] {
        let eye = V3::<f32>::from_f64(eye - scene.origin);
        for leaf in leaves(&scene, 1) {
            compare_leaf("integer mesh", &scene, &leaf, eye, &mut rng, &mut c);
        }
    }
    assert!(c.edge_hits > 1_000 && c.misses > 1_000, "{c:?}");
}
