use super::*;
use crestflow_geom::shapes;

/// Whether every edge of `m` has two faces that run along it in opposite directions (a
/// closed, coherently oriented surface).
fn closed_and_oriented(m: &TriMesh) -> bool {
    let mut sides = std::collections::HashMap::new();
    for t in &m.triangles {
        for i in 0..3 {
            *sides.entry((t[i], t[(i + 1) % 3])).or_insert(0) += 1;
        }
    }
    sides
        .iter()
        .all(|(&(a, b), &k)| k == 1 && sides.get(&(b, a)) == Some(&1))
}

/// An icosphere (162 vertices) with face `f` removed and its corners moved toward their
/// centroid, so that the hole's edges are `size` long.
fn sphere_with_hole(f: usize, size: f64) -> TriMesh {
    let mut m = shapes::sphere(1.0, 2).unwrap();
    let t = m.triangles.remove(f);
    let c = vec3::scale(
        vec3::add(
            vec3::add(m.positions[t[0] as usize], m.positions[t[1] as usize]),
            m.positions[t[2] as usize],
        ),
        1.0 / 3.0,
    );
    for v in t {
        let p = m.positions[v as usize];
        let d = vec3::sub(p, c);
        let scale = size / vec3::norm(d) / 3f64.sqrt();
        m.positions[v as usize] = vec3::add(c, vec3::scale(d, scale));
    }
    TriMesh::new(m.positions, m.triangles)
}

#[test]
fn a_hole_of_three_short_edges_is_closed_with_the_surface_s_orientation() {
    let m = sphere_with_hole(7, 0.01);
    assert!(!closed_and_oriented(&m));
    let (closed, n) = close_small_triangular_holes(&m, 0.05).expect("one hole");
    assert_eq!(n, 1);
    assert_eq!(closed.n_faces(), m.n_faces() + 1);
    assert!(closed_and_oriented(&closed));
}

#[test]
fn larger_holes_and_loops_of_more_edges_stay_open() {
    // The same hole with edges of 0.01 is kept when the limit is below them.
    let m = sphere_with_hole(7, 0.01);
    assert!(close_small_triangular_holes(&m, 0.009).is_none());
    // Two neighbouring faces removed: a loop of four edges.
    let mut s = shapes::sphere(1.0, 2).unwrap();
    let t0 = s.triangles[0];
    let k = s
        .triangles
        .iter()
        .position(|t| *t != t0 && t.iter().filter(|v| t0.contains(v)).count() == 2)
        .unwrap();
    s.triangles.remove(k);
    s.triangles.remove(0);
    let s = TriMesh::new(s.positions, s.triangles);
    assert_eq!(s.topology().boundary_edge_count(), 4);
    assert!(close_small_triangular_holes(&s, 10.0).is_none());
    // A lone triangle is its own loop: no second face over it.
    let lone = TriMesh::new(
        vec![[0.0, 0.0, 0.0], [0.001, 0.0, 0.0], [0.0, 0.001, 0.0]],
        vec![[0, 1, 2]],
    );
    assert!(close_small_triangular_holes(&lone, 10.0).is_none());
    // A closed surface has nothing to close.
    assert!(close_small_triangular_holes(&shapes::sphere(1.0, 2).unwrap(), 10.0).is_none());
}
