//! `descriptors.curve_hks`: the heat kernel signature of feature curves (thesis §3.1.1, after
//! the point HKS of Sun, Ovsjanikov and Guibas 2009, thesis §2.6.1.2).
//!
//! The whole curve emits heat; the signature is the heat that comes back to the curve,
//! `HKS_t(c) = Σ_{v1,v2 ∈ c} w(v1) w(v2) Σ_i e^{−λ_i t} φ_i(v1) φ_i(v2)`, with `w` the
//! normalised curve length per vertex. The double sum factorises:
//! `HKS_t(c) = Σ_i e^{−λ_i t} (Σ_v w(v) φ_i(v))²`, so each curve costs O(k · |c| + k · q).
//! Eigenfunctions at curve points on mesh edges are interpolated linearly.
//!
//! Times: q samples log-spaced in `[4 ln 10 / λ_k, 4 ln 10 / λ_1]` (Sun et al. 2009), with
//! λ_1 the first non-zero eigenvalue. They come from the shape's own spectrum, which is
//! isometry invariant, so two poses of one shape get (nearly) the same times.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::fcn::FeatureCurveNetwork;
use crestflow_geom::mesh::TriMesh;
use crestflow_nodes_geodesic::heat::{
    corners_position, curve_corners, curve_vertex_weights, HeatError,
};
use crestflow_nodes_spectral::laplacian::{laplacian, LaplacianParams};
use crestflow_nodes_spectral::{eigenbasis, EigenBasis, EigenbasisParams};

use crate::descriptor::{CurveDescriptor, CurveDescriptors, DescriptorKind};

/// Parameters of `descriptors.curve_hks`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurveHksParams {
    /// Number of time samples q (default 16, range 1..=1000).
    pub times: usize,
    /// Eigenpairs to compute when no `basis` input is connected (default 100, range
    /// 2..=2000). A connected basis is used whole.
    pub k: usize,
}

impl Default for CurveHksParams {
    fn default() -> Self {
        CurveHksParams { times: 16, k: 100 }
    }
}

impl Validate for CurveHksParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "times", self.times, 1, 1000);
        check_range(&mut issues, "k", self.k, 2, 2000);
        issues
    }
}

/// Errors of [`curve_hks`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HksError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("the eigenbasis has {basis} rows but the mesh has {mesh} vertices")]
    SizeMismatch { basis: usize, mesh: usize },
    #[error("the eigenbasis needs at least one non-zero eigenvalue (it has {0} pairs)")]
    NoNonzeroEigenvalue(usize),
    #[error("curve {curve} has no vertices")]
    EmptyCurve { curve: usize },
    #[error("{0}")]
    Curve(HeatError),
    #[error("Laplacian: {0}")]
    Operator(String),
    #[error("eigenbasis: {0}")]
    Eigen(String),
}

/// Log-spaced times `[4 ln 10 / λ_max, 4 ln 10 / λ_1]`.
pub fn hks_times(basis: &EigenBasis, q: usize) -> Result<Vec<f64>, HksError> {
    let scale = basis.values.iter().map(|l| l.abs()).fold(0.0f64, f64::max);
    let lambda1 = basis
        .values
        .iter()
        .copied()
        .find(|&l| l > 1e-8 * scale)
        .ok_or(HksError::NoNonzeroEigenvalue(basis.k()))?;
    let t_min = 4.0 * 10f64.ln() / scale;
    let t_max = 4.0 * 10f64.ln() / lambda1;
    if q == 1 {
        return Ok(vec![t_min]);
    }
    let (a, b) = (t_min.ln(), t_max.ln());
    Ok((0..q)
        .map(|i| (a + (b - a) * i as f64 / (q - 1) as f64).exp())
        .collect())
}

