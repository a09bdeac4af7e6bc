//! The scene *description*: what an NFF file (or a generator) says, in `f64`, before any
//! render-ready preprocessing. The parser produces it, the writer prints it, the generators build
//! it, and [`crate::scene`] turns it into something to trace. It never holds derived data.

use crate::vec3::Vec3d;
pub use crate::vertices::Vertices;
use serde::{Deserialize, Serialize};

/// The `v` block: camera and image size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Eye position.
    pub from: Vec3d,
    /// Point that appears at the centre of the image.
    pub at: Vec3d,
    /// Approximate up direction (need not be perpendicular to the view).
    pub up: Vec3d,
    /// Full field of view in degrees, spanning the image's shorter side edge to edge.
    pub angle: f64,
    /// Primary rays ignore hits nearer than this.
    pub hither: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// A point light (`l`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    /// Position.
    pub position: Vec3d,
    /// Optional colour (NFF 2.7); `None` means the default white.
    pub color: Option<Vec3d>,
}

/// A material (`f r g b Kd Ks Shine T ior`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Surface colour.
    pub color: Vec3d,
    /// Diffuse weight.
    pub kd: f64,
    /// Specular weight: Phong highlight and mirror reflection.
    pub ks: f64,
    /// Phong exponent.
    pub shine: f64,
    /// Transmission weight.
    pub t: f64,
    /// Index of refraction of the inside (outside is 1); meaningful only when `t > 0`.
    pub ior: f64,
}

impl Material {
    /// The material given to primitives that come before any `f`: white, purely diffuse.
    pub fn default_white() -> Self {
        Material {
            color: Vec3d::new(1.0, 1.0, 1.0),
            kd: 1.0,
            ks: 0.0,
            shine: 0.0,
            t: 0.0,
            ior: 1.0,
        }
    }
}

/// A vertex of a polygonal patch: position and shading normal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PatchVertex {
    /// Position.
    pub position: Vec3d,
    /// Shading normal as written in the file (not necessarily unit length).
    pub normal: Vec3d,
}

/// One geometric primitive, as NFF describes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// `s`: centre and radius (negative: only the inside is visible).
    Sphere {
        /// Centre.
        center: Vec3d,
        /// Radius.
        radius: f64,
    },
    /// `c`: open truncated cone or cylinder between two circles, no caps.
    Cone(ConeShape),
    /// `p`: a planar polygon, counter-clockwise seen from the front, possibly concave.
    Polygon(Vertices),
    /// `pp`: a polygon with a normal at each vertex.
    Patch(Vec<PatchVertex>),
}

/// An NFF cone (`c` base.x base.y base.z base_radius apex.x apex.y apex.z apex_radius): the
/// open lateral surface between two circles perpendicular to the axis from `base` to `apex`,
/// without caps. Equal radii make a cylinder; one zero radius a cone with a tip. Both radii
/// negative: only the inside is visible.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConeShape {
    /// Centre of the base circle (the line's first three numbers).
    pub base: Vec3d,
    /// Radius of the base circle (the fourth number); negative for an inside-only cone.
    pub base_radius: f64,
    /// Centre of the apex circle (the fifth to seventh numbers).
    pub apex: Vec3d,
    /// Radius of the apex circle (the eighth number); may be zero (a pointed cone).
    pub apex_radius: f64,
}

impl ConeShape {
    /// The eight numbers of its NFF line, in file order.
    pub fn numbers(&self) -> [f64; 8] {
        let [bx, by, bz] = self.base.to_array();
        let [ax, ay, az] = self.apex.to_array();
        [bx, by, bz, self.base_radius, ax, ay, az, self.apex_radius]
    }

    /// True when both radii are equal: a cylinder, which the SPD counts apart from cones.
    pub fn is_cylinder(&self) -> bool {
        self.base_radius == self.apex_radius
    }

    /// Its bounding box: the boxes of its two end circles, whose planes are perpendicular to the
    /// axis.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::empty();
        let ext = disc_extent((self.apex - self.base).normalize());
        for (c, r) in [(self.base, self.base_radius), (self.apex, self.apex_radius)] {
            b.add_point(c - ext * r.abs());
            b.add_point(c + ext * r.abs());
        }
        b
    }

    /// The same cone under `x ↦ scale·x + shift`: both centres move, both radii scale.
    pub fn transformed(&self, scale: f64, shift: Vec3d) -> ConeShape {
        ConeShape {
            base: self.base * scale + shift,
            base_radius: self.base_radius * scale,
            apex: self.apex * scale + shift,
            apex_radius: self.apex_radius * scale,
        }
    }
}

/// A primitive and the index of its material in [`SceneDescription::materials`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Primitive {
    /// Geometry.
    pub shape: Shape,
    /// Index into [`SceneDescription::materials`].
    pub material: u32,
}

