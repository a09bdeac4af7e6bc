//! Every SPD scene parses, and survives parse → write → parse unchanged.

use crate::support;

use parrt_render::description::Shape;
use parrt_render::nff::{self, Limits};

#[test]
fn every_spd_file_parses_and_round_trips() {
    let limits = Limits::default();
    for path in support::spd_files() {
        let name = path.display().to_string();
        let parsed = nff::parse_file_bytes(&path, &limits).unwrap_or_else(|e| panic!("{e}"));
        let d = &parsed.description;
        assert!(!d.primitives.is_empty(), "{name}: no primitives");
        assert!(
            !parsed.default_material_inserted,
            "{name}: SPD files start with f"
        );
        assert_eq!(parsed.material_lines, d.materials.len(), "{name}");
        let text = nff::to_nff(d);
        let again = nff::parse(&text, "written", &limits).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&again, d, "{name}: round trip changed the description");
    }
}

#[test]
fn spd_specifics_are_read_as_documented() {
    let limits = Limits::default();
    let dir = support::spd_dir();
    // teapot pp normals contain -0, which must survive as a negative zero.
    let teapot = nff::parse_file(&dir.join("teapot-2.nff"), &limits).unwrap();
    let neg_zero = teapot.primitives.iter().any(|p| match &p.shape {
        Shape::Patch(vs) => vs.iter().any(|v| {
            v.normal
                .to_array()
                .iter()
                .any(|c| *c == 0.0 && c.is_sign_negative())
        }),
        _ => false,
    });
    assert!(neg_zero, "teapot-2 has -0 normals");
    // lattice has hither 0 and angle 60; sombrero's up is 32° from its view (must be accepted).
    let lattice = nff::parse_file(&dir.join("lattice-4.nff"), &limits).unwrap();
    assert_eq!((lattice.view.hither, lattice.view.angle), (0.0, 60.0));
    let sombrero = nff::parse_file(&dir.join("sombrero-1.nff"), &limits).unwrap();
    assert_eq!(sombrero.view.angle, 40.0);
    // Material indices never decrease and each f line is one material.
    let lat12 = nff::parse_file_bytes(&dir.join("lattice-4.nff"), &limits).unwrap();
    assert_eq!(lat12.material_lines, 425);
    let m: Vec<u32> = lat12
        .description
        .primitives
        .iter()
        .map(|p| p.material)
        .collect();
    assert!(m.windows(2).all(|w| w[0] <= w[1]));
}
