//! Writers for meshes (with curvature as vertex properties and colours) and feature curve
//! networks (thesis Def. 2.1), in forms MeshLab and Blender open, and a reader for the curve PLY
//! files written here.
//!
//! Files are written whole to a temporary file next to the target and renamed over it, so a
//! watcher never sees half a file; parent folders are created. Positions are written as `float`
//! when every coordinate is exactly a 32-bit float (meshes read from float files) and as
//! `double` otherwise, so reading a written file gives back the same positions.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};

use super::MeshError;
use crate::curvature::CurvatureField;
use crate::fcn::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crate::mesh::TriMesh;
use crate::vec3::V3;

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> MeshError + '_ {
    move |source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn invalid(path: &Path, message: impl Into<String>) -> MeshError {
    MeshError::InvalidData {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), MeshError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_err(path))?;
    }
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    let tmp: PathBuf = path.with_file_name(name);
    std::fs::write(&tmp, bytes).map_err(io_err(path))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io_err(path)(e)
    })
}

fn all_f32(points: impl Iterator<Item = V3>) -> bool {
    points
        .into_iter()
        .all(|p| p.iter().all(|&c| (c as f32) as f64 == c))
}

/// Diverging colours of mean curvature: blue where concave (H < 0), light grey where flat, red
/// where convex (H > 0), saturating at the 95th percentile of |H| so that a few extreme
/// vertices (sharp corners, noise) do not wash out the rest. Non-finite values are black.
pub fn curvature_colors(field: &CurvatureField) -> Vec<[u8; 3]> {
    let h: Vec<f64> = (0..field.len()).map(|v| field.mean(v)).collect();
    let mut mags: Vec<f64> = h
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    let scale = if mags.is_empty() {
        0.0
    } else {
        let k = ((mags.len() - 1) as f64 * 0.95).round() as usize;
        *mags.select_nth_unstable_by(k, f64::total_cmp).1
    };
    const NEG: [f64; 3] = [59.0, 76.0, 192.0];
    const MID: [f64; 3] = [221.0, 221.0, 221.0];
    const POS: [f64; 3] = [180.0, 4.0, 38.0];
    h.iter()
        .map(|&x| {
            if !x.is_finite() {
                return [0, 0, 0];
            }
            let t = if scale > 0.0 {
                (x / scale).clamp(-1.0, 1.0)
            } else {
                0.0
            };
            let end = if t < 0.0 { NEG } else { POS };
            let s = t.abs();
            [0, 1, 2].map(|k| (MID[k] + (end[k] - MID[k]) * s).round() as u8)
        })
        .collect()
}

fn push_coord(out: &mut Vec<u8>, c: f64, single: bool) {
    if single {
        out.extend_from_slice(&(c as f32).to_le_bytes());
    } else {
        out.extend_from_slice(&c.to_le_bytes());
    }
}

fn check_field(
    path: &Path,
    mesh: &TriMesh,
    field: Option<&CurvatureField>,
) -> Result<(), MeshError> {
    if let Some(f) = field {
        if f.len() != mesh.n_vertices() || f.k_min.len() != mesh.n_vertices() {
            return Err(invalid(
                path,
                format!(
                    "the curvature field has {} values but the mesh has {} vertices",
                    f.len(),
                    mesh.n_vertices()
                ),
            ));
        }
    }
    Ok(())
}

