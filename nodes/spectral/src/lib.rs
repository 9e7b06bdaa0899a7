//! crestflow node family `spectral`: the discrete Laplace–Beltrami operator and its
//! eigenbasis (thesis §2.3, used by the functional maps of §2.6.3 and §5.2).
//!
//! - [`sparse`]: the sparse matrix type, the cotangent Laplacian and lumped mass matrix, and a
//!   reusable sparse Cholesky solver — the sparse API other families build on.
//! - `spectral.laplacian` ([`mod@laplacian`]): `L` and `M` of a mesh as a [`LaplacianOperator`].
//! - `spectral.eigenbasis` ([`mod@eigenbasis`]): the k smallest eigenpairs of `L φ = λ M φ` as an
//!   [`EigenBasis`], by block shift-invert Lanczos.

use crestflow_flow::Registry;

pub mod assemble;
pub mod eigenbasis;
pub mod laplacian;
pub mod sparse;

pub use eigenbasis::{
    eigenbasis, eigenbasis_with_cancel, EigenBasis, EigenbasisError, EigenbasisNode,
    EigenbasisParams,
};
pub use laplacian::{laplacian, LaplacianNode, LaplacianOperator, LaplacianParams};
pub use sparse::{cotan_laplacian, lumped_mass, CsrMatrix, SpdSolver};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<LaplacianNode>();
    registry.add::<EigenbasisNode>();
}
