//! A renderer made for another camera from a built one (`Renderer::with_view`) gives exactly
//! the pixels of a fresh `Renderer::new` of the description seen from that camera: every frame
//! of an orbit, in `f32` and `f64`, at another size too; and it refuses what would need a build
//! of its own (another precision, an eye that moves the frame's origin) or no camera at all.

use parrt_render::render::{RenderError, Renderer};
use parrt_render::sequence::Sequence;
use parrt_render::settings::{Precision, RenderSettings};
use parrt_render::stats::RayStats;
use parrt_render::tile::tiles;
use parrt_render::vec3::Vec3d;

fn image(r: &Renderer) -> (Vec<[f32; 3]>, RayStats) {
    let s = r.settings();
    let (mut all, mut out, mut st) = (Vec::new(), Vec::new(), RayStats::default());
    for t in tiles(s.width, s.height, 16) {
        r.render_tile(&t, &mut out, &mut st);
        all.extend_from_slice(&out);
    }
    (all, st)
}

#[test]
fn every_frame_of_an_orbit_is_the_fresh_build_s_pixels() {
    // mount: spheres (glass, mirrored) and triangles; gears: polygons of many vertices.
    for name in ["mount", "gears"] {
        let desc = parrt_scenes::generate(name, Some(2)).expect("generate");
        for precision in [Precision::F32, Precision::F64] {
            let mut s = RenderSettings::new(48, 40);
            s.precision = precision;
            let seq = Sequence::orbit(desc.clone(), 300.0, 5).expect("orbit");
            let base = Renderer::new(&desc, &s).expect("build");
            for (k, f) in seq.frames().iter().enumerate() {
                let fresh = Renderer::new(&f.description(), &s).expect("fresh");
                let viewed = base.with_view(&f.view, &s).expect("with_view");
                let (a, sa) = image(&fresh);
                let (b, sb) = image(&viewed);
                assert!(
                    a.iter()
                        .zip(&b)
                        .all(|(p, q)| p.map(f32::to_bits) == q.map(f32::to_bits)),
                    "{name} {precision:?} frame {k}: pixels differ"
                );
                assert_eq!(a.len(), b.len());
                assert_eq!(format!("{sa:?}"), format!("{sb:?}"), "{name} frame {k}");
            }
            // Another size of the same frame: only the camera changes.
            let mut big = s.clone();
            big.width = 64;
            big.height = 24;
            let f = &seq.frames()[3];
            let fresh = Renderer::new(&f.description(), &big).expect("fresh");
            let viewed = base.with_view(&f.view, &big).expect("with_view");
            assert_eq!(image(&fresh).0, image(&viewed).0, "{name}: another size");
        }
    }
}

#[test]
fn what_would_need_another_build_or_is_no_camera_is_refused() {
    let desc = parrt_scenes::generate("balls", Some(1)).expect("generate");
    let s = RenderSettings::new(16, 16);
    let base = Renderer::new(&desc, &s).expect("build");
    let mut f64s = s.clone();
    f64s.precision = Precision::F64;
    assert!(matches!(
        base.with_view(&desc.view, &f64s),
        Err(RenderError::OtherBuild(_))
    ));
    let mut auto = s.clone();
    auto.precision = Precision::Auto;
    assert!(matches!(
        base.with_view(&desc.view, &auto),
        Err(RenderError::OtherBuild(_))
    ));
    // A scene far from the world origin is built about its eye: another eye moves the origin.
    let text = "v from 1000000 -10 0 at 1000000 0 0 up 0 0 1 angle 40 hither 0 resolution 8 8\n\
                l 1000000 -10 10\nf 1 0 0 1 0 0 0 0\ns 1000000 0 0 1\n";
    let far = parrt_render::nff::parse(text, "far.nff", &Default::default()).expect("parse");
    let built = Renderer::new(&far, &s).expect("build");
    let mut moved = far.view.clone();
    moved.from = Vec3d::new(1_000_003.0, -10.0, 0.0);
    let e = built.with_view(&moved, &s).err().expect("refused");
    assert!(
        e.to_string()
            .starts_with("the built scene cannot be reused: the eye [1000003.0, -10.0, 0.0] moves"),
        "{e}"
    );
    let mut v = desc.view.clone();
    v.at = v.from;
    assert_eq!(
        base.with_view(&v, &s).err().expect("refused").to_string(),
        "bad view: 'from' and 'at' are the same point, so there is no view direction"
    );
    let mut v = desc.view.clone();
    v.angle = f64::NAN;
    assert_eq!(
        base.with_view(&v, &s).err().expect("refused").to_string(),
        "bad view: the view angle NaN must lie strictly between 0 and 180 degrees"
    );
    let mut v = desc.view.clone();
    v.from.x = f64::INFINITY;
    assert_eq!(
        base.with_view(&v, &s).err().expect("refused").to_string(),
        "bad view: from, at and up must be finite"
    );
}
