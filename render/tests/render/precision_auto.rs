//! `--precision auto` and the camera-relative frame on whole scenes: mount, gears, teapot and the
//! sliver soup moved by 1e7 (both signs) and scaled by 1e-6 and 1e6 render like the untransformed
//! scene in f64 (within 0.1% of pixels off by more than 1/255), in auto and — wherever auto picks
//! it — in f32 alone; and auto picks f32 on SPD's seven default scenes, whose frame stays the
//! world's (origin 0: their images keep their bits).

use crate::support::render::render_with;
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::render::Renderer;
use parrt_render::settings::{Precision, RenderSettings};
use parrt_render::smp::Executor;
use parrt_render::vec3::V3;

fn render(desc: &SceneDescription, size: u32, precision: Precision) -> Film {
    let mut s = RenderSettings::new(size, size);
    s.precision = precision;
    let r = Renderer::new(desc, &s).expect("scene builds");
    render_with(&r, 2, 16, Executor::Queue).film
}

/// Share of pixels with a channel off by more than 1/255 (clamped linear film).
fn off(a: &Film, b: &Film) -> f64 {
    let n = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| {
            (0..3).any(|c| (p[c].clamp(0.0, 1.0) - q[c].clamp(0.0, 1.0)).abs() > 1.0 / 255.0)
        })
        .count();
    n as f64 / a.pixels.len() as f64
}

fn scenes() -> Vec<(&'static str, SceneDescription)> {
    vec![
        ("mount-6", parrt_scenes::generate("mount", None).unwrap()),
        ("gears-2", parrt_scenes::generate("gears", Some(2)).unwrap()),
        ("teapot-6", parrt_scenes::generate("teapot", None).unwrap()),
        ("soup-2", parrt_scenes::soup::generate(2).unwrap()),
    ]
}

#[test]
fn far_and_scaled_scenes_render_like_the_untransformed_f64() {
    let size = 64;
    let copies = [
        ("moved (1e7, -1e7, 1e7)", 1.0, V3::new(1e7, -1e7, 1e7)),
        ("moved (-1e7, 3e6, -1e7)", 1.0, V3::new(-1e7, 3e6, -1e7)),
        ("scaled 1e-6", 1e-6, V3::zero()),
        ("scaled 1e6", 1e6, V3::zero()),
    ];
    for (name, desc) in scenes() {
        let reference = render(&desc, size, Precision::F64);
        for (how, s, t) in copies {
            let moved = desc.transformed(s, t);
            let auto = parrt_render::precision::resolve(Precision::Auto, &moved);
            let share = off(&reference, &render(&moved, size, Precision::Auto));
            assert!(
                share <= 0.001,
                "{name} {how}, auto ({:?}: {}): {:.3}% of pixels off",
                auto.precision,
                auto.reason,
                share * 100.0
            );
            if auto.precision == Precision::F32 {
                let share = off(&reference, &render(&moved, size, Precision::F32));
                assert!(
                    share <= 0.001,
                    "{name} {how}, f32: {:.3}% of pixels off",
                    share * 100.0
                );
            }
        }
    }
}

#[test]
fn auto_picks_f32_and_the_world_frame_on_the_spd_scenes() {
    for name in [
        "balls", "gears", "mount", "rings", "teapot", "tetra", "tree",
    ] {
        let desc = parrt_scenes::generate(name, None).unwrap();
        let choice = parrt_render::precision::resolve(Precision::Auto, &desc);
        assert_eq!(
            choice.precision,
            Precision::F32,
            "{name}: {}",
            choice.reason
        );
        assert!(choice.reason.starts_with("auto: f32 resolves it"));
        assert_eq!(parrt_render::frame::origin(&desc), V3::zero(), "{name}");
    }
    // SPD's standard teapot size too.
    let teapot = parrt_scenes::generate("teapot", Some(12)).unwrap();
    let choice = parrt_render::precision::resolve(Precision::Auto, &teapot);
    assert_eq!(choice.precision, Precision::F32, "{}", choice.reason);
}

/// A scene auto must not render in f32: a unit sphere seen from 1e7 away through a tiny field
/// of view (the frame cannot help: the eye itself is far from the scene).
#[test]
fn auto_picks_f64_when_the_eye_is_far_from_small_features() {
    let mut desc = parrt_scenes::generate("balls", Some(1)).unwrap();
    desc.view.from = desc.view.at + (desc.view.from - desc.view.at).normalize() * 1e7;
    desc.view.angle = 1e-5;
    let choice = parrt_render::precision::resolve(Precision::Auto, &desc);
    assert_eq!(choice.precision, Precision::F64, "{}", choice.reason);
    assert!(choice.reason.contains("f32 does not resolve it"));
}
