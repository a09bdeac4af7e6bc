//! Prints a [`SceneDescription`] as Haines NFF text that the parser reads back to the identical
//! description: numbers in their shortest round-trip form, one entity per line, SPD's layout
//! (`b`, `v` block, lights, then `f` and primitive runs; a cone on one line).

use super::number::write_real as num;
use crate::description::{Material, SceneDescription, Shape};
use std::fmt::Write;

fn nums(out: &mut String, vs: &[f64]) {
    for v in vs {
        out.push(' ');
        num(out, *v);
    }
}

/// Renders the description as NFF text.
///
/// Materials are written in index order: an `f` line is emitted when a primitive needs a material
/// later in the list than the current one (unused materials in between are written too, so the
/// count of `f` lines is kept). A description whose primitives use materials in non-decreasing
/// order — which is what the parser and the generators produce — reads back identically. A
/// material index past the end of the list is written as [`Material::default_white`].
pub fn to_nff(desc: &SceneDescription) -> String {
    let mut out = String::with_capacity(64 + desc.primitives.len() * 64);
    let b = desc.background;
    out.push('b');
    nums(&mut out, &[b.x, b.y, b.z]);
    out.push('\n');
    let v = &desc.view;
    out.push_str("v\nfrom");
    nums(&mut out, &[v.from.x, v.from.y, v.from.z]);
    out.push_str("\nat");
    nums(&mut out, &[v.at.x, v.at.y, v.at.z]);
    out.push_str("\nup");
    nums(&mut out, &[v.up.x, v.up.y, v.up.z]);
    out.push_str("\nangle");
    nums(&mut out, &[v.angle]);
    out.push_str("\nhither");
    nums(&mut out, &[v.hither]);
    let _ = writeln!(out, "\nresolution {} {}", v.width, v.height);
    for l in &desc.lights {
        out.push('l');
        nums(&mut out, &[l.position.x, l.position.y, l.position.z]);
        if let Some(c) = l.color {
            nums(&mut out, &[c.x, c.y, c.z]);
        }
        out.push('\n');
    }
    let default_white = Material::default_white();
    let write_material = |out: &mut String, i: usize| {
        // A primitive naming a material past the list is malformed; write the reader's default
        // for it rather than panic, so the writer is total.
        let m = desc.materials.get(i).unwrap_or(&default_white);
        out.push('f');
        nums(
            out,
            &[
                m.color.x, m.color.y, m.color.z, m.kd, m.ks, m.shine, m.t, m.ior,
            ],
        );
        out.push('\n');
    };
    // Index of the next material not yet written.
    let mut next_material = 0usize;
    let mut current: Option<usize> = None;
    for p in &desc.primitives {
        let m = p.material as usize;
        if current != Some(m) {
            if m >= next_material {
                while next_material <= m {
                    write_material(&mut out, next_material);
                    next_material += 1;
                }
            } else {
                // Out-of-order reuse: write the material again (reads back as a new entry).
                write_material(&mut out, m);
            }
            current = Some(m);
        }
        match &p.shape {
            Shape::Sphere { center, radius } => {
                out.push('s');
                nums(&mut out, &[center.x, center.y, center.z, *radius]);
            }
            Shape::Cone(c) => {
                out.push('c');
                nums(&mut out, &c.numbers());
            }
            Shape::Polygon(vs) => {
                let _ = write!(out, "p {}", vs.len());
                for v in vs {
                    out.push('\n');
                    nums(&mut out, &[v.x, v.y, v.z]);
                }
            }
            Shape::Patch(vs) => {
                let _ = write!(out, "pp {}", vs.len());
                for v in vs {
                    out.push('\n');
                    let (p, n) = (v.position, v.normal);
                    nums(&mut out, &[p.x, p.y, p.z, n.x, n.y, n.z]);
                }
            }
        }
        out.push('\n');
    }
    while next_material < desc.materials.len() {
        write_material(&mut out, next_material);
        next_material += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::{Primitive, View};
    use crate::vec3::Vec3d;

    #[test]
    fn a_missing_material_is_written_as_the_default_instead_of_panicking() {
        let desc = SceneDescription {
            background: Vec3d::zero(),
            view: View {
                from: Vec3d::new(0.0, 0.0, 1.0),
                at: Vec3d::zero(),
                up: Vec3d::new(0.0, 1.0, 0.0),
                angle: 45.0,
                hither: 0.0,
                width: 2,
                height: 2,
            },
            lights: vec![],
            materials: vec![],
            primitives: vec![Primitive {
                shape: Shape::Sphere {
                    center: Vec3d::zero(),
                    radius: 1.0,
                },
                material: 0,
            }],
        };
        let text = to_nff(&desc);
        let back = crate::nff::parse(&text, "w", &Default::default()).unwrap();
        assert_eq!(back.materials, vec![Material::default_white()]);
        assert_eq!(back.primitives, desc.primitives);
    }
}
