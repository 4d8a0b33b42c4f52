//! Typed parameter lists of the pbrt format: `"float fov" [ 35 ]`, `"rgb Kd" [ .5 .5 .5 ]`,
//! `"string filename" "a.ply"`, `"bool twosided" "true"`, …
//!
//! Values are checked when they are read (numbers parse and are finite, integers are integers,
//! strings are quoted); lookups check the declared type and the number of values, and mark the
//! parameter as used. [`ParamList::finish`] then turns every parameter nobody asked for into an
//! error, so that a parameter which would change the look (`"rgb Kd"` on a mirror) is never
//! silently dropped.

use super::tokenizer::{Token, TokenKind, Tokenizer};
use crate::error::{Error, Location, Result};
use crate::math::DVec3;
use crate::spectrum::Rgb;
use std::cell::Cell;

/// Declared parameter types (pbrt-v3 names and their pbrt-v4 spellings).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ParamType {
    /// `integer`.
    Integer,
    /// `float`.
    Float,
    /// `point2`.
    Point2,
    /// `vector2`.
    Vector2,
    /// `point` / `point3`.
    Point3,
    /// `vector` / `vector3`.
    Vector3,
    /// `normal` / `normal3`.
    Normal3,
    /// `rgb` / `color`.
    Rgb,
    /// `xyz` (CIE XYZ; converted to linear sRGB).
    Xyz,
    /// `spectrum` (sampled or named spectra: unsupported).
    Spectrum,
    /// `blackbody` (unsupported).
    Blackbody,
    /// `bool`.
    Bool,
    /// `string`.
    Str,
    /// `texture` (a texture name).
    Texture,
}

impl ParamType {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "integer" => Self::Integer,
            "float" => Self::Float,
            "point2" => Self::Point2,
            "vector2" => Self::Vector2,
            "point" | "point3" => Self::Point3,
            "vector" | "vector3" => Self::Vector3,
            "normal" | "normal3" => Self::Normal3,
            "rgb" | "color" => Self::Rgb,
            "xyz" => Self::Xyz,
            "spectrum" => Self::Spectrum,
            "blackbody" => Self::Blackbody,
            "bool" => Self::Bool,
            "string" => Self::Str,
            "texture" => Self::Texture,
            _ => return None,
        })
    }

    fn is_real(self) -> bool {
        matches!(
            self,
            Self::Float
                | Self::Point2
                | Self::Vector2
                | Self::Point3
                | Self::Vector3
                | Self::Normal3
                | Self::Rgb
                | Self::Xyz
        )
    }
}

/// The values of one parameter.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Values {
    /// Reals (float, points, vectors, normals, rgb, xyz).
    Reals(Vec<f64>),
    /// Integers.
    Ints(Vec<i64>),
    /// Booleans.
    Bools(Vec<bool>),
    /// Strings and texture names.
    Strings(Vec<String>),
    /// Spectrum and blackbody values, kept only to name them in errors.
    Unsupported,
}

/// One parameter.
#[derive(Debug)]
pub(crate) struct Param {
    /// Declared type.
    pub ty: ParamType,
    /// The declaration as written, e.g. `float fov`.
    pub decl: String,
    /// Name.
    pub name: String,
    /// Values.
    pub values: Values,
    /// Where it was declared.
    pub location: Location,
    used: Cell<bool>,
}

/// A spectrum-valued argument: a constant or the name of a texture.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum SpectrumArg {
    /// A constant colour.
    Rgb(Rgb),
    /// A named texture.
    Texture(String),
}

/// A float-valued argument: a constant or the name of a (float) texture.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum FloatArg {
    /// A constant.
    Value(f64),
    /// A named texture.
    Texture(String),
}

/// The parameter list of one directive.
#[derive(Debug)]
pub(crate) struct ParamList {
    params: Vec<Param>,
    /// Where the directive was.
    pub directive: Location,
}

