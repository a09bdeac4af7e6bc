//! The kernels follow the tier the process chose, not the CPU: the ray-per-lane packet kernels
//! run only on the AVX tiers, and a tier the CPU lacks cannot be forced.

use crate::tiers::on_each_tier;
use parrt_render::geometry::packet_prims::{self, ShearedRays};
use parrt_render::geometry::{PreparedRay, Ray};
use parrt_render::isa::{self, Isa};
use parrt_render::vec3::V3;

#[test]
fn packet_lanes_exist_only_on_the_avx_tiers() {
    let ray = PreparedRay::new(Ray {
        o: V3::new(0.0f32, 0.0, -5.0),
        d: V3::new(0.0, 0.0, 1.0),
        t_min: 0.0,
        t_max: f32::INFINITY,
    });
    for (tier, (available, lanes)) in on_each_tier(|_| {
        (
            packet_prims::available(),
            ShearedRays::new(&[ray; 4]).is_some(),
        )
    }) {
        assert_eq!(available, tier.avx(), "packet_prims::available() on {tier}");
        assert_eq!(lanes, tier.avx(), "ShearedRays::new on {tier}");
    }
}

#[test]
fn a_tier_the_cpu_lacks_is_refused() {
    let _held = crate::tiers::LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let before = isa::current();
    for tier in Isa::ALL {
        match isa::force(tier) {
            Ok(_) => assert!(tier.supported(), "{tier} forced on a CPU without it"),
            Err(e) => {
                assert!(!tier.supported(), "{tier} refused: {e}");
                assert!(e.to_string().contains(tier.needs()), "{e}");
            }
        }
    }
    isa::force(before).expect("the tier chosen at start runs here");
}
