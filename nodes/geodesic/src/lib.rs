//! crestflow node family `geodesic`: geodesic distances on triangle meshes.
//!
//! - `geodesic.heat` ([`heat`]): the heat method of Crane, Weischedel and Wardetzky,
//!   "Geodesics in Heat" (ACM TOG 2013), from a set of mesh vertices or from whole feature
//!   curves. The thesis (§3.1.2.1, §3.1.2.5) names it as the fast alternative to exact
//!   geodesics for the Geodesic Iso-Curve Signature of feature curves.

use crestflow_flow::Registry;

pub mod heat;

pub use heat::{
    heat_distance, DistanceField, HeatError, HeatNode, HeatParams, HeatSolver, HeatSource,
};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<HeatNode>();
}
