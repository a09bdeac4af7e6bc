//! The image does not depend on thread count, tile size or executor: every combination gives the
//! same bits as one thread with one big tile (docs/design.md, *Determinism*).

use crate::support::render::render_with;
use parrt_render::description::SceneDescription;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::Executor;
use std::path::PathBuf;

fn spd(name: &str) -> SceneDescription {
    let dir = crate::support::spd_dir();
    let path: PathBuf = dir.join(name);
    parrt_render::nff::parse_file(&path, &parrt_render::nff::Limits::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn bits(r: &Renderer, threads: usize, tile: u32, executor: Executor) -> Vec<u32> {
    let res = render_with(r, threads, tile, executor);
    res.film
        .pixels
        .iter()
        .flatten()
        .map(|v| v.to_bits())
        .collect()
}

fn check_all_combinations(name: &str, settings: RenderSettings) {
    let desc = spd(name);
    let r = Renderer::new(&desc, &settings).expect("scene builds");
    let reference = bits(&r, 1, 1 << 16, Executor::Queue);
    assert!(
        reference.iter().any(|&b| b != 0),
        "{name}: image is all black"
    );
    for executor in Executor::ALL {
        for threads in [1, 2, 4] {
            for tile in [8, 13, 16, 32, 64] {
                assert!(
                    bits(&r, threads, tile, executor) == reference,
                    "{name}: {threads} threads, tile {tile}, {executor:?} differs"
                );
            }
        }
    }
}

#[test]
fn identical_bits_for_every_thread_count_tile_size_and_executor() {
    // Refraction (mount's glass), mirrors (balls), transmitting polygons (gears), cones (tree),
    // patches (teapot); a non-square size so edge tiles are ragged.
    for name in [
        "mount-4.nff",
        "balls-3.nff",
        "gears-1.nff",
        "tree-6.nff",
        "teapot-2.nff",
    ] {
        check_all_combinations(name, RenderSettings::new(96, 72));
    }
}

#[test]
fn identical_bits_with_several_samples_and_in_spd_mode() {
    let mut s = RenderSettings::new(40, 40);
    s.spp = 4;
    check_all_combinations("mount-4.nff", s);
    let mut s = RenderSettings::new(40, 40);
    s.spd_standard = true;
    check_all_combinations("balls-3.nff", s);
}

#[test]
fn spd_mode_counts_each_corner_ray_once_whatever_the_tiling() {
    let desc = spd("mount-4.nff");
    let mut s = RenderSettings::new(50, 30);
    s.spd_standard = true;
    let r = Renderer::new(&desc, &s).expect("scene builds");
    let mut seen = None;
    for tile in [7, 13, 64] {
        for threads in [1, 2] {
            let res = render_with(&r, threads, tile, Executor::Queue);
            assert_eq!(res.stats.eye_rays, 51 * 31, "tile {tile}");
            match &seen {
                None => seen = Some(res.stats),
                Some(st) => assert_eq!(*st, res.stats, "tile {tile}, {threads} threads"),
            }
        }
    }
}
