//! The memory-saving scene build (`Scene::build_owned`, used by `parrt render`), which consumes
//! the description from its last primitive back, gives exactly the scene `Scene::build` gives:
//! the same primitives, shading records and patch normals in the same order, for every kind of
//! primitive and both precisions; and it refuses a bad primitive as the borrowed build does.

use parrt_render::description::{Primitive, SceneDescription, Shape};
use parrt_render::real::Real;
use parrt_render::scene::{Scene, SceneError};
use parrt_render::vec3::V3;

fn same_scene<R: Real>(desc: &SceneDescription) {
    let a = Scene::<R>::build(desc).expect("borrowed build");
    let b = Scene::<R>::build_owned(desc.clone()).expect("owned build");
    assert!(!a.prims.is_empty());
    assert_eq!(format!("{:?}", a.prims), format!("{:?}", b.prims));
    assert_eq!(format!("{:?}", a.info), format!("{:?}", b.info));
    assert_eq!(format!("{:?}", a.normals), format!("{:?}", b.normals));
    assert_eq!(format!("{:?}", a.materials), format!("{:?}", b.materials));
    assert_eq!(format!("{:?}", a.lights), format!("{:?}", b.lights));
}

#[test]
fn owned_build_equals_borrowed_build_on_every_generator() {
    // teapot: patches (vertex normals); gears: polygons of many vertices; rings: cones and
    // spheres; mount, balls, shells: spheres and triangles; tetra, tree, lattice, jacks.
    for name in [
        "teapot", "gears", "rings", "mount", "balls", "shells", "tetra", "tree", "lattice", "jacks",
    ] {
        let desc = parrt_scenes::generate(name, Some(2)).expect("generate");
        same_scene::<f32>(&desc);
        same_scene::<f64>(&desc);
    }
}

#[test]
fn owned_build_equals_borrowed_build_past_the_release_steps() {
    // More than 32 × 4096 primitives, so the description is shrunk and the heap trimmed
    // several times on the way.
    let desc = parrt_scenes::generate("mount", Some(8)).expect("generate");
    assert!(desc.primitives.len() > 32 * 4096);
    same_scene::<f32>(&desc);
}

#[test]
fn owned_build_refuses_bad_primitives() {
    let mut desc = parrt_scenes::generate("balls", Some(1)).expect("generate");
    let good = desc.primitives.len();
    desc.primitives.push(Primitive {
        shape: Shape::Sphere {
            center: V3::new(0.0, 0.0, 0.0),
            radius: 0.0,
        },
        material: 0,
    });
    let e = Scene::<f32>::build_owned(desc.clone()).expect_err("zero radius");
    assert_eq!(e, Scene::<f32>::build(&desc).expect_err("zero radius"));
    assert!(matches!(e, SceneError::Degenerate { index, .. } if index == good));
    desc.primitives.pop();
    desc.primitives[0].material = 999;
    let e = Scene::<f32>::build_owned(desc).expect_err("bad material");
    assert!(matches!(
        e,
        SceneError::BadMaterial {
            index: 0,
            material: 999,
            ..
        }
    ));
}

// `parrt render` builds through `Renderer::from_description` (the owned build); a scene far
// from the origin must get the camera-relative frame there too, the image the
// borrowed build gives — and in f32 the untransformed scene's image, which world coordinates
// at 1e7 would not give.
#[test]
fn the_owned_build_renders_far_scenes_in_the_camera_relative_frame() {
    use parrt_render::render::Renderer;
    use parrt_render::settings::{Precision, RenderSettings};
    use parrt_render::smp::{render_smp, Executor, SmpOptions};
    let near = parrt_scenes::generate("mount", Some(2)).expect("generate");
    let far = near.transformed(1.0, parrt_render::vec3::Vec3d::new(1e7, -1e7, 3e6));
    let mut s = RenderSettings::new(48, 48);
    s.precision = Precision::F32;
    let opts = SmpOptions {
        threads: 1,
        tile: 16,
        executor: Executor::Queue,
    };
    let image = |r: &Renderer| render_smp(r, &opts, &|_, _| {}).film.to_rgb8();
    let owned = image(&Renderer::from_description(far.clone(), &s).expect("owned"));
    let borrowed = image(&Renderer::new(&far, &s).expect("borrowed"));
    assert!(
        owned == borrowed,
        "owned and borrowed builds differ far from the origin"
    );
    let untransformed = image(&Renderer::new(&near, &s).expect("near"));
    let off = owned
        .iter()
        .zip(&untransformed)
        .filter(|(a, b)| a.abs_diff(**b) > 1)
        .count();
    assert!(
        off * 1000 <= owned.len(),
        "{off} of {} bytes off against the untransformed render",
        owned.len()
    );
}
