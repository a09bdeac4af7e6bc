//! Degenerate input: zero-area polygons, degenerate cones and zero spheres are refused by the
//! parser and by `Scene::build` with a clear message; odd but valid shapes are accepted.

use crate::setup::{settings, unlit_scene, Direct};
use crate::support::scene::{prim, tri, v};
use parrt_render::description::{ConeShape, Shape};
use parrt_render::render::Renderer;
use parrt_render::scene::{Scene, SceneError};
use parrt_render::settings::{AccelKind, Precision};

const HEADER: &str = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 8 8\n\
                      b 0 0 0\nl 1 1 5\nf 1 1 1 1 0 0 0 1\n";

/// Zero-area polygons, degenerate cones and zero spheres are rejected by the parser and, when
/// they arrive as descriptions (from a generator or the network), by `Scene::build`, each with a
/// message that says what is wrong. Valid shapes that look odd (collinear *first* vertices, a
/// cone with one zero radius) are accepted and rendered.
#[test]
fn degenerate_input_is_rejected_with_a_clear_message() {
    let bad_nff = [
        ("p 3\n0 0 0\n1 1 1\n2 2 2\n", "collinear"),
        ("p 4\n0 0 0\n1 0 0\n1 0 0\n0 0 0\n", "repeated"),
        ("c 0 0 0 1 0 0 0 1\n", "base = apex"),
        ("c 0 0 0 0 0 0 1 0\n", "both radii 0"),
    ];
    for (body, what) in bad_nff {
        let text = format!("{HEADER}{body}");
        let err = parrt_render::nff::parse(&text, "bad.nff", &Default::default())
            .expect_err(what)
            .to_string();
        assert!(err.contains("bad.nff"), "{what}: {err}");
        assert!(err.contains(":5"), "{what}: error names the line: {err}");
    }

    let desc = |shape: Shape| {
        unlit_scene(
            v(0.0, 0.0, 5.0),
            vec![
                prim(
                    tri(v(-1.0, -1.0, 0.0), v(1.0, -1.0, 0.0), v(0.0, 1.0, 0.0)),
                    0,
                ),
                prim(shape, 0),
            ],
        )
    };
    let bad_shapes = [
        (
            tri(v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), v(2.0, 2.0, 2.0)),
            "zero area",
        ),
        (
            Shape::Polygon(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0)].into()),
            "fewer than 3",
        ),
        (
            Shape::Cone(ConeShape {
                base: v(0.0, 0.0, 0.0),
                base_radius: 1.0,
                apex: v(0.0, 0.0, 0.0),
                apex_radius: 1.0,
            }),
            "base equals apex",
        ),
        (
            Shape::Cone(ConeShape {
                base: v(0.0, 0.0, 0.0),
                base_radius: 0.0,
                apex: v(0.0, 0.0, 1.0),
                apex_radius: 0.0,
            }),
            "both radii are zero",
        ),
        (
            Shape::Sphere {
                center: v(0.0, 0.0, 0.0),
                radius: 0.0,
            },
            "radius is zero",
        ),
        (
            Shape::Sphere {
                center: v(f64::NAN, 0.0, 0.0),
                radius: 1.0,
            },
            "non-finite",
        ),
    ];
    for (shape, what) in bad_shapes {
        let d = desc(shape);
        for result in [
            Scene::<f32>::build(&d).map(|_| ()),
            Scene::<f64>::build(&d).map(|_| ()),
        ] {
            match result {
                Err(e @ SceneError::Degenerate { index: 1, .. }) => {
                    let msg = e.to_string();
                    assert!(msg.contains(what) && msg.contains("primitive 1"), "{msg}");
                }
                other => panic!("{what}: {other:?}"),
            }
        }
        let err = Renderer::new(&d, &settings(8, Precision::F32))
            .err()
            .expect("the renderer refuses it too");
        assert!(err.to_string().contains(what), "{err}");
    }

    // Collinear first three vertices of a valid square, and a true cone: accepted and visible.
    let ok = format!("{HEADER}p 5\n-1 -1 0\n0 -1 0\n1 -1 0\n1 1 0\n-1 1 0\nc 3 0 -1 1 3 0 1 0\n");
    let d =
        parrt_render::nff::parse(&ok, "ok.nff", &Default::default()).expect("valid input parses");
    let r = Renderer::new(&d, &settings(8, Precision::F32)).expect("and builds");
    assert!(r.probe(4.0, 4.0).is_some(), "the square is there");
    let edge = parrt_render::nff::parse(
        &format!("{HEADER}p 5\n-1 -1 0\n0 -1 0\n1 -1 0\n1 1 0\n-1 1 0\n"),
        "ok.nff",
        &Default::default(),
    )
    .expect("parses");
    let d64 = Direct::<f64>::new(&edge, AccelKind::Brute, 8);
    // The point (0.9, -0.9) lies in the corner the collinear start vertices border.
    assert!(d64.hit(v(0.9, -0.9, 1.0), v(0.0, 0.0, -1.0)).is_some());
    assert!(d64.hit(v(-0.95, -0.99, 1.0), v(0.0, 0.0, -1.0)).is_some());
}
