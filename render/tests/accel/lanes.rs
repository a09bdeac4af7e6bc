//! Packets in lanes: a [`RayPacket`] packet — eye rays made straight into lanes,
//! shadow rays written into lanes — gets from [`Bvh::intersect_lanes`] and
//! [`Bvh::occluded_lanes`] exactly what its rays get alone as [`PreparedRay`]s (the same hit
//! bit for bit, the same occlusion), and the same box and primitive test counts as
//! [`Bvh::intersect_packet`] and [`Bvh::occluded_packet`] on the prepared rays.

use crate::support::scene::{scene_of, tri, v, view};
use crate::support::spd::{key, load, Trio, SMALL_SCENES};
use parrt_render::accel::bvh::packet::PACKET;
use parrt_render::accel::{Accel, Bvh};
use parrt_render::camera::Camera;
use parrt_render::description::Shape;
use parrt_render::geometry::ray_packet::RayPacket;
use parrt_render::geometry::{offset_ray_origin, PreparedRay, Ray};
use parrt_render::packet::leaf::{LanesLeaf, PacketLeaf};
use parrt_render::scene::Scene;
use parrt_render::stats::RayStats;
use parrt_render::vec3::V3;
use proptest::prelude::*;

/// What a comparison covered.
#[derive(Default, Debug)]
struct Covered {
    rays: usize,
    hits: usize,
    blocked: usize,
}

/// Checks packet `l` against its rays prepared one by one (alone and as a slice packet):
/// closest hits, then occlusion. Returns the hits.
fn check(
    scene: &Scene<f32>,
    bvh: &Bvh,
    l: &RayPacket,
    cov: &mut Covered,
    what: &str,
) -> Vec<Option<parrt_render::geometry::PrimHit<f32>>> {
    let n = l.len();
    let prs: Vec<PreparedRay<f32>> = (0..n).map(|i| PreparedRay::new(l.ray(i))).collect();
    let mut buffer = [prs[0]; PACKET];
    let (mut lanes_st, mut slice_st) = (RayStats::default(), RayStats::default());
    let mut got = [None; PACKET];
    let mut want = [None; PACKET];
    bvh.intersect_lanes(
        l,
        &mut got[..n],
        &mut lanes_st,
        LanesLeaf::new(scene, &mut buffer),
    );
    let mut slot = None;
    let test = PacketLeaf::new(scene, &mut slot);
    bvh.intersect_packet(&prs, &mut want[..n], &mut slice_st, test);
    let (mut occ, mut occ_want) = ([false; PACKET], [false; PACKET]);
    bvh.occluded_lanes(
        l,
        &mut occ[..n],
        &mut lanes_st,
        LanesLeaf::new(scene, &mut buffer),
    );
    bvh.occluded_packet(
        &prs,
        &mut occ_want[..n],
        &mut slice_st,
        PacketLeaf::new(scene, &mut slot),
    );
    assert_eq!(
        (lanes_st.box_tests, lanes_st.primitive_tests),
        (slice_st.box_tests, slice_st.primitive_tests),
        "{what}: test counts"
    );
    for (i, pr) in prs.iter().enumerate() {
        let mut st = RayStats::default();
        let single = |p: u32, t: f32| scene.intersect_prim(p, pr, t);
        let alone = bvh.intersect(pr, &mut st, single);
        let occ_alone = bvh.occluded(pr, &mut st, single);
        assert_eq!(
            key(&got[i]),
            key(&alone),
            "{what}: ray {i} of {n}: {:?}",
            pr.ray
        );
        assert_eq!(key(&want[i]), key(&alone), "{what}: slice packet, ray {i}");
        assert_eq!(
            occ[i], occ_alone,
            "{what}: ray {i} of {n} occluded: {:?}",
            pr.ray
        );
        assert_eq!(
            occ_want[i], occ_alone,
            "{what}: slice packet occluded, ray {i}"
        );
        cov.rays += 1;
        cov.hits += alone.is_some() as usize;
        cov.blocked += occ_alone as usize;
    }
    got[..n].to_vec()
}

/// The eye rays of every 4 × 4 block of an `n × n` image, and the shadow packet of each
/// block's hits to each light, written into lanes as `parrt bench cast` writes them.
fn eye_and_shadow(trio: &Trio<f32>, camera: &Camera<f32>, cov: &mut Covered, name: &str) {
    let Accel::Bvh(bvh) = &trio.bvh else {
        panic!("Trio's bvh is a BVH")
    };
    let scene = &trio.scene;
    let n = camera.width;
    let mut eye = RayPacket::new();
    let mut shadow = RayPacket::new();
    for by in (0..n).step_by(4) {
        for bx in (0..n).step_by(4) {
            let (bw, bh) = (4.min(n - bx), 4.min(n - by));
            eye.eye(camera, bx, by, bw, bh);
            for i in 0..eye.len() {
                let (x, y) = (bx + i as u32 % bw, by + i as u32 / bw);
                let want = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                assert_eq!(format!("{:?}", eye.ray(i)), format!("{want:?}"));
            }
            let hits = check(scene, bvh, &eye, cov, &format!("{name} eye ({bx}, {by})"));
            for light in &scene.lights {
                shadow.clear();
                for (i, h) in hits.iter().enumerate() {
                    let Some(h) = h else { continue };
                    let s = scene.surface(&eye.ray(i), h);
                    let to = light.position - s.p;
                    let dist = to.length();
                    let o = offset_ray_origin(s.p, s.p_err, s.ng, to / dist);
                    let d = light.position - o;
                    let len = d.length();
                    shadow.push(&Ray {
                        o,
                        d: d / len,
                        t_min: 0.0,
                        t_max: len,
                    });
                }
                if !shadow.is_empty() {
                    shadow.prepare();
                    check(
                        scene,
                        bvh,
                        &shadow,
                        cov,
                        &format!("{name} shadow ({bx}, {by})"),
                    );
                }
            }
        }
    }
}

