//! A reader of PLY triangle meshes as pbrt's `plymesh` uses them: ASCII and binary (little and big
//! endian) bodies; vertex `x y z`, optional `nx ny nz` and texture coordinates (`u v`, `s t`,
//! `texture_u texture_v` or `texture_s texture_t`); faces as lists (`vertex_indices` or
//! `vertex_index`) of any integer type, triangles and quads (a quad `0 1 2 3` becomes `0 1 2` and
//! `3 0 2`, as in pbrt). Other elements and properties are read and skipped. Truncated bodies,
//! out-of-range indices and other polygons are errors.

use crate::math::DVec3;
use thiserror::Error;

/// What can be wrong with a PLY file.
#[derive(Debug, Error, PartialEq)]
pub enum PlyError {
    /// The header is malformed.
    #[error("bad header: {0}")]
    Header(String),
    /// The body ends too early.
    #[error("truncated: the data ends while reading {0}")]
    Truncated(String),
    /// An ASCII value does not parse.
    #[error("bad value `{value}` in {context}")]
    BadValue {
        /// The text.
        value: String,
        /// Where.
        context: String,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but the file has {count} vertices")]
    IndexOutOfRange {
        /// Face number.
        face: usize,
        /// The index.
        index: i64,
        /// Number of vertices.
        count: usize,
    },
    /// A face is neither a triangle nor a quad.
    #[error("face {face} has {count} vertices; only triangles and quads are supported")]
    Polygon {
        /// Face number.
        face: usize,
        /// Its vertex count.
        count: i64,
    },
    /// A required element or property is missing.
    #[error("{0}")]
    Missing(String),
}

/// A triangle mesh read from a PLY file (object space).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyMesh {
    /// Positions.
    pub positions: Vec<DVec3>,
    /// Per-vertex normals, when the file has `nx ny nz`.
    pub normals: Option<Vec<DVec3>>,
    /// Per-vertex texture coordinates, when present.
    pub uvs: Option<Vec<[f64; 2]>>,
    /// Triangles (quads split in two).
    pub triangles: Vec<[u32; 3]>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
}

#[derive(Clone, Debug)]
enum Property {
    Scalar {
        name: String,
        ty: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar { name, .. } | Property::List { name, .. } => name,
        }
    }
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// Values of the body, in order.
trait Body {
    fn read(&mut self, ty: Scalar, context: &dyn Fn() -> String) -> Result<f64, PlyError>;
}

struct AsciiBody<'a> {
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Body for AsciiBody<'_> {
    fn read(&mut self, ty: Scalar, context: &dyn Fn() -> String) -> Result<f64, PlyError> {
        let t = self
            .tokens
            .next()
            .ok_or_else(|| PlyError::Truncated(context()))?;
        let bad = || PlyError::BadValue {
            value: t.chars().take(40).collect(),
            context: context(),
        };
        if ty.is_integer() {
            t.parse::<i64>().map(|v| v as f64).map_err(|_| bad())
        } else {
            t.parse::<f64>().map_err(|_| bad())
        }
    }
}

