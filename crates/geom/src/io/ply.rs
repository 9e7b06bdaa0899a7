//! PLY (ascii, binary little and big endian) through ply-rs-bw: the header parser and the
//! per-element readers, driven element by element here so that errors can name the element,
//! its number and (in ascii files) the line.
//!
//! Read: `vertex` (`x y z` of any scalar type), `face` (a list property `vertex_indices` or
//! `vertex_index` of any list-count and integer index type), `tristrips` (the same list, with
//! -1 restarting the strip). Every other element and property is skipped.

use std::io::{BufRead, ErrorKind};
use std::path::Path;

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, PropertyAccess, PropertyAccessResult, PropertyType};

use super::{bounded_capacity, parse_err, MeshError, RawMesh};

/// One vertex: only the position is kept.
#[derive(Default)]
struct VertexElem {
    p: [f64; 3],
}

impl VertexElem {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        match name {
            "x" => self.p[0] = v,
            "y" => self.p[1] = v,
            "z" => self.p[2] = v,
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for VertexElem {
    fn new() -> Self {
        Self::default()
    }
    fn set_char(&mut self, n: &str, v: i8) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_uchar(&mut self, n: &str, v: u8) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_short(&mut self, n: &str, v: i16) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_ushort(&mut self, n: &str, v: u16) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_int(&mut self, n: &str, v: i32) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_uint(&mut self, n: &str, v: u32) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_float(&mut self, n: &str, v: f32) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_double(&mut self, n: &str, v: f64) -> PropertyAccessResult {
        self.set(n, v)
    }
}

/// One face or strip: only the index list is kept, widened to i64 (so `uint` indices above
/// `i32::MAX` and the strips' -1 both survive).
#[derive(Default)]
struct FaceElem {
    list: Vec<i64>,
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

macro_rules! list_setter {
    ($fn:ident, $t:ty) => {
        fn $fn(&mut self, n: &str, v: Vec<$t>) -> PropertyAccessResult {
            if is_index_list(n) {
                self.list.clear();
                self.list.extend(v.into_iter().map(|x| x as i64));
                PropertyAccessResult::Set
            } else {
                PropertyAccessResult::Ignored
            }
        }
    };
}

impl PropertyAccess for FaceElem {
    fn new() -> Self {
        Self::default()
    }
    list_setter!(set_list_char, i8);
    list_setter!(set_list_uchar, u8);
    list_setter!(set_list_short, i16);
    list_setter!(set_list_ushort, u16);
    list_setter!(set_list_int, i32);
    list_setter!(set_list_uint, u32);
}

/// Anything else: every property ignored.
struct SkipElem;

impl PropertyAccess for SkipElem {
    fn new() -> Self {
        SkipElem
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Role {
    Vertex,
    Face,
    Strip,
    Skip,
}

pub(crate) fn read(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshError> {
    let mut reader = Reader::new(bytes);
    let header = Parser::<SkipElem>::new()
        .read_header(&mut reader)
        .map_err(|e| MeshError::Parse {
            path: path.to_path_buf(),
            line: e.line(),
            message: clean(&e.to_string()),
        })?;
    let format = match header.encoding {
        Encoding::Ascii => "ply-ascii",
        Encoding::BinaryLittleEndian => "ply-binary-le",
        Encoding::BinaryBigEndian => "ply-binary-be",
    };
    let mut raw = RawMesh::new(format);
    let mut line = reader.line();
    let mut n_vertices: Option<usize> = None;
    let mut face_no = 0usize;

    for (_, def) in header.elements.iter() {
        let role = match def.name.as_str() {
            "vertex" => Role::Vertex,
            "face" => Role::Face,
            "tristrips" => Role::Strip,
            _ => Role::Skip,
        };
        match role {
            Role::Vertex => {
                for c in ["x", "y", "z"] {
                    match def.properties.get(c) {
                        Some(p) if matches!(p.data_type, PropertyType::Scalar(_)) => {}
                        _ => {
                            return Err(MeshError::Parse {
                                path: path.to_path_buf(),
                                line: None,
                                message: format!("element `vertex` has no scalar property `{c}`"),
                            })
                        }
                    }
                }
                raw.positions
                    .reserve(bounded_capacity(def.count, bytes.len(), 3));
            }
            Role::Face | Role::Strip => {
                let ok = def.properties.iter().any(|(name, p)| {
                    is_index_list(name)
                        && matches!(p.data_type, PropertyType::List(_, ref t) if is_int(t))
                });
                if !ok {
                    return Err(MeshError::Parse {
                        path: path.to_path_buf(),
                        line: None,
                        message: format!(
                            "element `{}` has no integer list property `vertex_indices`",
                            def.name
                        ),
                    });
                }
                if n_vertices.is_none() {
                    return Err(MeshError::Parse {
                        path: path.to_path_buf(),
                        line: None,
                        message: format!("element `{}` comes before element `vertex`", def.name),
                    });
                }
            }
            Role::Skip => {}
        }
        for i in 0..def.count {
            match role {
                Role::Vertex => {
                    let v: VertexElem =
                        read_elem(&mut reader, def, header.encoding, &mut line, i, path)?;
                    raw.positions.push(v.p);
                }
                Role::Face | Role::Strip => {
                    let f: FaceElem =
                        read_elem(&mut reader, def, header.encoding, &mut line, i, path)?;
                    let n = n_vertices.unwrap_or(0);
                    let this_line = (header.encoding == Encoding::Ascii).then_some(line - 1);
                    for &k in &f.list {
                        let restart = role == Role::Strip && k == -1;
                        if !restart && (k < 0 || k as u64 >= n as u64) {
                            return Err(MeshError::IndexOutOfRange {
                                path: path.to_path_buf(),
                                face: face_no,
                                index: k,
                                n_vertices: n,
                                line: this_line,
                            });
                        }
                    }
                    if role == Role::Face {
                        raw.push_face(f.list.iter().map(|&k| k as u32));
                    } else {
                        push_strip(&mut raw, &f.list, face_no);
                    }
                    face_no += 1;
                }
                Role::Skip => {
                    let _: SkipElem =
                        read_elem(&mut reader, def, header.encoding, &mut line, i, path)?;
                }
            }
        }
        if role == Role::Vertex {
            n_vertices = Some(raw.positions.len());
        }
    }
    raw.file_faces = face_no;
    Ok(raw)
}

fn is_int(t: &ply_rs_bw::ply::ScalarType) -> bool {
    use ply_rs_bw::ply::ScalarType as S;
    !matches!(t, S::Float | S::Double)
}

/// Triangles of one strip: (s_i, s_i+1, s_i+2) with every other one flipped to keep the
/// orientation; -1 restarts.
fn push_strip(raw: &mut RawMesh, list: &[i64], face_no: usize) {
    for run in list.split(|&k| k == -1) {
        for (i, w) in run.windows(3).enumerate() {
            let (a, b, c) = (w[0] as u32, w[1] as u32, w[2] as u32);
            let t = if i % 2 == 0 { [a, b, c] } else { [b, a, c] };
            raw.strip_triangles.push(t);
            raw.strip_faces.push(face_no);
        }
    }
}

/// Reads element `i` of `def`, turning a premature end of file into [`MeshError::Truncated`].
fn read_elem<E: PropertyAccess>(
    reader: &mut Reader<&[u8]>,
    def: &ElementDef,
    encoding: Encoding,
    line: &mut usize,
    i: usize,
    path: &Path,
) -> Result<E, MeshError> {
    let truncated = || MeshError::Truncated {
        path: path.to_path_buf(),
        what: format!("`{}` elements", def.name),
        expected: def.count,
        got: i,
    };
    let parser = Parser::<E>::new();
    let input = reader.get_mut();
    let result = match encoding {
        Encoding::Ascii => {
            // Blank lines between elements are tolerated.
            let mut text = String::new();
            loop {
                text.clear();
                let n = input.read_line(&mut text).map_err(|_| {
                    parse_err(path, *line, "not text (invalid UTF-8) in an ascii PLY body")
                })?;
                if n == 0 {
                    return Err(truncated());
                }
                *line += 1;
                if !text.trim().is_empty() {
                    break;
                }
            }
            parser
                .read_ascii_element(&text, def)
                .map_err(|e| parse_err(path, *line - 1, clean(&e.to_string())))
        }
        Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {
            let r = if encoding == Encoding::BinaryLittleEndian {
                parser.read_little_endian_element(input, def)
            } else {
                parser.read_big_endian_element(input, def)
            };
            r.map_err(|e| {
                if e.kind() == ErrorKind::UnexpectedEof {
                    truncated()
                } else {
                    MeshError::Parse {
                        path: path.to_path_buf(),
                        line: None,
                        message: format!(
                            "element `{}` number {i}: {}",
                            def.name,
                            clean(&e.to_string())
                        ),
                    }
                }
            })
        }
    };
    result
}

/// ply-rs messages span several lines with tabs; keep them on one line.
fn clean(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}
