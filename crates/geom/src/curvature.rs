//! Per-vertex principal curvatures, directions and extremality coefficients (thesis §2.1).

use serde::{Deserialize, Serialize};

use crate::vec3::V3;

/// What every curvature node outputs, so that swapping methods is one `kind:` line.
///
/// Conventions: `k_max >= k_min`; curvature is positive where the surface bends away from the
/// normal (a sphere with outward normals has k = +1/r); `t_max`, `t_min` are unit tangent
/// directions, orthogonal to each other and to `normal`, oriented consistently across the mesh
/// where possible (thesis §2.5.1.1 step 2). Extremality coefficients are the derivatives of the
/// principal curvatures along their own directions: `e_max = ∇k_max · t_max`,
/// `e_min = ∇k_min · t_min`. Ridges are zero crossings of `e_max` where k_max > |k_min|,
/// ravines zero crossings of `e_min` where k_min < -|k_max| (Def. 2.2, Thm 2.1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CurvatureField {
    pub k_max: Vec<f64>,
    pub k_min: Vec<f64>,
    pub t_max: Vec<V3>,
    pub t_min: Vec<V3>,
    pub normal: Vec<V3>,
    pub e_max: Vec<f64>,
    pub e_min: Vec<f64>,
    /// Which method made it (`curvature.polynomial`, …), for reports.
    pub method: String,
}

impl CurvatureField {
    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.k_max.len()
    }
    pub fn is_empty(&self) -> bool {
        self.k_max.is_empty()
    }
    /// Mean curvature (k_max + k_min) / 2 at vertex `v`.
    pub fn mean(&self, v: usize) -> f64 {
        0.5 * (self.k_max[v] + self.k_min[v])
    }
    /// Gaussian curvature k_max · k_min at vertex `v`.
    pub fn gaussian(&self, v: usize) -> f64 {
        self.k_max[v] * self.k_min[v]
    }
}
