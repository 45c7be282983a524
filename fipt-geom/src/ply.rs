//! The PLY reader: ASCII, binary little- and big-endian; `vertex` x y z [nx ny nz] and `face`
//! `vertex_indices` (or `vertex_index`) lists, polygons fanned into triangles; other elements
//! and properties are read past.
use crate::error::parse_err;
use crate::error::{GeomError, Result};
use crate::mesh::{fan, Mesh};
use glam::Vec3;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    Le,
    Be,
}

#[derive(Clone, Debug)]
enum Prop {
    /// (type, name)
    Scalar(String, String),
    /// (count type, item type, name)
    List(String, String, String),
}

struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

fn size_of(ty: &str) -> Option<usize> {
    Some(match ty {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "int32" | "uint32" | "float" | "float32" => 4,
        "double" | "float64" => 8,
        _ => return None,
    })
}

fn read_bin(r: &mut impl Read, ty: &str, fmt: Format) -> std::io::Result<f64> {
    let n = size_of(ty).unwrap_or(4);
    let mut b = [0u8; 8];
    r.read_exact(&mut b[..n])?;
    if fmt == Format::Be {
        b[..n].reverse();
    }
    Ok(match ty {
        "char" | "int8" => b[0] as i8 as f64,
        "uchar" | "uint8" => b[0] as f64,
        "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
        "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
        "int" | "int32" => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        "uint" | "uint32" => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        "float" | "float32" => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        _ => f64::from_le_bytes(b),
    })
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> GeomError + '_ {
    move |e| GeomError::Io {
        path: path.to_path_buf(),
        source: e,
    }
}

fn last<'e>(elements: &'e mut [Element], path: &Path) -> Result<&'e mut Element> {
    elements
        .last_mut()
        .ok_or_else(|| parse_err(path, "property before element"))
}

/// Reads the header up to `end_header`: the format and the elements with their properties.
fn read_header(r: &mut impl BufRead, path: &Path) -> Result<(Format, Vec<Element>)> {
    let mut line = String::new();
    let mut fmt = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut first = true;
    loop {
        line.clear();
        if r.read_line(&mut line).map_err(io_err(path))? == 0 {
            return Err(parse_err(path, "header ended without end_header"));
        }
        let toks: Vec<&str> = line.split_whitespace().collect();
        if first {
            if toks.first() != Some(&"ply") {
                return Err(parse_err(path, "not a PLY file (no `ply` magic)"));
            }
            first = false;
            continue;
        }
        match toks.as_slice() {
            ["format", f, ..] => {
                fmt = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Le,
                    "binary_big_endian" => Format::Be,
                    other => return Err(parse_err(path, format!("unknown format {other}"))),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| parse_err(path, format!("bad element count {count}")))?,
                props: Vec::new(),
            }),
            ["property", "list", ct, it, name] => last(&mut elements, path)?
                .props
                .push(Prop::List(ct.to_string(), it.to_string(), name.to_string())),
            ["property", ty, name] => {
                if size_of(ty).is_none() {
                    return Err(parse_err(path, format!("unknown property type {ty}")));
                }
                last(&mut elements, path)?
                    .props
                    .push(Prop::Scalar(ty.to_string(), name.to_string()));
            }
            ["end_header"] => break,
            _ => {}
        }
    }
    let fmt = fmt.ok_or_else(|| parse_err(path, "no format line"))?;
    Ok((fmt, elements))
}

/// The body's values one after another, from ASCII tokens or binary fields.
struct Values<'a, R> {
    path: &'a Path,
    fmt: Format,
    reader: R,
    tokens: Vec<f64>,
    next: usize,
}

impl<'a, R: Read> Values<'a, R> {
    fn new(path: &'a Path, fmt: Format, mut reader: R) -> Result<Self> {
        let mut tokens = Vec::new();
        if fmt == Format::Ascii {
            let mut rest = String::new();
            reader.read_to_string(&mut rest).map_err(io_err(path))?;
            tokens = rest
                .split_whitespace()
                .map(|t| {
                    t.parse::<f64>()
                        .map_err(|_| parse_err(path, format!("`{t}` is not a number")))
                })
                .collect::<Result<_>>()?;
        }
        Ok(Self {
            path,
            fmt,
            reader,
            tokens,
            next: 0,
        })
    }

