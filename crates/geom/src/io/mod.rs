//! Mesh and curve file IO with validation (DESIGN §7, issue 3).
//!
//! [`load_mesh`] reads OBJ, PLY (ascii, binary little and big endian; face lists and triangle
//! strips), OFF (with the `COFF`/`NOFF`/`CNOFF` variants) and STL (ascii and binary), then
//! validates and cleans the result the same way for every format:
//!
//! | found in the file | what happens |
//! |---|---|
//! | no vertices or no faces | [`MeshError::Empty`] |
//! | NaN or infinite coordinate | [`MeshError::NonFinite`] naming the vertex |
//! | coordinate beyond ±[`MAX_COORDINATE`] (squared lengths would overflow) | [`MeshError::CoordinateTooLarge`] naming the vertex |
//! | face index outside the vertex list | [`MeshError::IndexOutOfRange`] naming face, index, line |
//! | polygon with more than 3 corners | fan-triangulated, counted |
//! | face with a repeated vertex index (or < 3 corners) | dropped and counted; an error with [`LoadOptions::reject_degenerate`] |
//! | the same triangle twice (any orientation) | later copies dropped, counted |
//! | vertex used by no face | dropped, counted (order of the others kept) |
//! | STL corners closer than [`WELD_TOLERANCE`] × the bounding-box diagonal | welded into one vertex, counted |
//! | edge with more than two faces, vertex whose faces form several fans | [`MeshError::NonManifold`]; with [`LoadOptions::repair`] the vertices are split instead |
//! | faces of a component oriented inconsistently (two faces running along an edge the same way) | reported; with [`LoadOptions::repair`] faces are flipped so that each component is coherent (a closed one outward) |
//! | several connected components, boundary edges, zero-area faces | reported in [`LoadReport`] |
//!
//! Writers ([`save_mesh_ply`], [`save_mesh_obj`], [`save_curves_ply`], [`save_curves_obj`])
//! produce files for MeshLab and Blender; [`load_curves_ply`] reads curve files back.
//!
//! The curves are the feature curve networks of thesis §2.5 (Def. 2.1); the curvature colours
//! show the mean curvature of §2.1.

mod obj;
mod off;
mod ply;
mod stl;
#[cfg(test)]
mod tests;
mod validate;
mod write;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::mesh::TriMesh;
use crate::vec3::V3;

pub use stl::WELD_TOLERANCE;
pub use validate::{find_nonmanifold, NonManifoldInfo};
pub use write::{
    curvature_colors, load_curves_ply, save_curves_obj, save_curves_ply, save_mesh_obj,
    save_mesh_ply,
};

/// How [`load_mesh`] treats problems it can fix.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LoadOptions {
    /// Split non-manifold edges and vertices (duplicate vertices so that every edge has at most
    /// two faces and every vertex's faces form one fan) instead of failing with
    /// [`MeshError::NonManifold`], and flip faces so that each component is coherently
    /// oriented (a closed one outward).
    pub repair: bool,
    /// Fail with [`MeshError::DegenerateFace`] on a face with a repeated vertex index instead of
    /// dropping it.
    pub reject_degenerate: bool,
}

