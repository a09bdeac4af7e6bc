//! Scenes built in code: vectors, triangles, views, materials and primitives in one line each,
//! a scene of bare shapes for the tests that only look at hits, and the one-sphere test scene.

use parrt_render::description::{Light, Material, Primitive, SceneDescription, Shape, View};
use parrt_render::vec3::{Vec3d, V3};

/// The point or direction (x, y, z).
pub fn v(x: f64, y: f64, z: f64) -> Vec3d {
    V3::new(x, y, z)
}

/// The triangle `a b c` as a three-vertex polygon.
pub fn tri(a: Vec3d, b: Vec3d, c: Vec3d) -> Shape {
    Shape::Polygon(vec![a, b, c].into())
}

/// A square `size`×`size` view from `from` towards `at` (hither 1e-3).
pub fn view(from: Vec3d, at: Vec3d, up: Vec3d, angle: f64, size: u32) -> View {
    View {
        from,
        at,
        up,
        angle,
        hither: 1e-3,
        width: size,
        height: size,
    }
}

/// A material of colour `c` with diffuse `kd`, specular `ks` (shine 20), transmission `t` and
/// index of refraction `ior`.
pub fn mat(c: [f64; 3], kd: f64, ks: f64, t: f64, ior: f64) -> Material {
    Material {
        color: v(c[0], c[1], c[2]),
        kd,
        ks,
        shine: 20.0,
        t,
        ior,
    }
}

/// `shape` in material `material`.
pub fn prim(shape: Shape, material: u32) -> Primitive {
    Primitive { shape, material }
}

/// A test scene of `shapes` seen through `view`: black background, no lights, every shape in
/// one white material (what the hit-agreement tests need, which never shade).
pub fn scene_of(shapes: Vec<Shape>, view: View) -> SceneDescription {
    SceneDescription {
        background: v(0.0, 0.0, 0.0),
        view,
        lights: Vec::new(),
        materials: vec![Material::default_white()],
        primitives: shapes
            .into_iter()
            .map(|shape| Primitive { shape, material: 0 })
            .collect(),
    }
}

/// The one-sphere test scene, `size`×`size`: a white unit sphere at the origin seen from
/// (0, 0, 5) through a 40° view, one white light at (1, 2, 3), background (0.1, 0.2, 0.3).
pub fn one_sphere(size: u32) -> SceneDescription {
    SceneDescription {
        background: v(0.1, 0.2, 0.3),
        view: View {
            from: v(0.0, 0.0, 5.0),
            at: v(0.0, 0.0, 0.0),
            up: v(0.0, 1.0, 0.0),
            angle: 40.0,
            hither: 0.01,
            width: size,
            height: size,
        },
        lights: vec![Light {
            position: v(1.0, 2.0, 3.0),
            color: None,
        }],
        materials: vec![Material::default_white()],
        primitives: vec![prim(
            Shape::Sphere {
                center: v(0.0, 0.0, 0.0),
                radius: 1.0,
            },
            0,
        )],
    }
}
