//! The scene builder every generator writes through: it keeps SPD's `f`-line structure (one
//! material entry per `f` line, primitives referring to the latest one) and the size checks that
//! keep a generated scene under [`MAX_PRIMITIVES`]. It never decides geometry.

use crate::GenError;
use parrt_render::description::{
    ConeShape, Light, Material, PatchVertex, Primitive, SceneDescription, Shape, View,
};
use parrt_render::vec3::Vec3d;

/// The most primitives a generator may produce: 2^24 (16.7 million). A generated triangle costs
/// 88 bytes in a [`SceneDescription`] (its three vertices inline, see
/// [`parrt_render::vertices::Vertices`]; a gear quad about 250 with its vertex block and its share of
/// the 144-gon faces), so the largest allowed scene needs about 1.5–4 GB; the
/// limit is a quarter of the NFF parser's default primitive limit, so every scene we generate can
/// also be written out and read back with default limits. Sizes that would exceed it (mount 12,
/// balls 8, tetra 13, ...) are refused with [`GenError::BadSize`] before anything is allocated.
pub const MAX_PRIMITIVES: u64 = 1 << 24;

/// SPD's usual background colour (a mid blue).
pub const SPD_BACKGROUND: Vec3d = Vec3d::new(0.078, 0.361, 0.753);

/// Shorthand for a [`Vec3d`].
#[inline]
pub fn v3(x: f64, y: f64, z: f64) -> Vec3d {
    Vec3d::new(x, y, z)
}

/// Builds a material from the eight numbers of an `f` line.
#[allow(clippy::too_many_arguments)]
pub fn material(
    r: f64,
    g: f64,
    b: f64,
    kd: f64,
    ks: f64,
    shine: f64,
    t: f64,
    ior: f64,
) -> Material {
    Material {
        color: v3(r, g, b),
        kd,
        ks,
        shine,
        t,
        ior,
    }
}

/// Builds the `v` block.
pub fn view(from: Vec3d, at: Vec3d, up: Vec3d, angle: f64, hither: f64, res: u32) -> View {
    View {
        from,
        at,
        up,
        angle,
        hither,
        width: res,
        height: res,
    }
}

/// A light without colour (SPD never writes light colours).
pub fn light(x: f64, y: f64, z: f64) -> Light {
    Light {
        position: v3(x, y, z),
        color: None,
    }
}

/// Checks the size factor and the primitive count a generator is about to produce.
///
/// `count` is `None` when the count overflowed `u64`. Size 0 is always refused.
pub fn check_size(name: &str, size: u32, count: Option<u64>) -> Result<u64, GenError> {
    let bad = |why: String| GenError::BadSize {
        name: name.to_string(),
        size,
        why,
    };
    if size == 0 {
        return Err(bad("the size factor must be at least 1".to_string()));
    }
    match count {
        Some(n) if n <= MAX_PRIMITIVES => Ok(n),
        Some(n) => Err(bad(format!(
            "it would have {n} primitives, more than the limit of {MAX_PRIMITIVES}"
        ))),
        None => Err(bad(format!(
            "it would have more primitives than fit in 64 bits (limit {MAX_PRIMITIVES})"
        ))),
    }
}

/// Accumulates a scene in SPD's output order.
#[derive(Debug)]
pub struct SceneBuilder {
    desc: SceneDescription,
}

impl SceneBuilder {
    /// Starts a scene with its background, camera and lights; `capacity` is the expected number of
    /// primitives (reserved up front).
    pub fn new(background: Vec3d, view: View, lights: Vec<Light>, capacity: u64) -> Self {
        SceneBuilder {
            desc: SceneDescription {
                background,
                view,
                lights,
                materials: Vec::new(),
                primitives: Vec::with_capacity(usize::try_from(capacity).unwrap_or(0)),
            },
        }
    }

    /// Writes an `f` line: every primitive from now on uses `m`. A new entry is made each time,
    /// even when `m` equals the current material, so the material count equals SPD's `f` count.
    pub fn material(&mut self, m: Material) {
        self.desc.materials.push(m);
    }

    fn push(&mut self, shape: Shape) {
        // Generators always write an `f` first; fall back to the default white if one did not.
        if self.desc.materials.is_empty() {
            self.desc.materials.push(Material::default_white());
        }
        let material = (self.desc.materials.len() - 1) as u32;
        self.desc.primitives.push(Primitive { shape, material });
    }

    /// Writes a sphere.
    pub fn sphere(&mut self, center: Vec3d, radius: f64) {
        self.push(Shape::Sphere { center, radius });
    }

    /// Writes a cone or cylinder (no caps).
    pub fn cone(&mut self, base: Vec3d, base_radius: f64, apex: Vec3d, apex_radius: f64) {
        self.push(Shape::Cone(ConeShape {
            base,
            base_radius,
            apex,
            apex_radius,
        }));
    }

    /// Writes a polygon (counter-clockwise seen from the front).
    pub fn polygon(&mut self, vertices: Vec<Vec3d>) {
        self.push(Shape::Polygon(vertices.into()));
    }

    /// Writes a polygonal patch (vertices with normals).
    pub fn patch(&mut self, vertices: Vec<PatchVertex>) {
        self.push(Shape::Patch(vertices));
    }

    /// Number of primitives written so far.
    pub fn len(&self) -> usize {
        self.desc.primitives.len()
    }

    /// True when no primitive was written yet.
    pub fn is_empty(&self) -> bool {
        self.desc.primitives.is_empty()
    }

    /// The finished scene.
    pub fn finish(self) -> SceneDescription {
        self.desc
    }
}

// Generated scenes must stay readable by the parser with its default limits.
const _: () = assert!(MAX_PRIMITIVES <= parrt_render::nff::limits::DEFAULT_MAX_PRIMITIVES);
