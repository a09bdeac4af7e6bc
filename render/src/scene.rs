//! The render-ready scene: the description turned into primitives in the renderer's precision
//! (polygons triangulated exactly, negative radii turned into inward normals), materials, lights
//! with their SPD intensities, and the primitive bounds the accelerators are built from. Every
//! position is relative to the scene's [`crate::frame`] origin, subtracted in `f64`.

use crate::description::{SceneDescription, Shape};
use crate::geometry::aabb::Aabb;
use crate::geometry::cone::Cone;
use crate::geometry::sphere::Sphere;
use crate::geometry::triangle::{intersect_triangle, triangle_point};
use crate::geometry::triangulate::{newell_normal, triangulate};
use crate::geometry::{PreparedRay, PrimHit, Ray};
use crate::real::Real;
use crate::vec3::V3;
use thiserror::Error;

/// Errors turning a description into a scene.
#[derive(Debug, Error, PartialEq)]
pub enum SceneError {
    /// A primitive cannot be rendered.
    #[error("primitive {index} ({kind}): {reason}")]
    Degenerate {
        /// Index of the primitive in the description.
        index: usize,
        /// `sphere`, `cone`, `polygon` or `patch`.
        kind: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A primitive names a material that does not exist.
    #[error("primitive {index} uses material {material} but the scene has {count}")]
    BadMaterial {
        /// Index of the primitive.
        index: usize,
        /// The material index.
        material: u32,
        /// Number of materials.
        count: usize,
    },
    /// A value is NaN or infinite.
    #[error("{0} is not finite")]
    NotFinite(String),
    /// More primitives than the accelerators can index (2²⁹).
    #[error("too many primitives after triangulation ({0})")]
    TooMany(usize),
}

/// One traceable primitive.
#[derive(Clone, Copy, Debug)]
pub enum Prim<R> {
    /// A sphere.
    Sphere(Sphere<R>),
    /// An open cone or cylinder.
    Cone(Cone<R>),
    /// A triangle of a polygon or patch (vertices counter-clockwise around the front).
    Triangle([V3<R>; 3]),
}

/// What shading needs to know about a primitive besides its geometry.
#[derive(Clone, Copy, Debug)]
pub struct PrimInfo {
    /// Material index.
    pub material: u32,
    /// Index into [`Scene::normals`] for patch triangles, `u32::MAX` otherwise.
    pub normals: u32,
    /// The geometric normal points inward (negative radii).
    pub inward: bool,
    /// Index of the primitive in the description it came from.
    pub source: u32,
}

/// A material in the renderer's precision.
#[derive(Clone, Copy, Debug)]
pub struct Mat<R> {
    /// Surface colour.
    pub color: V3<R>,
    /// Diffuse weight.
    pub kd: R,
    /// Specular weight (highlight and mirror).
    pub ks: R,
    /// Phong exponent.
    pub shine: R,
    /// Transmission weight.
    pub t: R,
    /// Index of refraction of the inside (≤ 0 treated as 1).
    pub ior: R,
}

/// A point light with its intensity already scaled.
#[derive(Clone, Copy, Debug)]
pub struct PointLight<R> {
    /// Position.
    pub position: V3<R>,
    /// RGB intensity.
    pub intensity: V3<R>,
}

/// A hit made ready for shading.
#[derive(Clone, Copy, Debug)]
pub struct Surface<R> {
    /// Hit point.
    pub p: V3<R>,
    /// Absolute error bound of `p` per component.
    pub p_err: V3<R>,
    /// Unit geometric normal, pointing to the primitive's front (outside).
    pub ng: V3<R>,
    /// Unit shading normal on the same side as `ng`.
    pub ns: V3<R>,
    /// Material index.
    pub material: u32,
}

/// The render-ready scene.
#[derive(Clone, Debug)]
pub struct Scene<R> {
    /// Primitives; accelerators refer to them by index.
    pub prims: Vec<Prim<R>>,
    /// Per-primitive shading data, same indexing.
    pub info: Vec<PrimInfo>,
    /// Unit vertex normals of patch triangles.
    pub normals: Vec<[V3<R>; 3]>,
    /// Materials.
    pub materials: Vec<Mat<R>>,
    /// Lights.
    pub lights: Vec<PointLight<R>>,
    /// Ambient intensity (SPD: √L / 2L for L lights).
    pub ambient: R,
    /// Background colour.
    pub background: V3<R>,
    /// World position of this scene's origin ([`crate::frame`]): every position above is
    /// relative to it.
    pub origin: V3<f64>,
}

fn finite3(v: V3<f64>, what: &str) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::NotFinite(what.to_string()))
    }
}

impl<R: Real> Scene<R> {
    /// Builds the scene from a description in world coordinates (origin 0; pair it with
    /// [`crate::camera::Camera::new`]).
    pub fn build(desc: &SceneDescription) -> Result<Self, SceneError> {
        Self::build_in(desc, V3::zero())
    }

