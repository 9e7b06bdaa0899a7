//! `symmetry.draw`: pictures of the reoccurrences, in the spirit of thesis Fig. 3.7 and 4.3 —
//! the feature curves coloured by the orbit (or the transformation cluster) they belong to,
//! written as PLY curve networks with per-vertex and per-edge colours and as a PNG of the
//! curves over the shaded surface.
//!
//! A curve in several orbits (clusters) takes the colour of the strongest one; curves in none
//! are left out. Colours repeat after the palette's 12 entries.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::vec3::V3;
use crestflow_geom::{FeatureCurveNetwork, TriMesh};
use crestflow_nodes_render::raster::{rasterize, Scene, Segment, Style};
use crestflow_nodes_render::{write_png, Camera, UpAxis, View};
use serde::{Deserialize, Serialize};

use crate::cluster::TransformClusters;
use crate::orbits::Orbits;

/// Distinct colours of the groups (orbits or clusters), strongest first.
pub const PALETTE: [[u8; 3]; 12] = [
    [230, 25, 75],
    [0, 130, 200],
    [60, 180, 75],
    [245, 130, 48],
    [145, 30, 180],
    [70, 190, 190],
    [240, 50, 230],
    [128, 128, 0],
    [0, 0, 128],
    [170, 110, 40],
    [128, 0, 0],
    [0, 128, 128],
];

/// What colours the curves of the PNG.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ColorBy {
    Orbit,
    Cluster,
}

/// Parameters of `symmetry.draw`. Empty paths skip that output.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DrawParams {
    /// PLY of the curves coloured by orbit. Default `orbit_curves.ply`.
    pub orbit_ply: PathBuf,
    /// PLY of the curves coloured by cluster. Default `cluster_curves.ply`.
    pub cluster_ply: PathBuf,
    /// PNG of the coloured curves over the surface (needs the mesh). Default `render.png`.
    pub png: PathBuf,
    /// `Orbit` (default) or `Cluster`: the colouring of the PNG.
    pub color_by: ColorBy,
    /// Only the strongest this many clusters are coloured. In [1, 10000]. Default 12.
    pub clusters: u32,
    /// Image size in pixels, each in [16, 8192]. Default 1024 × 768.
    pub width: u32,
    pub height: u32,
    /// Camera azimuth and elevation in degrees. Defaults 30 and 20.
    pub azimuth: f64,
    pub elevation: f64,
    /// World axis shown upwards. Default `Y`.
    pub up: UpAxis,
    /// Curve width in pixels, in [0.5, 50]. Default 3.
    pub line_width: f64,
}

impl Default for DrawParams {
    fn default() -> Self {
        DrawParams {
            orbit_ply: PathBuf::from("orbit_curves.ply"),
            cluster_ply: PathBuf::from("cluster_curves.ply"),
            png: PathBuf::from("render.png"),
            color_by: ColorBy::Orbit,
            clusters: 12,
            width: 1024,
            height: 768,
            azimuth: 30.0,
            elevation: 20.0,
            up: UpAxis::Y,
            line_width: 3.0,
        }
    }
}

impl Validate for DrawParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "clusters", self.clusters, 1, 10_000);
        check_range(&mut v, "width", self.width, 16, 8192);
        check_range(&mut v, "height", self.height, 16, 8192);
        check_range(&mut v, "azimuth", self.azimuth, -360.0, 360.0);
        check_range(&mut v, "elevation", self.elevation, -89.0, 89.0);
        check_range(&mut v, "line_width", self.line_width, 0.5, 50.0);
        v
    }
}

/// Why `symmetry.draw` cannot run.
#[derive(Debug, thiserror::Error)]
pub enum DrawError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("curve {curve} references network vertex {index} but the network has {n} vertices")]
    VertexIndex { curve: usize, index: u32, n: usize },
    #[error("network vertex {vertex} has a non-finite position {position:?}")]
    NonFinite { vertex: usize, position: V3 },
    #[error("{what} refers to curve {curve} but the network has {n} curves")]
    CurveIndex {
        what: &'static str,
        curve: u32,
        n: usize,
    },
    #[error("the mesh cannot be drawn: {0}")]
    Mesh(String),
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// Per curve: the index of the strongest orbit containing it (orbits are sorted by support).
pub fn orbit_groups(n_curves: usize, orbits: &Orbits) -> Result<Vec<Option<u32>>, DrawError> {
    let mut out = vec![None; n_curves];
    for (k, o) in orbits.orbits.iter().enumerate() {
        for &c in &o.curves {
            let slot = out.get_mut(c as usize).ok_or(DrawError::CurveIndex {
                what: "an orbit",
                curve: c,
                n: n_curves,
            })?;
            slot.get_or_insert(k as u32);
        }
    }
    Ok(out)
}

