//! `eval.curvature_error`: compares a [`CurvatureField`] with the closed-form curvature of an
//! analytic shape (thesis §2.1.2 for the quantities; the estimators it grades are those of
//! §2.4: Yoshizawa, Belyaev, Seidel 2005 and Hildebrandt, Polthier, Wardetzky 2005).
//!
//! Every vertex is projected onto the shape and compared with the exact values there
//! (`crestflow_geom::shapes::analytic_curvature_field`). Definitions, over the evaluated
//! vertices (boundary vertices left out unless `skip_boundary` is false):
//!
//! - `k_max.mean_rel`, `k_max.p95_rel` (and `k_min.*`): mean and 95th percentile (nearest
//!   rank) of |k − k_true| / |k_true|, over vertices where |k_true| > `zero_tol` · RMS, with
//!   RMS = sqrt(mean((k_max,true² + k_min,true²) / 2)). Where k_true is ~0 (the cylinder's
//!   k_min, the torus' k_min on its top and bottom circles) a relative error means nothing;
//!   `k_*.n_rel` says how many vertices entered.
//! - `rel_mae`: mean |k − k_true| over both curvatures divided by RMS: scale free, defined
//!   everywhere.
//! - `dir.mean_deg`, `dir.p95_deg`: angle between the estimated and exact t_max lines
//!   (0..90°) where the shape is not umbilic: (k_max − k_min)_true > `umbilic_tol` · RMS.
//!   Absent for the sphere.
//! - `e.rel_mae`: mean |e − e_true| over e_max and e_min, each estimate taken along the exact
//!   direction's orientation, divided by RMS²; `e_max.mae`, `e_min.mae` in mesh units.
//! - `surface_dist.max_rel`: largest distance of a vertex from the shape over the mesh's bbox
//!   diagonal: a large value means the mesh does not sample this shape.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::shapes::{analytic_curvature_field, AnalyticShape, ShapeError};
use crestflow_geom::vec3;
use crestflow_geom::{CurvatureField, TriMesh};

/// Parameters of `eval.curvature_error`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurvatureErrorParams {
    /// The shape the mesh samples, e.g. `Torus(major: 1.0, minor: 0.35)` (default
    /// `Sphere(radius: 1.0)`).
    pub shape: AnalyticShape,
    /// Leave boundary vertices (one-sided neighbourhoods, e.g. the rims of the open cylinder)
    /// out of every figure (default true).
    pub skip_boundary: bool,
    /// Relative errors skip vertices with |k_true| ≤ zero_tol · RMS (default 0.01, range
    /// 0..=1).
    pub zero_tol: f64,
    /// Direction errors skip vertices with (k_max − k_min)_true ≤ umbilic_tol · RMS (default
    /// 0.05, range 0..=10).
    pub umbilic_tol: f64,
}

impl Default for CurvatureErrorParams {
    fn default() -> Self {
        CurvatureErrorParams {
            shape: AnalyticShape::default(),
            skip_boundary: true,
            zero_tol: 0.01,
            umbilic_tol: 0.05,
        }
    }
}

impl Validate for CurvatureErrorParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if let Err(e) = self.shape.check() {
            issues.push(ParamIssue::new("shape", e.to_string()));
        }
        check_range(&mut issues, "zero_tol", self.zero_tol, 0.0, 1.0);
        check_range(&mut issues, "umbilic_tol", self.umbilic_tol, 0.0, 10.0);
        issues
    }
}

