//! The fields of each NFF entity after its keyword (view block, light, material, sphere, cone,
//! polygon, patch), read by the [`Parser`] and checked against the geometric rules of
//! [`super::checks`]; the file grammar that dispatches on the keywords is in [`super::parser`].

use super::checks::{self, CameraProblem, ConeProblem, PolygonProblem};
use super::error::NffError;
use super::lexer::Token;
use super::number;
use super::parser::{show, Field, Parser};
use crate::description::{ConeShape, Light, Material, PatchVertex, Shape, View};

/// Minimum bytes one vertex of `p` takes: three numbers, each at least one byte after at least one
/// separator. `pp` vertices take twice this.
const MIN_VERTEX_BYTES: u64 = 6;

impl Parser<'_> {
    pub(super) fn view(&mut self) -> Result<View, NffError> {
        self.view_word("from")?;
        let from = self.point("the view's from")?;
        let at_tok = self.view_word("at")?;
        let at = self.point("the view's at")?;
        let up_tok = self.view_word("up")?;
        let up = self.point("the view's up")?;
        match checks::camera(from, at, up) {
            Ok(()) => {}
            Err(CameraProblem::NoViewDirection) => {
                return Err(self.syntax(
                    &at_tok,
                    "degenerate camera: 'from' and 'at' are the same point (or too far apart to compute), so there is no view direction".into(),
                ))
            }
            Err(CameraProblem::ZeroUp) => {
                return Err(self.syntax(&up_tok, "degenerate camera: the 'up' vector is zero".into()))
            }
            Err(CameraProblem::UpParallel) => {
                return Err(self.syntax(
                    &up_tok,
                    "degenerate camera: 'up' is parallel to the view direction (at - from)".into(),
                ))
            }
        }
        self.view_word("angle")?;
        let (angle, angle_tok) = self.real_tok(Field::Named("the view angle (degrees)"))?;
        if !(angle > 0.0 && angle < 180.0) {
            let text = show(self.lx.text(&angle_tok));
            return Err(self.syntax(
                &angle_tok,
                format!(
                    "the view angle must lie strictly between 0 and 180 degrees, found '{text}'"
                ),
            ));
        }
        self.view_word("hither")?;
        let (hither, hither_tok) = self.real_tok(Field::Named("the view's hither distance"))?;
        if hither < 0.0 {
            let text = show(self.lx.text(&hither_tok));
            return Err(self.syntax(
                &hither_tok,
                format!("the hither distance must not be negative, found '{text}'"),
            ));
        }
        self.view_word("resolution")?;
        let (w, wt) = self.count("the resolution width")?;
        let (h, ht) = self.count("the resolution height")?;
        for (v, t, name) in [(w, wt, "width"), (h, ht, "height")] {
            if v == 0 {
                return Err(self.syntax(
                    &t,
                    format!("the resolution {name} must be at least 1, found 0"),
                ));
            }
        }
        let pixels = w.checked_mul(h);
        let width = u32::try_from(w);
        let height = u32::try_from(h);
        match (width, height, pixels) {
            (Ok(width), Ok(height), Some(p)) if p <= self.limits.max_pixels => Ok(View {
                from,
                at,
                up,
                angle,
                hither,
                width,
                height,
            }),
            _ => Err(self.limit(
                &wt,
                format!(
                    "resolution {w} × {h} exceeds the limit of {} pixels (raise it with --max-pixels)",
                    self.limits.max_pixels
                ),
            )),
        }
    }

    pub(super) fn light(&mut self) -> Result<Light, NffError> {
        let position = self.point("the light's")?;
        let has_color = match self.lx.peek() {
            Some(t) => number::looks_numeric(self.lx.text(&t)),
            None => false,
        };
        let color = if has_color {
            Some(self.vec3(&[
                "the light's red (a light has 3 or 6 numbers)",
                "the light's green (a light has 3 or 6 numbers)",
                "the light's blue (a light has 3 or 6 numbers)",
            ])?)
        } else {
            None
        };
        Ok(Light { position, color })
    }

    pub(super) fn material(&mut self) -> Result<Material, NffError> {
        let color = self.vec3(&[
            "the material's red",
            "the material's green",
            "the material's blue",
        ])?;
        let names = [
            "the material's Kd (f has 8 numbers: r g b Kd Ks Shine T ior)",
            "the material's Ks (f has 8 numbers: r g b Kd Ks Shine T ior)",
            "the material's Shine (f has 8 numbers: r g b Kd Ks Shine T ior)",
            "the material's T (f has 8 numbers: r g b Kd Ks Shine T ior)",
            "the material's ior (f has 8 numbers: r g b Kd Ks Shine T ior)",
        ];
        let [kd, ks, shine, t, ior] = self.reals(names.map(Field::Named))?;
        Ok(Material {
            color,
            kd,
            ks,
            shine,
            t,
            ior,
        })
    }

    pub(super) fn sphere(&mut self) -> Result<Shape, NffError> {
        let center = self.point("the sphere centre's")?;
        let (radius, rt) = self.real_tok(Field::Named("the sphere radius"))?;
        if radius == 0.0 {
            return Err(self.syntax(&rt, "the sphere radius must not be zero".into()));
        }
        Ok(Shape::Sphere { center, radius })
    }

    pub(super) fn cone(&mut self, kw: &Token) -> Result<Shape, NffError> {
        let base = self.point("the cone base's")?;
        let (base_radius, brt) = self.real_tok(Field::Named("the cone base radius"))?;
        let apex = self.point("the cone apex's")?;
        let (apex_radius, art) = self.real_tok(Field::Named("the cone apex radius"))?;
        match checks::cone(base, base_radius, apex, apex_radius) {
            Ok(()) => Ok(Shape::Cone(ConeShape {
                base,
                base_radius,
                apex,
                apex_radius,
            })),
            Err(ConeProblem::NoAxis) => Err(self.syntax(
                kw,
                "degenerate cone: the base and apex centres are the same point (no axis)".into(),
            )),
            Err(ConeProblem::MixedSigns) => Err(self.syntax(
                if base_radius < 0.0 { &brt } else { &art },
                "cone with exactly one negative radius: both must be negative (inside only) or neither".into(),
            )),
            Err(ConeProblem::ZeroRadii) => Err(self.syntax(
                kw,
                "degenerate cone: both radii are zero".into(),
            )),
        }
    }

    /// Reads a vertex count and checks it before anything is allocated: at least 3, small enough
    /// for the bytes left in the file, and within the vertex limit.
    fn vertex_count(
        &mut self,
        entity: &'static str,
        bytes_per_vertex: u64,
    ) -> Result<usize, NffError> {
        let what = if entity == "patch" {
            "the patch's vertex count"
        } else {
            "the polygon's vertex count"
        };
        let (n, t) = self.count(what)?;
        if n < 3 {
            return Err(self.syntax(
                &t,
                format!("a {entity} needs at least 3 vertices, its count is {n}"),
            ));
        }
        let left = self.lx.remaining_after(&t) as u64;
        if n.checked_mul(bytes_per_vertex)
            .is_none_or(|need| need > left)
        {
            return Err(self.syntax(
                &t,
                format!(
                    "the {entity}'s count says {n} vertices, which need at least {bytes_per_vertex} bytes each, \
                     but only {left} bytes are left in the file: the count disagrees with the file"
                ),
            ));
        }
        if n > u64::from(self.limits.max_vertices) {
            return Err(self.limit(
                &t,
                format!(
                    "a {entity} with {n} vertices exceeds the limit of {} (raise it with --max-vertices)",
                    self.limits.max_vertices
                ),
            ));
        }
        usize::try_from(n).map_err(|_| self.limit(&t, format!("{n} vertices do not fit in memory")))
    }

    /// A polygon, or `None` for one of zero area (its vertices read; the caller drops it).
    pub(super) fn polygon(&mut self, kw: &Token) -> Result<Option<Shape>, NffError> {
        let n = self.vertex_count("polygon", MIN_VERTEX_BYTES)?;
        let mut vs = Vec::with_capacity(n);
        for i in 1..=n as u64 {
            vs.push(self.vertex_vec3("polygon", ["x", "y", "z"], i, n as u64)?);
        }
        let flat = self.plane(kw, "polygon", checks::polygon(vs.iter().copied()))?;
        Ok((!flat).then(|| Shape::Polygon(vs.into())))
    }

    /// A patch, or `None` for one of zero area (its vertices read; the caller drops it).
    pub(super) fn patch(&mut self, kw: &Token) -> Result<Option<Shape>, NffError> {
        let n = self.vertex_count("patch", 2 * MIN_VERTEX_BYTES)?;
        let mut vs = Vec::with_capacity(n);
        for i in 1..=n as u64 {
            let position = self.vertex_vec3("patch", ["x", "y", "z"], i, n as u64)?;
            let normal = ["normal x", "normal y", "normal z"];
            let normal = self.vertex_vec3("patch", normal, i, n as u64)?;
            vs.push(PatchVertex { position, normal });
        }
        let flat = self.plane(kw, "patch", checks::polygon(vs.iter().map(|v| v.position)))?;
        Ok((!flat).then_some(Shape::Patch(vs)))
    }

    /// Whether a polygon's plane is usable: `Ok(false)` yes, `Ok(true)` for zero area (such a
    /// polygon is dropped, as SPD's own generators can emit one: a teapot patch at size 1 is
    /// collinear), an error for coordinates too large to compute with.
    fn plane(
        &self,
        kw: &Token,
        entity: &str,
        r: Result<(), PolygonProblem>,
    ) -> Result<bool, NffError> {
        match r {
            Ok(()) => Ok(false),
            Err(PolygonProblem::ZeroArea) => Ok(true),
            Err(PolygonProblem::Overflow) => Err(self.syntax(
                kw,
                format!("{entity} coordinates too large: its normal overflows a double"),
            )),
        }
    }
}
