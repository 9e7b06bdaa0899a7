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
mod tests {
    use super::*;
    use crestflow_geom::{shapes, TriMesh};

    #[test]
    fn matches_brute_force_with_any_hint() {
        let m = shapes::sphere(1.0, 3).unwrap();
        let bvh = Bvh::new(&m);
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
        };
        for i in 0..300 {
            let p = [rnd(), rnd(), rnd()];
            let brute = (0..m.n_faces() as u32)
                .map(|f| bvh.on_face(f, p))
                .min_by(|x, y| x.dist2.total_cmp(&y.dist2).then(x.face.cmp(&y.face)))
                .unwrap();
            let hint = if i % 2 == 0 {
                u32::MAX
            } else {
                (i * 7) as u32 % 1280
            };
            let h = bvh.closest_with_hint(p, hint);
            assert_eq!(h.dist2, brute.dist2, "query {i}");
        }
    }

    #[test]
    fn segment_and_triangle_points() {
        let (q, t) = closest_on_segment([0.5, 1.0, 0.0], [0.0; 3], [1.0, 0.0, 0.0]);
        assert_eq!((q, t), ([0.5, 0.0, 0.0], 0.5));
        let tri = TriMesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        let bvh = Bvh::new(&tri);
        let q = bvh.closest([0.25, 0.25, 2.0]).point;
        assert!(vec3::dist(q, [0.25, 0.25, 0.0]) < 1e-15);
        let q = bvh.closest([2.0, 2.0, 0.0]).point;
        assert!(vec3::dist(q, [0.5, 0.5, 0.0]) < 1e-15);
    }
}
