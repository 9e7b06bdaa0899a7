//! `io.load_mesh`: reads a triangle mesh (OBJ, PLY, OFF, STL), validates it and repairs what the
//! params allow. Every later step (curvature, thesis §2.4; ridges and the feature curve network,
//! §2.5) starts from the mesh this node produces, so its checks are the ones DESIGN §7 lists:
//! empty meshes, non-finite coordinates, out-of-range indices and non-manifold connectivity are
//! typed errors; degenerate and duplicate faces and unreferenced vertices are dropped and
//! counted; several components and inconsistent orientation are reported (`repair` splits
//! non-manifold vertices and orients each component coherently). The work is done by [`crestflow_geom::io`].

use std::path::{Path, PathBuf};

use crestflow_flow::{
    Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Report, Validate,
};
use crestflow_geom::io::{self, LoadOptions, LoadReport, MeshError, MeshFormat};
use crestflow_geom::TriMesh;
use serde::{Deserialize, Serialize};

/// Parameters of `io.load_mesh`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoadMeshParams {
    /// The mesh file, relative to the pipeline file's folder. Required. The format comes from
    /// the extension: `.obj`, `.ply`, `.off`, `.stl` (any case).
    pub path: PathBuf,
    /// Split non-manifold edges and vertices instead of failing, and flip faces so that each
    /// component is coherently oriented, a closed one outward (default false).
    pub repair: bool,
    /// Fail on faces with a repeated vertex index instead of dropping them (default false).
    pub reject_degenerate: bool,
}

impl Default for LoadMeshParams {
    fn default() -> Self {
        LoadMeshParams {
            path: PathBuf::new(),
            repair: false,
            reject_degenerate: false,
        }
    }
}

impl Validate for LoadMeshParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if self.path.as_os_str().is_empty() {
            issues.push(ParamIssue::new("path", "a mesh file is required"));
        } else if let Err(MeshError::UnsupportedFormat { reason, .. }) =
            MeshFormat::from_path(&self.path)
        {
            issues.push(ParamIssue::new("path", reason));
        }
        issues
    }
}

/// The mesh and what loading found and did.
#[derive(Clone, Debug)]
pub struct LoadMeshOutput {
    pub mesh: TriMesh,
    pub report: LoadReport,
}

/// Loads `path` (already resolved) with the params' options.
pub fn load_mesh(
    path: &Path,
    params: &LoadMeshParams,
    _par: Par,
) -> Result<LoadMeshOutput, MeshError> {
    let options = LoadOptions {
        repair: params.repair,
        reject_degenerate: params.reject_degenerate,
    };
    let loaded = io::load_mesh(path, &options)?;
    Ok(LoadMeshOutput {
        mesh: loaded.mesh,
        report: loaded.report,
    })
}

/// The load report as a [`Report`] (counts as numbers, the format as text).
pub fn load_report(r: &LoadReport) -> Report {
    let mut out = Report::new();
    out.set("format", r.format.as_str())
        .set("file_vertices", r.file_vertices)
        .set("file_faces", r.file_faces)
        .set("polygons_triangulated", r.polygons_triangulated)
        .set("vertices_welded", r.vertices_welded)
        .set("degenerate_faces_dropped", r.degenerate_faces_dropped)
        .set("strip_degenerates_skipped", r.strip_degenerates_skipped)
        .set("duplicate_faces_dropped", r.duplicate_faces_dropped)
        .set(
            "unreferenced_vertices_dropped",
            r.unreferenced_vertices_dropped,
        )
        .set("nonmanifold_edges", r.nonmanifold_edges)
        .set("nonmanifold_vertices", r.nonmanifold_vertices)
        .set("vertices_split", r.vertices_split)
        .set("zero_area_faces", r.zero_area_faces)
        .set("inconsistent_edges", r.inconsistent_edges)
        .set("faces_flipped", r.faces_flipped)
        .set("nonorientable_components", r.nonorientable_components)
        .set("boundary_edges", r.boundary_edges)
        .set("components", r.components)
        .set("vertices", r.vertices)
        .set("faces", r.faces);
    out
}

/// How a mesh error is classified for the engine.
pub(crate) fn node_error(e: MeshError) -> NodeError {
    let kind = match e {
        MeshError::UnsupportedFormat { .. } => ErrorKind::Unsupported,
        _ => ErrorKind::InvalidInput,
    };
    NodeError::from_source(kind, e)
}

/// `io.load_mesh`.
pub struct LoadMeshNode;

impl NodeKind for LoadMeshNode {
    type Params = LoadMeshParams;
    const KIND: &'static str = "io.load_mesh";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Loads a triangle mesh from OBJ, PLY (ascii/binary, face lists and \
        triangle strips), OFF or STL (coincident corners welded). Polygons are fan-triangulated; \
        degenerate and duplicate faces and unreferenced vertices are dropped and reported; empty \
        meshes, NaN/inf coordinates, out-of-range indices and non-manifold edges or vertices are \
        errors unless `repair: true` splits the latter; `repair: true` also flips faces so that \
        each component is coherently oriented (a closed one outward). The input of the curvature and ridge \
        steps (thesis §2.4, §2.5). Outputs the mesh and a report of what loading found.";

    fn inputs() -> Vec<Port> {
        Vec::new()
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the validated triangle mesh"),
            Port::of::<Report>(
                "report",
                "counts of what loading found, dropped and repaired",
            ),
        ]
    }
    fn input_files(params: &Self::Params) -> Vec<PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, _inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let path = ctx.resolve(&params.path);
        let out = load_mesh(&path, params, ctx.par).map_err(node_error)?;
        for w in out.report.warnings() {
            ctx.warn(&format!("{}: {w}", params.path.display()));
        }
        let report = load_report(&out.report);
        Ok(Outputs::new().with("mesh", out.mesh).with("report", report))
    }
}
