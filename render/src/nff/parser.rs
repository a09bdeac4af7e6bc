//! The strict NFF reader: the entity grammar over the [`Lexer`]'s tokens, producing a
//! [`SceneDescription`]. Every refusal names the file, the 1-based line and column of the
//! offending token and what was expected; nothing is skipped silently, and no size read from the
//! file is allocated before it has been checked against the bytes left and the [`Limits`].
//!
//! Grammar (tokens; any whitespace separates them, `#` comments run to the end of the line):
//! `b r g b` · `v from x y z at x y z up x y z angle a hither h resolution w h` (exactly once,
//! in this order) · `l x y z [r g b]` · `f r g b Kd Ks Shine T ior` · `c bx by bz br ax ay az ar`
//! · `s x y z r` · `p n` + n × `x y z` · `pp n` + n × `x y z nx ny nz`.
//!
//! Choices where the format leaves one (docs/design-rendering.md, *NFF reading*): `b`, `l` and `v` may come after
//! objects (a late `v` is logged); a second `b` replaces the first (logged); a primitive before
//! any `f` gets [`Material::default_white`] as material 0 (logged); a first token `nff` is refused
//! as Sense8 NFF. Refused as degenerate (rules in [`super::checks`]): from = at, a zero `up` or
//! one parallel to the view, an angle outside (0, 180), a negative hither, a zero resolution, a
//! polygon or patch with fewer than 3 vertices, a cone without an axis, with exactly one
//! negative radius (`-0` is not negative) or with both radii zero, a sphere of radius zero.
//! A polygon or patch of zero area (a zero Newell normal: coincident or collinear vertices,
//! which SPD's own generators can emit) is dropped instead, and all of them are reported in
//! one warning naming the first one's line, as a missing `f` is; a file left with no
//! primitive by the dropping is refused at the first one.

use super::checks::{self, CameraProblem, ConeProblem, PolygonProblem};
use super::error::{NffError, NffErrorKind};
use super::lexer::{Lexer, Position, Token};
use super::limits::Limits;
use super::number::{self, CountError, RealError};
use crate::description::{Light, Material, PatchVertex, Primitive, SceneDescription, Shape, View};
use crate::vec3::Vec3d;
use std::path::Path;

/// A parsed file with what the description alone cannot tell.
#[derive(Clone, Debug, PartialEq)]
pub struct ParsedNff {
    /// The scene.
    pub description: SceneDescription,
    /// Number of `f` lines in the file (the inserted default material is not one).
    pub material_lines: usize,
    /// True when a primitive came before every `f`, so material 0 is
    /// [`Material::default_white`] rather than a line of the file.
    pub default_material_inserted: bool,
}

/// What a polygon of zero area is, in the parser's messages.
const ZERO_AREA: &str =
    "zero area (its Newell normal is zero: the vertices coincide or are collinear)";

