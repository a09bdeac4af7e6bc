//! `--precision auto`: decides from the description, before anything is built, whether `f32`
//! in the rebased frame ([`crate::frame`]) resolves the scene, and says why.
//!
//! A feature of size F at distance L from the frame's origin (the larger of its own coordinates
//! and the eye's, where rays start: L ≥ every coordinate the intersection computes with; exact
//! when the origin is 0, else bounded by its distance from the eye plus the eye's from the
//! origin) has its coordinates rounded by up to u·L (u: the unit round-off) and its hit points carry the error
//! bound γ₇·L (the triangle's, [`crate::geometry::triangle`]; spheres and cones carry less), by
//! which spawned rays are pushed off the surface. Two kinds of feature must survive that:
//!
//! - **shading features** — the shortest polygon edge, the smallest sphere or cone radius, the
//!   shortest cone: normals are computed from them, and their direction errs by about γ₃·L/F;
//!   `f32` suffices while that is under one 8-bit step: `L/F ≤ 1/(256·γ₃) ≈ 21,845`;
//! - **separations** — the thinnest polygon (twice its area over its longest edge) and the
//!   smallest gap between neighbouring primitives in a sample: a ray spawned from one side must
//!   not be pushed through to the other, `2·√3·γ₇·L ≤ F`: `L/F ≤ 1/(2√3·γ₇) ≈ 6.9·10⁵`.
//!
//! And the numbers must stay in range: intersection tests square and multiply coordinates up to
//! four deep (a sphere's discriminant, a triangle's normal before it is normalised), so the
//! largest coordinate must stay below ⁴√MAX/4 (1.1·10⁹ for `f32`) and the smallest feature above
//! 4·⁴√MIN_POSITIVE (1.3·10⁻⁹ for `f32`).
//!
//! When all hold, `f32`; otherwise `f64`, whose ratio limits are 2²⁹ ≈ 5·10⁸ times larger and
//! whose range reaches 10⁷⁶.
//!
//! One pass over the primitives — all of them up to [`frame::SAMPLE_LIMIT`], every k-th of a
//! larger scene (the same ones the frame's origin is chosen from), without square roots — and
//! pairwise gaps among 128 of those: under a percent of parsing the same file. A lone
//! sliver among millions of primitives can escape the sample; `--precision f64` forces the
//! reference.

use crate::description::{Bounds, SceneDescription, Shape};
use crate::frame;
use crate::real::Real;
use crate::settings::Precision;
use crate::vec3::Vec3d;

/// A normal may turn by at most this (radians): one 8-bit step of shading.
const SHADE_STEP: f64 = 1.0 / 256.0;
/// Rounded operations behind a normal's error (γ₃).
const SHADE_OPS: u32 = 3;
/// Rounded operations behind a hit point's error bound (the triangle's γ₇).
const BOUND_OPS: u32 = 7;
/// Primitives sampled for the nearest-neighbour gap (pairwise among the sample).
const GAP_SAMPLE: usize = 128;
/// Gaps below this fraction of the coordinates are `f64` rounding of touching primitives.
const TOUCHING: f64 = 64.0 * f64::EPSILON;

/// The hardest feature of one kind: the largest distance-over-size ratio.
#[derive(Clone, Debug, PartialEq)]
pub struct Feature {
    /// Distance from the origin over size (0 when the scene has no such feature).
    pub ratio: f64,
    /// Its size.
    pub size: f64,
    /// What it is (`"polygon 12 edge"`, `"sphere 3 radius"`, `"primitives 40 gap"`, ...).
    pub what: String,
}

/// What the estimate measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// The frame's origin ([`crate::frame::origin`]).
    pub origin: Vec3d,
    /// The largest |coordinate − origin| over the sampled primitives' bounds and the eye.
    pub extent: f64,
    /// The smallest feature of any kind (∞ for a scene without primitives).
    pub smallest: f64,
    /// The hardest shading feature (edge, radius, cone length).
    pub shading: Feature,
    /// The hardest separation (polygon thickness, sampled gap).
    pub separation: Feature,
}

/// The largest distance/shading-feature ratio precision `R` resolves.
pub fn max_shading_ratio<R: Real>() -> f64 {
    SHADE_STEP / R::gamma(SHADE_OPS).to_f64()
}