/// Per curve: the index of the strongest of the first `limit` clusters that maps it or maps
/// onto it (clusters are sorted by support).
pub fn cluster_groups(
    n_curves: usize,
    clusters: &TransformClusters,
    limit: usize,
) -> Result<Vec<Option<u32>>, DrawError> {
    let mut out = vec![None; n_curves];
    for (k, cl) in clusters.clusters.iter().enumerate().take(limit) {
        for m in &cl.members {
            for c in [m.from, m.to] {
                let slot = out.get_mut(c as usize).ok_or(DrawError::CurveIndex {
                    what: "a cluster",
                    curve: c,
                    n: n_curves,
                })?;
                slot.get_or_insert(k as u32);
            }
        }
    }
    Ok(out)
}

fn check_network(net: &FeatureCurveNetwork) -> Result<(), DrawError> {
    let n = net.vertices.len();
    for (c, curve) in net.curves.iter().enumerate() {
        if let Some(&index) = curve.vertices.iter().find(|&&v| v as usize >= n) {
            return Err(DrawError::VertexIndex { curve: c, index, n });
        }
    }
    if let Some((vertex, v)) = net
        .vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !v.position.iter().all(|x| x.is_finite()))
    {
        return Err(DrawError::NonFinite {
            vertex,
            position: v.position,
        });
    }
    Ok(())
}

/// ASCII PLY of the grouped curves: every network vertex (coloured by the first grouped curve
/// through it, grey otherwise) and the edges of the grouped curves with their group and
/// colour.
pub fn colored_ply(net: &FeatureCurveNetwork, groups: &[Option<u32>]) -> String {
    let mut vcolor = vec![[160u8, 160, 160]; net.vertices.len()];
    let mut colored = vec![false; net.vertices.len()];
    let mut edges = Vec::new();
    for (c, g) in groups.iter().enumerate() {
        let Some(g) = *g else {
            continue;
        };
        let color = PALETTE[g as usize % PALETTE.len()];
        for &v in &net.curves[c].vertices {
            if !colored[v as usize] {
                colored[v as usize] = true;
                vcolor[v as usize] = color;
            }
        }
        for (a, b) in net.curve_edges(c) {
            edges.push((a, b, g, color));
        }
    }
    let mut s = String::new();
    let _ = write!(
        s,
        "ply\nformat ascii 1.0\ncomment crestflow feature curves coloured by group\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element edge {}\nproperty int vertex1\nproperty int vertex2\nproperty int group\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
        net.vertices.len(),
        edges.len()
    );
    for (v, fv) in net.vertices.iter().enumerate() {
        let p = fv.position;
        let c = vcolor[v];
        let _ = writeln!(s, "{} {} {} {} {} {}", p[0], p[1], p[2], c[0], c[1], c[2]);
    }
    for (a, b, g, c) in edges {
        let _ = writeln!(s, "{a} {b} {g} {} {} {}", c[0], c[1], c[2]);
    }
    s
}

/// The grouped curves over the grey, flat-shaded surface.
pub fn draw_png(
    mesh: &TriMesh,
    net: &FeatureCurveNetwork,
    groups: &[Option<u32>],
    params: &DrawParams,
    par: Par,
) -> Result<crestflow_nodes_render::RgbImage, DrawError> {
    if mesh.n_faces() == 0 {
        return Err(DrawError::Mesh("it has no triangles".into()));
    }
    mesh.check_data()
        .map_err(|d| DrawError::Mesh(format!("{d:?}")))?;
    let corner_normals: Vec<V3> = (0..mesh.n_faces())
        .flat_map(|f| {
            let n = crestflow_geom::vec3::normalize(mesh.face_normal_raw(f));
            [n, n, n]
        })
        .collect();
    let colors = vec![[0.8, 0.8, 0.8]; mesh.n_vertices()];
    let mut segments = Vec::new();
    for (c, g) in groups.iter().enumerate() {
        let Some(g) = *g else {
            continue;
        };
        for (a, b) in net.curve_edges(c) {
            segments.push(Segment {
                a: net.vertices[a as usize].position,
                b: net.vertices[b as usize].position,
                color: PALETTE[g as usize % PALETTE.len()],
            });
        }
    }
    let (lo, hi) = mesh.bbox();
    let view = View {
        up: params.up,
        azimuth_deg: params.azimuth,
        elevation_deg: params.elevation,
        margin: 0.04,
    };
    let camera = Camera::framing(lo, hi, &view, params.width as f64, params.height as f64);
    let style = Style {
        background: [255, 255, 255],
        ambient: 0.3,
        line_width: params.line_width,
        depth_offset: 0.005 * mesh.bbox_diagonal(),
        supersample: 2,
    };
    let scene = Scene {
        positions: &mesh.positions,
        triangles: &mesh.triangles,
        corner_normals: &corner_normals,
        vertex_colors: &colors,
    };
    Ok(rasterize(&scene, &segments, &camera, &style, par).0)
}