/// Binary little-endian PLY. With a curvature field, every vertex also carries `k_max`, `k_min`,
/// `quality` = mean curvature (float; MeshLab shows `quality` as a colour ramp and histogram) and
/// `red green blue` (uchar, [`curvature_colors`]).
pub fn save_mesh_ply(
    path: impl AsRef<Path>,
    mesh: &TriMesh,
    curvature: Option<&CurvatureField>,
) -> Result<(), MeshError> {
    let path = path.as_ref();
    check_field(path, mesh, curvature)?;
    if mesh.n_vertices() > i32::MAX as usize {
        return Err(invalid(path, "too many vertices for PLY int indices"));
    }
    let single = all_f32(mesh.positions.iter().copied());
    let ty = if single { "float" } else { "double" };
    let mut out = Vec::with_capacity(64 + mesh.n_vertices() * 40 + mesh.n_faces() * 13);
    let _ = write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment written by crestflow\n\
         element vertex {}\nproperty {ty} x\nproperty {ty} y\nproperty {ty} z\n",
        mesh.n_vertices()
    );
    if curvature.is_some() {
        out.extend_from_slice(
            b"property float k_max\nproperty float k_min\nproperty float quality\n\
              property uchar red\nproperty uchar green\nproperty uchar blue\n",
        );
    }
    let _ = write!(
        out,
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.n_faces()
    );
    let colors = curvature.map(curvature_colors);
    for (v, p) in mesh.positions.iter().enumerate() {
        for &c in p {
            push_coord(&mut out, c, single);
        }
        if let (Some(f), Some(col)) = (curvature, &colors) {
            out.extend_from_slice(&(f.k_max[v] as f32).to_le_bytes());
            out.extend_from_slice(&(f.k_min[v] as f32).to_le_bytes());
            out.extend_from_slice(&(f.mean(v) as f32).to_le_bytes());
            out.extend_from_slice(&col[v]);
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for &i in t {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    write_atomic(path, &out)
}

/// Wavefront OBJ (`v` and `f` lines). With a curvature field, vertices carry the colours of
/// [`curvature_colors`] as `v x y z r g b` (read by MeshLab and Blender).
pub fn save_mesh_obj(
    path: impl AsRef<Path>,
    mesh: &TriMesh,
    curvature: Option<&CurvatureField>,
) -> Result<(), MeshError> {
    let path = path.as_ref();
    check_field(path, mesh, curvature)?;
    let colors = curvature.map(curvature_colors);
    let mut out = Vec::with_capacity(mesh.n_vertices() * 40 + mesh.n_faces() * 24);
    let _ = writeln!(
        out,
        "# written by crestflow: {} vertices, {} faces",
        mesh.n_vertices(),
        mesh.n_faces()
    );
    for (v, p) in mesh.positions.iter().enumerate() {
        // `{}` prints the shortest text that parses back to the same f64.
        let _ = write!(out, "v {} {} {}", p[0], p[1], p[2]);
        if let Some(col) = &colors {
            let c = col[v].map(|x| x as f64 / 255.0);
            let _ = write!(out, " {:.4} {:.4} {:.4}", c[0], c[1], c[2]);
        }
        out.push(b'\n');
    }
    for t in &mesh.triangles {
        let _ = writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    write_atomic(path, &out)
}

fn label_code(l: CurveLabel) -> u8 {
    match l {
        CurveLabel::Ridge => 0,
        CurveLabel::Ravine => 1,
        CurveLabel::Other => 2,
    }
}

fn label_color(l: CurveLabel) -> [u8; 3] {
    match l {
        CurveLabel::Ridge => [220, 40, 40],
        CurveLabel::Ravine => [40, 90, 220],
        CurveLabel::Other => [40, 160, 60],
    }
}

fn label_name(l: CurveLabel) -> &'static str {
    match l {
        CurveLabel::Ridge => "ridge",
        CurveLabel::Ravine => "ravine",
        CurveLabel::Other => "other",
    }
}

fn check_network(path: &Path, net: &FeatureCurveNetwork) -> Result<(), MeshError> {
    let n = net.vertices.len();
    for (c, curve) in net.curves.iter().enumerate() {
        if let Some(&v) = curve.vertices.iter().find(|&&v| v as usize >= n) {
            return Err(invalid(
                path,
                format!("curve {c} references vertex {v} but the network has {n} vertices"),
            ));
        }
    }
    if n > i32::MAX as usize || net.curves.len() > i32::MAX as usize {
        return Err(invalid(path, "network too large for PLY int indices"));
    }
    Ok(())
}

/// Binary little-endian PLY of a feature curve network: vertices (`x y z`, `strength`, colour
/// by label: ridges red, ravines blue, others green, unused grey) and an `edge` element
/// (`vertex1 vertex2` as MeshLab expects, `curve` index, `label` 0 ridge / 1 ravine / 2 other,
/// `closing` = 1 on the edge that closes a loop, and the label colour).
pub fn save_curves_ply(path: impl AsRef<Path>, net: &FeatureCurveNetwork) -> Result<(), MeshError> {
    let path = path.as_ref();
    check_network(path, net)?;
    let mut vcolor = vec![[128u8, 128, 128]; net.vertices.len()];
    let mut colored = vec![false; net.vertices.len()];
    for curve in &net.curves {
        for &v in &curve.vertices {
            if !colored[v as usize] {
                colored[v as usize] = true;
                vcolor[v as usize] = label_color(curve.label);
            }
        }
    }
    let edges: Vec<(u32, u32, usize, bool)> = (0..net.curves.len())
        .flat_map(|c| {
            let e = net.curve_edges(c);
            let closing = net.curves[c].closed && net.curves[c].vertices.len() > 2;
            let last = e.len().saturating_sub(1);
            e.into_iter()
                .enumerate()
                .map(move |(k, (a, b))| (a, b, c, closing && k == last))
        })
        .collect();
    let single = all_f32(net.vertices.iter().map(|v| v.position));
    let ty = if single { "float" } else { "double" };
    let mut out = Vec::new();
    let _ = write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment crestflow feature curve network\n\
         element vertex {}\nproperty {ty} x\nproperty {ty} y\nproperty {ty} z\n\
         property float strength\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         element edge {}\nproperty int vertex1\nproperty int vertex2\nproperty int curve\n\
         property uchar label\nproperty uchar closing\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
        net.vertices.len(),
        edges.len()
    );
    for (v, fv) in net.vertices.iter().enumerate() {
        for &c in &fv.position {
            push_coord(&mut out, c, single);
        }
        out.extend_from_slice(&(fv.strength as f32).to_le_bytes());
        out.extend_from_slice(&vcolor[v]);
    }
    for &(a, b, c, closing) in &edges {
        let label = net.curves[c].label;
        out.extend_from_slice(&(a as i32).to_le_bytes());
        out.extend_from_slice(&(b as i32).to_le_bytes());
        out.extend_from_slice(&(c as i32).to_le_bytes());
        out.push(label_code(label));
        out.push(closing as u8);
        out.extend_from_slice(&label_color(label));
    }
    write_atomic(path, &out)
}

/// Wavefront OBJ of a feature curve network: the vertices, then per curve a group
/// `ridge_<i>`, `ravine_<i>` or `other_<i>` (`i` = curve index) holding its edges as two-vertex
/// `l` lines (the closing edge of a loop included). Blender imports the groups as edge objects;
/// two-vertex lines are used because MeshLab keeps only the first segment of a longer `l`.
/// Curves with fewer than two vertices have no edges and are left out.
pub fn save_curves_obj(path: impl AsRef<Path>, net: &FeatureCurveNetwork) -> Result<(), MeshError> {
    let path = path.as_ref();
    check_network(path, net)?;
    let mut out = Vec::new();
    let _ = writeln!(
        out,
        "# crestflow feature curve network: {} vertices, {} curves",
        net.vertices.len(),
        net.curves.len()
    );
    for v in &net.vertices {
        let p = v.position;
        let _ = writeln!(out, "v {} {} {}", p[0], p[1], p[2]);
    }
    for (c, curve) in net.curves.iter().enumerate() {
        let edges = net.curve_edges(c);
        if edges.is_empty() {
            continue;
        }
        let _ = writeln!(out, "g {}_{c}", label_name(curve.label));
        for (a, b) in edges {
            let _ = writeln!(out, "l {} {}", a + 1, b + 1);
        }
    }
    write_atomic(path, &out)
}

/// A curve's edges as read, its label code and whether an edge closes it.
type CurveEdges = (Vec<(u32, u32)>, u8, bool);

fn num(e: &DefaultElement, name: &str) -> Option<f64> {
    Some(match e.get(name)? {
        Property::Char(x) => *x as f64,
        Property::UChar(x) => *x as f64,
        Property::Short(x) => *x as f64,
        Property::UShort(x) => *x as f64,
        Property::Int(x) => *x as f64,
        Property::UInt(x) => *x as f64,
        Property::Float(x) => *x as f64,
        Property::Double(x) => *x,
        _ => return None,
    })
}

/// Reads a curve PLY written by [`save_curves_ply`] back into a network. Vertex locations on
/// the mesh are not stored in the file: they come back as [`SurfacePoint::Free`]. Curves with
/// no edges (fewer than two vertices) are not in the file either; the others keep their order
/// and are numbered densely.
pub fn load_curves_ply(path: impl AsRef<Path>) -> Result<FeatureCurveNetwork, MeshError> {
    let path = path.as_ref();
    let bytes = super::read_file(path).map_err(io_err(path))?;
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut &bytes[..])
        .map_err(|e| MeshError::Parse {
            path: path.to_path_buf(),
            line: e.line(),
            message: e.to_string(),
        })?;
    let missing = |what: &str| invalid(path, format!("missing {what}"));
    let mut net = FeatureCurveNetwork::default();
    for (i, e) in ply
        .payload
        .get("vertex")
        .map(|v| v.as_slice())
        .unwrap_or(&[])
        .iter()
        .enumerate()
    {
        let c = |n: &str| num(e, n).ok_or_else(|| missing(&format!("`{n}` of vertex {i}")));
        net.vertices.push(FcnVertex {
            position: [c("x")?, c("y")?, c("z")?],
            location: SurfacePoint::Free,
            strength: num(e, "strength").unwrap_or(0.0),
        });
    }
    let n = net.vertices.len();
    // Edges grouped by curve, in file order.
    let mut curves: BTreeMap<usize, CurveEdges> = BTreeMap::new();
    for (i, e) in ply
        .payload
        .get("edge")
        .map(|v| v.as_slice())
        .unwrap_or(&[])
        .iter()
        .enumerate()
    {
        let c = |n: &str| num(e, n).ok_or_else(|| missing(&format!("`{n}` of edge {i}")));
        let (a, b, curve) = (c("vertex1")?, c("vertex2")?, c("curve")?);
        for v in [a, b] {
            if v < 0.0 || v >= n as f64 {
                return Err(invalid(
                    path,
                    format!("edge {i} references vertex {v} of {n}"),
                ));
            }
        }
        if curve < 0.0 {
            return Err(invalid(path, format!("edge {i} has curve index {curve}")));
        }
        let entry = curves
            .entry(curve as usize)
            .or_insert((Vec::new(), 2, false));
        entry.0.push((a as u32, b as u32));
        entry.1 = num(e, "label").unwrap_or(2.0) as u8;
        entry.2 |= num(e, "closing").unwrap_or(0.0) != 0.0;
    }
    for (c, (edges, label, closing)) in curves {
        let Some(&(first, _)) = edges.first() else {
            continue;
        };
        let mut vertices = vec![first];
        for (k, &(a, b)) in edges.iter().enumerate() {
            if a != *vertices.last().unwrap_or(&a) {
                return Err(invalid(
                    path,
                    format!("curve {c}: edge {k} does not continue the polyline"),
                ));
            }
            vertices.push(b);
        }
        if closing {
            vertices.pop();
        }
        let label = match label {
            0 => CurveLabel::Ridge,
            1 => CurveLabel::Ravine,
            _ => CurveLabel::Other,
        };
        net.curves.push(FeatureCurve {
            vertices,
            closed: closing,
            label,
        });
    }
    Ok(net)
}