/// The largest distance/separation ratio precision `R` resolves.
pub fn max_separation_ratio<R: Real>() -> f64 {
    1.0 / (2.0 * 3f64.sqrt() * R::gamma(BOUND_OPS).to_f64())
}

/// The largest coordinate and the smallest feature precision `R` keeps in range.
pub fn range<R: Real>() -> (f64, f64) {
    let (max, min) = (R::MAX.to_f64(), R::MIN_POSITIVE.to_f64());
    (max.sqrt().sqrt() / 4.0, min.sqrt().sqrt() * 4.0)
}

impl Estimate {
    /// Whether the scene's numbers stay in precision `R`'s range.
    fn in_range<R: Real>(&self) -> bool {
        let (hi, lo) = range::<R>();
        self.extent <= hi && !(self.smallest < lo)
    }

    /// Whether precision `R` resolves the scene by every rule.
    pub fn fits<R: Real>(&self) -> bool {
        self.in_range::<R>()
            && self.shading.ratio <= max_shading_ratio::<R>()
            && self.separation.ratio <= max_separation_ratio::<R>()
    }

    /// The rule closest to (or past) its `f32` limit, as text.
    fn binding(&self) -> String {
        if !self.in_range::<f32>() {
            let (hi, lo) = range::<f32>();
            return format!(
                "origin ({}, {}, {}), extent {:.3e}, smallest feature {:.3e}: out of f32's range \
                 [{lo:.1e}, {hi:.1e}] for products of four coordinates",
                self.origin.x, self.origin.y, self.origin.z, self.extent, self.smallest
            );
        }
        let (ls, lg) = (max_shading_ratio::<f32>(), max_separation_ratio::<f32>());
        let (f, l, rule) = if self.shading.ratio / ls >= self.separation.ratio / lg {
            (&self.shading, ls, "shading feature")
        } else {
            (&self.separation, lg, "separation")
        };
        format!(
            "origin ({}, {}, {}), extent {:.3e}; hardest {rule}: {} of {:.3e} at {:.3e}·its size \
             from the origin {} {:.0} (f32's limit)",
            self.origin.x,
            self.origin.y,
            self.origin.z,
            self.extent,
            f.what,
            f.size,
            f.ratio,
            if f.ratio <= l { "≤" } else { ">" },
            l
        )
    }
}

/// The precision a render uses and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// `F32` or `F64`, never `Auto`.
    pub precision: Precision,
    /// One line for `--stats` and `info --json`.
    pub reason: String,
}

/// The hardest feature so far. The frame's origin is known only once every primitive has been
/// seen; it is 0 for most scenes, so the exact ratio from the world origin is kept, and for a
/// rebased scene the bound `max d/F + e·max 1/F`: a feature's distance from the origin is at
/// most its distance d from the eye plus the eye's e from the origin (at most twice exact).
struct Hardest {
    /// Largest max(|p|², |eye|²)/F² from the world origin, and the feature it came from.
    world_sq: f64,
    world: (f64, &'static str, &'static str, usize),
    /// Largest d²/F², and the feature it came from.
    far_sq: f64,
    far: (f64, &'static str, &'static str, usize),
    /// Smallest F², and the feature it came from.
    small_sq: f64,
    small: (&'static str, &'static str, usize),
}

impl Hardest {
    fn new() -> Self {
        Hardest {
            world_sq: 0.0,
            world: (0.0, "", "", 0),
            far_sq: 0.0,
            far: (0.0, "", "", 0),
            small_sq: f64::INFINITY,
            small: ("", "", 0),
        }
    }

    /// Offers a feature of squared size `size_sq` at squared distance `d_sq` from the eye and
    /// `w_sq` from the world origin (at least the eye's).
    #[inline]
    fn offer(
        &mut self,
        size_sq: f64,
        (d_sq, w_sq): (f64, f64),
        kind: &'static str,
        what: &'static str,
        index: usize,
    ) {
        if size_sq > 0.0 {
            let w = w_sq / size_sq;
            if w > self.world_sq {
                self.world_sq = w;
                self.world = (size_sq, kind, what, index);
            }
            let r = d_sq / size_sq;
            if r > self.far_sq {
                self.far_sq = r;
                self.far = (size_sq, kind, what, index);
            }
            if size_sq < self.small_sq {
                self.small_sq = size_sq;
                self.small = (kind, what, index);
            }
        }
    }

