//! crestflow node family `curvature`: principal curvatures, principal directions and
//! extremality coefficients of triangle meshes (thesis §2.1.2 for the quantities, §2.4 for the
//! estimators, §2.5.1.1 step 2 for the orientation of directions).
//!
//! Two interchangeable estimators produce the same [`CurvatureField`](crestflow_geom::CurvatureField),
//! so a pipeline swaps them by editing one `kind:` line:
//!
//! - `curvature.polynomial` ([`polynomial`]): local bivariate cubic fitting with neighbour
//!   normals (Yoshizawa, Belyaev, Seidel 2005; Goldfeather, Interrante 2004). Accurate,
//!   derivatives from the cubic terms.
//! - `curvature.shape_operator` ([`shape_operator`]): discrete shape operator (Hildebrandt,
//!   Polthier, Wardetzky 2005; Rusinkiewicz 2004) with piecewise-linear derivatives. Faster,
//!   coarser.
//!
//! Both orient their directions with [`orient::orient_directions`] and run in parallel over
//! vertices with results independent of the thread count.

use crestflow_flow::Registry;

pub mod local;
pub mod orient;
pub mod polynomial;
pub mod shape_operator;

pub use polynomial::{polynomial_curvature, PolynomialNode, PolynomialParams};
pub use shape_operator::{shape_operator_curvature, ShapeOperatorNode, ShapeOperatorParams};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<PolynomialNode>();
    registry.add::<ShapeOperatorNode>();
}
