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

use super::error::{NffError, NffErrorKind};
use super::lexer::{Lexer, Position, Token};
use super::limits::Limits;
use super::number::{self, CountError, RealError};
use crate::description::{Light, Material, Primitive, SceneDescription, View};
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

/// What the file has declared so far, entity by entity.
struct Gathered {
    background: Option<Vec3d>,
    /// The view block and its keyword (for "a second view block").
    view: Option<(View, Token)>,
    lights: Vec<Light>,
    materials: Vec<Material>,
    primitives: Vec<Primitive>,
    /// `f` lines read (the inserted default material is not one).
    material_lines: usize,
    default_material_inserted: bool,
    /// Polygons and patches of zero area, dropped (reported once, after the file).
    flat: Flat,
}

impl Gathered {
    /// Nothing yet, with room for `primitives`.
    fn with_room(primitives: usize) -> Self {
        Gathered {
            background: None,
            view: None,
            lights: Vec::new(),
            materials: Vec::new(),
            primitives: Vec::with_capacity(primitives),
            material_lines: 0,
            default_material_inserted: false,
            flat: Flat::default(),
        }
    }
}

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

/// Which number is being read, for messages; formatted only on error.
#[derive(Clone, Copy)]
pub(super) enum Field {
    /// A named field: "the sphere radius".
    Named(&'static str),
    /// A coordinate of a named point: "the sphere centre's" and "x".
    Coordinate {
        /// Whose coordinate: "the sphere centre's", "the view's from".
        of: &'static str,
        /// "x", "y" or "z".
        axis: &'static str,
    },
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
            Field::Coordinate { of, axis } => format!("{of} {axis}"),
            Field::Vertex {
                entity,
                what,
                index,
                count,
            } => format!("the {what} of {entity} vertex {index} (its count says {count} vertices)"),
        }
    }
}

/// The reader's state: the tokens, the file's name for messages, and the limits.
pub(super) struct Parser<'a> {
    pub(super) lx: Lexer<'a>,
    pub(super) file: &'a str,
    pub(super) limits: &'a Limits,
}

/// Shows a token in a message: lossy UTF-8, control characters escaped, long tokens cut.
pub(super) fn show(bytes: &[u8]) -> String {
    const MAX: usize = 40;
    let s = String::from_utf8_lossy(&bytes[..bytes.len().min(MAX)]);
    let mut out: String = s.chars().flat_map(char::escape_debug).collect();
    if bytes.len() > MAX {
        out.push('…');
    }
    out
}

impl<'a> Parser<'a> {
    pub(super) fn error_at(&self, pos: Position, kind: NffErrorKind, message: String) -> NffError {
        NffError {
            file: self.file.to_string(),
            line: pos.line,
            column: pos.column,
            message,
            kind,
        }
    }

    #[cold]
    pub(super) fn syntax(&self, t: &Token, message: String) -> NffError {
        self.error_at(t.position(), NffErrorKind::Syntax, message)
    }

    #[cold]
    pub(super) fn limit(&self, t: &Token, message: String) -> NffError {
        self.error_at(t.position(), NffErrorKind::Limit, message)
    }

