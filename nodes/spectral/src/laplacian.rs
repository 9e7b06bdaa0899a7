//! `spectral.laplacian`: the cotangent Laplace–Beltrami operator of a mesh (thesis §2.3:
//! cotangent weights and lumped mass matrix, with `L φ = λ M φ`; Pinkall & Polthier 1993,
//! Meyer, Desbrun, Schröder, Barr 2003).
//!
//! The output [`LaplacianOperator`] carries the stiffness matrix `L` (positive semi-definite:
//! `L = −cotmatrix`, rows sum to zero) and the lumped mass diagonal `M`. See
//! [`crate::sparse`] for the discretisation details: mixed Voronoi or barycentric mass,
//! intrinsic mollification of near-degenerate triangles and clamped cotangents.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::TriMesh;

use crate::sparse::{laplacian_and_mass, CsrMatrix, LaplacianOptions, MassKind, OperatorError};

/// Parameters of `spectral.laplacian`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LaplacianParams {
    /// Lumped mass: `Voronoi` (mixed Voronoi areas, Meyer et al. 2003; default) or
    /// `Barycentric` (a third of each triangle's area).
    pub mass: MassKind,
    /// Intrinsic mollification slack as a fraction of the mean edge length (default 1e-6,
    /// range 0..=0.1; 0 disables it and leaves only the cotangent clamp).
    pub mollify: f64,
}

impl Default for LaplacianParams {
    fn default() -> Self {
        let o = LaplacianOptions::default();
        LaplacianParams {
            mass: o.mass,
            mollify: o.mollify,
        }
    }
}

impl Validate for LaplacianParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "mollify", self.mollify, 0.0, 0.1);
        issues
    }
}

/// The discrete Laplace–Beltrami operator of a mesh: `L φ = λ M φ`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaplacianOperator {
    /// Cotangent stiffness matrix, symmetric positive semi-definite, `n × n`.
    pub stiffness: CsrMatrix,
    /// Lumped mass matrix diagonal (vertex areas), length `n`; 0 for unreferenced vertices.
    pub mass: Vec<f64>,
    /// The mass discretisation used.
    pub mass_kind: MassKind,
}

impl LaplacianOperator {
    /// Number of vertices.
    pub fn n(&self) -> usize {
        self.mass.len()
    }
    /// Total mass (the surface area).
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }
}

/// Builds `L` and `M` of `mesh` (see [`crate::sparse`]); per-face terms in parallel under
/// `Par::Rayon`, assembled in face order.
pub fn laplacian(
    mesh: &TriMesh,
    params: &LaplacianParams,
    par: Par,
) -> Result<LaplacianOperator, OperatorError> {
    let opts = LaplacianOptions {
        mass: params.mass,
        mollify: params.mollify,
    };
    let (stiffness, mass) = laplacian_and_mass(mesh, &opts, par)?;
    Ok(LaplacianOperator {
        stiffness,
        mass,
        mass_kind: params.mass,
    })
}

/// Node wrapper of [`laplacian`].
pub struct LaplacianNode;

impl NodeKind for LaplacianNode {
    type Params = LaplacianParams;
    const KIND: &'static str = "spectral.laplacian";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Cotangent Laplace-Beltrami operator of a triangle mesh: the \
        positive semi-definite stiffness matrix L (cotangent weights, Pinkall & Polthier 1993) \
        and the lumped mass matrix M (mixed Voronoi areas, Meyer et al. 2003, or barycentric), \
        robust to degenerate triangles by intrinsic mollification (Sharp & Crane 2020) and \
        clamped cotangents (thesis §2.3). Output: a LaplacianOperator for spectral.eigenbasis \
        and solvers.";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<TriMesh>("mesh", "the triangle mesh")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<LaplacianOperator>(
            "operator",
            "stiffness matrix L and lumped mass M",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        ctx.check_cancelled()?;
        let op = laplacian(mesh, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("operator", op))
    }
}