struct BinaryBody<'a> {
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl Body for BinaryBody<'_> {
    fn read(&mut self, ty: Scalar, context: &dyn Fn() -> String) -> Result<f64, PlyError> {
        let n = ty.size();
        let bytes = self
            .data
            .get(self.pos..self.pos + n)
            .ok_or_else(|| PlyError::Truncated(context()))?;
        self.pos += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(bytes);
        if self.big_endian {
            b[..n].reverse();
        }
        Ok(match ty {
            Scalar::I8 => i8::from_le_bytes([b[0]]) as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

/// Parse the header; returns the format, the elements and the offset of the body.
fn parse_header(data: &[u8]) -> Result<(Format, Vec<Element>, usize), PlyError> {
    let mut pos = 0;
    let mut lines = Vec::new();
    loop {
        let Some(len) = data[pos..].iter().position(|&b| b == b'\n') else {
            return Err(PlyError::Header("no `end_header` line".into()));
        };
        let line = String::from_utf8_lossy(&data[pos..pos + len])
            .trim()
            .to_string();
        pos += len + 1;
        if line == "end_header" {
            break;
        }
        lines.push(line);
        if lines.len() > 100_000 {
            return Err(PlyError::Header("no `end_header` line".into()));
        }
    }
    if lines.first().map(String::as_str) != Some("ply") {
        return Err(PlyError::Header(
            "the file does not start with `ply`".into(),
        ));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in &lines[1..] {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    _ => return Err(PlyError::Header(format!("unknown format `{f}`"))),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| PlyError::Header(format!("bad element count `{count}`")))?,
                properties: Vec::new(),
            }),
            ["property", "list", count, item, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(PlyError::Header(format!("bad list property `{line}`")));
                };
                if !count.is_integer() {
                    return Err(PlyError::Header(format!(
                        "list count of `{name}` must be an integer type"
                    )));
                }
                elements
                    .last_mut()
                    .ok_or_else(|| PlyError::Header("property before any element".into()))?
                    .properties
                    .push(Property::List {
                        name: name.to_string(),
                        count,
                        item,
                    });
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| PlyError::Header(format!("unknown property type `{ty}`")))?;
                elements
                    .last_mut()
                    .ok_or_else(|| PlyError::Header("property before any element".into()))?
                    .properties
                    .push(Property::Scalar {
                        name: name.to_string(),
                        ty,
                    });
            }
            _ => return Err(PlyError::Header(format!("unexpected line `{line}`"))),
        }
    }
    let format = format.ok_or_else(|| PlyError::Header("no `format` line".into()))?;
    Ok((format, elements, pos))
}

/// Column of each vertex attribute in the vertex element.
struct VertexLayout {
    position: [usize; 3],
    normal: Option<[usize; 3]>,
    uv: Option<[usize; 2]>,
}

fn vertex_layout(e: &Element) -> Result<VertexLayout, PlyError> {
    let col = |n: &str| {
        e.properties
            .iter()
            .position(|p| matches!(p, Property::Scalar { name, .. } if name == n))
    };
    let triple = |a, b, c| Some([col(a)?, col(b)?, col(c)?]);
    let position = triple("x", "y", "z").ok_or_else(|| {
        PlyError::Missing("the vertex element lacks scalar properties x, y, z".into())
    })?;
    let uv = [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ]
    .iter()
    .find_map(|(a, b)| Some([col(a)?, col(b)?]));
    Ok(VertexLayout {
        position,
        normal: triple("nx", "ny", "nz"),
        uv,
    })
}