/// The polygons and patches of zero area a file held, dropped as they were read.
#[derive(Default)]
struct Flat {
    /// How many.
    count: u64,
    /// The first one's entity name and keyword token.
    first: Option<(&'static str, Token)>,
}

/// Parses NFF text. `file` is the name used in error messages.
pub fn parse(src: &str, file: &str, limits: &Limits) -> Result<SceneDescription, NffError> {
    parse_bytes(src.as_bytes(), file, limits).map(|p| p.description)
}

/// Parses NFF bytes (need not be UTF-8: bytes outside tokens' ASCII grammar are refused where
/// they stand, and comments may hold anything), keeping the counts [`parse`] drops.
pub fn parse_bytes(src: &[u8], file: &str, limits: &Limits) -> Result<ParsedNff, NffError> {
    Parser {
        lx: Lexer::new(src),
        file,
        limits,
    }
    .file()
}

/// Reads and parses an NFF file.
pub fn parse_file(path: &Path, limits: &Limits) -> Result<SceneDescription, NffError> {
    parse_file_bytes(path, limits).map(|p| p.description)
}

/// Reads and parses an NFF file, keeping the counts [`parse_file`] drops. A file that cannot be
/// read (missing, unreadable, not a regular file, over [`Limits::max_file_bytes`]) is an
/// [`NffErrorKind::Io`] error at line 0, column 0.
pub fn parse_file_bytes(path: &Path, limits: &Limits) -> Result<ParsedNff, NffError> {
    let name = path.display().to_string();
    let src = super::read::read_bounded(path, limits.max_file_bytes).map_err(|e| NffError {
        file: name.clone(),
        line: 0,
        column: 0,
        message: e.to_string(),
        kind: NffErrorKind::Io,
    })?;
    parse_bytes(&src, &name, limits)
}

/// The keywords that may start an entity, for messages.
const KEYWORDS: &str = "b, v, l, f, c, s, p or pp";

/// The order of a view block, for messages.
const VIEW_ORDER: &str = "v from x y z at x y z up x y z angle a hither h resolution w h";

/// Minimum bytes one vertex of `p` takes: three numbers, each at least one byte after at least one
/// separator. `pp` vertices take twice this.
const MIN_VERTEX_BYTES: u64 = 6;

/// Which number is being read, for messages; formatted only on error.
#[derive(Clone, Copy)]
enum Field {
    /// A named field: "the sphere radius".
    Named(&'static str),
    /// A coordinate of a polygon or patch vertex.
    Vertex {
        /// "polygon" or "patch".
        entity: &'static str,
        /// "x", "normal y", ...
        what: &'static str,
        /// 1-based vertex number.
        index: u64,
        /// Declared count.
        count: u64,
    },
}

impl Field {
    fn describe(self) -> String {
        match self {
            Field::Named(s) => s.to_string(),
            Field::Vertex {
                entity,
                what,
                index,
                count,
            } => format!("the {what} of {entity} vertex {index} (its count says {count} vertices)"),
        }
    }
}

struct Parser<'a> {
    lx: Lexer<'a>,
    file: &'a str,
    limits: &'a Limits,
}

/// Shows a token in a message: lossy UTF-8, control characters escaped, long tokens cut.
fn show(bytes: &[u8]) -> String {
    const MAX: usize = 40;
    let s = String::from_utf8_lossy(&bytes[..bytes.len().min(MAX)]);
    let mut out: String = s.chars().flat_map(char::escape_debug).collect();
    if bytes.len() > MAX {
        out.push('…');
    }
    out
}

impl<'a> Parser<'a> {
    fn error_at(&self, pos: Position, kind: NffErrorKind, message: String) -> NffError {
        NffError {
            file: self.file.to_string(),
            line: pos.line,
            column: pos.column,
            message,
            kind,
        }
    }

    #[cold]
    fn syntax(&self, t: &Token, message: String) -> NffError {
        self.error_at(t.position(), NffErrorKind::Syntax, message)
    }

    #[cold]
    fn limit(&self, t: &Token, message: String) -> NffError {
        self.error_at(t.position(), NffErrorKind::Limit, message)
    }

    /// "expected X, found 'tok'" at the token, or "..., found the end of the file" at the end.
    #[cold]
    fn expected(&self, tok: Option<Token>, what: String) -> NffError {
        match tok {
            Some(t) => {
                let text = show(self.lx.text(&t));
                self.syntax(&t, format!("expected {what}, found '{text}'"))
            }
            None => {
                let pos = self.lx.end_position();
                self.error_at(
                    pos,
                    NffErrorKind::Syntax,
                    format!("expected {what}, found the end of the file (truncated?)"),
                )
            }
        }
    }

    #[cold]
    fn bad_number(&self, tok: Option<Token>, field: Field, e: Option<RealError>) -> NffError {
        let what = field.describe();
        match (tok, e) {
            (Some(t), Some(RealError::NotFinite)) => {
                let text = show(self.lx.text(&t));
                self.syntax(
                    &t,
                    format!("expected a finite number for {what}, found '{text}' (NaN and infinity are not allowed)"),
                )
            }
            (Some(t), Some(RealError::Overflow)) => {
                let text = show(self.lx.text(&t));
                self.syntax(
                    &t,
                    format!("the number '{text}' for {what} is out of range (not a finite double)"),
                )
            }
            _ => self.expected(tok, format!("a number for {what}")),
        }
    }

