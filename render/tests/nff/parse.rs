//! What the NFF reader accepts and how it reads it: number forms, layouts, whitespace and
//! comments, defaults, and the error values (kind, position) of the library API.

use parrt_render::description::{ConeShape, Material, Shape};
use parrt_render::nff::{self, Limits, NffErrorKind};
use parrt_render::vec3::Vec3d;

const V: &str = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 64 48\n";

fn ok(src: &str) -> parrt_render::description::SceneDescription {
    nff::parse(src, "t.nff", &Limits::default()).unwrap_or_else(|e| panic!("{e}\n{src}"))
}

fn err(src: &str) -> nff::NffError {
    match nff::parse(src, "t.nff", &Limits::default()) {
        Ok(_) => panic!("accepted:\n{src}"),
        Err(e) => e,
    }
}

fn sphere_radius(src: &str) -> f64 {
    match ok(src).primitives[0].shape {
        Shape::Sphere { radius, .. } => radius,
        ref s => panic!("not a sphere: {s:?}"),
    }
}

#[test]
fn every_c_g_number_form_reads_exactly() {
    for (text, value) in [
        ("1", 1.0f64),
        ("-0.5", -0.5),
        (".5", 0.5),
        ("5.", 5.0),
        ("+1", 1.0),
        ("1e-3", 1e-3),
        ("2E+2", 200.0),
        ("-2.55836e-17", -2.55836e-17),
        ("100000", 100000.0),
        ("0.1", 0.1),
        ("1e-320", 1e-320),
    ] {
        let r = sphere_radius(&format!("{V}f 1 1 1 1 0 0 0 0\ns 0 0 0 {text}\n"));
        assert_eq!(r.to_bits(), value.to_bits(), "{text}");
    }
    let d = ok(&format!("{V}f 1 1 1 1 0 0 0 0\ns -0 0 0 1\n"));
    match d.primitives[0].shape {
        Shape::Sphere { center, .. } => assert!(center.x == 0.0 && center.x.is_sign_negative()),
        _ => unreachable!(),
    }
}

#[test]
fn cone_on_one_line_or_three_is_the_same() {
    let one = ok(&format!("{V}f 1 1 1 1 0 0 0 0\nc 0 0 0 1 0 0 2 0.5\n"));
    let three = ok(&format!("{V}f 1 1 1 1 0 0 0 0\nc\n0 0 0 1\n0 0 2 0.5\n"));
    assert_eq!(one, three);
    assert_eq!(
        one.primitives[0].shape,
        Shape::Cone(ConeShape {
            base: Vec3d::new(0.0, 0.0, 0.0),
            base_radius: 1.0,
            apex: Vec3d::new(0.0, 0.0, 2.0),
            apex_radius: 0.5
        })
    );
}

#[test]
fn whitespace_kinds_and_comments_do_not_matter() {
    let plain = ok(&format!(
        "b 0.1 0.2 0.3\n{V}l 1 2 3\nf 1 0 0 1 0 0 0 0\np 3\n0 0 0\n1 0 0\n0 1 0\n"
    ));
    let messy = "# scene\r\nb\t0.1 0.2 0.3 # background\r\n\x0cv\r\nfrom 0 0 5\r\nat 0 0 0 \
                 \r\nup 0 1 0\r\nangle 45\r\nhither 0.01\r\nresolution 64 48\r\n#\r\nl 1 2 3#x\r\n\
                 f 1 0 0 1 0 0 0 0\r\np 3 0 0 0 1 0 0\t0 1 0";
    assert_eq!(ok(messy), plain);
}

#[test]
fn defaults_and_order_freedoms() {
    // No b: black. Primitive before any f: the default white material, flagged.
    let src = format!("{V}s 0 0 0 1\n");
    let parsed = nff::parse_bytes(src.as_bytes(), "t", &Limits::default()).unwrap();
    let d = &parsed.description;
    assert_eq!(d.background, Vec3d::zero());
    assert_eq!(d.materials, vec![Material::default_white()]);
    assert!(parsed.default_material_inserted);
    assert_eq!(parsed.material_lines, 0);
    // b and l after objects, v last, a second b replacing the first.
    let d = ok(&format!(
        "b 1 1 1\nf 1 1 1 1 0 0 0 0\ns 0 0 0 1\nl 1 2 3 0.5 0.25 1\nb 0 0.5 0\nl 4 5 6\n{V}"
    ));
    assert_eq!(d.background, Vec3d::new(0.0, 0.5, 0.0));
    assert_eq!(d.lights.len(), 2);
    assert_eq!(d.lights[0].color, Some(Vec3d::new(0.5, 0.25, 1.0)));
    assert_eq!(d.lights[1].color, None);
    assert_eq!(d.view.width, 64);
}

#[test]
fn materials_apply_until_the_next_f() {
    let d = ok(&format!(
        "{V}f 1 0 0 1 0 0 0 0\ns 0 0 0 1\ns 0 0 3 1\nf 0 1 0 0.5 0.5 10 0.2 1.5\ns 0 0 6 1\n"
    ));
    let m: Vec<u32> = d.primitives.iter().map(|p| p.material).collect();
    assert_eq!(m, [0, 0, 1]);
    assert_eq!(d.materials[1].shine, 10.0);
    assert_eq!(d.materials[1].ior, 1.5);
}

