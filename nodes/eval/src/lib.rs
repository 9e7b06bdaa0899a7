//! crestflow node family `eval`: measurements that end in a [`Report`](crestflow_flow::Report),
//! which experiments collect into comparison tables.
//!
//! - `eval.curvature_error` ([`mod@curvature_error`]): a curvature field against the closed-form
//!   curvature of an analytic shape (thesis §2.1.2, §2.4).

use crestflow_flow::Registry;

pub mod curvature_error;
pub mod mesh_distance;
pub mod mesh_quality;

pub use curvature_error::{curvature_error, CurvatureErrorNode, CurvatureErrorParams};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<CurvatureErrorNode>();
    registry.add::<mesh_quality::MeshQualityNode>();
    registry.add::<mesh_distance::MeshDistanceNode>();
}
