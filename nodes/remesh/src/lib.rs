//! crestflow node family `remesh`: feature-constrained isotropic remeshing (thesis §5.1.1,
//! after Botsch & Kobbelt 2004, "A remeshing approach to multiresolution modeling"; the
//! feature network that constrains it is the subject of thesis §4.3).
//!
//! - `remesh.isotropic` ([`isotropic()`]): splits, collapses, valence-improving flips and
//!   tangential relaxation with projection onto the input surface, keeping feature edges
//!   (from a [`FeatureCurveNetwork`](crestflow_geom::FeatureCurveNetwork), sharp dihedral
//!   angles and boundaries) in the output; feature vertices slide along their chain
//!   ([`chain`]: arc-length parametrised feature polylines) without cutting its bends;
//!   tips narrower than the target keep a vertex at their apex ([`tips`]).
//! - `remesh.sharp_edges` ([`sharp_edges()`]): those sharp-edge and boundary chains as a feature
//!   curve network (the features of CAD meshes, e.g. for the symmetry nodes).

// Comparisons are written `!(x > y)` where NaN must take the rejecting branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crestflow_flow::Registry;

pub mod bvh;
pub mod chain;
pub mod features;
pub mod holes;
pub mod isotropic;
pub mod project;
pub mod prune;
pub mod sharp_edges;
pub mod tips;

pub use isotropic::{
    isotropic, IsotropicNode, IsotropicParams, Relaxation, RemeshError, RemeshOutput,
};
pub use sharp_edges::{sharp_edges, SharpEdgesNode, SharpEdgesParams};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<IsotropicNode>();
    registry.add::<SharpEdgesNode>();
}
