//! Every SPD file (all 27 of `data/spd`) under Haines' procedure at 64 × 64 (65 × 65 corner
//! rays, depth 5, no cut-off): the same image and counts on every tier.

use crate::support::render::render_with;
use crate::tiers::{assert_same_on_every_tier, bytes, on_each_tier};
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::Executor;

const SIZE: u32 = 64;

#[test]
fn every_spd_file_renders_the_same_bits_on_every_tier() {
    for (name, desc) in crate::support::spd_scenes() {
        let mut s = RenderSettings::new(SIZE, SIZE);
        s.spd_standard = true;
        // SPD asks for the teapot two-sided: its lid leaves a gap.
        s.two_sided = name.starts_with("teapot");
        let r = Renderer::new(&desc, &s).unwrap_or_else(|e| panic!("{name}: {e}"));
        let runs = on_each_tier(|_| {
            let res = render_with(&r, 2, 16, Executor::Rayon);
            let b = bytes(&res.film);
            (res.film, res.stats, b)
        });
        assert!(runs[0].1 .1.eye_hits > 0, "{name}: no eye ray hit");
        assert_same_on_every_tier(&name, &runs);
    }
}
