//! Unit tests of `bvh.rs`: the parallel build against the sequential one and brute force.

use super::*;
use crate::shapes;

/// Query points around the unit sphere: a fixed stream in [-1.5, 1.5)³.
fn points(n: usize) -> Vec<V3> {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

#[test]
fn parallel_build_is_the_same_tree_with_the_same_answers() {
    // 81 920 faces: three levels of parallel splits (ranges from 16 384 faces up).
    let mesh = shapes::sphere(1.0, 6).unwrap();
    assert!(mesh.n_faces() >= 4 * PARALLEL_MIN);
    let seq = TriangleBvh::new(&mesh);
    let par = TriangleBvh::new_in_parallel(&mesh);
    // The sequential build numbers the nodes depth first (a node's two children side by
    // side, then the left subtree, then the right), which is how the parallel halves are
    // joined: the two trees are the same node for node.
    assert_eq!(seq.order, par.order);
    assert_eq!(seq.slot, par.slot);
    assert!(seq.layout() == par.layout(), "node layouts differ");
    for (i, p) in points(2000).into_iter().enumerate() {
        let (x, y) = (seq.closest(p), par.closest(p));
        assert_eq!(
            (x.dist2.to_bits(), x.face, x.point.map(f64::to_bits)),
            (y.dist2.to_bits(), y.face, y.point.map(f64::to_bits)),
            "query {i}"
        );
        assert_eq!(
            seq.any_within(p, 0.05),
            par.any_within(p, 0.05),
            "query {i}"
        );
    }
}

#[test]
fn answers_match_brute_force_on_a_mesh_with_parallel_splits() {
    let mesh = shapes::sphere(1.0, 5).unwrap();
    assert!(mesh.n_faces() > PARALLEL_MIN);
    let bvh = TriangleBvh::new_in_parallel(&mesh);
    for (i, p) in points(25).into_iter().enumerate() {
        let brute = (0..mesh.n_faces())
            .map(|f| {
                let [a, b, c] = mesh.face_points(f);
                (closest_point_on_triangle(p, a, b, c).0, f as u32)
            })
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
            .unwrap();
        let got = bvh.closest(p);
        assert_eq!((got.dist2, got.face), brute, "query {i}");
    }
}

#[test]
fn empty_and_tiny_meshes() {
    let empty = TriangleBvh::new_in_parallel(&TriMesh::new(Vec::new(), Vec::new()));
    assert_eq!(empty.closest([0.0; 3]).face, u32::MAX);
    assert!(!empty.any_within([0.0; 3], 1e9));
    let one = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let bvh = TriangleBvh::new_in_parallel(&one);
    let hit = bvh.closest([0.25, 0.25, 1.0]);
    assert_eq!((hit.face, hit.dist2), (0, 1.0));
}