    fn read(&mut self, ty: &str) -> Result<f64> {
        let short = || parse_err(self.path, "file ends before all elements were read");
        if self.fmt == Format::Ascii {
            let x = *self.tokens.get(self.next).ok_or_else(short)?;
            self.next += 1;
            Ok(x)
        } else {
            read_bin(&mut self.reader, ty, self.fmt).map_err(|_| short())
        }
    }
}

/// Refuses a header whose elements cannot fit in the file (`len` bytes): each entry takes at
/// least its scalars' and list counts' bytes (binary) or a character a value (ASCII), so a
/// count of 10¹¹ is an error before anything is allocated. A `vertex` element needs x, y, z.
fn check_counts(path: &Path, fmt: Format, elements: &[Element], len: u64) -> Result<()> {
    let mut need = 0u128;
    for e in elements {
        if e.name == "vertex" && e.count > 0 {
            let has = |n: &str| (e.props.iter()).any(|p| matches!(p, Prop::Scalar(_, m) if m == n));
            if !(has("x") && has("y") && has("z")) {
                return Err(parse_err(
                    path,
                    "the vertex element has no x, y, z properties",
                ));
            }
        }
        let entry: usize = (e.props.iter())
            .map(|p| match (fmt, p) {
                (Format::Ascii, _) => 1,
                (_, Prop::Scalar(t, _)) | (_, Prop::List(t, _, _)) => size_of(t).unwrap_or(1),
            })
            .sum();
        need += e.count as u128 * entry as u128;
    }
    if need > len as u128 {
        return Err(parse_err(
            path,
            format!(
                "the header declares elements of at least {need} bytes, more than the file's \
                 {len}: a truncated file or a wrong element count"
            ),
        ));
    }
    Ok(())
}

/// Loads a PLY file (see the module docs).
pub(crate) fn load(path: &Path) -> Result<Mesh> {
    let file = std::fs::File::open(path).map_err(io_err(path))?;
    let mut r = BufReader::new(file);
    let (fmt, elements) = read_header(&mut r, path)?;
    let len = std::fs::metadata(path).map_err(io_err(path))?.len();
    check_counts(path, fmt, &elements, len)?;
    let mut values = Values::new(path, fmt, r)?;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut tris = Vec::new();
    let mut has_normals = false;
    let mut poly = Vec::new();
    for e in elements.iter().filter(|e| !e.props.is_empty()) {
        let is_vertex = e.name == "vertex";
        for _ in 0..e.count {
            let mut v = [0.0f64; 6];
            for p in &e.props {
                match p {
                    Prop::Scalar(ty, name) => {
                        let x = values.read(ty)?;
                        let slot = ["x", "y", "z", "nx", "ny", "nz"]
                            .iter()
                            .position(|n| n == name);
                        if let (true, Some(s)) = (is_vertex, slot) {
                            v[s] = x;
                        }
                    }
                    Prop::List(ct, it, name) => {
                        let n = values.read(ct)? as usize;
                        poly.clear();
                        for _ in 0..n {
                            poly.push(values.read(it)? as u32);
                        }
                        if e.name == "face" && (name == "vertex_indices" || name == "vertex_index")
                        {
                            fan(&poly, &mut tris);
                        }
                    }
                }
            }
            if is_vertex {
                positions.push(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32));
                normals.push(Vec3::new(v[3] as f32, v[4] as f32, v[5] as f32));
            }
        }
        if is_vertex {
            has_normals = e
                .props
                .iter()
                .any(|p| matches!(p, Prop::Scalar(_, n) if n == "nx"));
        }
    }
    let np = positions.len() as u32;
    if let Some(t) = tris.iter().find(|t| t.iter().any(|&i| i >= np)) {
        return Err(parse_err(
            path,
            format!("face {t:?} indexes past the {np} vertices"),
        ));
    }
    Ok(Mesh::from_triangles(
        positions,
        has_normals.then_some(normals),
        tris,
    ))
}
