//! The master rejects tile results whose ray statistics no render could have
//! produced. This checks the other side of that rule: every tile of real renders — SPD scenes,
//! the SPD procedure, several samples, both precisions, packets on and off, the grid — passes
//! the check, so an honest worker is never turned away.

use crate::support::spd;
use parrt_render::render::Renderer;
use parrt_render::settings::{AccelKind, Precision, RenderSettings};
use parrt_render::stats::RayStats;
use parrt_render::tile::tiles;

fn check_every_tile(name: &str, settings: &RenderSettings, packets: bool, tile: u32) {
    let desc = spd::load(name);
    let lights = desc.lights.len();
    let mut r = Renderer::new(&desc, settings).unwrap();
    r.set_packets(packets);
    let mut out = Vec::new();
    for t in tiles(settings.width, settings.height, tile) {
        let mut st = RayStats::default();
        r.render_tile(&t, &mut out, &mut st);
        if let Err(e) = st.check_tile(&t, settings, lights) {
            panic!("{name} tile {t:?} ({settings:?}, packets {packets}): {e}; {st:?}");
        }
    }
}

#[test]
fn real_tiles_are_plausible() {
    for name in [
        "balls-3", "gears-1", "rings-2", "teapot-2", "tetra-4", "mount-4",
    ] {
        let mut s = RenderSettings::new(40, 30);
        check_every_tile(name, &s, true, 8);
        check_every_tile(name, &s, false, 7);
        s.spd_standard = true;
        s.cutoff = 0.0;
        check_every_tile(name, &s, false, 16);
        let mut s = RenderSettings::new(24, 24);
        s.spp = 4;
        s.precision = Precision::F64;
        s.accel = AccelKind::Grid;
        s.max_depth = 8;
        check_every_tile(name, &s, true, 12);
    }
}

#[test]
fn wrapped_or_inflated_counts_are_rejected() {
    let s = RenderSettings::new(16, 16);
    let t = tiles(16, 16, 8)[0];
    let good = RayStats {
        eye_rays: 64,
        eye_hits: 60,
        shadow_rays: 100,
        shadow_hits: 10,
        reflection_rays: 20,
        reflection_hits: 20,
        ..RayStats::default()
    };
    assert!(good.check_tile(&t, &s, 2).is_ok());
    for bad in [
        RayStats {
            eye_rays: u64::MAX,
            ..good
        },
        RayStats {
            eye_rays: 65,
            ..good
        },
        RayStats {
            eye_hits: 65,
            ..good
        },
        RayStats {
            shadow_hits: 101,
            ..good
        },
        RayStats {
            shadow_rays: u64::MAX,
            shadow_hits: 0,
            ..good
        },
        RayStats {
            reflection_rays: 81,
            reflection_hits: 0,
            ..good
        },
        RayStats {
            refraction_rays: 81,
            ..good
        },
    ] {
        let e = bad.check_tile(&t, &s, 2).unwrap_err();
        assert!(
            e.to_string().starts_with("implausible ray statistics"),
            "{e}"
        );
    }
    // Sums saturate instead of wrapping: u64::MAX + 32 736 used to read as 32 735.
    let mut sum = RayStats {
        eye_rays: u64::MAX,
        ..RayStats::default()
    };
    sum += RayStats {
        eye_rays: 32_736,
        ..RayStats::default()
    };
    assert_eq!(sum.eye_rays, u64::MAX);
    assert_eq!(sum.total_rays(), u64::MAX);
}