    /// The feature with the eye `e` from the `origin`.
    fn feature(&self, origin: Vec3d, e: f64) -> Feature {
        if !self.small_sq.is_finite() {
            return Feature {
                ratio: 0.0,
                size: 0.0,
                what: "none".to_string(),
            };
        }
        if origin == Vec3d::zero() {
            let (size_sq, kind, what, index) = self.world;
            return Feature {
                ratio: self.world_sq.sqrt(),
                size: size_sq.sqrt(),
                what: format!("{kind} {index} {what}"),
            };
        }
        let far = self.far_sq.sqrt();
        let small = self.small_sq.sqrt();
        let ratio = far + e / small;
        // Name the term that dominates.
        let (size, (kind, what, index)) = if far >= e / small {
            (self.far.0.sqrt(), (self.far.1, self.far.2, self.far.3))
        } else {
            (small, self.small)
        };
        Feature {
            ratio,
            size,
            what: format!("{kind} {index} {what}"),
        }
    }
}

/// Polygon features: shortest edge² and (2·area / longest edge)², without square roots.
fn polygon_features(vs: impl Iterator<Item = Vec3d> + Clone) -> (f64, f64) {
    let mut it = vs.clone();
    let Some(first) = it.next() else {
        return (0.0, 0.0);
    };
    let (mut prev, mut min_e, mut max_e) = (first, f64::INFINITY, 0.0f64);
    let mut twice_area = Vec3d::zero();
    for v in it {
        let e = (v - prev).length_squared();
        if e > 0.0 {
            min_e = min_e.min(e);
        }
        max_e = max_e.max(e);
        twice_area += (prev - first).cross(v - first);
        prev = v;
    }
    let e = (first - prev).length_squared();
    if e > 0.0 {
        min_e = min_e.min(e);
    }
    max_e = max_e.max(e);
    let thin = if max_e > 0.0 {
        twice_area.length_squared() / max_e
    } else {
        0.0
    };
    (min_e, thin)
}

/// Squared Euclidean gap between two boxes: 0 when they overlap or touch, where a gap within
/// `f64`'s own rounding of their coordinates (touching spheres computed in `f64`) is touching.
fn gap_sq(a: &Bounds, b: &Bounds) -> f64 {
    let axis = |alo: f64, ahi: f64, blo: f64, bhi: f64| {
        let g = (blo - ahi).max(alo - bhi);
        let scale = alo.abs().max(ahi.abs()).max(blo.abs()).max(bhi.abs());
        if g > TOUCHING * scale {
            g
        } else {
            0.0
        }
    };
    let dx = axis(a.min.x, a.max.x, b.min.x, b.max.x);
    let dy = axis(a.min.y, a.max.y, b.min.y, b.max.y);
    let dz = axis(a.min.z, a.max.z, b.min.z, b.max.z);
    dx * dx + dy * dy + dz * dz
}

/// Largest |coordinate − eye| of a box, squared, and largest |coordinate| or |eye|, squared.
fn reach_sq(b: &Bounds, eye: Vec3d) -> (f64, f64) {
    let d = (b.min - eye).abs().max((b.max - eye).abs()).max_component();
    let w = b.min.abs().max(b.max.abs()).max(eye.abs()).max_component();
    (d * d, w * w)
}

