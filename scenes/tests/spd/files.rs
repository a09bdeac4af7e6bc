//! Compares each generated scene with the SPD output file of the same generator and size in
//! `data/spd/` (read with parrt's NFF parser): bounds within 1% of the scene's diagonal (the
//! acceptance check), and beyond that the background, camera, lights, materials and every
//! primitive's coordinates to SPD's printing precision (6 significant digits). Also checks that
//! what we write reads back identically.

use parrt_render::description::{SceneDescription, Shape};
use parrt_render::nff::Limits;
use parrt_test_support::readme::{close, readme};
use parrt_test_support::spd_dir;

const NOT_OURS: &[&str] = &["nurbtst", "sample"];

/// Every listed (file, generator, size) we can generate, with SPD's file parsed.
fn pairs() -> Vec<(String, SceneDescription, SceneDescription)> {
    let dir = spd_dir();
    readme()
        .files
        .into_iter()
        .filter(|f| !NOT_OURS.contains(&f.generator.as_str()))
        .map(|f| {
            let spd = parrt_render::nff::parse_file(&dir.join(&f.file), &Limits::default())
                .unwrap_or_else(|e| panic!("{}: {e}", f.file));
            let ours = parrt_scenes::generate(&f.generator, Some(f.size)).unwrap();
            (f.file, ours, spd)
        })
        .collect()
}

#[test]
fn bounds_agree_with_spd_within_one_percent() {
    for (file, ours, spd) in pairs() {
        let (a, b) = (ours.bounds(), spd.bounds());
        let diag = (b.max - b.min).length();
        let err = (a.min - b.min)
            .abs()
            .max((a.max - b.max).abs())
            .max_component();
        assert!(
            err <= 0.01 * diag,
            "{file}: bounds {a:?} vs SPD {b:?} differ by {err} (diagonal {diag})"
        );
    }
}

fn coords(s: &Shape) -> Vec<f64> {
    match s {
        Shape::Sphere { center, radius } => vec![center.x, center.y, center.z, *radius],
        Shape::Cone(c) => c.numbers().to_vec(),
        Shape::Polygon(v) => v.iter().flat_map(|p| p.to_array()).collect(),
        Shape::Patch(v) => v
            .iter()
            .flat_map(|p| p.position.to_array().into_iter().chain(p.normal.to_array()))
            .collect(),
    }
}

fn kind(s: &Shape) -> (u8, usize) {
    match s {
        Shape::Sphere { .. } => (0, 0),
        Shape::Cone(_) => (1, 0),
        Shape::Polygon(v) => (2, v.len()),
        Shape::Patch(v) => (3, v.len()),
    }
}

#[test]
fn scenes_equal_spd_files_to_print_precision() {
    for (file, ours, spd) in pairs() {
        let v = [&ours.view, &spd.view];
        let cam = |x: &parrt_render::description::View| {
            let mut c: Vec<f64> = [x.from, x.at, x.up]
                .iter()
                .flat_map(|p| p.to_array())
                .collect();
            c.extend([x.angle, x.hither]);
            c
        };
        assert!(
            cam(v[0]).iter().zip(cam(v[1])).all(|(a, b)| close(*a, b)),
            "{file}: camera {:?} vs {:?}",
            v[0],
            v[1]
        );
        assert_eq!(
            (v[0].width, v[0].height),
            (v[1].width, v[1].height),
            "{file}"
        );
        assert!(
            ours.background
                .to_array()
                .iter()
                .zip(spd.background.to_array())
                .all(|(a, b)| close(*a, b)),
            "{file}: background"
        );
        assert_eq!(ours.lights.len(), spd.lights.len(), "{file}: lights");
        for (a, b) in ours.lights.iter().zip(&spd.lights) {
            let (p, q) = (a.position.to_array(), b.position.to_array());
            assert!(
                p.iter().zip(q).all(|(x, y)| close(*x, y)),
                "{file}: light {p:?} vs {q:?}"
            );
            assert_eq!(a.color, b.color, "{file}: light colour");
        }
        assert_eq!(
            ours.materials.len(),
            spd.materials.len(),
            "{file}: materials"
        );
        for (i, (a, b)) in ours.materials.iter().zip(&spd.materials).enumerate() {
            let m = |m: &parrt_render::description::Material| {
                [
                    m.color.x, m.color.y, m.color.z, m.kd, m.ks, m.shine, m.t, m.ior,
                ]
            };
            assert!(
                m(a).iter().zip(m(b)).all(|(x, y)| close(*x, y)),
                "{file}: material {i}: {a:?} vs {b:?}"
            );
        }
        // Coordinates that are differences of larger numbers (mountain heights near zero) carry
        // SPD's own rounding, so allow an absolute error of 1e-7 of the scene's size as well.
        let bounds = spd.bounds();
        let floor = 1e-7 * (bounds.max - bounds.min).length();
        let near = |x: f64, y: f64| close(x, y) || (x - y).abs() <= floor;
        assert_eq!(
            ours.primitives.len(),
            spd.primitives.len(),
            "{file}: primitives"
        );
        for (i, (a, b)) in ours.primitives.iter().zip(&spd.primitives).enumerate() {
            assert_eq!(a.material, b.material, "{file}: primitive {i} material");
            assert_eq!(kind(&a.shape), kind(&b.shape), "{file}: primitive {i} kind");
            let (ca, cb) = (coords(&a.shape), coords(&b.shape));
            assert!(
                ca.iter().zip(&cb).all(|(x, y)| near(*x, *y)),
                "{file}: primitive {i}: {ca:?} vs SPD {cb:?}"
            );
        }
    }
}

#[test]
fn written_scenes_read_back_identically() {
    for g in parrt_scenes::generators() {
        let scene = parrt_scenes::generate(g.name, None).unwrap();
        let text = parrt_render::nff::to_nff(&scene);
        let back = parrt_render::nff::parse(&text, g.name, &Limits::default())
            .unwrap_or_else(|e| panic!("{}: {e}", g.name));
        assert!(
            back == scene,
            "{}: the written NFF does not read back identically",
            g.name
        );
    }
}
