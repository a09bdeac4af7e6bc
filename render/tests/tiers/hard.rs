//! The hard placements on every tier: mount-4 (triangles and spheres) and rings-2 (cylinders and
//! spheres) as written, moved by 1e7, scaled by 1e-6 and by 1e6, in f32 (where auto keeps it),
//! f64 and auto.

use crate::support::render::render_with;
use crate::support::scene::v;
use crate::tiers::{assert_same_on_every_tier, bytes, on_each_tier};
use parrt_render::render::Renderer;
use parrt_render::settings::{Precision, RenderSettings};
use parrt_render::smp::Executor;

const SIZE: u32 = 40;

#[test]
fn hard_placements_and_precisions_render_the_same_bits_on_every_tier() {
    let placements = [
        ("as written", 1.0, v(0.0, 0.0, 0.0)),
        ("moved 1e7", 1.0, v(1e7, -1e7, 3e6)),
        ("scaled 1e-6", 1e-6, v(0.0, 0.0, 0.0)),
        ("scaled 1e6", 1e6, v(0.0, 0.0, 0.0)),
    ];
    for scene in ["mount-4", "rings-2"] {
        let path = crate::support::spd_dir().join(format!("{scene}.nff"));
        let base = parrt_render::nff::parse_file(&path, &Default::default())
            .unwrap_or_else(|e| panic!("{scene}: {e}"));
        for (place, scale, shift) in placements {
            let desc = base.transformed(scale, shift);
            let auto = parrt_render::precision::resolve(Precision::Auto, &desc).precision;
            for precision in [Precision::F32, Precision::F64, Precision::Auto] {
                if precision == Precision::F32 && auto != Precision::F32 {
                    continue; // outside what f32 resolves: auto's f64 is the answer
                }
                let what = format!("{scene} {place} {precision:?}");
                let mut s = RenderSettings::new(SIZE, SIZE);
                s.precision = precision;
                let r = Renderer::new(&desc, &s).unwrap_or_else(|e| panic!("{what}: {e}"));
                let runs = on_each_tier(|_| {
                    let res = render_with(&r, 2, 8, Executor::Queue);
                    let b = bytes(&res.film);
                    (res.film, res.stats, b)
                });
                assert_same_on_every_tier(&what, &runs);
            }
        }
    }
}
