//! Secondary and shadow rays traced as streams (`parrt::stream_trace`, issue 33) give every
//! pixel the bits, and the ray counts, of tracing each eye ray on its own: on SPD scenes whose
//! reflections fan out (rings, balls, lattice) and refract (mount), on tiles that hold several
//! streams and tiles that cut blocks, and on a glass scene whose tree of rays grows past the
//! stream's per-level bound (the levels beyond it traced depth first).

use crate::support::film::assert_same_bits;
use crate::support::scene::{mat, prim, v, view};
use crate::support::spd::load;
use parrt::description::{Light, SceneDescription, Shape};
use parrt::render::Renderer;
use parrt::settings::{Precision, RenderSettings};
use parrt::smp::{render_smp, Executor, SmpOptions, SmpResult};
use parrt::stats::RayStats;

/// The ray and hit counts (the box and primitive tests count work, which packets change).
fn rays(st: &RayStats) -> [u64; 8] {
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
}

fn render(desc: &SceneDescription, s: &RenderSettings, packets: bool, tile: u32) -> SmpResult {
    let mut r = Renderer::new(desc, s).expect("scene builds");
    r.set_packets(packets);
    let opts = SmpOptions {
        threads: 1,
        tile,
        executor: Executor::Queue,
    };
    render_smp(&r, &opts, &|_, _| {})
}

/// Streams (the default path) against one ray at a time: same bits, same counts.
fn streams_match(what: &str, desc: &SceneDescription, s: &RenderSettings) {
    let want = render(desc, s, false, 16);
    assert!(
        want.stats.reflection_rays > 0,
        "{what}: no secondary rays to test"
    );
    // 64: four streams in a tile; 13: tiles that cut the 4×4 blocks.
    for tile in [64, 13] {
        let got = render(desc, s, true, tile);
        let label = format!("{what}, tile {tile}");
        assert_same_bits(&got.film, &want.film, &label);
        assert_eq!(rays(&got.stats), rays(&want.stats), "{label}: ray counts");
    }
}

#[test]
fn streams_give_the_bits_and_counts_of_single_rays_on_spd_scenes() {
    for (name, precision) in [
        ("rings-2", Precision::F32),
        ("balls-3", Precision::F32),
        ("lattice-4", Precision::F32),
        ("mount-4", Precision::F32),
        ("balls-3", Precision::F64),
    ] {
        let mut s = RenderSettings::new(96, 80);
        s.precision = precision;
        streams_match(&format!("{name} {precision:?}"), &load(name), &s);
    }
}

#[test]
fn streams_give_the_same_bits_past_their_level_bound() {
    // The camera inside a glass sphere inside another: every ray splits in two at every
    // surface, so with the cut-off off the sixth level holds 32 rays per eye ray, past the
    // stream's bound of 16.
    let glass = mat([0.9, 0.95, 1.0], 0.1, 0.3, 0.7, 1.5);
    let matte = mat([0.8, 0.3, 0.2], 0.9, 0.0, 0.0, 1.0);
    let sphere = |x, r| Shape::Sphere {
        center: v(x, 0.0, 0.0),
        radius: r,
    };
    let desc = SceneDescription {
        background: v(0.1, 0.2, 0.3),
        view: view(
            v(0.0, 0.0, 0.0),
            v(1.0, 0.1, 0.05),
            v(0.0, 0.0, 1.0),
            60.0,
            24,
        ),
        lights: vec![Light {
            position: v(-0.5, 0.3, 0.4),
            color: None,
        }],
        materials: vec![glass, matte],
        primitives: vec![
            prim(sphere(0.0, 1.0), 0),
            prim(sphere(0.0, 3.0), 0),
            prim(sphere(2.0, 0.5), 1),
        ],
    };
    let mut s = RenderSettings::new(24, 24);
    s.max_depth = 10;
    s.cutoff = 0.0;
    streams_match("nested glass", &desc, &s);
}