    /// Builds the scene relative to `origin` (from [`crate::frame::origin`]; pair it with
    /// [`crate::camera::Camera::in_frame`] of the same origin). Origin 0 is exactly
    /// [`Scene::build`].
    pub fn build_in(desc: &SceneDescription, origin: V3<f64>) -> Result<Self, SceneError> {
        let mut scene = Self::without_primitives(desc, origin)?;
        for (index, p) in desc.primitives.iter().enumerate() {
            scene.add_primitive(index, &p.shape, p.material)?;
        }
        scene.check_count()?;
        Ok(scene)
    }

    /// Like [`Scene::build`], but consumes the description from its last primitive back, freeing
    /// each one (and, every so often, the tail of the primitive array) as soon as it is turned
    /// into the scene's: the f64 description and the scene then never both exist in full, which
    /// halves the peak memory of a large scene. The scene is the same, in the same order; when
    /// several primitives are bad, the error names the last of them rather than the first.
    pub fn build_owned(desc: SceneDescription) -> Result<Self, SceneError> {
        Self::build_owned_in(desc, V3::zero())
    }

    /// [`Scene::build_owned`] relative to `origin`, as [`Scene::build_in`] is to [`Scene::build`].
    pub fn build_owned_in(desc: SceneDescription, origin: V3<f64>) -> Result<Self, SceneError> {
        let mut scene = Self::without_primitives(&desc, origin)?;
        let prims = desc.primitives;
        // Reserved, not touched: pages of the scene's arrays cost memory only once written.
        scene.prims.reserve(prims.len());
        scene.info.reserve(prims.len());
        // Memory is handed back every 1/32 of the primitives: the peak is then the
        // description plus a 32nd of the scene.
        crate::heap::drain_back(prims, |i, p| scene.add_primitive(i, &p.shape, p.material))?;
        scene.reverse_primitive_blocks();
        scene.check_count()?;
        Ok(scene)
    }

    /// Puts the primitives of a backward build ([`Scene::build_owned`]: the description's
    /// primitives last to first, each one's triangles in order) in the forward order, and the
    /// patch normals with them.
    fn reverse_primitive_blocks(&mut self) {
        self.prims.reverse();
        self.info.reverse();
        // Each description primitive's triangles are one run of equal `source`: put each run
        // back in its own order.
        let mut start = 0;
        while start < self.info.len() {
            let src = self.info[start].source;
            let mut end = start + 1;
            while end < self.info.len() && self.info[end].source == src {
                end += 1;
            }
            self.prims[start..end].reverse();
            self.info[start..end].reverse();
            start = end;
        }
        if !self.normals.is_empty() {
            let old = std::mem::take(&mut self.normals);
            self.normals.reserve_exact(old.len());
            for info in &mut self.info {
                if info.normals != u32::MAX {
                    self.normals.push(old[info.normals as usize]);
                    info.normals = (self.normals.len() - 1) as u32;
                }
            }
        }
    }