/// Errors of [`curvature_error`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurvatureErrorError {
    #[error("the curvature field has {field} vertices but the mesh has {mesh}")]
    LengthMismatch { field: usize, mesh: usize },
    #[error("field `{name}` of the curvature field has {len} entries, expected {expected}")]
    FieldLength {
        name: &'static str,
        len: usize,
        expected: usize,
    },
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("no vertex to evaluate (the mesh is empty or all vertices are on the boundary)")]
    NoVertices,
    #[error(transparent)]
    Shape(#[from] ShapeError),
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// 95th percentile by nearest rank (NaN for an empty list).
fn p95(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let rank = (0.95 * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

/// Compares `field` on `mesh` with the exact curvature of `params.shape` (definitions in the
/// module docs). Sequential: the cost is a few closed-form evaluations per vertex, and the
/// reductions stay in vertex order.
pub fn curvature_error(
    mesh: &TriMesh,
    field: &CurvatureField,
    params: &CurvatureErrorParams,
    _par: Par,
) -> Result<Report, CurvatureErrorError> {
    params.shape.check()?;
    let n = mesh.n_vertices();
    if field.len() != n {
        return Err(CurvatureErrorError::LengthMismatch {
            field: field.len(),
            mesh: n,
        });
    }
    for (name, len) in [
        ("k_min", field.k_min.len()),
        ("t_max", field.t_max.len()),
        ("t_min", field.t_min.len()),
        ("normal", field.normal.len()),
        ("e_max", field.e_max.len()),
        ("e_min", field.e_min.len()),
    ] {
        if len != n {
            return Err(CurvatureErrorError::FieldLength {
                name,
                len,
                expected: n,
            });
        }
    }
    for (face, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(CurvatureErrorError::IndexOutOfRange {
                face,
                index,
                n_vertices: n,
            });
        }
    }
    let boundary = &mesh.topology().is_boundary_vertex;
    let used: Vec<usize> = (0..n)
        .filter(|&v| !(params.skip_boundary && boundary[v]))
        .collect();
    if used.is_empty() {
        return Err(CurvatureErrorError::NoVertices);
    }
    let exact = analytic_curvature_field(mesh, &params.shape);

    let rms = (used
        .iter()
        .map(|&v| 0.5 * (exact.k_max[v].powi(2) + exact.k_min[v].powi(2)))
        .sum::<f64>()
        / used.len() as f64)
        .sqrt();
    let mut rel_max = Vec::new();
    let mut rel_min = Vec::new();
    let mut abs_k = Vec::with_capacity(2 * used.len());
    let mut dir = Vec::new();
    let mut e_max_err = Vec::with_capacity(used.len());
    let mut e_min_err = Vec::with_capacity(used.len());
    let mut dist_max = 0.0f64;
    for &v in &used {
        let (k1, k2) = (exact.k_max[v], exact.k_min[v]);
        let (d1, d2) = ((field.k_max[v] - k1).abs(), (field.k_min[v] - k2).abs());
        abs_k.push(d1);
        abs_k.push(d2);
        if k1.abs() > params.zero_tol * rms {
            rel_max.push(d1 / k1.abs());
        }
        if k2.abs() > params.zero_tol * rms {
            rel_min.push(d2 / k2.abs());
        }
        if k1 - k2 > params.umbilic_tol * rms {
            let c = vec3::dot(vec3::normalize(field.t_max[v]), exact.t_max[v])
                .abs()
                .min(1.0);
            dir.push(c.acos().to_degrees());
        }
        // Extremality is signed by its direction: compare along the exact orientation.
        let s_max = if vec3::dot(field.t_max[v], exact.t_max[v]) < 0.0 {
            -1.0
        } else {
            1.0
        };
        let s_min = if vec3::dot(field.t_min[v], exact.t_min[v]) < 0.0 {
            -1.0
        } else {
            1.0
        };
        e_max_err.push((s_max * field.e_max[v] - exact.e_max[v]).abs());
        e_min_err.push((s_min * field.e_min[v] - exact.e_min[v]).abs());
        let q = params.shape.project(mesh.positions[v]);
        dist_max = dist_max.max(vec3::dist(q, mesh.positions[v]));
    }

    let mut r = Report::new();
    r.set("shape", params.shape.name());
    r.set("method", field.method.clone());
    r.set("n_vertices", used.len());
    r.set("k.rms_true", rms);
    r.set("k_max.mean_rel", mean(&rel_max));
    r.set("k_max.n_rel", rel_max.len());
    r.set("k_max.p95_rel", p95(&mut rel_max));
    r.set("k_min.mean_rel", mean(&rel_min));
    r.set("k_min.n_rel", rel_min.len());
    r.set("k_min.p95_rel", p95(&mut rel_min));
    r.set("rel_mae", mean(&abs_k) / rms);
    if !dir.is_empty() {
        r.set("dir.mean_deg", mean(&dir));
        r.set("dir.n", dir.len());
        r.set("dir.p95_deg", p95(&mut dir));
    }
    let (e_max_mae, e_min_mae) = (mean(&e_max_err), mean(&e_min_err));
    r.set("e_max.mae", e_max_mae);
    r.set("e_min.mae", e_min_mae);
    r.set("e.rel_mae", 0.5 * (e_max_mae + e_min_mae) / (rms * rms));
    let diag = mesh.bbox_diagonal();
    r.set(
        "surface_dist.max_rel",
        if diag > 0.0 { dist_max / diag } else { 0.0 },
    );
    Ok(r)
}

/// The `eval.curvature_error` node.
pub struct CurvatureErrorNode;

impl NodeKind for CurvatureErrorNode {
    type Params = CurvatureErrorParams;
    const KIND: &'static str = "eval.curvature_error";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Errors of a curvature field against the closed-form curvature \
        of an analytic shape (sphere, cylinder, torus, ellipsoid): mean and 95th-percentile \
        relative errors of k_max and k_min, scale-free mean absolute error, direction error \
        in degrees, extremality error (thesis §2.1.2, §2.4). Output: a Report.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the mesh the field was computed on"),
            Port::of::<CurvatureField>("curvature", "the estimate to grade"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<Report>(
            "report",
            "error figures (see the node's documentation)",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let field = inputs.get::<CurvatureField>("curvature")?;
        ctx.check_cancelled()?;
        let report = curvature_error(mesh, field, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        if let Some(d) = report.num("surface_dist.max_rel") {
            if d > 1e-3 {
                ctx.warn(&format!(
                    "vertices lie up to {:.2} % of the bbox diagonal off the {}: is it the \
                     right shape?",
                    100.0 * d,
                    params.shape.name()
                ));
            }
        }
        Ok(Outputs::new().with("report", report))
    }
}