/// Read a PLY mesh from the bytes of a file.
pub fn parse(data: &[u8]) -> Result<PlyMesh, PlyError> {
    let (format, elements, body_start) = parse_header(data)?;
    let vertex = elements
        .iter()
        .find(|e| e.name == "vertex")
        .ok_or_else(|| PlyError::Missing("no `vertex` element".into()))?;
    let layout = vertex_layout(vertex)?;
    let face = elements
        .iter()
        .find(|e| e.name == "face")
        .ok_or_else(|| PlyError::Missing("no `face` element".into()))?;
    if face.count == 0 {
        return Err(PlyError::Missing("the file has no faces".into()));
    }
    let index_column = face
        .properties
        .iter()
        .position(|p| {
            matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
        })
        .ok_or_else(|| {
            PlyError::Missing("the face element lacks a `vertex_indices` list".into())
        })?;
    let vertex_count = vertex.count;
    if u32::try_from(vertex_count).is_err() {
        return Err(PlyError::Header(format!(
            "too many vertices ({vertex_count})"
        )));
    }

    let body = &data[body_start..];
    let mut reader: Box<dyn Body> = match format {
        Format::Ascii => Box::new(AsciiBody {
            tokens: std::str::from_utf8(body)
                .map_err(|_| PlyError::Header("ASCII body is not valid text".into()))?
                .split_ascii_whitespace(),
        }),
        Format::BinaryLe | Format::BinaryBe => Box::new(BinaryBody {
            data: body,
            pos: 0,
            big_endian: format == Format::BinaryBe,
        }),
    };
    // Never reserve more than the file could hold (a lying header must not exhaust memory).
    let cap = |n: usize| n.min(body.len());
    let mut mesh = PlyMesh {
        positions: Vec::with_capacity(cap(vertex_count)),
        normals: layout.normal.map(|_| Vec::with_capacity(cap(vertex_count))),
        uvs: layout.uv.map(|_| Vec::with_capacity(cap(vertex_count))),
        triangles: Vec::with_capacity(cap(face.count)),
    };
    let mut row: Vec<f64> = Vec::new();
    for e in &elements {
        if e.properties.is_empty() {
            continue; // nothing to read, however large the count
        }
        for i in 0..e.count {
            row.clear();
            let mut polygon: Vec<i64> = Vec::new();
            for (c, p) in e.properties.iter().enumerate() {
                let context = || format!("{} {i} (property `{}`)", e.name, p.name());
                match p {
                    Property::Scalar { ty, .. } => row.push(reader.read(*ty, &context)?),
                    Property::List { count, item, .. } => {
                        let n = reader.read(*count, &context)?;
                        row.push(n);
                        let is_index = e.name == "face" && c == index_column;
                        if is_index && n != 3.0 && n != 4.0 {
                            return Err(PlyError::Polygon {
                                face: i,
                                count: n as i64,
                            });
                        }
                        if n < 0.0 {
                            return Err(PlyError::BadValue {
                                value: n.to_string(),
                                context: context(),
                            });
                        }
                        for _ in 0..n as u64 {
                            let v = reader.read(*item, &context)?;
                            if is_index {
                                polygon.push(v as i64);
                            }
                        }
                    }
                }
            }
            if e.name == "vertex" && std::ptr::eq(e, vertex) {
                let [x, y, z] = layout.position;
                mesh.positions.push(DVec3::new(row[x], row[y], row[z]));
                if let (Some([a, b, c]), Some(n)) = (layout.normal, mesh.normals.as_mut()) {
                    n.push(DVec3::new(row[a], row[b], row[c]));
                }
                if let (Some([a, b]), Some(uv)) = (layout.uv, mesh.uvs.as_mut()) {
                    uv.push([row[a], row[b]]);
                }
            } else if e.name == "face" && std::ptr::eq(e, face) {
                let mut idx = [0u32; 4];
                for (k, &v) in polygon.iter().enumerate() {
                    if v < 0 || v as u64 >= vertex_count as u64 {
                        return Err(PlyError::IndexOutOfRange {
                            face: i,
                            index: v,
                            count: vertex_count,
                        });
                    }
                    idx[k] = v as u32;
                }
                mesh.triangles.push([idx[0], idx[1], idx[2]]);
                if polygon.len() == 4 {
                    mesh.triangles.push([idx[3], idx[0], idx[2]]);
                }
            }
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nproperty float s\nproperty float t\nelement face 1\n\
        property list uchar int vertex_indices\nend_header\n0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n\
        0 1 0 0 1\n4 0 1 2 3\n";

    #[test]
    fn ascii_quad_is_split_like_pbrt() {
        let m = parse(ASCII.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [3, 0, 2]]);
        assert_eq!(m.uvs.unwrap()[2], [1.0, 1.0]);
        assert!(m.normals.is_none());
    }

    #[test]
    fn errors() {
        let trunc = &ASCII[..ASCII.len() - 4];
        assert!(matches!(
            parse(trunc.as_bytes()),
            Err(PlyError::Truncated(_))
        ));
        let oob = ASCII.replace("4 0 1 2 3", "3 0 1 9");
        assert!(matches!(
            parse(oob.as_bytes()),
            Err(PlyError::IndexOutOfRange { index: 9, .. })
        ));
        let pent = ASCII.replace("4 0 1 2 3", "5 0 1 2 3 0");
        assert!(matches!(
            parse(pent.as_bytes()),
            Err(PlyError::Polygon { .. })
        ));
        assert!(parse(b"plx\n").is_err());
        assert!(parse(b"ply\nformat ascii 1.0\nelement vertex 99999999999\nend_header\n").is_err());
    }
}
