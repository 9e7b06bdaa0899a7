//! crestflow node family `smooth`: feature-preserving mesh smoothing (thesis §5.1.3, Table 5.1).
//!
//! - `smooth.laplacian` ([`laplacian`]): uniform or cotangent (§2.3) Laplacian smoothing with
//!   explicit or implicit steps (Desbrun, Meyer, Schröder & Barr 1999; Taubin 1995); the mesh
//!   vertices under an optional feature curve network stay fixed ([`constraints`]), so the
//!   features survive while the noise between them is removed.

use crestflow_flow::Registry;

pub mod constraints;
pub mod laplacian;

pub use constraints::{curve_fixed_vertices, ConstraintError};
pub use laplacian::{
    laplacian_smooth, laplacian_smooth_with, LaplacianNode, LaplacianParams, Mass, SmoothError,
    SmoothOutput, SmoothStats, Step, Weights,
};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<LaplacianNode>();
}
