//! Ridge and ravine points on mesh edges: zero crossings of the extremality coefficient with
//! the conditions of thesis Thm 2.1 (steps 2 and 3 of the tracing scheme in §2.5.1.1, after
//! Ohtake, Belyaev & Seidel 2004 and Yoshizawa, Belyaev & Seidel 2005).

use crestflow_flow::Par;
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{CurvatureField, TriMesh};
use serde::{Deserialize, Serialize};

/// Which principal curvature's extrema a curve follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Family {
    /// Extrema of k_max along its curvature lines (ridges).
    Ridge,
    /// Extrema of k_min along its curvature lines (ravines).
    Ravine,
}

/// Which extrema count as feature points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Definition {
    /// Thesis Def. 2.2 / Thm 2.1: ridges are positive maxima of k_max with k_max > |k_min|,
    /// ravines negative minima of k_min with k_min < −|k_max|.
    #[default]
    Thesis,
    /// Every extremum (maximum or minimum) of k_max is a "ridge" point and every extremum of
    /// k_min a "ravine" point, whatever the signs: the general extremal lines of both principal
    /// curvatures (on convex shapes Def. 2.2 has no ravines at all; this option shows them).
    Extrema,
}

/// A feature point on mesh edge (a, b), `a < b`, at `a + t (b − a)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    pub t: f64,
    pub position: V3,
    /// |k_max| (ridges) or |k_min| (ravines), interpolated.
    pub strength: f64,
    /// Integrand of the cyclideness (thesis eq. 2.1): sqrt(e_max² + e_min²) from the
    /// interpolated magnitudes at the edge's ends. The traced family's own coefficient vanishes
    /// at the crossing itself, so the magnitudes at the vertices measure how sharply it changes.
    pub cyclideness: f64,
    /// The sign of ∂e/∂t estimated along this edge alone (negative: a maximum). Used where a
    /// triangle cannot decide (see [`crate::network`]).
    pub edge_slope: f64,
}

/// The candidate feature point of `family` on each unique edge of `mesh` (in `Topology::edges`
/// order): a sign change of the aligned extremality coefficient where, for [`Definition::Thesis`],
/// the dominance condition of Thm 2.1 holds at the interpolated point; `None` elsewhere. The
/// maximum/minimum condition is decided per triangle ([`crate::network::segment_graph`]), where
/// the gradient of e is better defined than along an edge that runs along the ridge. `umbilic_tolerance` skips edges with an endpoint
/// where |k_max − k_min| ≤ tol · max(|k_max|, |k_min|): principal directions are undefined there.
pub fn edge_crossings(
    mesh: &TriMesh,
    field: &CurvatureField,
    family: Family,
    definition: Definition,
    umbilic_tolerance: f64,
    par: Par,
) -> Vec<Option<Crossing>> {
    let topo = mesh.topology();
    let (k, t, e) = match family {
        Family::Ridge => (&field.k_max, &field.t_max, &field.e_max),
        Family::Ravine => (&field.k_min, &field.t_min, &field.e_min),
    };
    let umbilic = |v: usize| {
        let (a, b) = (field.k_max[v], field.k_min[v]);
        (a - b).abs() <= umbilic_tolerance * a.abs().max(b.abs())
    };
    par.map_collect(topo.edges.len(), |i| {
        let [a, b] = topo.edges[i];
        let (a, b) = (a as usize, b as usize);
        if umbilic_tolerance > 0.0 && (umbilic(a) || umbilic(b)) {
            return None;
        }
        // Step 2: directions are defined up to sign; align b's with a's before comparing.
        let (ta, mut tb) = (t[a], t[b]);
        let ea = e[a];
        let mut eb = e[b];
        if vec3::dot(ta, tb) < 0.0 {
            tb = vec3::scale(tb, -1.0);
            eb = -eb;
        }
        // A sign change, with zero counted as positive so a zero at a vertex is found once.
        if (ea >= 0.0) == (eb >= 0.0) {
            return None;
        }
        // Maximum (ridge) or minimum (ravine) along the curvature line: the sign of ∂e/∂t,
        // from the change of e along the edge and the edge's direction against t.
        let (pa, pb) = (mesh.positions[a], mesh.positions[b]);
        let along = vec3::dot(vec3::sub(pb, pa), vec3::add(ta, tb));
        let de_dt = (eb - ea) * along;
        if !de_dt.is_finite() {
            return None;
        }
        let s = ea / (ea - eb);
        let kmax = field.k_max[a] + s * (field.k_max[b] - field.k_max[a]);
        let kmin = field.k_min[a] + s * (field.k_min[b] - field.k_min[a]);
        if definition == Definition::Thesis {
            let dominant = match family {
                Family::Ridge => kmax > kmin.abs(),
                Family::Ravine => kmin < -kmax.abs(),
            };
            if !dominant {
                return None;
            }
        }
        let kf = k[a] + s * (k[b] - k[a]);
        let mag = |x: &[f64]| (1.0 - s) * x[a].abs() + s * x[b].abs();
        let (em, en) = (mag(&field.e_max), mag(&field.e_min));
        Some(Crossing {
            t: s,
            position: vec3::lerp(pa, pb, s),
            strength: kf.abs(),
            cyclideness: (em * em + en * en).sqrt(),
            edge_slope: de_dt,
        })
    })
}
