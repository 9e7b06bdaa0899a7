//! `io.save_mesh`: writes a mesh as binary PLY (with per-vertex `k_max`, `k_min` and a
//! mean-curvature colour when a curvature field is connected) or OBJ, so that the curvature of
//! thesis §2.1 (estimated as in §2.4) can be inspected in MeshLab or Blender.

use std::path::{Path, PathBuf};

use crestflow_flow::{Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate};
use crestflow_geom::io::{self, MeshError};
use crestflow_geom::{CurvatureField, TriMesh};
use serde::{Deserialize, Serialize};

use crate::load_mesh::node_error;

/// Parameters of `io.save_mesh`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SaveMeshParams {
    /// Output file, relative to the pipeline file's folder; `.ply` or `.obj`. Folders are
    /// created. Required.
    pub path: PathBuf,
}

impl Default for SaveMeshParams {
    fn default() -> Self {
        SaveMeshParams {
            path: PathBuf::new(),
        }
    }
}

/// The writable formats, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutFormat {
    Ply,
    Obj,
}

/// `.ply` or `.obj` (any case), else an unsupported-format error naming the extension.
pub fn out_format(path: &Path) -> Result<OutFormat, MeshError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("ply") => Ok(OutFormat::Ply),
        Some("obj") => Ok(OutFormat::Obj),
        other => Err(MeshError::UnsupportedFormat {
            path: path.to_path_buf(),
            reason: format!(
                "cannot write {}; use .ply or .obj",
                other
                    .map(|e| format!("`.{e}` files"))
                    .unwrap_or_else(|| "without extension".into())
            ),
        }),
    }
}

/// Checks an output path param: present, with a `.ply`/`.obj` extension.
pub(crate) fn check_out_path(path: &Path) -> Vec<ParamIssue> {
    if path.as_os_str().is_empty() {
        return vec![ParamIssue::new("path", "an output file is required")];
    }
    match out_format(path) {
        Err(MeshError::UnsupportedFormat { reason, .. }) => vec![ParamIssue::new("path", reason)],
        _ => Vec::new(),
    }
}

impl Validate for SaveMeshParams {
    fn validate(&self) -> Vec<ParamIssue> {
        check_out_path(&self.path)
    }
}

/// Writes `mesh` (and the curvature, if any) to `path` (already resolved).
pub fn save_mesh(
    mesh: &TriMesh,
    curvature: Option<&CurvatureField>,
    path: &Path,
    _par: Par,
) -> Result<(), MeshError> {
    match out_format(path)? {
        OutFormat::Ply => io::save_mesh_ply(path, mesh, curvature),
        OutFormat::Obj => io::save_mesh_obj(path, mesh, curvature),
    }
}

/// `io.save_mesh`.
pub struct SaveMeshNode;

impl NodeKind for SaveMeshNode {
    type Params = SaveMeshParams;
    const KIND: &'static str = "io.save_mesh";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Writes a mesh as binary little-endian PLY or OBJ (by extension). \
        With a curvature field connected, PLY vertices carry `k_max`, `k_min` (thesis §2.1, \
        estimated as in §2.4), `quality` = mean curvature H, and a blue-grey-red colour of H \
        saturating at the 95th percentile of |H|; OBJ vertices carry the colour.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the mesh to write"),
            Port::optional::<CurvatureField>("curvature", "per-vertex curvature to attach"),
        ]
    }
    fn outputs() -> Vec<Port> {
        Vec::new()
    }
    fn output_files(params: &Self::Params) -> Vec<PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let curvature = inputs.opt::<CurvatureField>("curvature")?;
        save_mesh(mesh, curvature, &ctx.resolve(&params.path), ctx.par).map_err(node_error)?;
        Ok(Outputs::new())
    }
}