/// Parse the parameters following a directive's positional arguments: every quoted string that
/// follows starts a `"type name" value` pair.
pub(crate) fn parse_list(tok: &mut Tokenizer, directive: Location) -> Result<ParamList> {
    let mut params: Vec<Param> = Vec::new();
    while let Some(Token {
        kind: TokenKind::Str,
        ..
    }) = tok.peek()?
    {
        let Some(decl) = tok.next_token()? else { break };
        let location = tok.location(decl.line);
        let mut parts = decl.text.split_whitespace();
        let (Some(ty_name), Some(name), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(Error::scene(
                &location,
                format!(
                    "malformed parameter declaration \"{}\" (expected \"type name\")",
                    decl.text
                ),
            ));
        };
        let Some(ty) = ParamType::parse(ty_name) else {
            return Err(Error::scene(
                &location,
                format!(
                    "unknown parameter type `{ty_name}` in \"{}\" (known: integer, float, point2, \
                     vector2, point3, vector3, normal3, rgb, color, xyz, spectrum, blackbody, \
                     bool, string, texture)",
                    decl.text
                ),
            ));
        };
        if let Some(prev) = params.iter().find(|p| p.name == name) {
            return Err(Error::scene(
                &location,
                format!(
                    "parameter \"{name}\" given twice (first at line {})",
                    prev.location.line
                ),
            ));
        }
        let values = read_values(tok, ty, &decl, &location)?;
        params.push(Param {
            ty,
            decl: format!("{ty_name} {name}"),
            name: name.to_string(),
            values,
            location,
            used: Cell::new(false),
        });
    }
    Ok(ParamList { params, directive })
}

/// The values of one parameter, a bracketed list or a single token, converted to `ty` as they
/// are read (a mesh's millions of numbers never exist as tokens all at once).
fn read_values(
    tok: &mut Tokenizer,
    ty: ParamType,
    decl: &Token,
    location: &Location,
) -> Result<Values> {
    let missing = || {
        Error::scene(
            location,
            format!("parameter \"{}\" has no value", decl.text),
        )
    };
    let mut values = match ty {
        _ if ty.is_real() => Values::Reals(Vec::new()),
        ParamType::Integer => Values::Ints(Vec::new()),
        ParamType::Bool => Values::Bools(Vec::new()),
        ParamType::Str | ParamType::Texture => Values::Strings(Vec::new()),
        _ => Values::Unsupported,
    };
    let first = tok.next_token()?.ok_or_else(missing)?;
    match first.kind {
        TokenKind::Open => loop {
            let Some(t) = tok.next_token()? else {
                return Err(Error::scene(
                    &tok.location(first.line),
                    format!("`[` of parameter \"{}\" is never closed", decl.text),
                ));
            };
            match t.kind {
                TokenKind::Close => return Ok(values),
                TokenKind::Open => {
                    return Err(Error::scene(
                        &tok.location(t.line),
                        format!("nested `[` in the value of parameter \"{}\"", decl.text),
                    ));
                }
                _ => push_value(&mut values, &decl.text, t, tok)?,
            }
        },
        TokenKind::Close => Err(Error::scene(
            &tok.location(first.line),
            format!("unexpected `]` as the value of parameter \"{}\"", decl.text),
        )),
        _ => {
            push_value(&mut values, &decl.text, first, tok)?;
            Ok(values)
        }
    }
}

/// Parse a real number as pbrt writes them; NaN and infinities are errors.
pub(crate) fn parse_real(text: &str) -> Option<f64> {
    let v: f64 = text.parse().ok()?;
    v.is_finite().then_some(v)
}

/// Convert one value token to the kind of `values`.
fn push_value(values: &mut Values, decl: &str, t: Token, tok: &Tokenizer) -> Result<()> {
    let bad = |t: &Token, what: &str| {
        Error::scene(
            &tok.location(t.line),
            format!(
                "parameter \"{decl}\": expected {what}, found {}",
                t.describe()
            ),
        )
    };
    match values {
        Values::Reals(v) => v.push(
            (t.kind == TokenKind::Bare)
                .then(|| parse_real(&t.text))
                .flatten()
                .ok_or_else(|| bad(&t, "a finite number"))?,
        ),
        Values::Ints(v) => v.push(
            (t.kind == TokenKind::Bare)
                .then(|| t.text.parse::<i64>().ok())
                .flatten()
                .ok_or_else(|| bad(&t, "an integer"))?,
        ),
        Values::Bools(v) => v.push(match t.text.as_str() {
            "true" => true,
            "false" => false,
            _ => return Err(bad(&t, "\"true\" or \"false\"")),
        }),
        Values::Strings(v) => {
            if t.kind != TokenKind::Str {
                return Err(bad(&t, "a quoted string"));
            }
            v.push(t.text);
        }
        Values::Unsupported => {}
    }
    Ok(())
}