/// Measures `desc`: the frame's origin, the extent seen from it and the hardest features.
pub fn estimate(desc: &SceneDescription) -> Estimate {
    let n = desc.primitives.len();
    let step = frame::sample_stride(n);
    let last = n.checked_sub(1).filter(|&l| l % step != 0);
    let looked = n.div_ceil(step);
    let gap_every = looked.div_ceil(GAP_SAMPLE).max(1);
    let eye = desc.view.from;
    let mut bounds = Bounds::empty();
    let (mut shade, mut sep) = (Hardest::new(), Hardest::new());
    let mut sample: Vec<(usize, Bounds, (f64, f64))> = Vec::with_capacity(GAP_SAMPLE + 1);
    // One pass over the description (its polygons live all over the heap).
    for (k, i) in (0..n).step_by(step).chain(last).enumerate() {
        let p = &desc.primitives[i];
        let b = p.shape.bounds();
        bounds.union(&b);
        let d = reach_sq(&b, eye);
        match &p.shape {
            Shape::Sphere { radius, .. } => {
                shade.offer(radius * radius, d, "sphere", "radius", i);
            }
            Shape::Cone(c) => {
                shade.offer(c.base_radius * c.base_radius, d, "cone", "radius", i);
                shade.offer(c.apex_radius * c.apex_radius, d, "cone", "radius", i);
                let len = (c.apex - c.base).length_squared();
                shade.offer(len, d, "cone", "length", i);
            }
            Shape::Polygon(vs) => {
                let (e, t) = polygon_features(vs.iter().copied());
                shade.offer(e, d, "polygon", "edge", i);
                sep.offer(t, d, "polygon", "thickness", i);
            }
            Shape::Patch(vs) => {
                let (e, t) = polygon_features(vs.iter().map(|v| v.position));
                shade.offer(e, d, "patch", "edge", i);
                sep.offer(t, d, "patch", "thickness", i);
            }
        }
        if k % gap_every == 0 {
            sample.push((i, b, d));
        }
    }
    // Nearest-neighbour gap among 128 of them: primitives that do not touch but
    // nearly do (a decal above a floor, stacked layers) must stay apart.
    for (a, (ia, ba, ra)) in sample.iter().enumerate() {
        for (_, bb, rb) in &sample[a + 1..] {
            let d = (ra.0.max(rb.0), ra.1.max(rb.1));
            sep.offer(gap_sq(ba, bb), d, "primitives", "gap", *ia);
        }
    }
    let origin = frame::origin_for(&bounds, eye);
    let e = (eye - origin).abs().max_component();
    let mut extent = e;
    if !bounds.is_empty() {
        extent = extent
            .max((bounds.min - origin).abs().max_component())
            .max((bounds.max - origin).abs().max_component());
    }
    Estimate {
        origin,
        extent,
        smallest: shade.small_sq.min(sep.small_sq).sqrt(),
        shading: shade.feature(origin, e),
        separation: sep.feature(origin, e),
    }
}

/// The precision to render `desc` with when `requested` was asked for: `Auto` decides by
/// [`estimate`]; `F32` and `F64` are kept (the reason then says what auto would have said).
pub fn resolve(requested: Precision, desc: &SceneDescription) -> Choice {
    let e = estimate(desc);
    let fits32 = e.fits::<f32>();
    let why = e.binding();
    let auto = if fits32 {
        format!("f32 resolves it: {why}")
    } else if e.fits::<f64>() {
        format!("f32 does not resolve it, f64 does: {why}")
    } else {
        format!("not even f64 resolves it, f64 is the best there is: {why}")
    };
    match requested {
        Precision::Auto => Choice {
            precision: if fits32 {
                Precision::F32
            } else {
                Precision::F64
            },
            reason: format!("auto: {auto}"),
        },
        Precision::F32 if !fits32 => Choice {
            precision: Precision::F32,
            reason: format!("forced; auto would pick f64: {auto}"),
        },
        forced => Choice {
            precision: forced,
            reason: format!("forced; {auto}"),
        },
    }
}

