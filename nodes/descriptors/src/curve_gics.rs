//! `descriptors.curve_gics`: the Geodesic Iso-Curve Signature of feature curves (thesis §3.1.2;
//! Gehre, Bronstein, Kobbelt et al. 2016, extending Tabia et al. 2011 to curves).
//!
//! For each curve c: the geodesic distance from the whole curve (heat method, Crane et al.
//! 2013, instead of the thesis's exact geodesics — §3.1.2.5 suggests it), d_max(c) its largest
//! value, radii `r_i = f_s(i/n) · d_max(c) / f_s(1)` for i = 1..n with `f_s(x) = x` or `x⁴`
//! (§3.1.2.4), and the length of the iso-contour at each radius, found by marching over the
//! triangles with linear interpolation on the edges (§3.1.2.2, Fig. 3.1).
//!
//! Distance fields are solved in batches of right-hand sides against one factorisation;
//! contours of different curves are measured in parallel and collected in curve order, so the
//! result does not depend on the thread count.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::fcn::FeatureCurveNetwork;
use crestflow_geom::mesh::TriMesh;
use crestflow_geom::vec3::{dist, lerp, V3};
use crestflow_nodes_geodesic::{HeatError, HeatSolver, HeatSource};

use crate::descriptor::{CurveDescriptor, CurveDescriptors, DescriptorKind};

/// The radius sampling function f_s of §3.1.2.4.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Sampling {
    /// f_s(x) = x: uniform radii.
    Linear,
    /// f_s(x) = x⁴: dense near the curve.
    Quartic,
}

/// Parameters of `descriptors.curve_gics`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurveGicsParams {
    /// Number of radii n (default 32, range 1..=4096).
    pub radii: usize,
    /// Sampling function (default Quartic, as in the thesis's Fig. 3.6).
    pub sampling: Sampling,
    /// Heat-method time factor m, t = m·h² (default 1, range 1e-3..=1e3).
    pub time_factor: f64,
    /// Curves per block of right-hand sides (default 16, range 1..=1024): bounds memory.
    pub batch: usize,
}

impl Default for CurveGicsParams {
    fn default() -> Self {
        CurveGicsParams {
            radii: 32,
            sampling: Sampling::Quartic,
            time_factor: 1.0,
            batch: 16,
        }
    }
}

impl Validate for CurveGicsParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "radii", self.radii, 1, 4096);
        check_range(&mut issues, "time_factor", self.time_factor, 1e-3, 1e3);
        check_range(&mut issues, "batch", self.batch, 1, 1024);
        issues
    }
}

/// Errors of [`curve_gics`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GicsError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("curve {curve} has no vertices")]
    EmptyCurve { curve: usize },
    #[error("geodesic distance: {0}")]
    Heat(#[from] HeatError),
}

/// The radii r_1..r_n for `d_max`.
pub fn radii(n: usize, sampling: Sampling, d_max: f64) -> Vec<f64> {
    (1..=n)
        .map(|i| {
            let x = i as f64 / n as f64;
            let f = match sampling {
                Sampling::Linear => x,
                Sampling::Quartic => x * x * x * x,
            };
            f * d_max
        })
        .collect()
}

/// Lengths of the iso-contours `d = r` for each radius (ascending or not), marching over the
/// triangles: a triangle whose corners straddle r contributes the segment between the two
/// edge crossings. Faces with a non-finite distance are skipped.
pub fn contour_lengths(mesh: &TriMesh, d: &[f64], radii: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; radii.len()];
    for t in &mesh.triangles {
        let dv = [d[t[0] as usize], d[t[1] as usize], d[t[2] as usize]];
        if !dv.iter().all(|x| x.is_finite()) {
            continue;
        }
        let p: [V3; 3] = [
            mesh.positions[t[0] as usize],
            mesh.positions[t[1] as usize],
            mesh.positions[t[2] as usize],
        ];
        let lo = dv[0].min(dv[1]).min(dv[2]);
        let hi = dv[0].max(dv[1]).max(dv[2]);
        for (k, &r) in radii.iter().enumerate() {
            // "Above" is d ≥ r, so every triangle is cut at exactly 0 or 2 edges.
            if r <= lo || r > hi {
                continue;
            }
            let mut pts = [[0.0; 3]; 2];
            let mut m = 0;
            for e in 0..3 {
                let (i, j) = (e, (e + 1) % 3);
                if (dv[i] >= r) != (dv[j] >= r) && m < 2 {
                    let w = (r - dv[i]) / (dv[j] - dv[i]);
                    pts[m] = lerp(p[i], p[j], w);
                    m += 1;
                }
            }
            if m == 2 {
                out[k] += dist(pts[0], pts[1]);
            }
        }
    }
    out
}

