//! `fmap.transfer`: carries a colour field from the source to the target (thesis §5.2.5,
//! Fig. 5.6–5.9), through a point map (`colour(y) = colour(T(y))`) or directly through a
//! functional map (`Φ₂' C Φ₁'ᵀ M₁' U`, the thesis' texture transport).
//!
//! The source field: `Coordinates` colours each source vertex by its position in the source
//! bounding box (x, y, z ↦ r, g, b), a smooth field where a wrong map shows as a jump in hue;
//! `Stripes` adds bands along an axis so that stretching is visible too.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate,
};
use crestflow_geom::TriMesh;
use crestflow_nodes_spectral::EigenBasis;

use crate::dense::{tall_mul, Basis};
use crate::types::{FmapError, FunctionalMap, PointMap, VertexColors};

/// The colour field on the source.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum SourceField {
    /// Position in the bounding box as RGB.
    #[default]
    Coordinates,
    /// Coordinates darkened in `count` bands along axis 0, 1 or 2.
    Stripes { axis: usize, count: usize },
}

/// How the field is carried.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum TransferVia {
    /// Through the `points` input.
    #[default]
    Points,
    /// Through the `map` input and both bases.
    Functional,
}

/// Parameters of `fmap.transfer`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TransferParams {
    /// Source field (default `Coordinates`).
    pub field: SourceField,
    /// Transport (default `Points`).
    pub via: TransferVia,
}

impl Validate for TransferParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if let SourceField::Stripes { axis, count } = self.field {
            check_range(&mut issues, "field.axis", axis, 0, 2);
            check_range(&mut issues, "field.count", count, 1, 1000);
        }
        issues
    }
}

/// The source colour field.
pub fn source_colors(mesh: &TriMesh, field: SourceField) -> Vec<[f64; 3]> {
    let (lo, hi) = mesh.bbox();
    let ext: Vec<f64> = (0..3).map(|i| (hi[i] - lo[i]).max(1e-300)).collect();
    mesh.positions
        .iter()
        .map(|p| {
            let u = [0, 1, 2].map(|i| ((p[i] - lo[i]) / ext[i]).clamp(0.0, 1.0));
            let base = [0.15 + 0.85 * u[0], 0.15 + 0.85 * u[1], 0.15 + 0.85 * u[2]];
            match field {
                SourceField::Coordinates => base,
                SourceField::Stripes { axis, count } => {
                    let band = (u[axis] * count as f64).floor() as i64;
                    let f = if band % 2 == 0 { 1.0 } else { 0.55 };
                    base.map(|c| c * f)
                }
            }
        })
        .collect()
}

/// Carries the source field to the target.
pub fn transfer(
    source_mesh: &TriMesh,
    target_mesh: &TriMesh,
    points: Option<&PointMap>,
    functional: Option<(&FunctionalMap, &EigenBasis, &EigenBasis)>,
    params: &TransferParams,
    par: Par,
) -> Result<VertexColors, FmapError> {
    let src = source_colors(source_mesh, params.field);
    let n1 = source_mesh.n_vertices();
    let n2 = target_mesh.n_vertices();
    let target = match params.via {
        TransferVia::Points => {
            let pm = points.ok_or(FmapError::Param {
                field: "via",
                message: "Points needs the `points` input".into(),
            })?;
            check_point_map(pm, n1, n2)?;
            pm.target_to_source
                .iter()
                .map(|&x| src[x as usize])
                .collect()
        }
        TransferVia::Functional => {
            let (m, e1, e2) = functional.ok_or(FmapError::Param {
                field: "via",
                message: "Functional needs the `map`, `source_basis` and `target_basis` inputs"
                    .into(),
            })?;
            if e1.n != n1 || e2.n != n2 {
                return Err(FmapError::BasisMeshMismatch {
                    side: if e1.n != n1 { "source" } else { "target" },
                    basis: if e1.n != n1 { e1.n } else { e2.n },
                    mesh: if e1.n != n1 { n1 } else { n2 },
                });
            }
            if m.k_source > e1.k() || m.k_target > e2.k() {
                return Err(FmapError::MapSizeMismatch {
                    rows: m.k_target,
                    cols: m.k_source,
                    k_target: e2.k(),
                    k_source: e1.k(),
                });
            }
            let b1 = Basis::new(e1, m.k_source, "source")?;
            let b2 = Basis::new(e2, m.k_target, "target")?;
            let u: Vec<f64> = (0..3).flat_map(|c| src.iter().map(move |s| s[c])).collect();
            let coef = b1.project(&u, 3, par);
            let mapped = crate::dense::mul(&m.matrix, m.k_target, m.k_source, &coef, 3);
            let g = tall_mul(&b2.vectors, n2, m.k_target, &mapped, 3, par);
            (0..n2)
                .map(|y| [0, 1, 2].map(|c| g[c * n2 + y].clamp(0.0, 1.0)))
                .collect()
        }
    };
    Ok(VertexColors {
        source: src,
        target,
    })
}

/// Checks a point map against the vertex counts.
pub fn check_point_map(pm: &PointMap, n_source: usize, n_target: usize) -> Result<(), FmapError> {
    if pm.target_to_source.len() != n_target {
        return Err(FmapError::PointMapSize {
            have: pm.target_to_source.len(),
            want: n_target,
        });
    }
    if let Some((y, &x)) = pm
        .target_to_source
        .iter()
        .enumerate()
        .find(|(_, &x)| x as usize >= n_source)
    {
        return Err(FmapError::PointMapOutOfRange {
            target: y,
            source_vertex: x,
            n_source,
        });
    }
    Ok(())
}

/// Node wrapper of [`transfer`].
pub struct TransferNode;

impl NodeKind for TransferNode {
    type Params = TransferParams;
    const KIND: &'static str = "fmap.transfer";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Carries a colour field (bounding-box coordinates as RGB, \
        optionally striped) from the source to the target through a point map or directly \
        through a functional map (thesis §5.2.5). Output: VertexColors for fmap.render_colors.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("source_mesh", "the source mesh"),
            Port::of::<TriMesh>("target_mesh", "the target mesh"),
            Port::optional::<PointMap>("points", "target → source point map (via Points)"),
            Port::optional::<FunctionalMap>("map", "functional map (via Functional)"),
            Port::optional::<EigenBasis>("source_basis", "source eigenbasis (via Functional)"),
            Port::optional::<EigenBasis>("target_basis", "target eigenbasis (via Functional)"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<VertexColors>(
            "colors",
            "per-vertex colours on source and target",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let functional = match (
            inputs.opt::<FunctionalMap>("map")?,
            inputs.opt::<EigenBasis>("source_basis")?,
            inputs.opt::<EigenBasis>("target_basis")?,
        ) {
            (Some(m), Some(a), Some(b)) => Some((m, a, b)),
            _ => None,
        };
        let c = transfer(
            inputs.get("source_mesh")?,
            inputs.get("target_mesh")?,
            inputs.opt("points")?,
            functional,
            params,
            ctx.par,
        )
        .map_err(FmapError::into_node)?;
        Ok(Outputs::new().with("colors", c))
    }
}

#[cfg(test)]
#[path = "transfer_test.rs"]
mod tests;
