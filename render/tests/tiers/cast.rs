//! `parrt bench cast`'s rays (eye rays through pixel centres, one shadow ray per light per hit)
//! on every SPD file at 48 × 48: in `f32` the packets live in lanes from the camera on
//! ([`parrt_render::geometry::ray_packet`]) on the `avx2` and `avx512` tiers and are prepared
//! rays on the others; every tier counts the same rays, hits, blockers and box and primitive tests, and the packets
//! find the hits and blockers the rays find one by one.

use crate::tiers::on_each_tier;
use parrt_render::render::Renderer;
use parrt_render::settings::{Precision, RenderSettings};
use parrt_render::stats::RayStats;

const SIZE: u32 = 48;

/// The statistics of casting every tile of `r`, with packets or one by one, culled or not.
fn cast(r: &mut Renderer, packets: bool, cull: bool) -> RayStats {
    r.set_packets(packets);
    let mut st = RayStats::default();
    for t in parrt_render::tile::tiles(SIZE, SIZE, 16) {
        r.cast_tile(&t, cull, &mut st);
    }
    st
}

#[test]
fn casting_counts_the_same_on_every_tier_and_as_one_by_one() {
    for (name, desc) in crate::support::spd_scenes() {
        for precision in [Precision::F32, Precision::F64] {
            let mut s = RenderSettings::new(SIZE, SIZE);
            s.precision = precision;
            let mut r = Renderer::new(&desc, &s).unwrap_or_else(|e| panic!("{name}: {e}"));
            for cull in [false, true] {
                let what = format!("{name} {precision:?} cull {cull}");
                let runs = on_each_tier(|_| (cast(&mut r, true, cull), cast(&mut r, false, cull)));
                let (_, (want, alone)) = &runs[0];
                assert!(want.eye_hits > 0, "{what}: no eye ray hit");
                for (tier, (packets, one_by_one)) in &runs {
                    assert_eq!(packets, want, "{what}: packets on {tier}");
                    assert_eq!(one_by_one, alone, "{what}: one by one on {tier}");
                    let rays =
                        |s: &RayStats| (s.eye_rays, s.eye_hits, s.shadow_rays, s.shadow_hits);
                    assert_eq!(
                        rays(packets),
                        rays(alone),
                        "{what}: packets against one by one"
                    );
                }
            }
        }
    }
}