/// The lower-case name of a precision.
pub fn name(p: Precision) -> &'static str {
    match p {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
        Precision::Auto => "auto",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::{Material, Primitive, View};

    fn desc(shapes: Vec<Shape>, from: Vec3d) -> SceneDescription {
        SceneDescription {
            background: Vec3d::zero(),
            view: View {
                from,
                at: Vec3d::zero(),
                up: Vec3d::new(0.0, 0.0, 1.0),
                angle: 45.0,
                hither: 0.0,
                width: 8,
                height: 8,
            },
            lights: vec![],
            materials: vec![Material::default_white()],
            primitives: shapes
                .into_iter()
                .map(|shape| Primitive { shape, material: 0 })
                .collect(),
        }
    }

    fn tri(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Shape {
        Shape::Polygon(
            vec![
                Vec3d::from_array(a),
                Vec3d::from_array(b),
                Vec3d::from_array(c),
            ]
            .into(),
        )
    }

    #[test]
    fn limits_follow_the_unit_roundoff() {
        let s = max_shading_ratio::<f32>();
        assert!(s > 21_000.0 && s < 22_000.0, "{s}");
        let g = max_separation_ratio::<f32>();
        assert!(g > 6e5 && g < 7e5, "{g}");
        assert!(max_shading_ratio::<f64>() > 5e8 * s);
    }

    #[test]
    fn thin_triangle_and_small_sphere_are_features() {
        let d = desc(
            vec![
                tri([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [5.0, 0.001, 0.0]),
                Shape::Sphere {
                    center: Vec3d::new(0.0, 5.0, 0.0),
                    radius: 0.5,
                },
            ],
            Vec3d::new(0.0, -10.0, 0.0),
        );
        let e = estimate(&d);
        assert!((e.separation.size - 0.001).abs() < 1e-9, "{e:?}");
        assert_eq!(e.separation.what, "polygon 0 thickness");
        // Origin 0: the larger of its own distance and the eye's, 10, over 0.001.
        assert!((e.separation.ratio - 1e4).abs() < 1e-3, "{e:?}");
        assert_eq!(e.shading.size, 0.5);
        assert_eq!(e.shading.what, "sphere 1 radius");
        assert_eq!(e.origin, Vec3d::zero());
        assert_eq!(e.extent, 10.0);
    }

    #[test]
    fn translation_does_not_change_the_choice_but_distance_does() {
        let shapes = |t: Vec3d| {
            vec![Shape::Sphere {
                center: t,
                radius: 0.01,
            }]
        };
        let near = desc(shapes(Vec3d::zero()), Vec3d::new(0.0, -10.0, 0.0));
        let t = Vec3d::new(1e7, -1e7, 3e6);
        let far = desc(shapes(t), t + Vec3d::new(0.0, -10.0, 0.0));
        let (a, b) = (
            resolve(Precision::Auto, &near),
            resolve(Precision::Auto, &far),
        );
        assert_eq!(a.precision, Precision::F32, "{}", a.reason);
        assert_eq!(b.precision, Precision::F32, "{}", b.reason);
        // The same sphere seen from 1e4 radii... 1e7 units away needs f64.
        let distant = desc(shapes(Vec3d::zero()), Vec3d::new(0.0, -1e7, 0.0));
        let c = resolve(Precision::Auto, &distant);
        assert_eq!(c.precision, Precision::F64, "{}", c.reason);
        assert!(c.reason.starts_with("auto: "));
        let forced = resolve(Precision::F32, &distant);
        assert_eq!(forced.precision, Precision::F32);
        assert!(forced.reason.contains("auto would pick f64"));
    }

    #[test]
    fn close_layers_are_a_feature() {
        let d = desc(
            vec![
                tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                tri([0.0, 0.0, 1e-6], [1.0, 0.0, 1e-6], [0.0, 1.0, 1e-6]),
            ],
            Vec3d::new(0.0, -3.0, 1.0),
        );
        let e = estimate(&d);
        assert!((e.separation.size - 1e-6).abs() < 1e-12, "{e:?}");
        assert_eq!(resolve(Precision::Auto, &d).precision, Precision::F64);
    }

    #[test]
    fn huge_and_tiny_scenes_leave_f32_range() {
        let (hi, lo) = range::<f32>();
        assert!(
            hi > 1e9 && hi < 1.1e9 && lo > 1e-9 && lo < 2e-9,
            "{hi} {lo}"
        );
        let ball = |s: f64| {
            desc(
                vec![Shape::Sphere {
                    center: Vec3d::zero(),
                    radius: s,
                }],
                Vec3d::new(0.0, -3.0 * s, 0.0),
            )
        };
        assert_eq!(
            resolve(Precision::Auto, &ball(1.0)).precision,
            Precision::F32
        );
        let huge = resolve(Precision::Auto, &ball(1e9));
        assert_eq!(huge.precision, Precision::F64);
        assert!(huge.reason.contains("range"), "{}", huge.reason);
        assert_eq!(
            resolve(Precision::Auto, &ball(1e-10)).precision,
            Precision::F64
        );
    }

    #[test]
    fn empty_scene_is_f32() {
        let d = desc(vec![], Vec3d::new(0.0, -3.0, 1.0));
        assert_eq!(resolve(Precision::Auto, &d).precision, Precision::F32);
    }
}
