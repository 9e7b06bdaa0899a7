//! `shapes.analytic`: meshes of the analytic test shapes (sphere, open cylinder, torus,
//! ellipsoid) whose curvature is known in closed form, so that pipelines and experiments can
//! measure estimators against ground truth (thesis §2.1.2 for the quantities; §2.4 for the
//! estimators evaluated on them, Yoshizawa et al. 2005 and Hildebrandt et al. 2005).
//!
//! The generators live in `crestflow_geom::shapes`; this node only exposes them.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::shapes::{AnalyticShape, ShapeError, MAX_JITTER, MAX_VERTICES};
use crestflow_geom::TriMesh;

/// Parameters of `shapes.analytic`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnalyticParams {
    /// The shape and its dimensions, e.g. `Torus(major: 1.0, minor: 0.35)` (default
    /// `Sphere(radius: 1.0)`).
    pub shape: AnalyticShape,
    /// About how many vertices (default 10000, range 12..=20000000). Icospheres (sphere,
    /// ellipsoid) take the nearest count 10·4^L + 2.
    pub vertices: usize,
    /// Irregular sampling: each sample moves randomly by up to this fraction of the grid
    /// spacing and grid quads get random diagonals (default 0: regular, range 0..=0.45).
    pub jitter: f64,
    /// Seed of the jitter (default 0).
    pub seed: u64,
}

impl Default for AnalyticParams {
    fn default() -> Self {
        AnalyticParams {
            shape: AnalyticShape::default(),
            vertices: 10_000,
            jitter: 0.0,
            seed: 0,
        }
    }
}

impl Validate for AnalyticParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if let Err(e) = self.shape.check() {
            issues.push(ParamIssue::new("shape", e.to_string()));
        }
        check_range(&mut issues, "vertices", self.vertices, 12, MAX_VERTICES);
        check_range(&mut issues, "jitter", self.jitter, 0.0, MAX_JITTER);
        issues
    }
}

/// Builds the mesh of `params.shape` (see [`AnalyticShape::mesh`]). Single-threaded: the
/// generators are linear-time and cheap next to any consumer.
pub fn analytic_mesh(params: &AnalyticParams, _par: Par) -> Result<TriMesh, ShapeError> {
    params
        .shape
        .mesh(params.vertices, params.jitter, params.seed)
}

/// The `shapes.analytic` node.
pub struct AnalyticNode;

impl NodeKind for AnalyticNode {
    type Params = AnalyticParams;
    const KIND: &'static str = "shapes.analytic";
    const VERSION: u32 = 1;
    const DOC: &'static str = "A mesh of an analytic shape with closed-form curvature: \
        sphere (icosphere), open cylinder, ring torus or ellipsoid, optionally irregularly \
        sampled (seeded jitter). Pair it with eval.curvature_error to measure curvature \
        estimators (thesis §2.1.2, §2.4).";

    fn inputs() -> Vec<Port> {
        Vec::new()
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<TriMesh>(
            "mesh",
            "the sampled shape, triangles facing outwards",
        )]
    }
    fn run(params: &Self::Params, _inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = analytic_mesh(params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("mesh", mesh))
    }
}

#[cfg(test)]
#[path = "analytic_test.rs"]
mod tests;