#[test]
fn legal_unusual_shapes() {
    let d = ok(&format!(
        "{V}f 1 1 1 1 0 0 0 0\ns 0 0 0 -2\nc 0 0 0 -1 0 0 1 -0.5\nc 0 0 0 1 0 0 1 0\n\
         p 5\n0 0 0\n2 0 0\n2 2 0\n1 0.5 0\n0 2 0\n"
    ));
    assert_eq!(d.primitives.len(), 4);
}

#[test]
fn library_errors_carry_kind_and_position() {
    let e = err(&format!("{V}f 1 1 1 1 0 0 0 0\ns 0 0 0 x\n"));
    assert_eq!((e.file.as_str(), e.line, e.column), ("t.nff", 3, 9));
    assert_eq!(e.kind, NffErrorKind::Syntax);
    assert_eq!(
        e.to_string(),
        "t.nff:3:9: expected a number for the sphere radius, found 'x'"
    );
    let limits = Limits {
        max_primitives: 1,
        ..Limits::default()
    };
    let e = nff::parse(&format!("{V}s 0 0 0 1\ns 0 0 3 1\n"), "t", &limits).unwrap_err();
    assert_eq!((e.kind, e.line, e.column), (NffErrorKind::Limit, 3, 1));
    let e = nff::parse_file(
        std::path::Path::new("/no/such/dir/x.nff"),
        &Limits::default(),
    )
    .unwrap_err();
    assert_eq!((e.kind, e.line, e.column), (NffErrorKind::Io, 0, 0));
    assert!(e.file.contains("x.nff"));
}

/// Every number of every entity is named in the message when it is not a number: the point
/// coordinates, the material's fields and the vertex coordinates each by their own words.
#[test]
fn a_bad_number_is_named_by_what_it_stands_for() {
    let f = "f 1 1 1 1 0 0 0 0\n";
    // Enough bytes after a short vertex list that its count is believed.
    let pad = format!("\n#{}\n", " ".repeat(60));
    let cases: [(String, &str); 14] = [
        ("v from 0 x".into(), "the view's from y"),
        ("v from 0 0 5 at x".into(), "the view's at x"),
        ("v from 0 0 5 at 0 0 0 up 0 x".into(), "the view's up y"),
        (format!("{V}l 1 x"), "the light's y"),
        (
            format!("{V}l 1 2 3 0.5 x"),
            "the light's green (a light has 3 or 6 numbers)",
        ),
        (
            format!("{V}f 1 1 1 x"),
            "the material's Kd (f has 8 numbers: r g b Kd Ks Shine T ior)",
        ),
        (
            format!("{V}f 1 1 1 1 0 0 x"),
            "the material's T (f has 8 numbers: r g b Kd Ks Shine T ior)",
        ),
        (
            format!("{V}f 1 1 1 1 0 0 0 x"),
            "the material's ior (f has 8 numbers: r g b Kd Ks Shine T ior)",
        ),
        (format!("{V}{f}s 0 x"), "the sphere centre's y"),
        (format!("{V}{f}c 0 0 0 1 0 x"), "the cone apex's y"),
        (format!("{V}{f}c 0 0 x"), "the cone base's z"),
        (
            format!("{V}{f}p 3 0 0 0 1 0 0 1 x{pad}"),
            "the y of polygon vertex 3 (its count says 3 vertices)",
        ),
        (
            format!("{V}{f}pp 3 0 0 0 0 0 1 1 0 0 0 0 x{pad}"),
            "the normal z of patch vertex 2 (its count says 3 vertices)",
        ),
        (
            format!("{V}{f}pp 3 0 0 0 0 0 1 1 0 x{pad}"),
            "the z of patch vertex 2 (its count says 3 vertices)",
        ),
    ];
    for (src, what) in cases {
        let e = err(&src);
        assert_eq!(
            e.message,
            format!("expected a number for {what}, found 'x'"),
            "{src}"
        );
    }
}

#[test]
fn long_and_odd_tokens_are_shown_shortly_and_safely() {
    let long = "z".repeat(500);
    let e = err(&format!("{V}{long}\n"));
    assert!(e.message.len() < 200, "{}", e.message);
    let e = err(&format!("{V}s 0 0 0 \u{1b}[31m\n"));
    assert!(
        !e.message.contains('\u{1b}'),
        "control characters are escaped"
    );
}

#[test]
fn comments_may_hold_any_bytes_but_tokens_may_not() {
    let mut src = V.as_bytes().to_vec();
    src.extend_from_slice(b"# caf\xe9 (Latin-1)\nf 1 1 1 1 0 0 0 0\ns 0 0 0 1\n");
    assert!(nff::parse_bytes(&src, "t", &Limits::default()).is_ok());
    src.extend_from_slice(b"s 0 0 0 \xe9\n");
    let e = nff::parse_bytes(&src, "t", &Limits::default()).unwrap_err();
    assert_eq!((e.line, e.column), (5, 9));
}