/// What loading found and did. Every count is in terms of the file as read.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LoadReport {
    /// `obj`, `off`, `ply-ascii`, `ply-binary-le`, `ply-binary-be`, `stl-ascii`, `stl-binary`.
    pub format: String,
    /// Vertices in the file (for STL: distinct corner positions after welding).
    pub file_vertices: usize,
    /// Faces (polygons, strips for PLY `tristrips`) in the file.
    pub file_faces: usize,
    /// Polygons with more than three corners that were fan-triangulated.
    pub polygons_triangulated: usize,
    /// STL only: corners merged into an earlier corner at the same position (see the STL
    /// reader for the tolerance).
    pub vertices_welded: usize,
    /// Faces (or fan/strip triangles) with a repeated vertex index or fewer than three corners.
    pub degenerate_faces_dropped: usize,
    /// Zero-area triangles that triangle strips use to turn or restart (not a defect).
    pub strip_degenerates_skipped: usize,
    /// Triangles whose vertex set repeats an earlier triangle's.
    pub duplicate_faces_dropped: usize,
    /// Vertices referenced by no face.
    pub unreferenced_vertices_dropped: usize,
    /// Edges with more than two faces (found before any repair).
    pub nonmanifold_edges: usize,
    /// Vertices whose faces form more than one fan (found before any repair).
    pub nonmanifold_vertices: usize,
    /// Vertices added by the repair (0 without `repair`).
    pub vertices_split: usize,
    /// Triangles with (nearly) zero area: kept, but curvature there is unreliable.
    pub zero_area_faces: usize,
    /// Interior edges whose two faces run along it in the same direction (inconsistent
    /// orientation; found before any repair).
    pub inconsistent_edges: usize,
    /// Faces turned over by the repair so that each component is coherently oriented
    /// (0 without `repair`).
    #[serde(default)]
    pub faces_flipped: usize,
    /// Components that no choice of face orientations makes coherent (a Möbius strip); their
    /// inconsistent edges stay after the repair.
    #[serde(default)]
    pub nonorientable_components: usize,
    /// Edges with exactly one face, in the final mesh.
    pub boundary_edges: usize,
    /// Connected components (through shared edges), in the final mesh.
    pub components: usize,
    /// Vertices of the final mesh.
    pub vertices: usize,
    /// Triangles of the final mesh.
    pub faces: usize,
}

impl LoadReport {
    /// Sentences for what a user should know about: data dropped, repaired or suspicious.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        let mut say = |n: usize, what: &str| {
            if n > 0 {
                w.push(format!("{n} {what}"));
            }
        };
        say(
            self.degenerate_faces_dropped,
            "degenerate faces (repeated vertex index) dropped",
        );
        say(self.duplicate_faces_dropped, "duplicate faces dropped");
        say(
            self.unreferenced_vertices_dropped,
            "unreferenced vertices dropped",
        );
        say(self.nonmanifold_edges, "non-manifold edges split by repair");
        say(
            self.nonmanifold_vertices,
            "non-manifold vertices split by repair",
        );
        say(
            self.zero_area_faces,
            "zero-area faces (curvature unreliable there)",
        );
        say(
            if self.faces_flipped == 0 {
                self.inconsistent_edges
            } else {
                0
            },
            "edges with inconsistently oriented faces (load with `repair: true` to orient \
             them coherently; in the shipped graphs: `--set repair=true`)",
        );
        say(
            self.faces_flipped,
            "faces flipped by repair to orient each component coherently",
        );
        say(
            self.nonorientable_components,
            "non-orientable components (their inconsistent edges stay)",
        );
        if self.components > 1 {
            w.push(format!("{} connected components", self.components));
        }
        w
    }
}

/// A mesh as loaded, with what loading found and did.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    pub mesh: TriMesh,
    pub report: LoadReport,
}

