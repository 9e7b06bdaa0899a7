//! Unit tests of `project.rs`.

use super::*;
use crestflow_geom::{shapes, vec3, TriMesh};

fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn brute(bvh: &Bvh, p: V3) -> Hit {
    (0..bvh.n_faces() as u32)
        .map(|f| bvh.on_face(f, p))
        .min_by(|x, y| x.dist2.total_cmp(&y.dist2).then(x.face.cmp(&y.face)))
        .unwrap()
}

/// An n × n grid of squares (two triangles each) in the plane z = `z`, offset by (x0, 0).
fn grid(n: usize, x0: f64, z: f64) -> (Vec<V3>, Vec<[u32; 3]>) {
    let mut p = Vec::new();
    let mut t = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            p.push([x0 + i as f64 / n as f64, j as f64 / n as f64, z]);
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (p, t)
}

#[test]
fn walk_on_a_sphere_finds_the_exact_closest_point() {
    // Convex surface: the local minimum the walk reaches is the global one. Points move away
    // from the face centroid they start at by up to a few faces, in and off the surface.
    let m = shapes::sphere(1.0, 3).unwrap();
    let proj = Projector::new(&m);
    let bvh = proj.bvh();
    let mut rnd = lcg(7);
    let mut walked = 0;
    for i in 0..400 {
        let f = (i * 37 % m.n_faces()) as u32;
        let [a, b, c] = m.face_points(f as usize);
        let centre = vec3::scale(vec3::add(vec3::add(a, b), c), 1.0 / 3.0);
        let off = [rnd() - 0.5, rnd() - 0.5, rnd() - 0.5];
        let p = vec3::add(centre, vec3::scale(off, 0.4));
        let got = proj.project(p, f, 1.0);
        let want = brute(bvh, p);
        assert!(
            (got.hit.dist2 - want.dist2).abs() <= 1e-12,
            "query {i}: {} vs {}",
            got.hit.dist2,
            want.dist2
        );
        assert!(vec3::dist(got.hit.point, want.point) < 1e-9, "query {i}");
        walked += !got.fallback as usize;
    }
    assert_eq!(walked, 400, "no walk should need the BVH on a sphere");
}

#[test]
fn walk_crosses_many_faces_of_a_plane() {
    let (p, t) = grid(10, 0.0, 0.0);
    let m = TriMesh::new(p, t);
    let proj = Projector::new(&m);
    // From the first face to the far corner region: the closest point is the point itself
    // dropped onto the plane.
    let q = [0.83, 0.71, 0.05];
    let got = proj.project(q, 0, 1.0);
    assert!(!got.fallback);
    assert!(vec3::dist(got.hit.point, [0.83, 0.71, 0.0]) < 1e-12);
    assert!((got.hit.distance - 0.05).abs() < 1e-12);
    // Outside the square: the closest point is on the border.
    let got = proj.project([1.3, 0.5, 0.0], 0, 1.0);
    assert!(vec3::dist(got.hit.point, [1.0, 0.5, 0.0]) < 1e-12);
}

/// One sheet at z = 0 over x in [0, 1] (faces 0..32) and one at z = 0.1 over x in [0.5, 1.5].
fn two_sheets() -> TriMesh {
    let (mut p, mut t) = grid(4, 0.0, 0.0);
    let (p2, t2) = grid(2, 0.5, 0.1);
    let off = p.len() as u32;
    p.extend(p2);
    t.extend(t2.into_iter().map(|f| f.map(|v| v + off)));
    TriMesh::new(p, t)
}

#[test]
fn bad_start_and_far_points_fall_back_to_the_bvh() {
    // Two sheets: one at z = 0 over x in [0, 1] and one at z = 0.1 over x in [0.5, 1.5]. A
    // point just below the upper sheet, walked from the lower one, stops at a local minimum
    // 0.09 away; with `far` below that the BVH finds the upper sheet 0.01 away.
    let m = two_sheets();
    let proj = Projector::new(&m);
    let bvh = proj.bvh();
    let q = [0.75, 0.5, 0.09];
    let local = proj.project(q, 0, 1.0);
    assert!(!local.fallback);
    assert!((local.hit.distance - 0.09).abs() < 1e-12);
    assert!(local.hit.face < 32);
    let exact = proj.project(q, 0, 0.05);
    assert!(exact.fallback);
    assert!((exact.hit.distance - 0.01).abs() < 1e-12);
    assert!(
        exact.hit.face >= 32,
        "on the upper sheet, got {}",
        exact.hit.face
    );
    // No start face: the BVH answers.
    let none = proj.project(q, u32::MAX, 1.0);
    assert!(none.fallback);
    assert_eq!(none.hit.dist2, brute(bvh, q).dist2);
    let none = proj.project(q, m.n_faces() as u32, 1.0);
    assert!(none.fallback);
}

#[test]
fn walk_alone_answers_where_the_walk_does_and_nothing_else() {
    // The two sheets of the test above: where `project` keeps the walk's answer,
    // `project_walk` gives the same hit; where `project` needs the BVH, it gives none (and
    // builds no BVH).
    let m = two_sheets();
    let proj = Projector::new(&m);
    let q = [0.75, 0.5, 0.09];
    let walked = proj
        .project_walk(q, 0, 1.0)
        .expect("the walk settles within `far`");
    assert_eq!(walked, proj.project(q, 0, 1.0).hit);
    assert!((walked.distance - 0.09).abs() < 1e-12);
    assert_eq!(proj.project_walk(q, 0, 0.05), None);
    assert_eq!(proj.project_walk(q, u32::MAX, 1.0), None);
    assert_eq!(proj.project_walk(q, m.n_faces() as u32, 1.0), None);
    assert!(proj.bvh.get().is_none(), "the BVH was built");
}
