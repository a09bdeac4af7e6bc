//! Prints a [`SceneDescription`] as a POV-Ray 3.7 scene, laid out as Haines' SPD generators
//! write their POV-Ray output (`-r 4`): the same camera vectors, one light intensity
//! 1/sqrt(N) for N lights, one declared texture per material, cylinders and cones as open
//! `cone`s, every polygon split into `triangle`s and every patch into `smooth_triangle`s. The
//! POV-Ray speed comparison renders these files, so POV-Ray and parrt trace the same scene.
//!
//! What NFF does not carry is filled in as the classic generators (balls, gears, mount, rings,
//! teapot, tetra, tree, shells) write it: `ambient 0`, and Ks weights both the Phong highlight
//! (exponent `Shine`; none at SPD's "no highlight" sentinel 100000) and the mirror reflection,
//! as it does in NFF. A transmitting material (T > 0) gets `filter T` and `refraction 1.0 ior
//! …`, as Haines writes it; like his files, the output has no `#version`, so POV-Ray 3.7 reads
//! it with its 3.6 defaults (a warning, then max_trace_level 5 and no gamma correction).
//!
//! A polygon is cut into triangles by ear clipping in its own plane (concave ones too, such as
//! the gears' 144-vertex outlines); one that cannot be cut (collinear runs, a self-touching
//! outline) is written as a POV-Ray `polygon` instead, which draws the same area.

use super::number::write_real as num;
use crate::description::{Material, SceneDescription, Shape};
use crate::vec3::Vec3d;
use std::fmt::Write;

/// The `Shine` value SPD writes for a material with no highlight.
const NO_HIGHLIGHT: f64 = 100000.0;

/// Writes the three numbers of `v`, each after its text in `before`.
fn interleaved(out: &mut String, before: [&str; 3], v: Vec3d) {
    for (text, x) in before.into_iter().zip(v.to_array()) {
        out.push_str(text);
        num(out, x);
    }
}

/// Writes `<x, y, z>`.
fn vector(out: &mut String, v: Vec3d) {
    interleaved(out, ["<", ", ", ", "], v);
    out.push('>');
}

/// Writes `color red r green g blue b`.
fn color(out: &mut String, c: Vec3d) {
    interleaved(out, ["color red ", " green ", " blue "], c);
}

/// The unit vector along `v`, or `v` itself when it has no length.
fn unit(v: Vec3d) -> Vec3d {
    let len = v.length();
    if len > 0.0 {
        v / len
    } else {
        v
    }
}

/// Writes the camera: POV-Ray's `direction` is the unit view direction, `right` and `up` span
/// the image plane at unit distance (`angle` across the shorter side, edge to edge, as parrt's
/// camera has it), and `right` points to screen right in NFF's right-handed world, which is
/// POV-Ray's left-handed default negated.
fn camera(out: &mut String, desc: &SceneDescription) {
    let v = &desc.view;
    let dir = unit(v.at - v.from);
    let right = unit(unit(v.up).cross(dir));
    let up = unit(dir.cross(right));
    let side = 2.0 * (v.angle.to_radians() * 0.5).tan();
    let (w, h) = (f64::from(v.width.max(1)), f64::from(v.height.max(1)));
    let (width, height) = if w >= h {
        (side * w / h, side)
    } else {
        (side, side * h / w)
    };
    out.push_str("camera {\n    location ");
    vector(out, v.from);
    out.push_str("\n    direction ");
    vector(out, dir);
    out.push_str("\n    right     ");
    vector(out, -(right * width));
    out.push_str("\n    up        ");
    vector(out, up * height);
    out.push_str("\n} // camera\n\n");
}

/// Writes the texture `txtNNN` of material `m` (`index` counts from 1, as Haines names them).
fn texture(out: &mut String, index: usize, m: &Material) {
    let _ = writeln!(out, "#declare txt{index:03} = texture {{");
    out.push_str("    pigment {\n        ");
    color(out, m.color);
    if m.t > 0.0 {
        out.push_str(" filter ");
        num(out, m.t);
    }
    out.push_str("\n    } // pigment\n    finish {\n        ambient 0\n        diffuse ");
    num(out, m.kd);
    if m.ks != 0.0 && m.shine < NO_HIGHLIGHT {
        out.push_str("\n        phong ");
        num(out, m.ks);
        out.push_str("  phong_size ");
        num(out, m.shine);
    }
    if m.ks != 0.0 {
        out.push_str("\n        reflection ");
        num(out, m.ks);
    }
    if m.t != 0.0 {
        out.push_str("\n        refraction 1.0 ior ");
        num(out, if m.ior > 0.0 { m.ior } else { 1.0 });
    }
    let _ = write!(out, "\n    }} // finish\n}} // texture txt{index:03}\n\n");
}