/// Why a mesh or curve file could not be read or written. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    #[error("{}: file ends after {got} of the {expected} {what} its header announces", path.display())]
    Truncated {
        path: PathBuf,
        what: String,
        expected: usize,
        got: usize,
    },
    #[error("{}: the mesh is empty ({vertices} vertices, {faces} faces)", path.display())]
    Empty {
        path: PathBuf,
        vertices: usize,
        faces: usize,
    },
    #[error("{}: vertex {vertex} has a non-finite coordinate ({value})", path.display())]
    NonFinite {
        path: PathBuf,
        vertex: usize,
        value: f64,
    },
    #[error(
        "{}: vertex {vertex} has a coordinate of {value:e}, beyond ±{MAX_COORDINATE:e}: squared \
         lengths and areas would overflow (scale the mesh down)",
        path.display()
    )]
    CoordinateTooLarge {
        path: PathBuf,
        vertex: usize,
        value: f64,
    },
    #[error(
        "{}{}: face {face} references vertex {index} but the mesh has {n_vertices} vertices \
         (indices counted from 0)",
        path.display(), line.map(|l| format!(":{l}")).unwrap_or_default()
    )]
    IndexOutOfRange {
        path: PathBuf,
        /// 0-based face number in the file.
        face: usize,
        /// 0-based vertex index (OBJ's 1-based and negative indices converted).
        index: i64,
        n_vertices: usize,
        line: Option<usize>,
    },
    #[error("{}: face {face} repeats a vertex ({vertices:?})", path.display())]
    DegenerateFace {
        path: PathBuf,
        face: usize,
        vertices: Vec<u32>,
    },
    #[error(
        "{}: {edges} non-manifold edges (more than two faces) and {vertices} non-manifold \
         vertices (faces forming several fans); load with `repair: true` to split them (in the \
         shipped graphs: `--set repair=true`)",
        path.display()
    )]
    NonManifold {
        path: PathBuf,
        edges: usize,
        vertices: usize,
    },
    #[error("{}: {reason}", path.display())]
    UnsupportedFormat { path: PathBuf, reason: String },
    #[error("{}: {message}", path.display())]
    InvalidData { path: PathBuf, message: String },
}

impl MeshError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            MeshError::Io { path, .. }
            | MeshError::Parse { path, .. }
            | MeshError::Truncated { path, .. }
            | MeshError::Empty { path, .. }
            | MeshError::NonFinite { path, .. }
            | MeshError::CoordinateTooLarge { path, .. }
            | MeshError::IndexOutOfRange { path, .. }
            | MeshError::DegenerateFace { path, .. }
            | MeshError::NonManifold { path, .. }
            | MeshError::UnsupportedFormat { path, .. }
            | MeshError::InvalidData { path, .. } => path,
        }
    }
}

/// Mesh formats [`load_mesh`] reads, chosen by file extension (case-insensitive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Off,
    Ply,
    Stl,
}

impl MeshFormat {
    /// The format for `path`'s extension.
    pub fn from_path(path: &Path) -> Result<MeshFormat, MeshError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => Ok(MeshFormat::Obj),
            Some("off") => Ok(MeshFormat::Off),
            Some("ply") => Ok(MeshFormat::Ply),
            Some("stl") => Ok(MeshFormat::Stl),
            other => Err(MeshError::UnsupportedFormat {
                path: path.to_path_buf(),
                reason: format!(
                    "unknown mesh extension {}; expected .obj, .off, .ply or .stl",
                    other
                        .map(|e| format!("`.{e}`"))
                        .unwrap_or_else(|| "(none)".into())
                ),
            }),
        }
    }
}

/// Polygons as read from a file, before validation. Indices are already checked against the
/// vertex count by each reader (which knows the line to report).
#[derive(Debug, Default)]
pub(crate) struct RawMesh {
    pub positions: Vec<V3>,
    /// `offsets[i]..offsets[i+1]` are face i's corners in `indices`.
    pub offsets: Vec<usize>,
    pub indices: Vec<u32>,
    /// Triangles that come from strips (their degenerates are skips, not defects).
    pub strip_triangles: Vec<[u32; 3]>,
    /// The file number of each strip triangle's strip, for error messages.
    pub strip_faces: Vec<usize>,
    pub format: &'static str,
    pub file_faces: usize,
    pub vertices_welded: usize,
}

impl RawMesh {
    pub fn new(format: &'static str) -> Self {
        RawMesh {
            offsets: vec![0],
            format,
            ..Default::default()
        }
    }
    pub fn push_face(&mut self, corners: impl IntoIterator<Item = u32>) {
        self.indices.extend(corners);
        self.offsets.push(self.indices.len());
    }
    pub fn n_polygons(&self) -> usize {
        self.offsets.len() - 1
    }
}

