//! The slab kernels of every tier against the scalar test, lane by lane: mask bit and entry
//! distance, axis-parallel rays and rays in a box face included.

use super::*;
use crate::geometry::test_coords::point;
use crate::geometry::Ray;
use crate::vec3::V3;
use proptest::prelude::*;

fn slab_ray<R: Real>(pr: &PreparedRay<R>) -> NodeRay<R> {
    NodeRay {
        o: [pr.ray.o.x, pr.ray.o.y, pr.ray.o.z],
        inv: [pr.inv_d.x, pr.inv_d.y, pr.inv_d.z],
        neg: pr.neg,
        t_min: pr.ray.t_min,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    /// Every tier's node kernel and the scalar slab test agree on every lane — mask bit and
    /// entry distance — axis-parallel rays and rays in a box face included.
    #[test]
    fn every_node_kernel_agrees_with_the_scalar_test(
        o in point(),
        d in point(),
        corners in proptest::collection::vec(
            (point(), proptest::array::uniform3(0.0f32..5.0)),
            0..=WIDTH),
        t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..30.0],
    ) {
        prop_assume!(d.iter().any(|&c| c != 0.0));
        let pr = PreparedRay::new(Ray {
            o: V3::from_array(o),
            d: V3::from_array(d),
            t_min: 0.0,
            t_max,
        });
        let mut b = Box8::EMPTY;
        let mut boxes = Vec::new();
        for (i, (lo, ext)) in corners.iter().enumerate() {
            let hi = [lo[0] + ext[0], lo[1] + ext[1], lo[2] + ext[2]];
            b.set(i, *lo, hi);
            boxes.push((*lo, hi));
        }
        let sr = slab_ray(&pr);
        for tier in Isa::supported_tiers() {
            let (mask, t) = slab8_tier(tier, &b, &sr, t_max).unwrap();
            prop_assert_eq!((mask, t), slab8_on(tier, &b, &sr, t_max), "{}", tier);
            for (i, t_i) in t.iter().enumerate() {
                let scalar = boxes.get(i).and_then(|(lo, hi)| slab(lo, hi, &pr, t_max));
                prop_assert_eq!(mask & (1 << i) != 0, scalar.is_some(), "{} lane {}", tier, i);
                if let Some(t_s) = scalar {
                    prop_assert_eq!(t_i.to_bits(), t_s.to_bits(), "{} lane {}", tier, i);
                }
            }
        }
    }

    /// Every tier's packet kernel and the scalar slab test agree for every ray of a packet,
    /// rays in a box face and axis-parallel rays included.
    #[test]
    fn every_packet_kernel_agrees_with_the_scalar_test(
        rays in proptest::collection::vec(
            (point(), point(),
             prop_oneof![Just(f32::INFINITY), 0.0f32..30.0]),
            1..=LANES),
        dir_signs in proptest::array::uniform3(any::<bool>()),
        lo in point(),
        ext in proptest::array::uniform3(0.0f32..5.0),
    ) {
        // One set of direction signs for the packet: flip components to match.
        let prs: Vec<_> = rays
            .iter()
            .map(|(o, d, t_max)| {
                let d = [0, 1, 2].map(|a| {
                    let c = d[a].abs();
                    if dir_signs[a] { -c } else { c }
                });
                PreparedRay::new(Ray { o: V3::from_array(*o), d: V3::from_array(d), t_min: 0.0, t_max: *t_max })
            })
            .collect();
        // A +0 component with a negative sign wanted stays +0 (1/+0 = +∞): skip those.
        let neg = prs[0].neg;
        prop_assume!(prs.iter().all(|p| p.neg == neg));
        let hi = [lo[0] + ext[0], lo[1] + ext[1], lo[2] + ext[2]];
        let lanes = LeafRays::new(&prs, neg);
        let mut reach = [0.0f32; LANES];
        for (i, r) in reach.iter_mut().enumerate() {
            *r = prs.get(i).unwrap_or(&prs[0]).ray.t_max;
        }
        let mut want = 0u32;
        for i in 0..LANES {
            let pr = prs.get(i).unwrap_or(&prs[0]);
            want |= u32::from(slab(&lo, &hi, pr, pr.ray.t_max).is_some()) << i;
        }
        prop_assert_eq!(enter16(&lanes, &lo, &hi, &reach), want);
        for tier in Isa::supported_tiers() {
            prop_assert_eq!(enter16_tier(tier, &lanes, &lo, &hi, &reach), Some(want), "{}", tier);
        }
    }
}

/// The `f64` kernels (one lane at a time on every tier) take the same boxes as the scalar test
/// in `f64`, in the node and the packet form.
#[test]
fn the_f64_kernels_agree_with_the_scalar_test() {
    let mut b = Box8::EMPTY;
    b.set(0, [-1.0; 3], [1.0; 3]);
    b.set(3, [2.0, -1.0, -1.0], [3.0, 1.0, 1.0]);
    b.set(7, [2.0, 5.0, -1.0], [3.0, 6.0, 1.0]);
    let pr = PreparedRay::<f64>::new(Ray {
        o: V3::new(-5.0, 0.25, 0.5),
        d: V3::new(1.0, 0.0, 0.0),
        t_min: 0.0,
        t_max: 100.0,
    });
    let sr = slab_ray(&pr);
    for tier in Isa::supported_tiers() {
        let (mask, t) = slab8_tier(tier, &b, &sr, 100.0).unwrap();
        assert_eq!(mask, 0b1001, "{tier}");
        assert_eq!(Some(t[0]), slab(&[-1.0; 3], &[1.0; 3], &pr, 100.0));
        assert_eq!(t[3], 7.0);
    }
    assert_eq!(slab8(&b, &sr, 100.0).0, 0b1001);
    let lanes = LeafRays::new(&[pr], pr.neg);
    let reach = [100.0f64; LANES];
    assert_eq!(
        enter16(&lanes, &[2.0, -1.0, -1.0], &[3.0, 1.0, 1.0], &reach),
        0xffff
    );
    assert_eq!(
        enter16(&lanes, &[2.0, 5.0, -1.0], &[3.0, 6.0, 1.0], &reach),
        0
    );
}

/// An axis-parallel ray (reciprocal ∞ on two axes) on every tier: boxes 0, 2 and 6 are on its
/// line, box 7 beside it.
#[test]
fn every_tier_takes_the_boxes_on_an_axis_parallel_ray() {
    let mut b = Box8::EMPTY;
    b.set(0, [-1.0; 3], [1.0; 3]);
    b.set(2, [2.0, -1.0, -1.0], [3.0, 1.0, 1.0]);
    b.set(6, [4.0, -1.0, -1.0], [5.0, 1.0, 1.0]);
    b.set(7, [4.0, 2.0, -1.0], [5.0, 3.0, 1.0]);
    let r32 = NodeRay::<f32> {
        o: [-5.0, 0.25, 0.5],
        inv: [1.0, f32::INFINITY, f32::INFINITY],
        neg: [false; 3],
        t_min: 0.0,
    };
    let want = slab8_tier(Isa::Scalar, &b, &r32, 100.0).unwrap();
    assert_eq!(want.0, 0b0100_0101);
    assert_eq!(want.1[2], 7.0);
    for tier in Isa::supported_tiers() {
        assert_eq!(slab8_on(tier, &b, &r32, 100.0), want, "{tier}");
    }
}