/// A whole scene as described by NFF.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneDescription {
    /// Background colour (`b`), black when the file has none.
    pub background: Vec3d,
    /// Camera and resolution.
    pub view: View,
    /// Point lights in file order.
    pub lights: Vec<Light>,
    /// Materials in file order (one per `f`; a leading default material when a primitive
    /// precedes every `f`).
    pub materials: Vec<Material>,
    /// Primitives in file order.
    pub primitives: Vec<Primitive>,
}

/// An axis-aligned box in `f64`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Minimum corner.
    pub min: Vec3d,
    /// Maximum corner.
    pub max: Vec3d,
}

impl Bounds {
    /// The empty box (min = +inf, max = -inf).
    pub fn empty() -> Self {
        Bounds {
            min: Vec3d::splat(f64::INFINITY),
            max: Vec3d::splat(f64::NEG_INFINITY),
        }
    }
    /// Grows the box to contain `p`.
    pub fn add_point(&mut self, p: Vec3d) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    /// Grows the box to contain `o`.
    pub fn union(&mut self, o: &Bounds) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }
    /// True when nothing was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }
}

/// Half-extent per axis of a unit-radius disc whose normal is the unit vector `axis`:
/// `sqrt(1 − a_i²)`. A disc of radius r around centre c spans exactly c ± r·extent.
pub fn disc_extent(axis: Vec3d) -> Vec3d {
    Vec3d::new(
        (1.0 - axis.x * axis.x).max(0.0).sqrt(),
        (1.0 - axis.y * axis.y).max(0.0).sqrt(),
        (1.0 - axis.z * axis.z).max(0.0).sqrt(),
    )
}

impl Shape {
    /// The shape's bounding box.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::empty();
        match self {
            Shape::Sphere { center, radius } => {
                let r = Vec3d::splat(radius.abs());
                b.add_point(*center - r);
                b.add_point(*center + r);
            }
            Shape::Cone(c) => b.union(&c.bounds()),
            Shape::Polygon(vs) => vs.iter().for_each(|v| b.add_point(*v)),
            Shape::Patch(vs) => vs.iter().for_each(|v| b.add_point(v.position)),
        }
        b
    }
}

impl SceneDescription {
    /// The same scene under `x ↦ scale·x + shift`, computed in `f64`: camera, lights and
    /// primitives move; radii and hither scale by `scale` (which must be positive); directions
    /// and patch normals are unchanged. The precision study and tests place scenes far away and
    /// at other scales with it.
    pub fn transformed(&self, scale: f64, shift: Vec3d) -> SceneDescription {
        let p = |x: Vec3d| x * scale + shift;
        let mut d = self.clone();
        d.view.from = p(d.view.from);
        d.view.at = p(d.view.at);
        d.view.hither *= scale;
        for l in &mut d.lights {
            l.position = p(l.position);
        }
        for pr in &mut d.primitives {
            match &mut pr.shape {
                Shape::Sphere { center, radius } => {
                    *center = p(*center);
                    *radius *= scale;
                }
                Shape::Cone(c) => *c = c.transformed(scale, shift),
                Shape::Polygon(vs) => vs.iter_mut().for_each(|x| *x = p(*x)),
                Shape::Patch(vs) => vs.iter_mut().for_each(|x| x.position = p(x.position)),
            }
        }
        d
    }

    /// The bounding box of every primitive (empty for a scene without primitives).
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::empty();
        for p in &self.primitives {
            b.union(&p.shape.bounds());
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> Vec3d {
        Vec3d::new(x, y, z)
    }

    /// A cylinder along z, inside-only: its line's numbers in file order, its box (the two end
    /// circles, radii taken by magnitude), and the same cylinder doubled and moved.
    #[test]
    fn a_cone_reads_back_as_its_line_and_bounds_its_two_circles() {
        let c = ConeShape {
            base: v(1.0, 2.0, 3.0),
            base_radius: -0.5,
            apex: v(1.0, 2.0, 7.0),
            apex_radius: -0.5,
        };
        assert_eq!(c.numbers(), [1.0, 2.0, 3.0, -0.5, 1.0, 2.0, 7.0, -0.5]);
        assert!(c.is_cylinder());
        let b = Shape::Cone(c).bounds();
        assert_eq!((b.min, b.max), (v(0.5, 1.5, 3.0), v(1.5, 2.5, 7.0)));
        let moved = c.transformed(2.0, v(0.0, 0.0, -1.0));
        assert_eq!(moved.numbers(), [2.0, 4.0, 5.0, -1.0, 2.0, 4.0, 13.0, -1.0]);
        let cone = ConeShape {
            apex_radius: 0.0,
            ..moved
        };
        assert!(!cone.is_cylinder());
    }
}