    /// Reads one real number and its token.
    #[inline]
    fn real_tok(&mut self, field: Field) -> Result<(f64, Token), NffError> {
        let tok = match self.lx.next_number() {
            Some((t, Some(v))) => return Ok((v, t)),
            Some((t, None)) => Some(t),
            None => None,
        };
        if let Some(t) = tok {
            match number::parse_real(self.lx.text(&t)) {
                Ok(v) => return Ok((v, t)),
                Err(e) => return Err(self.bad_number(tok, field, Some(e))),
            }
        }
        Err(self.bad_number(tok, field, None))
    }

    #[inline]
    fn real(&mut self, field: Field) -> Result<f64, NffError> {
        self.real_tok(field).map(|(v, _)| v)
    }

    #[inline]
    fn vec3(&mut self, names: &[&'static str; 3]) -> Result<Vec3d, NffError> {
        Ok(Vec3d::new(
            self.real(Field::Named(names[0]))?,
            self.real(Field::Named(names[1]))?,
            self.real(Field::Named(names[2]))?,
        ))
    }

    /// Reads a whole number (a count or a resolution) and its token.
    fn count(&mut self, what: &str) -> Result<(u64, Token), NffError> {
        let tok = self.lx.next();
        let Some(t) = tok else {
            return Err(self.expected(tok, format!("a whole number for {what}")));
        };
        match number::parse_count(self.lx.text(&t)) {
            Ok(n) => Ok((n, t)),
            Err(CountError::TooLarge) => {
                let text = show(self.lx.text(&t));
                Err(self.syntax(&t, format!("{what} '{text}' is too large")))
            }
            Err(CountError::Invalid) => {
                Err(self.expected(tok, format!("a whole number (digits only) for {what}")))
            }
        }
    }

    /// Consumes the view sub-keyword `word` or fails.
    fn view_word(&mut self, word: &str) -> Result<Token, NffError> {
        let tok = self.lx.next();
        match tok {
            Some(t) if self.lx.text(&t) == word.as_bytes() => Ok(t),
            _ => Err(self.expected(
                tok,
                format!("'{word}' in the view block (its order is: {VIEW_ORDER})"),
            )),
        }
    }

    fn file(mut self) -> Result<ParsedNff, NffError> {
        let mut background: Option<Vec3d> = None;
        let mut view: Option<(View, Token)> = None;
        let mut lights = Vec::new();
        let mut materials: Vec<Material> = Vec::new();
        // SPD files spend 50-200 bytes per primitive: reserving for one per 64 bytes avoids
        // regrowth copies and costs only untouched address space when too much.
        let guess = (self.lx.src().len() / 64) as u64;
        let mut primitives: Vec<Primitive> =
            Vec::with_capacity(guess.min(self.limits.max_primitives).min(1 << 24) as usize);
        let mut material_lines = 0usize;
        let mut default_material_inserted = false;
        // The last entity read, for "extra field" messages.
        let mut last: Option<(&'static str, Token)> = None;
        let mut first = true;
        // Polygons and patches of zero area, dropped: how many, and the first one's keyword
        // (they are reported once, after the file, in one warning).
        let mut flat = Flat::default();

        while let Some(t) = self.lx.next() {
            let kw = self.lx.text(&t);
            if first && kw.eq_ignore_ascii_case(b"nff") {
                return Err(self.syntax(
                    &t,
                    "this is a Sense8 (WorldToolKit) NFF file, which starts with 'nff'; parrt \
                     reads Eric Haines' Neutral File Format (SPD), a different format"
                        .into(),
                ));
            }
            first = false;
            let name: &'static str = match kw {
                b"b" => {
                    let c = self.vec3(&[
                        "the background red",
                        "the background green",
                        "the background blue",
                    ])?;
                    if background.is_some() {
                        tracing::warn!(
                            "{}:{}:{}: a second background 'b' replaces the first",
                            self.file,
                            t.line,
                            t.column
                        );
                    }
                    background = Some(c);
                    "background"
                }
                b"v" => {
                    if let Some((_, first_v)) = &view {
                        return Err(self.syntax(
                            &t,
                            format!(
                                "a second view block 'v' (the first is at line {}); a file has exactly one",
                                first_v.line
                            ),
                        ));
                    }
                    if !primitives.is_empty() {
                        tracing::warn!(
                            "{}:{}:{}: the view block comes after objects (allowed, but NFF puts it first)",
                            self.file,
                            t.line,
                            t.column
                        );
                    }
                    view = Some((self.view()?, t));
                    "view block"
                }
                b"l" => {
                    lights.push(self.light()?);
                    "light"
                }
                b"f" => {
                    materials.push(self.material()?);
                    material_lines += 1;
                    "material"
                }
                b"c" | b"s" | b"p" | b"pp" => {
                    if primitives.len() as u64 >= self.limits.max_primitives {
                        return Err(self.limit(
                            &t,
                            format!(
                                "more than {} primitives: the limit is {} (raise it with --max-primitives)",
                                self.limits.max_primitives, self.limits.max_primitives
                            ),
                        ));
                    }
                    let (shape, name) = match kw {
                        b"c" => (Some(self.cone(&t)?), "cone"),
                        b"s" => (Some(self.sphere()?), "sphere"),
                        b"p" => (self.polygon(&t)?, "polygon"),
                        _ => (self.patch(&t)?, "patch"),
                    };
                    let Some(shape) = shape else {
                        flat.count += 1;
                        flat.first.get_or_insert((name, t));
                        last = Some((name, t));
                        continue;
                    };
                    if materials.is_empty() {
                        tracing::warn!(
                            "{}:{}:{}: a primitive before any material 'f': using white, diffuse (Kd 1) material",
                            self.file,
                            t.line,
                            t.column
                        );
                        materials.push(Material::default_white());
                        default_material_inserted = true;
                    }
                    let material = u32::try_from(materials.len() - 1)
                        .map_err(|_| self.limit(&t, "more than 2^32 materials".to_string()))?;
                    primitives.push(Primitive { shape, material });
                    name
                }
                _ => return Err(self.unexpected(&t, last)),
            };
            last = Some((name, t));
        }

        let Some((view, _)) = view else {
            return Err(self.error_at(
                self.lx.end_position(),
                NffErrorKind::Syntax,
                format!("the file has no view block: expected one ({VIEW_ORDER}) before the end of the file"),
            ));
        };
        if let Some((entity, t)) = flat.first {
            let n = flat.count;
            if primitives.is_empty() {
                // Nothing would be left to render: refused, as before any was dropped.
                return Err(self.syntax(
                    &t,
                    format!(
                        "degenerate {entity}: {ZERO_AREA}, and the file has no other primitive \
                         to render ({n} of zero area)"
                    ),
                ));
            }
            let what = if n == 1 {
                "polygon or patch"
            } else {
                "polygons and patches"
            };
            tracing::warn!(
                "{}:{}:{}: {n} {what} of zero area dropped (the vertices coincide or are \
                 collinear); the first is this {entity}",
                self.file,
                t.line,
                t.column
            );
        }
        Ok(ParsedNff {
            description: SceneDescription {
                background: background.unwrap_or_else(Vec3d::zero),
                view,
                lights,
                materials,
                primitives,
            },
            material_lines,
            default_material_inserted,
        })
    }

    /// The error for a token where an entity keyword should be.
    #[cold]
    fn unexpected(&self, t: &Token, last: Option<(&'static str, Token)>) -> NffError {
        let text = show(self.lx.text(t));
        if number::looks_numeric(self.lx.text(t)) {
            let after = match last {
                Some((name, lt)) => {
                    format!(
                        " after the {name} at line {}, column {}",
                        lt.line, lt.column
                    )
                }
                None => String::new(),
            };
            self.syntax(
                t,
                format!("unexpected number '{text}'{after} (an extra field, or a count too small?): expected a keyword ({KEYWORDS})"),
            )
        } else {
            self.syntax(t, format!("unknown keyword '{text}': expected {KEYWORDS}"))
        }
    }

    fn view(&mut self) -> Result<View, NffError> {
        self.view_word("from")?;
        let from = self.vec3(&[
            "the view's from x",
            "the view's from y",
            "the view's from z",
        ])?;
        let at_tok = self.view_word("at")?;
        let at = self.vec3(&["the view's at x", "the view's at y", "the view's at z"])?;
        let up_tok = self.view_word("up")?;
        let up = self.vec3(&["the view's up x", "the view's up y", "the view's up z"])?;
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

    fn light(&mut self) -> Result<Light, NffError> {
        let position = self.vec3(&["the light's x", "the light's y", "the light's z"])?;
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

    fn material(&mut self) -> Result<Material, NffError> {
        let color = self.vec3(&[
            "the material's red",
            "the material's green",
            "the material's blue",
        ])?;
        Ok(Material {
            color,
            kd: self.real(Field::Named(
                "the material's Kd (f has 8 numbers: r g b Kd Ks Shine T ior)",
            ))?,
            ks: self.real(Field::Named(
                "the material's Ks (f has 8 numbers: r g b Kd Ks Shine T ior)",
            ))?,
            shine: self.real(Field::Named(
                "the material's Shine (f has 8 numbers: r g b Kd Ks Shine T ior)",
            ))?,
            t: self.real(Field::Named(
                "the material's T (f has 8 numbers: r g b Kd Ks Shine T ior)",
            ))?,
            ior: self.real(Field::Named(
                "the material's ior (f has 8 numbers: r g b Kd Ks Shine T ior)",
            ))?,
        })
    }

    fn sphere(&mut self) -> Result<Shape, NffError> {
        let center = self.vec3(&[
            "the sphere centre's x",
            "the sphere centre's y",
            "the sphere centre's z",
        ])?;
        let (radius, rt) = self.real_tok(Field::Named("the sphere radius"))?;
        if radius == 0.0 {
            return Err(self.syntax(&rt, "the sphere radius must not be zero".into()));
        }
        Ok(Shape::Sphere { center, radius })
    }

    fn cone(&mut self, kw: &Token) -> Result<Shape, NffError> {
        let base = self.vec3(&[
            "the cone base's x",
            "the cone base's y",
            "the cone base's z",
        ])?;
        let (base_radius, brt) = self.real_tok(Field::Named("the cone base radius"))?;
        let apex = self.vec3(&[
            "the cone apex's x",
            "the cone apex's y",
            "the cone apex's z",
        ])?;
        let (apex_radius, art) = self.real_tok(Field::Named("the cone apex radius"))?;
        match checks::cone(base, base_radius, apex, apex_radius) {
            Ok(()) => Ok(Shape::Cone {
                base,
                base_radius,
                apex,
                apex_radius,
            }),
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
    fn polygon(&mut self, kw: &Token) -> Result<Option<Shape>, NffError> {
        let n = self.vertex_count("polygon", MIN_VERTEX_BYTES)?;
        let mut vs = Vec::with_capacity(n);
        for i in 1..=n as u64 {
            let f = |what| Field::Vertex {
                entity: "polygon",
                what,
                index: i,
                count: n as u64,
            };
            vs.push(Vec3d::new(
                self.real(f("x"))?,
                self.real(f("y"))?,
                self.real(f("z"))?,
            ));
        }
        let flat = self.plane(kw, "polygon", checks::polygon(vs.iter().copied()))?;
        Ok((!flat).then(|| Shape::Polygon(vs.into())))
    }

    /// A patch, or `None` for one of zero area (its vertices read; the caller drops it).
    fn patch(&mut self, kw: &Token) -> Result<Option<Shape>, NffError> {
        let n = self.vertex_count("patch", 2 * MIN_VERTEX_BYTES)?;
        let mut vs = Vec::with_capacity(n);
        for i in 1..=n as u64 {
            let f = |what| Field::Vertex {
                entity: "patch",
                what,
                index: i,
                count: n as u64,
            };
            let position = Vec3d::new(self.real(f("x"))?, self.real(f("y"))?, self.real(f("z"))?);
            let normal = Vec3d::new(
                self.real(f("normal x"))?,
                self.real(f("normal y"))?,
                self.real(f("normal z"))?,
            );
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