/// Linear sRGB (Rec. 709 primaries, D65) from CIE XYZ.
fn xyz_to_rgb(x: f64, y: f64, z: f64) -> Rgb {
    Rgb::new(
        3.240479 * x - 1.537150 * y - 0.498535 * z,
        -0.969256 * x + 1.875991 * y + 0.041556 * z,
        0.055648 * x - 0.204043 * y + 1.057311 * z,
    )
}

impl ParamList {
    fn find(&self, name: &str) -> Option<&Param> {
        let p = self.params.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    /// Whether a parameter of that name was given (does not mark it used).
    pub fn has(&self, name: &str) -> bool {
        self.params.iter().any(|p| p.name == name)
    }

    /// Where parameter `name` was declared (the directive's location when absent).
    pub fn location(&self, name: &str) -> Location {
        self.params
            .iter()
            .find(|p| p.name == name)
            .map_or_else(|| self.directive.clone(), |p| p.location.clone())
    }

    /// An error about parameter `name`, at its line.
    pub fn error(&self, name: &str, message: impl Into<String>) -> Error {
        Error::scene(&self.location(name), message)
    }

    fn wrong_type(&self, p: &Param, expected: &str) -> Error {
        Error::scene(
            &p.location,
            format!(
                "parameter \"{}\" must be given as {expected}, found \"{}\"",
                p.name, p.decl
            ),
        )
    }

    fn one<T: Copy>(&self, p: &Param, v: &[T]) -> Result<T> {
        match v {
            [x] => Ok(*x),
            _ => Err(Error::scene(
                &p.location,
                format!(
                    "parameter \"{}\" takes exactly one value, found {}",
                    p.decl,
                    v.len()
                ),
            )),
        }
    }

    fn reals_of(&self, name: &str, types: &[ParamType], expected: &str) -> Result<Option<&[f64]>> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Reals(v) if types.contains(&p.ty) => Ok(Some(v)),
            _ => Err(self.wrong_type(p, expected)),
        }
    }

    /// A single `float`.
    pub fn float(&self, name: &str) -> Result<Option<f64>> {
        let Some(v) = self.reals_of(name, &[ParamType::Float], "\"float\"")? else {
            return Ok(None);
        };
        self.find(name).map(|p| self.one(p, v)).transpose()
    }

    /// A single `integer`.
    pub fn int(&self, name: &str) -> Result<Option<i64>> {
        let v = self.ints(name)?;
        match (v, self.find(name)) {
            (Some(v), Some(p)) => self.one(p, v).map(Some),
            _ => Ok(None),
        }
    }

    /// An `integer` array.
    pub fn ints(&self, name: &str) -> Result<Option<&[i64]>> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Ints(v) => Ok(Some(v)),
            _ => Err(self.wrong_type(p, "\"integer\"")),
        }
    }

    /// A single `bool`.
    pub fn bool(&self, name: &str) -> Result<Option<bool>> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Bools(v) => self.one(p, v).map(Some),
            _ => Err(self.wrong_type(p, "\"bool\"")),
        }
    }

    /// A single `string`.
    pub fn string(&self, name: &str) -> Result<Option<&str>> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match (&p.values, p.ty) {
            (Values::Strings(v), ParamType::Str) if v.len() == 1 => Ok(Some(&v[0])),
            (Values::Strings(v), ParamType::Str) => Err(Error::scene(
                &p.location,
                format!(
                    "parameter \"{}\" takes exactly one value, found {}",
                    p.decl,
                    v.len()
                ),
            )),
            _ => Err(self.wrong_type(p, "\"string\"")),
        }
    }

    fn triples(&self, name: &str, ty: ParamType, expected: &str) -> Result<Option<Vec<DVec3>>> {
        let Some(v) = self.reals_of(name, &[ty], expected)? else {
            return Ok(None);
        };
        if !v.len().is_multiple_of(3) {
            return Err(self.error(
                name,
                format!(
                    "parameter \"{name}\" needs a multiple of 3 values, found {}",
                    v.len()
                ),
            ));
        }
        Ok(Some(
            v.chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect(),
        ))
    }

    /// A `point3` array.
    pub fn points(&self, name: &str) -> Result<Option<Vec<DVec3>>> {
        self.triples(name, ParamType::Point3, "\"point3\" (or \"point\")")
    }

    /// A `normal3` array.
    pub fn normals(&self, name: &str) -> Result<Option<Vec<DVec3>>> {
        self.triples(name, ParamType::Normal3, "\"normal3\" (or \"normal\")")
    }

    /// A `vector3` array.
    pub fn vectors(&self, name: &str) -> Result<Option<Vec<DVec3>>> {
        self.triples(name, ParamType::Vector3, "\"vector3\" (or \"vector\")")
    }

    /// A single `point3`.
    pub fn point(&self, name: &str) -> Result<Option<DVec3>> {
        match self.points(name)? {
            None => Ok(None),
            Some(v) if v.len() == 1 => Ok(Some(v[0])),
            Some(v) => Err(self.error(
                name,
                format!(
                    "parameter \"{name}\" takes one point (3 numbers), found {} numbers",
                    3 * v.len()
                ),
            )),
        }
    }

    /// Texture coordinates: `float` or `point2` pairs.
    pub fn uvs(&self, name: &str) -> Result<Option<Vec<[f64; 2]>>> {
        let Some(v) = self.reals_of(
            name,
            &[ParamType::Float, ParamType::Point2],
            "\"float\" or \"point2\"",
        )?
        else {
            return Ok(None);
        };
        if !v.len().is_multiple_of(2) {
            return Err(self.error(
                name,
                format!(
                    "parameter \"{name}\" needs an even number of values, found {}",
                    v.len()
                ),
            ));
        }
        Ok(Some(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect()))
    }

    fn unsupported_spectrum(&self, p: &Param) -> Error {
        Error::scene(
            &p.location,
            format!(
                "parameter \"{}\": \"{}\" values are not supported (this renderer is RGB); give \
                 the value as \"rgb {}\" [ r g b ]",
                p.name,
                p.decl.split(' ').next().unwrap_or_default(),
                p.name
            ),
        )
    }

    /// An RGB value from `rgb`/`color`/`xyz`; when `allow_float`, also a grey `float`.
    fn rgb_of(&self, p: &Param, allow_float: bool) -> Result<Rgb> {
        match (&p.values, p.ty) {
            (Values::Reals(v), ParamType::Rgb | ParamType::Xyz) => {
                let [a, b, c] = v[..] else {
                    return Err(Error::scene(
                        &p.location,
                        format!(
                            "parameter \"{}\" takes exactly 3 values, found {}",
                            p.decl,
                            v.len()
                        ),
                    ));
                };
                Ok(if p.ty == ParamType::Xyz {
                    xyz_to_rgb(a, b, c)
                } else {
                    Rgb::new(a, b, c)
                })
            }
            (Values::Reals(v), ParamType::Float) if allow_float => Ok(Rgb::splat(self.one(p, v)?)),
            (_, ParamType::Spectrum | ParamType::Blackbody) => Err(self.unsupported_spectrum(p)),
            _ => Err(self.wrong_type(
                p,
                if allow_float {
                    "\"rgb\" (or \"color\", \"xyz\", \"float\")"
                } else {
                    "\"rgb\" (or \"color\", \"xyz\")"
                },
            )),
        }
    }

    /// A spectrum given as `rgb`, `color` or `xyz`.
    pub fn spectrum(&self, name: &str) -> Result<Option<Rgb>> {
        self.find(name).map(|p| self.rgb_of(p, false)).transpose()
    }

    /// A spectrum given as `rgb`, `color`, `xyz`, or a grey `float` (pbrt-v4 style `scale`).
    pub fn spectrum_or_float(&self, name: &str) -> Result<Option<Rgb>> {
        self.find(name).map(|p| self.rgb_of(p, true)).transpose()
    }

    /// A spectrum or the name of a texture.
    pub fn spectrum_arg(&self, name: &str, allow_float: bool) -> Result<Option<SpectrumArg>> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        if let (ParamType::Texture, Values::Strings(v)) = (p.ty, &p.values) {
            let [n] = &v[..] else {
                return Err(Error::scene(
                    &p.location,
                    format!("parameter \"{}\" takes exactly one texture name", p.decl),
                ));
            };
            return Ok(Some(SpectrumArg::Texture(n.clone())));
        }
        self.rgb_of(p, allow_float)
            .map(|c| Some(SpectrumArg::Rgb(c)))
    }

    /// A float or the name of a texture.
    pub fn float_arg(&self, name: &str) -> Result<Option<FloatArg>> {
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        match (p.ty, &p.values) {
            (ParamType::Texture, Values::Strings(v)) if v.len() == 1 => {
                Ok(Some(FloatArg::Texture(v[0].clone())))
            }
            (ParamType::Float, Values::Reals(v)) => Ok(Some(FloatArg::Value(self.one(p, v)?))),
            _ => Err(self.wrong_type(p, "\"float\" or \"texture\"")),
        }
    }

    /// Fail on the first parameter nobody asked for, unless its name is in `harmless` (parameters
    /// that only tune pbrt's own machinery, e.g. a light's sample count).
    pub fn finish(&self, what: &str, harmless: &[&str]) -> Result<()> {
        for p in &self.params {
            if !p.used.get() && !harmless.contains(&p.name.as_str()) {
                let hint = if matches!(p.ty, ParamType::Spectrum | ParamType::Blackbody) {
                    " (spectral values are not supported either)"
                } else {
                    ""
                };
                return Err(Error::scene(
                    &p.location,
                    format!(
                        "parameter \"{}\" is not supported by {what}{hint}; refusing to ignore a \
                         parameter that may change the image",
                        p.decl
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn list(text: &str) -> Result<ParamList> {
        let mut t = Tokenizer::new(text.into(), "p.pbrt".into());
        let loc = t.location(1);
        parse_list(&mut t, loc)
    }

    #[test]
    fn typed_lookups() {
        let p = list(
            "\"float fov\" 35 \"rgb Kd\" [ .1 .2 .3 ] \"string s\" \"x\" \"bool b\" \"true\" \
             \"integer i\" [ 1 2 ] \"point P\" [0 0 0 1 1 1] \"xyz X\" [0.9505 1 1.089]",
        )
        .unwrap();
        assert_eq!(p.float("fov").unwrap(), Some(35.0));
        assert_eq!(p.spectrum("Kd").unwrap(), Some(Rgb::new(0.1, 0.2, 0.3)));
        assert_eq!(p.string("s").unwrap(), Some("x"));
        assert_eq!(p.bool("b").unwrap(), Some(true));
        assert_eq!(p.ints("i").unwrap(), Some(&[1, 2][..]));
        assert_eq!(p.points("P").unwrap().unwrap().len(), 2);
        let w = p.spectrum("X").unwrap().unwrap();
        assert!((w.0[0] - 1.0).abs() < 2e-3 && (w.0[1] - 1.0).abs() < 2e-3);
        assert!(p.int("i").is_err());
        assert!(p.float("Kd").is_err());
        p.finish("test", &[]).unwrap();
    }

    #[test]
    fn unused_and_bad_values_are_errors() {
        let p = list("\"float a\" 1\n\"float b\" 2").unwrap();
        p.float("a").unwrap();
        let e = p.finish("Material \"x\"", &[]).unwrap_err().to_string();
        assert!(e.contains("p.pbrt:2") && e.contains("float b"), "{e}");
        assert!(list("\"float a\" [ 1 nan ]").is_err());
        assert!(list("\"float a\" [ 1 inf ]").is_err());
        assert!(list("\"integer a\" [ 1.5 ]").is_err());
        assert!(list("\"flaot a\" 1").is_err());
        assert!(list("\"float a\"").is_err());
        assert!(list("\"float a\" [ 1").is_err());
        assert!(list("\"float a\" 1 \"float a\" 2").is_err());
        let p = list("\"spectrum Kd\" [ 300 .3 800 .3 ]").unwrap();
        let e = p.spectrum("Kd").unwrap_err().to_string();
        assert!(e.contains("Kd") && e.contains("spectrum"), "{e}");
    }
}