/// GICS of every curve of `network` on `mesh`.
pub fn curve_gics(
    mesh: &TriMesh,
    network: &FeatureCurveNetwork,
    params: &CurveGicsParams,
    par: Par,
) -> Result<CurveDescriptors, GicsError> {
    curve_gics_with_cancel(mesh, network, params, par, &|| false)
}

/// [`curve_gics`] polling `cancelled` between batches; once cancelled it stops and the
/// result holds fewer curves (the node then reports the cancellation).
pub fn curve_gics_with_cancel(
    mesh: &TriMesh,
    network: &FeatureCurveNetwork,
    params: &CurveGicsParams,
    par: Par,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Result<CurveDescriptors, GicsError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(GicsError::Params(text.join("; ")));
    }
    let mut sources = Vec::with_capacity(network.curves.len());
    for c in 0..network.curves.len() {
        if network.curves[c].vertices.is_empty() {
            return Err(GicsError::EmptyCurve { curve: c });
        }
        sources.push(HeatSource::curve(network, c, mesh)?);
    }
    let mut curves = Vec::with_capacity(sources.len());
    if sources.is_empty() {
        return Ok(CurveDescriptors {
            kind: DescriptorKind::Gics,
            curves,
        });
    }
    let solver = HeatSolver::new(mesh, params.time_factor, par)?;
    for chunk in sources.chunks(params.batch) {
        if cancelled() {
            break;
        }
        let fields = solver.distances(chunk, par)?;
        let descs = par.map_collect(fields.len(), |k| {
            let d = &fields[k].values;
            let d_max = fields[k].max_finite();
            let r = radii(params.radii, params.sampling, d_max);
            let values = contour_lengths(mesh, d, &r);
            CurveDescriptor {
                values,
                samples: r,
                d_max,
            }
        });
        curves.extend(descs);
    }
    Ok(CurveDescriptors {
        kind: DescriptorKind::Gics,
        curves,
    })
}

/// Node wrapper of [`curve_gics`].
pub struct CurveGicsNode;

impl NodeKind for CurveGicsNode {
    type Params = CurveGicsParams;
    const KIND: &'static str = "descriptors.curve_gics";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Geodesic Iso-Curve Signature of every feature curve (thesis \
        §3.1.2; Gehre et al. 2016 after Tabia et al. 2011): heat-method geodesic distance from \
        the whole curve (Crane et al. 2013), iso-contour lengths at n radii sampled by \
        f_s(x) = x or x^4 scaled to d_max(c), contours marched over triangles. The curves' \
        surface points are read as mesh vertex/edge/face ids, so a network traced on one pose \
        can be evaluated on another pose with the same connectivity.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the surface the distances are measured on"),
            Port::of::<FeatureCurveNetwork>("curves", "the curves to describe"),
        ]
    }

    fn outputs() -> Vec<Port> {
        vec![Port::of::<CurveDescriptors>(
            "descriptors",
            "one GICS per curve, in curve order",
        )]
    }

    fn run(params: &CurveGicsParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let net = inputs.get::<FeatureCurveNetwork>("curves")?;
        let out = curve_gics_with_cancel(mesh, net, params, ctx.par, &|| ctx.cancel.is_cancelled())
            .map_err(|e| {
                let kind = match &e {
                    GicsError::Heat(HeatError::Sparse(_)) => ErrorKind::NumericalFailure,
                    _ => ErrorKind::InvalidInput,
                };
                NodeError::from_source(kind, e)
            })?;
        ctx.check_cancelled()?;
        Ok(Outputs::new().with("descriptors", out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contour_of_linear_field_on_square() {
        // Unit square, two triangles, d = x: the contour at r is a vertical segment of length 1.
        let mesh = TriMesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let d = [0.0, 1.0, 1.0, 0.0];
        let l = contour_lengths(&mesh, &d, &[0.25, 0.5, 0.9, 1.5]);
        for (k, want) in [1.0, 1.0, 1.0, 0.0].iter().enumerate() {
            assert!((l[k] - want).abs() < 1e-12, "{k}: {}", l[k]);
        }
    }

    #[test]
    fn radii_follow_the_sampling_function() {
        assert_eq!(radii(4, Sampling::Linear, 2.0), vec![0.5, 1.0, 1.5, 2.0]);
        let q = radii(2, Sampling::Quartic, 16.0);
        assert_eq!(q, vec![1.0, 16.0]);
    }
}
