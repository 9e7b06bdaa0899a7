//! crestflow node family `shapes`: analytic test shapes with closed-form curvature (thesis
//! §2.1.2), used as ground truth for the curvature estimators of §2.4 (Yoshizawa et al. 2005,
//! Hildebrandt et al. 2005) and for ridge tracing (§2.5).
//!
//! - `shapes.analytic` ([`analytic`]): sphere, open cylinder, torus or ellipsoid mesh, regular
//!   or irregularly sampled.

use crestflow_flow::Registry;

pub mod analytic;

pub use analytic::{analytic_mesh, AnalyticNode, AnalyticParams};

/// Adds this family's node kinds to `registry`.
pub fn register(registry: &mut Registry) {
    registry.add::<AnalyticNode>();
}
