//! An 8-bit output's film kept in 8 bits as tiles land ([`Film::for_output`]) writes the same
//! PNG and PPM bytes as the linear film converted at the end, at image sizes whose tiles do not
//! divide them, with several threads; an EXR output keeps its floats. Tiles written to an 8-bit
//! film as bytes or as linear values give the same film.

use parrt_render::film::{to_u8, unit, Film, ImageFormat, Rgb};
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, render_smp_into, Executor, SmpOptions};
use parrt_render::tile::Tile;

#[test]
fn the_8_bit_film_writes_the_linear_films_bytes() {
    let desc = parrt_scenes::generate("balls", Some(2)).expect("balls generates");
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
        let what = format!("{w}x{h}, tile {tile}, {threads} threads");
        assert_same_files(&linear, &eight, &what);
    }
    // An EXR keeps what the render made.
    assert!(!Film::for_output(4, 3, ImageFormat::Exr).is_rgb8());
    assert!(Film::for_output(4, 3, ImageFormat::Ppm).is_rgb8());
}

/// An 8-bit film holds what a linear film's PNG holds: tiles written as bytes or as linear
/// values give the same pixels, the same `get`, and byte-identical PNG and PPM files.
#[test]
fn an_8_bit_film_writes_the_linear_films_png() {
    let (w, h) = (5u32, 4u32);
    let tiles = [tile(0, 0, 0, 3, 4), tile(1, 3, 0, 2, 4)];
    let value = |x: u32, y: u32| [x as f32 / 4.0, y as f32 / 3.0 - 0.1, 1.5 - x as f32];
    let mut linear = Film::new(w, h);
    let mut from_bytes = Film::new_rgb8(w, h);
    let mut from_values = Film::new_rgb8(w, h);
    for t in &tiles {
        let px: Vec<Rgb> = (t.y..t.y + t.h)
            .flat_map(|y| (t.x..t.x + t.w).map(move |x| value(x, y)))
            .collect();
        let bytes: Vec<u8> = px.iter().flatten().map(|&v| to_u8(v)).collect();
        linear.write_tile(t, &px).unwrap();
        from_bytes.write_tile_rgb8(t, &bytes).unwrap();
        from_values.write_tile(t, &px).unwrap();
    }
    assert!(from_bytes.is_rgb8() && !linear.is_rgb8());
    assert!(
        from_bytes.pixels.is_empty(),
        "an 8-bit film keeps no floats"
    );
    assert_eq!(from_bytes, from_values);
    assert_eq!(from_bytes.to_rgb8(), linear.to_rgb8());
    let (x, y) = (4, 2);
    assert_eq!(from_bytes.get(x, y), value(x, y).map(|v| unit(to_u8(v))));
    // Bytes into a linear film become b / 255.
    let mut back = Film::new(w, h);
    back.write_tile_rgb8(&tiles[1], &from_bytes.to_rgb8()[..0])
        .unwrap_err();
    let all = tile(0, 0, 0, w, h);
    back.write_tile_rgb8(&all, &from_bytes.to_rgb8()).unwrap();
    assert_eq!(back.get(x, y), from_bytes.get(x, y));
    assert_same_files(&linear, &from_bytes, "a hand-made 5x4 film");
    // A misfit is refused as it is for floats.
    let t = tile(2, 4, 0, 2, 1);
    assert!(from_bytes.write_tile_rgb8(&t, &[0; 6]).is_err());
    assert!(from_bytes.write_tile_rgb8(&tiles[1], &[0; 7]).is_err());
}

/// Asserts that `a` and `b` saved as PNG and as PPM give the same bytes.
fn assert_same_files(a: &Film, b: &Film, what: &str) {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["png", "ppm"] {
        let (pa, pb) = (
            dir.path().join(format!("a.{ext}")),
            dir.path().join(format!("b.{ext}")),
        );
        a.save(&pa).unwrap();
        b.save(&pb).unwrap();
        assert!(
            std::fs::read(&pa).unwrap() == std::fs::read(&pb).unwrap(),
            "{what}: the {ext} differs"
        );
    }
}

/// Tile `id`: `w`×`h` pixels from column `x`, row `y`.
fn tile(id: u32, x: u32, y: u32, w: u32, h: u32) -> Tile {
    Tile { id, x, y, w, h }
}