/// Writes one flat triangle.
fn triangle(out: &mut String, a: Vec3d, b: Vec3d, c: Vec3d, tex: usize) {
    out.push_str("object {\n    triangle {\n        ");
    vector(out, a);
    out.push_str(",\n        ");
    vector(out, b);
    out.push_str(",\n        ");
    vector(out, c);
    let _ = write!(
        out,
        "\n    }} // tri\n    texture {{ txt{tex:03} }}\n}} // object\n\n"
    );
}

/// The polygon's vertices as index triples of triangles covering it, by ear clipping in the
/// polygon's plane; `None` when no ear can be cut (a degenerate or self-touching outline).
pub fn triangulate(vs: &[Vec3d]) -> Option<Vec<[usize; 3]>> {
    let n = vs.len();
    if n < 3 {
        return None;
    }
    if n == 3 {
        return Some(vec![[0, 1, 2]]);
    }
    // Newell's normal; drop its largest axis to work in 2D, keeping the winding positive.
    let mut normal = Vec3d::zero();
    for i in 0..n {
        let (p, q) = (vs[i], vs[(i + 1) % n]);
        normal.x += (p.y - q.y) * (p.z + q.z);
        normal.y += (p.z - q.z) * (p.x + q.x);
        normal.z += (p.x - q.x) * (p.y + q.y);
    }
    let abs = [normal.x.abs(), normal.y.abs(), normal.z.abs()];
    let axis = if abs[0] >= abs[1] && abs[0] >= abs[2] {
        0
    } else if abs[1] >= abs[2] {
        1
    } else {
        2
    };
    if abs[axis] == 0.0 || !abs[axis].is_finite() {
        return None;
    }
    let sign = [normal.x, normal.y, normal.z][axis].signum();
    let flat: Vec<(f64, f64)> = vs
        .iter()
        .map(|p| match axis {
            0 => (p.y, p.z * sign),
            1 => (p.z, p.x * sign),
            _ => (p.x, p.y * sign),
        })
        .collect();
    let cross = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| {
        (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
    };
    let mut left: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&i| {
            let (ia, ib, ic) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            let (a, b, c) = (flat[ia], flat[ib], flat[ic]);
            if cross(a, b, c) <= 0.0 {
                return false;
            }
            // No other remaining vertex inside or on the candidate triangle.
            left.iter().all(|&j| {
                if j == ia || j == ib || j == ic || flat[j] == a || flat[j] == b || flat[j] == c {
                    return true;
                }
                let p = flat[j];
                !(cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0)
            })
        })?;
        out.push([left[(ear + m - 1) % m], left[ear], left[(ear + 1) % m]]);
        left.remove(ear);
    }
    let [a, b, c] = [flat[left[0]], flat[left[1]], flat[left[2]]];
    if cross(a, b, c) > 0.0 {
        out.push([left[0], left[1], left[2]]);
    }
    Some(out)
}

