//! crestflow node family `io`: the edges of every pipeline. Meshes come in through
//! `io.load_mesh` (OBJ, PLY, OFF, STL, validated and optionally repaired as DESIGN §7 asks) and
//! results go out through `io.save_mesh` (curvature of thesis §2.1/§2.4 as vertex properties
//! and colours), `io.save_curves` (feature curve networks of §2.5, Def. 2.1, as PLY edges or
//! OBJ polylines) and `io.save_report` (JSON).
//!
//! The file formats live in [`crestflow_geom::io`]; these nodes resolve paths against the
//! pipeline file's folder, declare the files they read and write (so the cache keys a load by
//! the file's content and reruns a save whose file went missing), and pass loading warnings on.

use crestflow_flow::Registry;

pub mod load_mesh;
pub mod save_curves;
pub mod save_mesh;
pub mod save_report;

pub use load_mesh::{load_mesh, load_report, LoadMeshNode, LoadMeshOutput, LoadMeshParams};
pub use save_curves::{save_curves, SaveCurvesNode, SaveCurvesParams};
pub use save_mesh::{save_mesh, SaveMeshNode, SaveMeshParams};
pub use save_report::{save_report, SaveReportError, SaveReportNode, SaveReportParams};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<LoadMeshNode>();
    registry.add::<SaveMeshNode>();
    registry.add::<SaveCurvesNode>();
    registry.add::<SaveReportNode>();
}
