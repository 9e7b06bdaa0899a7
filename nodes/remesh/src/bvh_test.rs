//! Unit tests of `bvh.rs`.

use super::*;
use crestflow_geom::{shapes, TriMesh};

/// A deterministic stream of numbers in [-1.5, 1.5) (a linear congruential generator).
fn coordinates(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 3.0 - 1.5
    }
}

/// A level-3 icosphere, its BVH and 300 query points around it from `seed`.
fn sphere_and_queries(seed: u64) -> (TriMesh, Bvh, Vec<V3>) {
    let m = shapes::sphere(1.0, 3).unwrap();
    let bvh = Bvh::new(&m);
    let mut rnd = coordinates(seed);
    let points = (0..300).map(|_| [rnd(), rnd(), rnd()]).collect();
    (m, bvh, points)
}

/// The closest point of `m` to `p` by trying every face (ties to the smaller face).
fn brute_force(bvh: &Bvh, m: &TriMesh, p: V3) -> Hit {
    (0..m.n_faces() as u32)
        .map(|f| bvh.on_face(f, p))
        .min_by(|x, y| x.dist2.total_cmp(&y.dist2).then(x.face.cmp(&y.face)))
        .unwrap()
}

/// The same from the mesh's own triangles: squared distance and face.
fn brute_force_on_mesh(m: &TriMesh, p: V3) -> (f64, u32) {
    (0..m.n_faces())
        .map(|f| {
            let [a, b, c] = m.face_points(f);
            (
                crestflow_geom::bvh::closest_point_on_triangle(p, a, b, c).0,
                f as u32,
            )
        })
        .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
        .unwrap()
}

#[test]
fn matches_brute_force_with_any_hint() {
    let (m, bvh, points) = sphere_and_queries(12345);
    for (i, &p) in points.iter().enumerate() {
        let brute = brute_force(&bvh, &m, p);
        let hint = if i % 2 == 0 {
            u32::MAX
        } else {
            (i * 7) as u32 % 1280
        };
        let h = bvh.closest_with_hint(p, hint);
        assert_eq!(h.dist2, brute.dist2, "query {i}");
        // The triangles are stored in leaf order: the answer still names the mesh's face.
        assert_eq!((h.dist2, h.face), brute_force_on_mesh(&m, p), "query {i}");
        let [a, b, c] = m.face_points(h.face as usize);
        let q = [0, 1, 2].map(|k| h.bary[0] * a[k] + h.bary[1] * b[k] + h.bary[2] * c[k]);
        assert!(vec3::dist(q, h.point) < 1e-15, "query {i}");
    }
    // Every face is where `on_face` looks for it.
    for f in 0..m.n_faces() as u32 {
        let p = m.face_points(f as usize)[0];
        assert_eq!((bvh.on_face(f, p).face, bvh.on_face(f, p).dist2), (f, 0.0));
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

#[test]
fn any_within_agrees_with_the_brute_force_distance() {
    let (m, bvh, points) = sphere_and_queries(777);
    for (i, &p) in points.iter().enumerate() {
        let d = brute_force(&bvh, &m, p).distance;
        assert!(
            bvh.any_within(p, d * 1.001 + 1e-12),
            "query {i}: within {d}"
        );
        assert!(
            !bvh.any_within(p, d * 0.999),
            "query {i}: nothing nearer than {d}"
        );
    }
    let empty = Bvh::new(&TriMesh::new(Vec::new(), Vec::new()));
    assert!(!empty.any_within([0.0; 3], 1e9));
}