/// Renders the description as a POV-Ray scene (see the module documentation for the layout
/// and for what NFF leaves open). A material index past the end of the list is written as
/// [`Material::default_white`].
pub fn to_pov(desc: &SceneDescription) -> String {
    let mut out = String::with_capacity(256 + desc.primitives.len() * 160);
    out.push_str("// POV-Ray 3 scene file (written by parrt from an NFF scene)\n");
    out.push_str("background { ");
    color(&mut out, desc.background);
    out.push_str(" }\n\n");
    camera(&mut out, desc);
    let nl = desc.lights.len().max(1) as f64;
    let scale = 1.0 / nl.sqrt();
    for l in &desc.lights {
        let c = l.color.unwrap_or(Vec3d::new(1.0, 1.0, 1.0)) * scale;
        out.push_str("light_source {\n    ");
        vector(&mut out, l.position);
        out.push(' ');
        color(&mut out, c);
        out.push_str("\n} // light\n\n");
    }
    for (i, m) in desc.materials.iter().enumerate() {
        texture(&mut out, i + 1, m);
    }
    let fallback = desc.materials.len() + 1;
    if desc
        .primitives
        .iter()
        .any(|p| p.material as usize >= desc.materials.len())
    {
        texture(&mut out, fallback, &Material::default_white());
    }
    for p in &desc.primitives {
        let tex = if (p.material as usize) < desc.materials.len() {
            p.material as usize + 1
        } else {
            fallback
        };
        match &p.shape {
            Shape::Sphere { center, radius } => {
                out.push_str("sphere { ");
                vector(&mut out, *center);
                out.push_str(", ");
                num(&mut out, *radius);
                let _ = writeln!(out, "  texture {{ txt{tex:03} }} }}\n");
            }
            Shape::Cone(c) => {
                out.push_str("cone {\n    ");
                vector(&mut out, c.base);
                out.push_str(", ");
                num(&mut out, c.base_radius);
                out.push_str(",\n    ");
                vector(&mut out, c.apex);
                out.push_str(", ");
                num(&mut out, c.apex_radius);
                let _ = writeln!(out, " open\n    texture {{ txt{tex:03} }}\n}}\n");
            }
            Shape::Polygon(vs) => match triangulate(vs) {
                Some(tris) => {
                    for [a, b, c] in tris {
                        triangle(&mut out, vs[a], vs[b], vs[c], tex);
                    }
                }
                None => {
                    // POV-Ray closes a polygon whose last point repeats its first.
                    let _ = write!(out, "polygon {{\n    {}", vs.len() + 1);
                    for v in vs.iter().chain(vs.first()) {
                        out.push_str(",\n    ");
                        vector(&mut out, *v);
                    }
                    let _ = writeln!(out, "\n    texture {{ txt{tex:03} }}\n}}\n");
                }
            },
            Shape::Patch(vs) => {
                // A fan from the first vertex (SPD's patches are all triangles).
                for i in 1..vs.len().saturating_sub(1) {
                    out.push_str("object {\n    smooth_triangle {\n");
                    for (k, v) in [vs[0], vs[i], vs[i + 1]].iter().enumerate() {
                        out.push_str("        ");
                        vector(&mut out, v.position);
                        out.push(' ');
                        vector(&mut out, v.normal);
                        out.push_str(if k < 2 { ",\n" } else { "\n" });
                    }
                    let _ = write!(
                        out,
                        "    }} // tri\n    texture {{ txt{tex:03} }}\n}} // object\n\n"
                    );
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An outline in the plane z = 0, from its (x, y) corners in order.
    fn outline(xy: &[(i8, i8)]) -> Vec<Vec3d> {
        xy.iter()
            .map(|&(x, y)| Vec3d::new(x.into(), y.into(), 0.0))
            .collect()
    }

    /// Twice the area of the triangles, summed, in the plane z = 0.
    fn area2(vs: &[Vec3d], tris: &[[usize; 3]]) -> f64 {
        tris.iter()
            .map(|&[a, b, c]| {
                let (a, b, c) = (vs[a], vs[b], vs[c]);
                (b - a).cross(c - a).z
            })
            .sum()
    }

    #[test]
    fn a_convex_square_becomes_two_triangles_of_its_area() {
        let sq = outline(&[(0, 0), (2, 0), (2, 2), (0, 2)]);
        let t = triangulate(&sq).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(area2(&sq, &t), 8.0);
    }

    #[test]
    fn a_concave_outline_is_cut_inside_itself() {
        // An L: six vertices, area 3, reflex corner at (1, 1).
        let l = outline(&[(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]);
        let t = triangulate(&l).unwrap();
        assert_eq!(t.len(), 4);
        assert_eq!(area2(&l, &t), 6.0);
        // Every triangle keeps the outline's winding (none flipped across the notch).
        for &[a, b, c] in &t {
            assert!((l[b] - l[a]).cross(l[c] - l[a]).z > 0.0, "{a} {b} {c}");
        }
        // Clockwise, the same outline gives the same area, wound the other way.
        let mut rev = l;
        rev.reverse();
        let t = triangulate(&rev).unwrap();
        assert_eq!(area2(&rev, &t), -6.0);
    }

    /// The numbers of the `<…>` on the line of `text` that starts with `key`.
    fn vector_after(text: &str, key: &str) -> [f64; 3] {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(key))
            .unwrap_or_else(|| panic!("no {key} line in {text}"));
        let inner = &line[line.find('<').unwrap() + 1..line.find('>').unwrap()];
        let v: Vec<f64> = inner
            .split(',')
            .map(|x| x.trim().parse().unwrap())
            .collect();
        [v[0], v[1], v[2]]
    }

    const BALLS_HEAD: &str = "b 0.078 0.361 0.753\nv\nfrom 2.1 1.3 1.7\nat 0 0 0\nup 0 0 1\n\
        angle 45\nhither 0.01\nresolution 512 512\nl 4 3 2\nl 1 -4 4\nl -3 1 5\n";

    #[test]
    fn the_camera_and_lights_are_haines_own() {
        let desc = crate::nff::parse(
            &format!("{BALLS_HEAD}f 1 0.9 0.7 0.5 0.5 3.0827 0 1\ns 0 0 0 0.5\n"),
            "balls",
            &Default::default(),
        )
        .unwrap();
        let pov = to_pov(&desc);
        // What SPD's balls generator writes with `-r 4` for this view (printed with %g).
        for (key, want) in [
            ("location", [2.1, 1.3, 1.7]),
            ("direction", [-0.700389, -0.433574, -0.566982]),
            ("right", [-0.436046, 0.704383, 0.0]),
            ("up", [-0.399372, -0.24723, 0.682401]),
        ] {
            let got = vector_after(&pov, key);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-6,
                    "{key}: {got:?} vs {want:?}"
                );
            }
        }
        assert!(pov.contains("background { color red 0.078 green 0.361 blue 0.753 }\n"));
        // Three lights, each at 1/sqrt(3).
        let light = format!("color red {0} green {0} blue {0}\n", 1.0 / 3f64.sqrt());
        assert_eq!(pov.matches("light_source {").count(), 3);
        assert_eq!(pov.matches(&light).count(), 3, "{pov}");
        assert!(pov.contains("    <1, -4, 4> color red"), "{pov}");
        assert!(
            pov.contains("sphere { <0, 0, 0>, 0.5  texture { txt001 } }\n"),
            "{pov}"
        );
    }

    #[test]
    fn finishes_follow_the_material() {
        let desc = crate::nff::parse(
            &format!(
                "{BALLS_HEAD}f 1 0.9 0.7 0.5 0.5 3.0827 0 1\ns 0 0 0 0.5\n\
                 f 1 0.605523 0.408284 0.2 0 100000 0.8 1.1\ns 0 0 1 0.5\n\
                 f 1 1 1 1 0 100000 0 0\nc 0 0 0 0.1 0 0 1 0.2\n"
            ),
            "materials",
            &Default::default(),
        )
        .unwrap();
        let pov = to_pov(&desc);
        // Haines' own texture of balls' spheres, and of gears' glass, to the byte (but for the
        // comment he leaves where a `normal` would go).
        let mirror = "#declare txt001 = texture {\n    pigment {\n        color red 1 green 0.9 \
             blue 0.7\n    } // pigment\n    finish {\n        ambient 0\n        diffuse \
             0.5\n        phong 0.5  phong_size 3.0827\n        reflection 0.5\n    } // \
             finish\n} // texture txt001\n";
        assert!(pov.contains(mirror), "{pov}");
        let glass = "        color red 1 green 0.605523 blue 0.408284 filter 0.8\n    } // \
             pigment\n    finish {\n        ambient 0\n        diffuse 0.2\n        refraction \
             1.0 ior 1.1\n    } // finish\n} // texture txt002\n";
        assert!(pov.contains(glass), "{pov}");
        assert!(
            pov.contains(
                "cone {\n    <0, 0, 0>, 0.1,\n    <0, 0, 1>, 0.2 open\n    texture { txt003 }\n}\n"
            ),
            "{pov}"
        );
    }

    #[test]
    fn a_flat_outline_has_no_triangulation() {
        let line = outline(&[(0, 0), (1, 0), (2, 0), (3, 0)]);
        assert_eq!(triangulate(&line), None);
    }
}