    /// "expected X, found 'tok'" at the token, or "..., found the end of the file" at the end.
    #[cold]
    pub(super) fn expected(&self, tok: Option<Token>, what: String) -> NffError {
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
    pub(super) fn bad_number(
        &self,
        tok: Option<Token>,
        field: Field,
        e: Option<RealError>,
    ) -> NffError {
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
    pub(super) fn real_tok(&mut self, field: Field) -> Result<(f64, Token), NffError> {
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
    pub(super) fn real(&mut self, field: Field) -> Result<f64, NffError> {
        self.real_tok(field).map(|(v, _)| v)
    }

    /// Reads `N` numbers in order; a missing or bad one is reported as its entry of `fields`.
    #[inline]
    pub(super) fn reals<const N: usize>(
        &mut self,
        fields: [Field; N],
    ) -> Result<[f64; N], NffError> {
        let mut values = [0.0; N];
        for (v, field) in values.iter_mut().zip(fields) {
            *v = self.real(field)?;
        }
        Ok(values)
    }

    #[inline]
    pub(super) fn vec3(&mut self, names: &[&'static str; 3]) -> Result<Vec3d, NffError> {
        let [x, y, z] = self.reals(names.map(Field::Named))?;
        Ok(Vec3d::new(x, y, z))
    }

    /// Reads a point's x, y and z; `of` names the point in messages ("the light's").
    #[inline]
    pub(super) fn point(&mut self, of: &'static str) -> Result<Vec3d, NffError> {
        let [x, y, z] = self.reals(["x", "y", "z"].map(|axis| Field::Coordinate { of, axis }))?;
        Ok(Vec3d::new(x, y, z))
    }

    /// Reads the three numbers `what` (such as "x", "y", "z") of vertex `index` (1-based) of an
    /// `entity` ("polygon" or "patch") declared with `count` vertices.
    #[inline]
    pub(super) fn vertex_vec3(
        &mut self,
        entity: &'static str,
        what: [&'static str; 3],
        index: u64,
        count: u64,
    ) -> Result<Vec3d, NffError> {
        let field = |what| Field::Vertex {
            entity,
            what,
            index,
            count,
        };
        let [x, y, z] = self.reals(what.map(field))?;
        Ok(Vec3d::new(x, y, z))
    }

    /// Reads a whole number (a count or a resolution) and its token.
    pub(super) fn count(&mut self, what: &str) -> Result<(u64, Token), NffError> {
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
    pub(super) fn view_word(&mut self, word: &str) -> Result<Token, NffError> {
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
        // SPD files spend 50-200 bytes per primitive: reserving for one per 64 bytes avoids
        // regrowth copies and costs only untouched address space when too much.
        let guess = (self.lx.src().len() / 64) as u64;
        let mut g =
            Gathered::with_room(guess.min(self.limits.max_primitives).min(1 << 24) as usize);
        // The last entity read, for "extra field" messages.
        let mut last: Option<(&'static str, Token)> = None;
        let mut first = true;
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
                    self.background(&t, &mut g)?;
                    "background"
                }
                b"v" => {
                    self.view_entity(&t, &mut g)?;
                    "view block"
                }
                b"l" => {
                    g.lights.push(self.light()?);
                    "light"
                }
                b"f" => {
                    g.materials.push(self.material()?);
                    g.material_lines += 1;
                    "material"
                }
                b"c" | b"s" | b"p" | b"pp" => self.primitive(kw, &t, &mut g)?,
                _ => return Err(self.unexpected(&t, last)),
            };
            last = Some((name, t));
        }
        self.finish(g)
    }

    /// A background `b` (a second one replaces the first, with a warning).
    fn background(&mut self, t: &Token, g: &mut Gathered) -> Result<(), NffError> {
        let c = self.vec3(&[
            "the background red",
            "the background green",
            "the background blue",
        ])?;
        if g.background.is_some() {
            tracing::warn!(
                "{}:{}:{}: a second background 'b' replaces the first",
                self.file,
                t.line,
                t.column
            );
        }
        g.background = Some(c);
        Ok(())
    }

    /// The view block `v` at keyword `t`: exactly one per file, after objects with a warning.
    fn view_entity(&mut self, t: &Token, g: &mut Gathered) -> Result<(), NffError> {
        if let Some((_, first_v)) = &g.view {
            return Err(self.syntax(
                t,
                format!(
                    "a second view block 'v' (the first is at line {}); a file has exactly one",
                    first_v.line
                ),
            ));
        }
        if !g.primitives.is_empty() {
            tracing::warn!(
                "{}:{}:{}: the view block comes after objects (allowed, but NFF puts it first)",
                self.file,
                t.line,
                t.column
            );
        }
        g.view = Some((self.view()?, *t));
        Ok(())
    }

    /// A primitive of keyword `kw` at `t` (`c`, `s`, `p` or `pp`), with the last material (the
    /// default white one, with a warning, before any `f`); one of zero area is counted in
    /// [`Gathered::flat`] and dropped. Returns the entity's name.
    fn primitive(
        &mut self,
        kw: &[u8],
        t: &Token,
        g: &mut Gathered,
    ) -> Result<&'static str, NffError> {
        if g.primitives.len() as u64 >= self.limits.max_primitives {
            return Err(self.limit(
                t,
                format!(
                    "more than {} primitives: the limit is {} (raise it with --max-primitives)",
                    self.limits.max_primitives, self.limits.max_primitives
                ),
            ));
        }
        let (shape, name) = match kw {
            b"c" => (Some(self.cone(t)?), "cone"),
            b"s" => (Some(self.sphere()?), "sphere"),
            b"p" => (self.polygon(t)?, "polygon"),
            _ => (self.patch(t)?, "patch"),
        };
        let Some(shape) = shape else {
            g.flat.count += 1;
            g.flat.first.get_or_insert((name, *t));
            return Ok(name);
        };
        if g.materials.is_empty() {
            tracing::warn!(
                "{}:{}:{}: a primitive before any material 'f': using white, diffuse (Kd 1) material",
                self.file,
                t.line,
                t.column
            );
            g.materials.push(Material::default_white());
            g.default_material_inserted = true;
        }
        let material = u32::try_from(g.materials.len() - 1)
            .map_err(|_| self.limit(t, "more than 2^32 materials".to_string()))?;
        g.primitives.push(Primitive { shape, material });
        Ok(name)
    }

    /// The file's end: a view block is required; the polygons and patches of zero area are
    /// reported in one warning (refused if nothing else is left to render).
    fn finish(&self, g: Gathered) -> Result<ParsedNff, NffError> {
        let Some((view, _)) = g.view else {
            return Err(self.error_at(
                self.lx.end_position(),
                NffErrorKind::Syntax,
                format!("the file has no view block: expected one ({VIEW_ORDER}) before the end of the file"),
            ));
        };
        if let Some((entity, t)) = g.flat.first {
            let n = g.flat.count;
            if g.primitives.is_empty() {
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
                background: g.background.unwrap_or_else(Vec3d::zero),
                view,
                lights: g.lights,
                materials: g.materials,
                primitives: g.primitives,
            },
            material_lines: g.material_lines,
            default_material_inserted: g.default_material_inserted,
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
}
