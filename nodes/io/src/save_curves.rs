//! `io.save_curves`: writes a feature curve network Γ = (V, E, C) (thesis §2.5, Def. 2.1) as a
//! PLY with an `edge` element (MeshLab) or an OBJ of `l` edges in labelled groups (Blender),
//! ridges and ravines told apart by colour and group name.

use std::path::{Path, PathBuf};

use crestflow_flow::{Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate};
use crestflow_geom::io::{self, MeshError};
use crestflow_geom::FeatureCurveNetwork;
use serde::{Deserialize, Serialize};

use crate::load_mesh::node_error;
use crate::save_mesh::{check_out_path, out_format, OutFormat};

/// Parameters of `io.save_curves`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SaveCurvesParams {
    /// Output file, relative to the pipeline file's folder; `.ply` or `.obj`. Folders are
    /// created. Required.
    pub path: PathBuf,
}

impl Default for SaveCurvesParams {
    fn default() -> Self {
        SaveCurvesParams {
            path: PathBuf::new(),
        }
    }
}

impl Validate for SaveCurvesParams {
    fn validate(&self) -> Vec<ParamIssue> {
        check_out_path(&self.path)
    }
}

/// Writes `curves` to `path` (already resolved).
pub fn save_curves(curves: &FeatureCurveNetwork, path: &Path, _par: Par) -> Result<(), MeshError> {
    match out_format(path)? {
        OutFormat::Ply => io::save_curves_ply(path, curves),
        OutFormat::Obj => io::save_curves_obj(path, curves),
    }
}

/// `io.save_curves`.
pub struct SaveCurvesNode;

impl NodeKind for SaveCurvesNode {
    type Params = SaveCurvesParams;
    const KIND: &'static str = "io.save_curves";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Writes a feature curve network (thesis §2.5, Def. 2.1) by \
        extension: PLY with per-vertex strength and label colour (ridges red, ravines blue) and \
        an `edge` element (vertex1, vertex2, curve, label, closing) that MeshLab shows; or OBJ \
        with each curve's edges as `l` lines in a group `ridge_<i>` / `ravine_<i>` (Blender, \
        MeshLab).";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<FeatureCurveNetwork>(
            "curves",
            "the network to write",
        )]
    }
    fn outputs() -> Vec<Port> {
        Vec::new()
    }
    fn output_files(params: &Self::Params) -> Vec<PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let curves = inputs.get::<FeatureCurveNetwork>("curves")?;
        save_curves(curves, &ctx.resolve(&params.path), ctx.par).map_err(node_error)?;
        Ok(Outputs::new())
    }
}
