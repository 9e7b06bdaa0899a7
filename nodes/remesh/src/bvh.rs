//! Closest points on the input surface, the "projection back onto the original surface" step
//! of Botsch & Kobbelt 2004 (thesis §5.1.1): the triangle BVH of `crestflow_geom::bvh`, queried
//! with a hint face (the face a vertex was projected onto in the previous iteration), whose
//! distance is the starting bound; the answer is still the exact closest point, ties to the
//! smallest face index. Plus the closest point on a segment, for sliding feature vertices.

use crestflow_geom::vec3::{self, V3};

/// The hierarchy and its answers are the shared ones of `crestflow_geom::bvh`.
pub use crestflow_geom::bvh::{ClosestPoint as Hit, TriangleBvh as Bvh};

/// Closest point of segment [a, b] to `p` and its parameter in [0, 1].
pub fn closest_on_segment(p: V3, a: V3, b: V3) -> (V3, f64) {
    let d = vec3::sub(b, a);
    let l2 = vec3::dot(d, d);
    if !(l2 > 0.0) {
        return (a, 0.0);
    }
    let t = (vec3::dot(vec3::sub(p, a), d) / l2).clamp(0.0, 1.0);
    (vec3::add(a, vec3::scale(d, t)), t)
}

#[cfg(test)]
#[path = "bvh_test.rs"]
mod tests;
