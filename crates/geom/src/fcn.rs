//! Feature curve networks Γ = (V, E, C) (thesis Def. 2.1): vertices on the surface, edges between
//! them, and curves (arcs between extraordinary vertices, or closed loops) as vertex sequences.

use serde::{Deserialize, Serialize};

use crate::vec3::{dist, V3};

/// Where a network vertex sits on the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum SurfacePoint {
    /// At mesh vertex `v`.
    Vertex(u32),
    /// On mesh edge (a, b) at `a + t (b - a)`, `a < b`.
    Edge { a: u32, b: u32, t: f64 },
    /// Inside face `f` with barycentric coordinates.
    Face { f: u32, bary: [f64; 3] },
    /// Not tied to the mesh (e.g. a point of a completed template).
    Free,
}

/// Ridge (convex crest, along k_max) or ravine (concave valley, along k_min).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CurveLabel {
    Ridge,
    Ravine,
    /// Any other source (sharp edges, user curves, shortest paths).
    Other,
}

/// A vertex of the network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FcnVertex {
    pub position: V3,
    pub location: SurfacePoint,
    /// Feature strength at this point (|principal curvature| of the traced family).
    pub strength: f64,
}

/// One curve: a polyline through network vertices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureCurve {
    /// Indices into [`FeatureCurveNetwork::vertices`], in order. For a closed curve the first
    /// vertex is not repeated at the end.
    pub vertices: Vec<u32>,
    pub closed: bool,
    pub label: CurveLabel,
}

/// Γ = (V, E, C). Edges are the consecutive vertex pairs of the curves; curves meet at shared
/// vertices, which are the extraordinary vertices (valence ≠ 2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FeatureCurveNetwork {
    pub vertices: Vec<FcnVertex>,
    pub curves: Vec<FeatureCurve>,
}

impl FeatureCurveNetwork {
    /// A network of polylines over points not tied to a mesh (`closed` per curve; strength 1,
    /// label `Other`): hand-made networks such as sketches and test fixtures.
    pub fn from_polylines(points: &[V3], curves: &[(&[u32], bool)]) -> FeatureCurveNetwork {
        FeatureCurveNetwork {
            vertices: points
                .iter()
                .map(|&p| FcnVertex {
                    position: p,
                    location: SurfacePoint::Free,
                    strength: 1.0,
                })
                .collect(),
            curves: curves
                .iter()
                .map(|&(v, closed)| FeatureCurve {
                    vertices: v.to_vec(),
                    closed,
                    label: CurveLabel::Other,
                })
                .collect(),
        }
    }

    /// The edges of curve `c` as vertex index pairs (including the closing edge of a loop).
    pub fn curve_edges(&self, c: usize) -> Vec<(u32, u32)> {
        let curve = &self.curves[c];
        let v = &curve.vertices;
        let mut out: Vec<(u32, u32)> = v.windows(2).map(|w| (w[0], w[1])).collect();
        if curve.closed && v.len() > 2 {
            out.push((v[v.len() - 1], v[0]));
        }
        out
    }
    /// All edges of the network.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        (0..self.curves.len())
            .flat_map(|c| self.curve_edges(c))
            .collect()
    }
    /// Length of curve `c`.
    pub fn curve_length(&self, c: usize) -> f64 {
        self.curve_edges(c)
            .iter()
            .map(|&(a, b)| {
                dist(
                    self.vertices[a as usize].position,
                    self.vertices[b as usize].position,
                )
            })
            .sum()
    }
    /// Total length of all curves.
    pub fn total_length(&self) -> f64 {
        (0..self.curves.len()).map(|c| self.curve_length(c)).sum()
    }
    /// Number of edges at each network vertex.
    pub fn valence(&self) -> Vec<u32> {
        let mut val = vec![0u32; self.vertices.len()];
        for (a, b) in self.edges() {
            val[a as usize] += 1;
            val[b as usize] += 1;
        }
        val
    }
    /// Sharpness w_κ of curve `c` (thesis §4.1): the length-weighted mean strength along it.
    pub fn curve_strength(&self, c: usize) -> f64 {
        let mut num = 0.0;
        let mut den = 0.0;
        for (a, b) in self.curve_edges(c) {
            let (va, vb) = (&self.vertices[a as usize], &self.vertices[b as usize]);
            let l = dist(va.position, vb.position);
            num += 0.5 * (va.strength + vb.strength) * l;
            den += l;
        }
        if den > 0.0 {
            num / den
        } else {
            0.0
        }
    }
    /// Points of curve `c` in order (positions of its vertices).
    pub fn curve_points(&self, c: usize) -> Vec<V3> {
        self.curves[c]
            .vertices
            .iter()
            .map(|&i| self.vertices[i as usize].position)
            .collect()
    }
}