/// Curve HKS of every curve of `network` from `basis` (mesh-vertex eigenfunctions).
pub fn curve_hks_from_basis(
    mesh: &TriMesh,
    network: &FeatureCurveNetwork,
    basis: &EigenBasis,
    params: &CurveHksParams,
    par: Par,
) -> Result<CurveDescriptors, HksError> {
    if basis.n != mesh.n_vertices() || basis.vectors.len() != basis.n * basis.k() {
        return Err(HksError::SizeMismatch {
            basis: basis.n,
            mesh: mesh.n_vertices(),
        });
    }
    let times = hks_times(basis, params.times)?;
    // Curve points as mesh-vertex combinations, checked before the parallel part; lengths
    // measured on `mesh`.
    let mut curves_pts = Vec::with_capacity(network.curves.len());
    for (c, curve) in network.curves.iter().enumerate() {
        if curve.vertices.is_empty() {
            return Err(HksError::EmptyCurve { curve: c });
        }
        let corners = curve_corners(network, c, mesh).map_err(HksError::Curve)?;
        let pos: Vec<_> = corners
            .iter()
            .map(|cs| corners_position(mesh, cs))
            .collect();
        let w = curve_vertex_weights(&pos, curve.closed);
        curves_pts.push((w, corners));
    }
    let curves = par.map_collect(curves_pts.len(), |c| {
        let (w, corners) = &curves_pts[c];
        // a_i = Σ_v w(v) φ_i(v)
        let a: Vec<f64> = (0..basis.k())
            .map(|i| {
                let phi = basis.vector(i);
                w.iter()
                    .zip(corners)
                    .map(|(wv, cs)| wv * cs.iter().map(|&(m, b)| b * phi[m as usize]).sum::<f64>())
                    .sum()
            })
            .collect();
        let values = times
            .iter()
            .map(|&t| {
                basis
                    .values
                    .iter()
                    .zip(&a)
                    .map(|(l, ai)| (-l * t).exp() * ai * ai)
                    .sum()
            })
            .collect();
        CurveDescriptor {
            values,
            samples: times.clone(),
            d_max: 0.0,
        }
    });
    Ok(CurveDescriptors {
        kind: DescriptorKind::Hks,
        curves,
    })
}

/// Curve HKS with the mesh's own eigenbasis of `params.k` pairs, or `basis` when given.
pub fn curve_hks(
    mesh: &TriMesh,
    network: &FeatureCurveNetwork,
    basis: Option<&EigenBasis>,
    params: &CurveHksParams,
    par: Par,
) -> Result<CurveDescriptors, HksError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(HksError::Params(text.join("; ")));
    }
    match basis {
        Some(b) => curve_hks_from_basis(mesh, network, b, params, par),
        None => {
            let op = laplacian(mesh, &LaplacianParams::default(), par)
                .map_err(|e| HksError::Operator(e.to_string()))?;
            let ep = EigenbasisParams {
                k: params.k.min(mesh.n_vertices().saturating_sub(1)).max(1),
                ..Default::default()
            };
            let b = eigenbasis(&op, &ep, par).map_err(|e| HksError::Eigen(e.to_string()))?;
            curve_hks_from_basis(mesh, network, &b, params, par)
        }
    }
}

/// Node wrapper of [`curve_hks`].
pub struct CurveHksNode;

impl NodeKind for CurveHksNode {
    type Params = CurveHksParams;
    const KIND: &'static str = "descriptors.curve_hks";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Heat kernel signature of every feature curve (thesis §3.1.1, \
        after Sun, Ovsjanikov, Guibas 2009): the heat that flows from the whole curve back to \
        itself at q log-spaced times, length-weighted over the curve points, from the \
        Laplace-Beltrami eigenbasis (the `basis` input when connected, else k pairs of its \
        own).";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the surface"),
            Port::of::<FeatureCurveNetwork>("curves", "the curves to describe"),
            Port::optional::<EigenBasis>("basis", "Laplace-Beltrami eigenbasis of the mesh"),
        ]
    }

    fn outputs() -> Vec<Port> {
        vec![Port::of::<CurveDescriptors>(
            "descriptors",
            "one HKS per curve, in curve order",
        )]
    }

    fn run(params: &CurveHksParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let net = inputs.get::<FeatureCurveNetwork>("curves")?;
        let basis = inputs.opt::<EigenBasis>("basis")?;
        let out = curve_hks(mesh, net, basis, params, ctx.par).map_err(|e| {
            let kind = match &e {
                HksError::Eigen(_) => ErrorKind::NumericalFailure,
                _ => ErrorKind::InvalidInput,
            };
            NodeError::from_source(kind, e)
        })?;
        Ok(Outputs::new().with("descriptors", out))
    }
}