/// A capacity for `n` announced items that cannot exhaust memory on a lying header: the file
/// must hold at least `min_bytes` per item.
pub(crate) fn bounded_capacity(n: usize, file_len: usize, min_bytes: usize) -> usize {
    n.min(file_len / min_bytes.max(1) + 1)
}

/// The largest coordinate magnitude a loaded mesh may have. Norms of cross products square
/// products of two coordinates (fourth powers), which overflow above about 1e77; below 1e60
/// they stay finite with room for sums. No physical model needs more (a light year in
/// millimetres is 1e19).
pub const MAX_COORDINATE: f64 = 1e60;

/// The bytes of a file a user named (a mesh, a curve file, a landmark list). Only regular
/// files, or links to them, are read: a device such as `/dev/zero` or a pipe nobody writes
/// would otherwise fill memory or wait forever.
pub fn read_file(path: &Path) -> std::io::Result<Vec<u8>> {
    ensure_regular_file(path)?;
    std::fs::read(path)
}

/// [`read_file`] as UTF-8 text, without a leading byte-order mark (some Windows editors
/// write one; parsers would see it as a stray character on line 1).
pub fn read_text_file(path: &Path) -> std::io::Result<String> {
    ensure_regular_file(path)?;
    let text = std::fs::read_to_string(path)?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// Checked before opening: opening a pipe already waits for a writer.
fn ensure_regular_file(path: &Path) -> std::io::Result<()> {
    if std::fs::metadata(path)?.is_file() {
        Ok(())
    } else {
        Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a folder, a device or a pipe)",
        ))
    }
}

/// Loads a triangle mesh, choosing the format by extension, then validates and cleans it (see
/// the module docs for what is an error and what is repaired).
pub fn load_mesh(path: impl AsRef<Path>, options: &LoadOptions) -> Result<LoadedMesh, MeshError> {
    let path = path.as_ref();
    let format = MeshFormat::from_path(path)?;
    let bytes = read_file(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    load_mesh_bytes(&bytes, format, path, options)
}

/// [`load_mesh`] on bytes already in memory; `path` is only used in messages.
pub fn load_mesh_bytes(
    bytes: &[u8],
    format: MeshFormat,
    path: &Path,
    options: &LoadOptions,
) -> Result<LoadedMesh, MeshError> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            vertices: 0,
            faces: 0,
        });
    }
    // Text files saved by some Windows editors start with a UTF-8 byte-order mark; without
    // this the first line (an OBJ `v`, the OFF or PLY magic) would not be recognised. A binary
    // STL's 80-byte header may start with anything, so STL drops it only before `solid`.
    let bytes = match bytes.strip_prefix(b"\xEF\xBB\xBF") {
        Some(rest) if format != MeshFormat::Stl || rest.starts_with(b"solid") => rest,
        _ => bytes,
    };
    let raw = match format {
        MeshFormat::Obj => obj::read(bytes, path)?,
        MeshFormat::Off => off::read(bytes, path)?,
        MeshFormat::Ply => ply::read(bytes, path)?,
        MeshFormat::Stl => stl::read(bytes, path)?,
    };
    validate::build(raw, path, options)
}

/// Splits `bytes` into lines (`\n` or `\r\n`), numbered from 1, for the text readers.
pub(crate) fn text_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .enumerate()
        .map(|(i, l)| (i + 1, l))
}

/// The text of a line for parsing; non-UTF-8 is a parse error at that line.
pub(crate) fn line_str<'a>(line: &'a [u8], no: usize, path: &Path) -> Result<&'a str, MeshError> {
    std::str::from_utf8(line).map_err(|_| MeshError::Parse {
        path: path.to_path_buf(),
        line: Some(no),
        message: "not text (invalid UTF-8); is this a binary file with the wrong extension?".into(),
    })
}

pub(crate) fn parse_err(path: &Path, line: usize, message: impl Into<String>) -> MeshError {
    MeshError::Parse {
        path: path.to_path_buf(),
        line: Some(line),
        message: message.into(),
    }
}