#[test]
fn lanes_packets_agree_with_prepared_rays_on_spd_scenes() {
    let mut cov = Covered::default();
    for name in SMALL_SCENES {
        let desc = load(name);
        let trio = Trio::<f32>::new(&desc, 4.0);
        // 22 × 22: blocks of 4 × 4, 4 × 2, 2 × 4 and 2 × 2.
        let camera = Camera::<f32>::new(&desc.view, 22, 22);
        eye_and_shadow(&trio, &camera, &mut cov, name);
    }
    assert!(
        cov.rays > 20_000 && cov.hits > 5_000 && cov.blocked > 1_000,
        "{cov:?}"
    );
}

/// A random scene of triangles and spheres around the origin, or `None` when the scene builder
/// refuses it (degenerate triangles).
fn random_scene(tris: &[[[f32; 3]; 3]], spheres: &[([f32; 3], f32)]) -> Option<Scene<f32>> {
    let mut shapes: Vec<Shape> = tris
        .iter()
        .map(|t| {
            let p = t.map(|c| v(c[0] as f64, c[1] as f64, c[2] as f64));
            tri(p[0], p[1], p[2])
        })
        .collect();
    for &(c, r) in spheres {
        shapes.push(Shape::Sphere {
            center: v(c[0] as f64, c[1] as f64, c[2] as f64),
            radius: r as f64,
        });
    }
    let desc = scene_of(
        shapes,
        view(
            v(0.0, -10.0, 0.0),
            v(0.0, 0.0, 0.0),
            v(0.0, 0.0, 1.0),
            45.0,
            8,
        ),
    );
    Scene::build(&desc).ok()
}

fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![4 => -3.0f32..3.0, 1 => Just(0.0f32), 1 => Just(1.0f32)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Packets of rays from a patch of origins (or from anywhere: those go one by one) towards
    /// a random scene, some aimed at vertices, some axis-parallel, with finite and infinite
    /// ends: the lanes packet gives each ray its hit alone, bit for bit.
    #[test]
    fn lanes_packets_give_each_ray_its_hit_alone(
        tris in proptest::collection::vec(proptest::array::uniform3(proptest::array::uniform3(coord())), 1..40),
        spheres in proptest::collection::vec((proptest::array::uniform3(coord()), 0.05f32..1.5), 0..6),
        origin in proptest::array::uniform3(6.0f32..12.0),
        side in proptest::array::uniform3(any::<bool>()),
        spread in prop_oneof![2 => Just(0.0f32), 2 => 0.0f32..0.1, 1 => 0.0f32..5.0],
        rays in proptest::collection::vec(
            (proptest::array::uniform3(0.0f32..1.0), proptest::array::uniform3(coord()),
             0usize..12, prop_oneof![Just(f32::INFINITY), 5.0f32..40.0]),
            1..=PACKET),
    ) {
        let scene = random_scene(&tris, &spheres);
        prop_assume!(scene.is_some());
        let scene = scene.expect("assumed");
        let bounds = scene.all_bounds();
        let accel = Accel::build(parrt_render::settings::AccelKind::Bvh, &bounds, 4.0);
        let Accel::Bvh(bvh) = &accel else { panic!("a BVH") };
        let mut l = RayPacket::new();
        for &(jitter, target, aim, t_max) in &rays {
            // The patch of origins on one side of the scene on each axis: the packet's rays
            // share their direction signs unless aimed elsewhere.
            let o = V3::from_array([0, 1, 2].map(|a| {
                let c = origin[a] + jitter[a] * spread;
                if side[a] { -c } else { c }
            }));
            let to = match aim {
                0..=2 => V3::from_array(tris[0][aim]),
                3 => V3::new(o.x, o.y, o.z) + V3::new(1.0, 0.0, 0.0),
                _ => V3::from_array(target),
            };
            let d = to - o;
            prop_assume!(d.length() > 0.0);
            l.push(&Ray { o, d: d.normalize(), t_min: 0.0, t_max });
        }
        l.prepare();
        let mut cov = Covered::default();
        check(&scene, bvh, &l, &mut cov, "random");
    }
}
