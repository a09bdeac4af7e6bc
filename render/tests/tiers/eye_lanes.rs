//! The full render's eye packets: in `f32` on the `avx512` tier a 4 × 4 block's eye
//! rays, their hits and their shadow rays live in lanes (`Integrator::trace_eye_block`), on
//! the other tiers they are prepared rays. Every SPD file, pixel centres (packets on), at a
//! size whose tiles end in partial blocks: the same image bits, bytes and ray statistics on
//! every tier, and the same image and ray counts as tracing each pixel on its own.

use crate::tiers::{assert_same_on_every_tier, bytes, on_each_tier};
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_render::stats::RayStats;

/// 2 × 16 + 6: the last tiles' blocks are 4 × 2, 2 × 4 and 2 × 2.
const SIZE: u32 = 38;

#[test]
fn eye_packets_render_the_same_bits_on_every_tier_and_as_one_by_one() {
    let opts = SmpOptions {
        threads: 2,
        tile: 16,
        executor: Executor::Rayon,
    };
    for (name, desc) in crate::support::spd_scenes() {
        let s = RenderSettings::new(SIZE, SIZE);
        let mut r = Renderer::new(&desc, &s).unwrap_or_else(|e| panic!("{name}: {e}"));
        r.set_packets(true);
        let runs = on_each_tier(|_| {
            let res = render_smp(&r, &opts, &|_, _| {});
            let b = bytes(&res.film);
            (res.film, res.stats, b)
        });
        let (_, (film, stats, _)) = &runs[0];
        assert!(stats.eye_hits > 0, "{name}: no eye ray hit");
        assert!(stats.shadow_rays > 0, "{name}: no shadow ray");
        assert_same_on_every_tier(&name, &runs);
        r.set_packets(false);
        let alone = render_smp(&r, &opts, &|_, _| {});
        crate::support::film::assert_same_bits(film, &alone.film, &format!("{name} one by one"));
        let rays = |s: &RayStats| {
            let mut a = s.to_array();
            // Box, primitive and cell counts differ between packets and single rays.
            a[8..].fill(0);
            a
        };
        assert_eq!(rays(stats), rays(&alone.stats), "{name}: rays one by one");
    }
}