    /// The scene's lights, materials and background relative to `origin`, with no primitives
    /// yet.
    fn without_primitives(desc: &SceneDescription, origin: V3<f64>) -> Result<Self, SceneError> {
        if !origin.is_finite() {
            return Err(SceneError::NotFinite("frame origin".to_string()));
        }
        let nl = desc.lights.len().max(1) as f64;
        let factor = nl.sqrt() / (2.0 * nl);
        let mut lights = Vec::with_capacity(desc.lights.len());
        for (i, l) in desc.lights.iter().enumerate() {
            finite3(l.position, &format!("light {i} position"))?;
            let c = l.color.unwrap_or(V3::new(1.0, 1.0, 1.0));
            finite3(c, &format!("light {i} colour"))?;
            lights.push(PointLight {
                position: V3::from_f64(l.position - origin),
                intensity: V3::from_f64(c * factor),
            });
        }
        let mut materials = Vec::with_capacity(desc.materials.len());
        for (i, m) in desc.materials.iter().enumerate() {
            let vals = [m.kd, m.ks, m.shine, m.t, m.ior];
            if !m.color.is_finite() || vals.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::NotFinite(format!("material {i}")));
            }
            materials.push(Mat {
                color: V3::from_f64(m.color),
                kd: R::from_f64(m.kd),
                ks: R::from_f64(m.ks),
                shine: R::from_f64(m.shine),
                t: R::from_f64(m.t),
                ior: R::from_f64(if m.ior > 0.0 { m.ior } else { 1.0 }),
            });
        }
        finite3(desc.background, "background")?;
        Ok(Scene {
            prims: Vec::with_capacity(desc.primitives.len()),
            info: Vec::with_capacity(desc.primitives.len()),
            normals: Vec::new(),
            materials,
            lights,
            ambient: R::from_f64(factor),
            background: V3::from_f64(desc.background),
            origin,
        })
    }

    fn add_primitive(
        &mut self,
        index: usize,
        shape: &Shape,
        material: u32,
    ) -> Result<(), SceneError> {
        if material as usize >= self.materials.len() {
            return Err(SceneError::BadMaterial {
                index,
                material,
                count: self.materials.len(),
            });
        }
        self.add_shape(index, shape, material)
    }

    fn check_count(&self) -> Result<(), SceneError> {
        // The BVH's leaf references hold 29 bits of position.
        if self.prims.len() > crate::accel::bvh::wide::MAX_LEAF_OFFSET as usize {
            return Err(SceneError::TooMany(self.prims.len()));
        }
        Ok(())
    }

    fn push(&mut self, prim: Prim<R>, material: u32, normals: u32, inward: bool, source: usize) {
        self.prims.push(prim);
        self.info.push(PrimInfo {
            material,
            normals,
            inward,
            source: source as u32,
        });
    }

    fn add_shape(&mut self, index: usize, shape: &Shape, material: u32) -> Result<(), SceneError> {
        let degenerate = |kind: &'static str, reason: &str| SceneError::Degenerate {
            index,
            kind,
            reason: reason.to_string(),
        };
        match shape {
            Shape::Sphere { center, radius } => {
                if !center.is_finite() || !radius.is_finite() {
                    return Err(degenerate("sphere", "non-finite centre or radius"));
                }
                if *radius == 0.0 {
                    return Err(degenerate("sphere", "radius is zero"));
                }
                let s = Sphere {
                    center: V3::from_f64(*center - self.origin),
                    radius: R::from_f64(radius.abs()),
                };
                self.push(Prim::Sphere(s), material, u32::MAX, *radius < 0.0, index);
            }
            Shape::Cone(cone) => {
                let (base, apex) = (cone.base, cone.apex);
                let (r0, r1) = (cone.base_radius, cone.apex_radius);
                if !base.is_finite() || !apex.is_finite() || !r0.is_finite() || !r1.is_finite() {
                    return Err(degenerate("cone", "non-finite value"));
                }
                if (r0 < 0.0) != (r1 < 0.0) && r0 != 0.0 && r1 != 0.0 {
                    return Err(degenerate("cone", "exactly one radius is negative"));
                }
                let inward = r0 < 0.0 || r1 < 0.0;
                let c = Cone::new(
                    V3::from_f64(base - self.origin),
                    R::from_f64(r0.abs()),
                    V3::from_f64(apex - self.origin),
                    R::from_f64(r1.abs()),
                )
                .ok_or_else(|| degenerate("cone", "base equals apex or both radii are zero"))?;
                self.push(Prim::Cone(c), material, u32::MAX, inward, index);
            }
            Shape::Polygon(vs) => {
                self.add_polygon(index, vs, None, material)?;
            }
            Shape::Patch(pvs) => {
                let vs: Vec<V3<f64>> = pvs.iter().map(|v| v.position).collect();
                let ns: Vec<V3<f64>> = pvs.iter().map(|v| v.normal).collect();
                self.add_polygon(index, &vs, Some(&ns), material)?;
            }
        }
        Ok(())
    }

    fn add_polygon(
        &mut self,
        index: usize,
        vs: &[V3<f64>],
        normals: Option<&[V3<f64>]>,
        material: u32,
    ) -> Result<(), SceneError> {
        let kind = if normals.is_some() {
            "patch"
        } else {
            "polygon"
        };
        let degenerate = |reason: &str| SceneError::Degenerate {
            index,
            kind,
            reason: reason.to_string(),
        };
        if vs.len() < 3 {
            return Err(degenerate("fewer than 3 vertices"));
        }
        if vs.iter().any(|v| !v.is_finite()) {
            return Err(degenerate("non-finite vertex"));
        }
        // Relative to the frame's origin before anything is computed from the vertices (origin
        // 0: the description's own vertices, untouched).
        let rel: Vec<V3<f64>>;
        let vs = if self.origin == V3::zero() {
            vs
        } else {
            rel = vs.iter().map(|&v| v - self.origin).collect();
            &rel[..]
        };
        let n = newell_normal(vs);
        if !(n.length_squared() > 0.0) {
            return Err(degenerate("zero area (all vertices collinear)"));
        }
        let n_unit = n.normalize();
        for t in triangulate(vs) {
            let p = t.map(|i| V3::from_f64(vs[i as usize]));
            let ni = match normals {
                Some(ns) => {
                    let pick = |i: u32| {
                        let v = ns[i as usize];
                        let len = v.length();
                        // A zero or unusable normal falls back to the polygon's; every vertex
                        // normal is turned to the front side.
                        let v = if len > 0.0 && len.is_finite() {
                            v / len
                        } else {
                            n_unit
                        };
                        V3::from_f64(v.face_forward(n_unit))
                    };
                    self.normals.push(t.map(pick));
                    (self.normals.len() - 1) as u32
                }
                None => u32::MAX,
            };
            self.push(Prim::Triangle(p), material, ni, false, index);
        }
        Ok(())
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// True when the scene has no primitives.
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Conservative `f32` bounds of primitive `i`.
    pub fn prim_bounds(&self, i: usize) -> Aabb {
        match &self.prims[i] {
            Prim::Sphere(s) => {
                let c = s.center.to_f64();
                let r = V3::splat(s.radius.to_f64());
                Aabb::from_f64(c - r, c + r)
            }
            Prim::Cone(c) => {
                let a = c.axis.to_f64();
                let base = c.base.to_f64();
                let apex = base + a * c.height.to_f64();
                let r0 = c.r0.to_f64();
                let r1 = r0 + c.slope.to_f64() * c.height.to_f64();
                let ext = crate::description::disc_extent(a);
                // Widen slightly: the stored axis and slope are rounded.
                let pad = V3::splat(
                    1e-6 * (base.abs().max_component() + apex.abs().max_component() + r0 + r1),
                );
                let lo = (base - ext * r0).min(apex - ext * r1) - pad;
                let hi = (base + ext * r0).max(apex + ext * r1) + pad;
                Aabb::from_f64(lo, hi)
            }
            Prim::Triangle(p) => {
                let lo = p[0].min(p[1]).min(p[2]).to_f64();
                let hi = p[0].max(p[1]).max(p[2]).to_f64();
                Aabb::from_f64(lo, hi)
            }
        }
    }

    /// Bytes of the scene's arrays (primitives, shading data, patch normals, materials, lights):
    /// with the accelerator's bytes, the memory a render holds per primitive.
    pub fn bytes(&self) -> u64 {
        use std::mem::size_of;
        (self.prims.len() * size_of::<Prim<R>>()
            + self.info.len() * size_of::<PrimInfo>()
            + self.normals.len() * size_of::<[V3<R>; 3]>()
            + self.materials.len() * size_of::<Mat<R>>()
            + self.lights.len() * size_of::<PointLight<R>>()) as u64
    }

    /// Bounds of every primitive, by index.
    pub fn all_bounds(&self) -> Vec<Aabb> {
        (0..self.prims.len()).map(|i| self.prim_bounds(i)).collect()
    }

    /// Closest-hit test of primitive `i` against `pr` within `t_max` (inclusive).
    #[inline(always)]
    pub fn intersect_prim(&self, i: u32, pr: &PreparedRay<R>, t_max: R) -> Option<PrimHit<R>> {
        match &self.prims[i as usize] {
            Prim::Triangle(p) => intersect_triangle(pr, p[0], p[1], p[2], t_max).map(|h| PrimHit {
                t: h.t,
                prim: i,
                u: h.b1,
                v: h.b2,
            }),
            Prim::Sphere(s) => s.intersect(&pr.ray, t_max).map(|t| PrimHit {
                t,
                prim: i,
                u: R::ZERO,
                v: R::ZERO,
            }),
            Prim::Cone(c) => c.intersect(&pr.ray, t_max).map(|t| PrimHit {
                t,
                prim: i,
                u: R::ZERO,
                v: R::ZERO,
            }),
        }
    }

    /// The full surface description of a hit.
    pub fn surface(&self, ray: &Ray<R>, hit: &PrimHit<R>) -> Surface<R> {
        let info = self.info[hit.prim as usize];
        let (p, p_err, mut ng, mut ns) = match &self.prims[hit.prim as usize] {
            Prim::Triangle(v) => {
                let (p, err) = triangle_point(*v, hit.u, hit.v);
                let ng = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                let ns = if info.normals != u32::MAX {
                    let n = self.normals[info.normals as usize];
                    let b0 = R::ONE - hit.u - hit.v;
                    let s = n[0] * b0 + n[1] * hit.u + n[2] * hit.v;
                    let len = s.length();
                    if len > R::ZERO {
                        (s / len).face_forward(ng)
                    } else {
                        ng
                    }
                } else {
                    ng
                };
                (p, err, ng, ns)
            }
            Prim::Sphere(s) => {
                let (p, err, n) = s.surface(ray, hit.t);
                (p, err, n, n)
            }
            Prim::Cone(c) => {
                let (p, err, n) = c.surface(ray, hit.t);
                (p, err, n, n)
            }
        };
        if info.inward {
            ng = -ng;
            ns = -ns;
        }
        Surface {
            p,
            p_err,
            ng,
            ns,
            material: info.material,
        }
    }
}
