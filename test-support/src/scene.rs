//! Scenes built in code: vectors, triangles, views, materials and primitives in one line each,
//! a scene of bare shapes for the tests that only look at hits, the one-sphere test scene, and
//! the doubled integer grid whose hits all fall on edges, vertices and ties.

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

/// A flat `n`×`n` mesh on integer vertices in the plane z = 0: two triangles per unit square,
/// every one twice (once as is, once wound the other way, so every hit is a tie the primitive
/// index decides), seen from 10 above its centre through a 64×64 view of 60°.
pub fn doubled_grid(n: u32) -> SceneDescription {
    let p = |x: f64, y: f64| v(x, y, 0.0);
    let mut shapes = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (f64::from(i), f64::from(j));
            let a = vec![p(x, y), p(x + 1.0, y), p(x + 1.0, y + 1.0)];
            let b = vec![p(x, y), p(x + 1.0, y + 1.0), p(x, y + 1.0)];
            for t in [a, b] {
                let mut r = t.clone();
                r.reverse();
                shapes.push(Shape::Polygon(t.into()));
                shapes.push(Shape::Polygon(r.into()));
            }
        }
    }
    let c = f64::from(n) / 2.0;
    scene_of(
        shapes,
        view(v(c, c, 10.0), v(c, c, 0.0), v(0.0, 1.0, 0.0), 60.0, 64),
    )
}