fn write_text(path: &Path, text: &str) -> Result<(), DrawError> {
    let io = |source| DrawError::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
    }
    std::fs::write(path, text).map_err(io)
}

/// The `symmetry.draw` node.
pub struct DrawNode;

impl NodeKind for DrawNode {
    type Params = DrawParams;
    const KIND: &'static str = "symmetry.draw";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Pictures of reoccurring curves (thesis Fig. 3.7, 4.3): PLY curve \
        networks coloured by orbit and by transformation cluster (per-vertex and per-edge \
        colours, edge property `group`), and a PNG of the curves coloured by orbit or cluster \
        over the shaded surface. Curves in no group are left out.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "the matched network"),
            Port::of::<Orbits>("orbits", "orbits from symmetry.orbits"),
            Port::of::<TransformClusters>("clusters", "clusters from symmetry.cluster"),
            Port::optional::<TriMesh>("mesh", "the surface, for the PNG"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>(
            "report",
            "curves coloured by orbit and by cluster",
        )]
    }
    fn output_files(params: &Self::Params) -> Vec<PathBuf> {
        [&params.orbit_ply, &params.cluster_ply, &params.png]
            .into_iter()
            .filter(|p| !p.as_os_str().is_empty())
            .cloned()
            .collect()
    }
    fn run(params: &DrawParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let err = |e: DrawError| {
            let kind = match e {
                DrawError::Io { .. } => ErrorKind::Internal,
                _ => ErrorKind::InvalidInput,
            };
            NodeError::from_source(kind, e)
        };
        let issues = params.validate();
        if !issues.is_empty() {
            let text: Vec<String> = issues
                .iter()
                .map(|i| format!("{}: {}", i.field, i.message))
                .collect();
            return Err(err(DrawError::Params(text.join("; "))));
        }
        let net = inputs.get::<FeatureCurveNetwork>("network")?;
        let orbits = inputs.get::<Orbits>("orbits")?;
        let clusters = inputs.get::<TransformClusters>("clusters")?;
        check_network(net).map_err(err)?;
        let n = net.curves.len();
        let by_orbit = orbit_groups(n, orbits).map_err(err)?;
        let by_cluster = cluster_groups(n, clusters, params.clusters as usize).map_err(err)?;
        if !params.orbit_ply.as_os_str().is_empty() {
            write_text(
                &ctx.resolve(&params.orbit_ply),
                &colored_ply(net, &by_orbit),
            )
            .map_err(err)?;
        }
        if !params.cluster_ply.as_os_str().is_empty() {
            write_text(
                &ctx.resolve(&params.cluster_ply),
                &colored_ply(net, &by_cluster),
            )
            .map_err(err)?;
        }
        if !params.png.as_os_str().is_empty() {
            if let Some(mesh) = inputs.opt::<TriMesh>("mesh")? {
                let groups = match params.color_by {
                    ColorBy::Orbit => &by_orbit,
                    ColorBy::Cluster => &by_cluster,
                };
                let image = draw_png(mesh, net, groups, params, ctx.par).map_err(err)?;
                let path = ctx.resolve(&params.png);
                write_png(&image, &path).map_err(|e| {
                    err(DrawError::Io {
                        path: path.clone(),
                        source: std::io::Error::other(e.to_string()),
                    })
                })?;
            }
        }
        let mut r = Report::new();
        r.set(
            "curves_by_orbit",
            by_orbit.iter().filter(|g| g.is_some()).count(),
        );
        r.set(
            "curves_by_cluster",
            by_cluster.iter().filter(|g| g.is_some()).count(),
        );
        Ok(Outputs::new().with("report", r))
    }
}

#[cfg(test)]
#[path = "draw_test.rs"]
mod tests;
