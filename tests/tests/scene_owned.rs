//! The memory-saving scene build (`Scene::build_owned`, used by `parrt render`), which consumes
//! the description from its last primitive back, gives exactly the scene `Scene::build` gives:
//! the same primitives, shading records and patch normals in the same order, for every kind of
//! primitive and both precisions; and it refuses a bad primitive as the borrowed build does.

use parrt::description::{Primitive, SceneDescription, Shape};
use parrt::real::Real;
use parrt::scene::{Scene, SceneError};
use parrt::vec3::V3;

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
