//! An 8-bit output's film kept in 8 bits as tiles land ([`Film::for_output`]) writes the same
//! PNG and PPM bytes as the linear film converted at the end, at image sizes whose tiles do not
//! divide them, with several threads; an EXR output keeps its floats.

use parrt_render::film::{Film, ImageFormat};
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, render_smp_into, Executor, SmpOptions};

#[test]
fn the_8_bit_film_writes_the_linear_films_bytes() {
    let desc = parrt_scenes::generate("balls", Some(2)).expect("balls generates");
    let dir = tempfile::tempdir().unwrap();
    for (w, h, tile, threads) in [
        (37, 23, 5, 2),
        (64, 48, 13, 3),
        (101, 7, 32, 2),
        (9, 41, 8, 1),
    ] {
        let settings = RenderSettings::new(w, h);
        let r = Renderer::new(&desc, &settings).expect("scene builds");
        let opts = SmpOptions {
            threads,
            tile,
            executor: Executor::Morton,
        };
        let linear = render_smp(&r, &opts, &|_, _| {}).film;
        let film = Film::for_output(w, h, ImageFormat::Png);
        let eight = render_smp_into(&r, &opts, film, &|_| {}).film;
        assert!(eight.is_rgb8(), "a PNG's film keeps 8 bits");
        assert!(eight.pixels.is_empty(), "and no floats");
        assert!(
            linear.to_rgb8().iter().any(|&b| b != 0),
            "{w}x{h}: all black"
        );
        for ext in ["png", "ppm"] {
            let (a, b) = (
                dir.path().join(format!("linear.{ext}")),
                dir.path().join(format!("eight.{ext}")),
            );
            linear.save(&a).unwrap();
            eight.save(&b).unwrap();
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{w}x{h}, tile {tile}, {threads} threads: the {ext} differs"
            );
        }
    }
    // An EXR keeps what the render made.
    assert!(!Film::for_output(4, 3, ImageFormat::Exr).is_rgb8());
    assert!(Film::for_output(4, 3, ImageFormat::Ppm).is_rgb8());
}
