//! Round trip: any valid description → `to_nff` → `parse` gives the identical description. The
//! generated descriptions obey the reader's validity rules, applied with the reader's own
//! [`parrt_render::nff::checks`], and use materials in non-decreasing order as the writer requires.

use parrt_render::description::{
    ConeShape, Light, Material, PatchVertex, Primitive, SceneDescription, Shape, View,
};
use parrt_render::nff::{self, checks, Limits};
use parrt_render::vec3::Vec3d;
use proptest::prelude::*;

/// Zero of either sign, as often each.
fn zero() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), Just(-0.0)]
}

/// Any finite double, with the awkward ones (zeros, tiny, huge, subnormal) well represented.
fn real() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1e4f64..1e4,
        2 => zero(),
        1 => -1e-12f64..1e-12,
        1 => (-1_000_000i32..1_000_000).prop_map(f64::from),
        1 => any::<f64>().prop_filter("finite", |v| v.is_finite()),
        1 => prop::num::f64::SUBNORMAL,
    ]
}

/// Coordinates: moderate magnitudes, so differences and Newell normals stay finite.
fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1e3f64..1e3,
        2 => zero(),
        1 => (-100i32..100).prop_map(f64::from),
        1 => -1e-9f64..1e-9,
    ]
}

fn point() -> impl Strategy<Value = Vec3d> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3d::new(x, y, z))
}

fn color() -> impl Strategy<Value = Vec3d> {
    (real(), real(), real()).prop_map(|(x, y, z)| Vec3d::new(x, y, z))
}

fn view() -> impl Strategy<Value = View> {
    (
        point(),
        point(),
        point(),
        prop_oneof![1e-6f64..179.99999, Just(45.0), Just(90.0)],
        prop_oneof![0.0f64..100.0, Just(0.0)],
        1u32..5000,
        1u32..5000,
    )
        .prop_filter("a camera the reader accepts", |(f, a, u, ..)| {
            checks::camera(*f, *a, *u).is_ok()
        })
        .prop_map(|(from, at, up, angle, hither, width, height)| View {
            from,
            at,
            up,
            angle,
            hither,
            width,
            height,
        })
}

fn light() -> impl Strategy<Value = Light> {
    (point(), prop::option::of(color())).prop_map(|(position, color)| Light { position, color })
}

fn material() -> impl Strategy<Value = Material> {
    (color(), real(), real(), real(), real(), real()).prop_map(|(color, kd, ks, shine, t, ior)| {
        Material {
            color,
            kd,
            ks,
            shine,
            t,
            ior,
        }
    })
}

fn shape() -> impl Strategy<Value = Shape> {
    let sphere = (point(), coord().prop_filter("radius ≠ 0", |r| *r != 0.0))
        .prop_map(|(center, radius)| Shape::Sphere { center, radius });
    let cone = (point(), coord(), point(), coord())
        .prop_filter("a cone the reader accepts", |(b, br, a, ar)| {
            checks::cone(*b, *br, *a, *ar).is_ok()
        })
        .prop_map(|(base, base_radius, apex, apex_radius)| {
            Shape::Cone(ConeShape {
                base,
                base_radius,
                apex,
                apex_radius,
            })
        });
    let polygon = prop::collection::vec(point(), 3..9)
        .prop_filter("non-zero Newell normal", |vs| {
            checks::polygon(vs.iter().copied()).is_ok()
        })
        .prop_map(|vs| Shape::Polygon(vs.into()));
    let patch = prop::collection::vec((point(), color()), 3..7)
        .prop_filter("non-zero Newell normal", |vs| {
            checks::polygon(vs.iter().map(|v| v.0)).is_ok()
        })
        .prop_map(|vs| {
            Shape::Patch(
                vs.into_iter()
                    .map(|(position, normal)| PatchVertex { position, normal })
                    .collect(),
            )
        });
    prop_oneof![sphere, cone, polygon, patch]
}

fn description() -> impl Strategy<Value = SceneDescription> {
    (
        color(),
        view(),
        prop::collection::vec(light(), 0..4),
        prop::collection::vec(material(), 1..5),
        prop::collection::vec((shape(), 0u32..3), 0..12),
    )
        .prop_map(|(background, view, lights, materials, shapes)| {
            // Non-decreasing material indices: step forward by 0, 1 or 2, capped at the last.
            let last = materials.len() as u32 - 1;
            let mut m = 0u32;
            let primitives = shapes
                .into_iter()
                .map(|(shape, step)| {
                    m = (m + step / 2).min(last);
                    Primitive { shape, material: m }
                })
                .collect();
            SceneDescription {
                background,
                view,
                lights,
                materials,
                primitives,
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn write_then_parse_is_identity(desc in description()) {
        let text = nff::to_nff(&desc);
        let back = nff::parse(&text, "roundtrip.nff", &Limits::default());
        prop_assert!(back.is_ok(), "{:?}\n{}", back.err(), text);
        prop_assert_eq!(back.ok(), Some(desc));
    }
}

#[test]
fn a_description_without_primitives_or_with_a_default_material_round_trips() {
    let v = View {
        from: Vec3d::new(0.0, 0.0, 5.0),
        at: Vec3d::zero(),
        up: Vec3d::new(0.0, 1.0, 0.0),
        angle: 45.0,
        hither: 0.0,
        width: 1,
        height: 1,
    };
    let empty = SceneDescription {
        background: Vec3d::zero(),
        view: v.clone(),
        lights: vec![],
        materials: vec![],
        primitives: vec![],
    };
    assert_eq!(
        nff::parse(&nff::to_nff(&empty), "e", &Limits::default()),
        Ok(empty)
    );
    // What the reader makes of a primitive before any f reads back the same.
    let src = format!(
        "{}s 0 0 0 1\n",
        nff::to_nff(&SceneDescription {
            background: Vec3d::zero(),
            view: v,
            lights: vec![],
            materials: vec![],
            primitives: vec![],
        })
    );
    let d = nff::parse(&src, "d", &Limits::default()).unwrap();
    assert_eq!(
        nff::parse(&nff::to_nff(&d), "d2", &Limits::default()),
        Ok(d)
    );
}
