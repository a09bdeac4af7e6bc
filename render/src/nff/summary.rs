//! What a parsed NFF file contains, counted the way `parrt info` and the SPD table count it:
//! spheres, cones (radii differ) and cylinders (equal radii), polygons by vertex count, patches,
//! lights, materials (`f` lines only) and the scene bounds. Reads a description; never parses.

use super::parser::ParsedNff;
use crate::description::{Bounds, Shape};
use std::collections::BTreeMap;

/// Counts of the entities of a parsed file.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// `s` entries.
    pub spheres: usize,
    /// `c` entries whose radii differ.
    pub cones: usize,
    /// `c` entries with equal radii.
    pub cylinders: usize,
    /// `p` entries.
    pub polygons: usize,
    /// `p` entries by vertex count (vertex count → number of polygons).
    pub polygons_by_vertices: BTreeMap<usize, usize>,
    /// `pp` entries.
    pub patches: usize,
    /// `pp` entries by vertex count.
    pub patches_by_vertices: BTreeMap<usize, usize>,
    /// `l` entries.
    pub lights: usize,
    /// `f` lines (not counting a default material inserted for primitives before any `f`).
    pub materials: usize,
    /// Bounding box of every primitive (empty when there are none).
    pub bounds: Bounds,
}

impl Summary {
    /// Counts the entities of `parsed`.
    pub fn of(parsed: &ParsedNff) -> Self {
        let d = &parsed.description;
        let mut s = Summary {
            spheres: 0,
            cones: 0,
            cylinders: 0,
            polygons: 0,
            polygons_by_vertices: BTreeMap::new(),
            patches: 0,
            patches_by_vertices: BTreeMap::new(),
            lights: d.lights.len(),
            materials: parsed.material_lines,
            bounds: d.bounds(),
        };
        for p in &d.primitives {
            match &p.shape {
                Shape::Sphere { .. } => s.spheres += 1,
                Shape::Cone(c) if c.is_cylinder() => s.cylinders += 1,
                Shape::Cone(_) => s.cones += 1,
                Shape::Polygon(vs) => {
                    s.polygons += 1;
                    *s.polygons_by_vertices.entry(vs.len()).or_default() += 1;
                }
                Shape::Patch(vs) => {
                    s.patches += 1;
                    *s.patches_by_vertices.entry(vs.len()).or_default() += 1;
                }
            }
        }
        s
    }

    /// Total primitives.
    pub fn primitives(&self) -> usize {
        self.spheres + self.cones + self.cylinders + self.polygons + self.patches
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nff::{parse_bytes, Limits};

    #[test]
    fn counts_each_kind() {
        let src = b"v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 4 4\n\
            l 1 1 1\ns 0 0 0 1\nf 1 1 1 1 0 0 0 0\nc 0 0 0 1 0 0 1 1\nc 0 0 0 1 0 0 1 0.5\n\
            p 3 0 0 0 1 0 0 0 1 0\np 4 0 0 0 1 0 0 1 1 0 0 1 0\npp 3 0 0 0 0 0 1 1 0 0 0 0 1 0 1 0 0 0 1\n";
        let parsed = parse_bytes(src, "t", &Limits::default()).unwrap();
        assert!(parsed.default_material_inserted);
        let s = Summary::of(&parsed);
        assert_eq!(
            (
                s.spheres,
                s.cones,
                s.cylinders,
                s.polygons,
                s.patches,
                s.lights,
                s.materials
            ),
            (1, 1, 1, 2, 1, 1, 1)
        );
        assert_eq!(s.polygons_by_vertices, BTreeMap::from([(3, 1), (4, 1)]));
        assert_eq!(s.primitives(), 6);
        assert_eq!(parsed.description.materials.len(), 2);
    }
}
