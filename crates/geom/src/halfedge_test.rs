//! Unit tests of `halfedge.rs`.

use super::*;
use crate::shapes;

/// An n × n grid of the unit square (boundary), split along alternating diagonals.
fn grid(n: usize) -> TriMesh {
    let mut p = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            p.push([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                t.push([a, b, c]);
                t.push([a, c, d]);
            } else {
                t.push([a, b, d]);
                t.push([b, c, d]);
            }
        }
    }
    TriMesh::new(p, t)
}

fn euler_of(m: &TriMesh) -> i64 {
    m.n_vertices() as i64 - m.topology().edges.len() as i64 + m.n_faces() as i64
}

#[test]
fn builds_and_round_trips() {
    let s = shapes::sphere(1.0, 2).unwrap();
    let he = HalfEdgeMesh::from_trimesh(&s).unwrap();
    he.check().unwrap();
    assert_eq!(he.euler_characteristic(), 2);
    let (back, map) = he.to_trimesh();
    assert_eq!(back, s);
    assert!(map.iter().enumerate().all(|(i, &m)| m == i as u32));
    for v in 0..s.n_vertices() as u32 {
        assert_eq!(he.valence(v), s.topology().neighbors(v).len());
        assert!(!he.is_boundary_vertex(v));
    }
    let g = grid(3);
    let he = HalfEdgeMesh::from_trimesh(&g).unwrap();
    he.check().unwrap();
    assert_eq!(he.euler_characteristic(), 1);
    for v in 0..g.n_vertices() as u32 {
        assert_eq!(he.valence(v), g.topology().neighbors(v).len(), "vertex {v}");
        assert_eq!(
            he.is_boundary_vertex(v),
            g.topology().is_boundary_vertex[v as usize]
        );
        let mut nb = he.neighbors(v);
        nb.sort_unstable();
        assert_eq!(nb, g.topology().neighbors(v));
    }
}

#[test]
fn rejects_bad_input() {
    let p = vec![
        [0.0; 3],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, -1.0, 0.0],
    ];
    let three = TriMesh::new(p.clone(), vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
    assert_eq!(
        HalfEdgeMesh::from_trimesh(&three).unwrap_err(),
        HalfEdgeError::NonManifoldEdge {
            a: 0,
            b: 1,
            faces: [0, 1]
        }
    );
    let flipped = TriMesh::new(p.clone(), vec![[0, 1, 2], [0, 1, 3]]);
    let err = HalfEdgeMesh::from_trimesh(&flipped).unwrap_err();
    assert!(matches!(
        err,
        HalfEdgeError::InconsistentOrientation { a: 0, b: 1, .. }
    ));
    // The message names the way out.
    assert!(err.to_string().contains("repair: true"), "{err}");
    let bad = TriMesh::new(p.clone(), vec![[0, 1, 9]]);
    assert_eq!(
        HalfEdgeMesh::from_trimesh(&bad).unwrap_err(),
        HalfEdgeError::IndexOutOfRange {
            face: 0,
            index: 9,
            n_vertices: 5
        }
    );
    let degenerate = TriMesh::new(p.clone(), vec![[0, 1, 2], [3, 3, 4]]);
    assert!(matches!(
        HalfEdgeMesh::from_trimesh(&degenerate).unwrap_err(),
        HalfEdgeError::DegenerateFace { face: 1, .. }
    ));
    // Two triangles touching at vertex 0 only: a bow tie.
    let mut q = p.clone();
    q.push([-1.0, 0.0, 0.0]);
    q.push([0.0, 0.0, -1.0]);
    let bowtie = TriMesh::new(q, vec![[0, 1, 2], [0, 5, 6]]);
    assert!(matches!(
        HalfEdgeMesh::from_trimesh(&bowtie).unwrap_err(),
        HalfEdgeError::NonManifoldVertex { vertex: 0, .. }
    ));
}

#[test]
fn split_interior_and_boundary() {
    let g = grid(2);
    let mut he = HalfEdgeMesh::from_trimesh(&g).unwrap();
    let h = he.find_edge(1, 4); // interior edge (1 = (0.5, 0), 4 = centre)
    assert!(!he.is_boundary_edge(h));
    he.set_tag(h, 7);
    let m = he.split_edge(h, [0.5, 0.25, 0.0]);
    he.check().unwrap();
    assert_eq!(he.euler_characteristic(), 1);
    assert_eq!(he.n_live_faces(), g.n_faces() + 2);
    assert_eq!(he.valence(m), 4);
    assert_eq!(he.tag(he.find_edge(m, 1)), 7);
    assert_eq!(he.tag(he.find_edge(m, 4)), 7);
    assert!(he.find_edge(1, 4) == NONE);
    // A boundary edge.
    let hb = he.find_edge(0, 1);
    let hb = if he.is_boundary_edge(hb) {
        hb
    } else {
        he.opp(hb)
    };
    assert!(he.is_boundary_edge(hb));
    let n = he.split_edge(hb, [0.25, 0.0, 0.0]);
    he.check().unwrap();
    assert_eq!(he.euler_characteristic(), 1);
    assert!(he.is_boundary_vertex(n));
    assert_eq!(he.valence(n), 3);
    let (t, _) = he.to_trimesh();
    assert!((t.total_area() - 1.0).abs() < 1e-12);
    assert_eq!(t.topology().boundary_edge_count(), 9);
}

#[test]
fn flip_keeps_invariants_and_refuses_bad_flips() {
    let s = shapes::sphere(1.0, 1).unwrap();
    let mut he = HalfEdgeMesh::from_trimesh(&s).unwrap();
    let h = 0;
    let (a, b) = (he.from(h), he.to(h));
    let (va, vb) = (he.valence(a), he.valence(b));
    let c = he.from(prev(h));
    let d = he.from(prev(he.opp(h)));
    let (vc, vd) = (he.valence(c), he.valence(d));
    assert!(he.flip_ok(h));
    let k = he.flip(h);
    he.check().unwrap();
    assert_eq!(he.euler_characteristic(), 2);
    assert_eq!([he.from(k), he.to(k)], [c, d]);
    assert_eq!(
        [he.valence(a), he.valence(b), he.valence(c), he.valence(d)],
        [va - 1, vb - 1, vc + 1, vd + 1]
    );
    assert_eq!(he.find_edge(a, b), NONE);
    // Flipping back restores the same vertex sets of faces.
    assert!(he.flip_ok(k));
    he.flip(k);
    he.check().unwrap();
    assert_ne!(he.find_edge(a, b), NONE);
    // Boundary edges and planar configurations that would fold are refused.
    let g = grid(2);
    let he = HalfEdgeMesh::from_trimesh(&g).unwrap();
    let hb = he.find_edge(0, 1);
    let hb = if he.is_boundary_edge(hb) {
        hb
    } else {
        he.opp(hb)
    };
    assert!(!he.flip_ok(hb));
    // Diagonal 0–4 of the convex corner square: allowed.
    let d = he.find_edge(0, 4);
    assert!(he.flip_ok(d));
    // Square (4, 5, 8, 7) with diagonal 4–8: with 4 moved to (0.9, 0.9) the quad is no
    // longer convex and the flipped triangle (7, 8, 5) would turn over.
    let mut he3 = he.clone();
    he3.set_position(4, [0.9, 0.9, 0.0]);
    let f = he3.find_edge(4, 8);
    assert!(!he3.flip_ok(f));
    he3.set_position(4, [0.5, 0.5, 0.0]);
    assert!(he3.flip_ok(f));
}

#[test]
fn collapse_keeps_invariants() {
    let s = shapes::sphere(1.0, 2).unwrap();
    let mut he = HalfEdgeMesh::from_trimesh(&s).unwrap();
    let mut collapsed = 0;
    for h in 0..he.n_halfedge_slots() as u32 {
        if collapsed == 20 {
            break;
        }
        if !he.is_halfedge_alive(h) {
            continue;
        }
        let p = he.position(he.to(h));
        if he.collapse_ok(h, p, 1.5).is_ok() {
            let (a, b) = (he.from(h), he.to(h));
            let expect = he.valence(a) + he.valence(b) - 4;
            he.collapse(h);
            he.check().unwrap();
            assert!(!he.is_vertex_alive(a));
            assert_eq!(he.valence(b), expect);
            assert_eq!(he.euler_characteristic(), 2);
            collapsed += 1;
        }
    }
    assert_eq!(collapsed, 20);
    let before = he.to_trimesh().0;
    let h = (0..he.n_halfedge_slots() as u32)
        .rev()
        .find(|&h| he.is_halfedge_alive(h))
        .unwrap();
    let (a, b) = (he.from(h), he.to(h));
    he.set_tag(h, 42);
    let map = he.compact();
    let k = he.find_edge(map[a as usize], map[b as usize]);
    assert_eq!(he.tag(k), 42);
    he.check().unwrap();
    assert_eq!(he.n_vertex_slots(), s.n_vertices() - 20);
    assert_eq!(he.n_halfedge_slots(), 3 * (s.n_faces() - 40));
    assert_eq!(map.iter().filter(|&&m| m == NONE).count(), 20);
    assert_eq!(he.to_trimesh().0, before);
    let (t, _) = he.to_trimesh();
    assert_eq!(t.n_vertices(), s.n_vertices() - 20);
    assert_eq!(t.n_faces(), s.n_faces() - 40);
    assert_eq!(euler_of(&t), 2);
    assert!(t.topology().nonmanifold_edges.is_empty());
}

/// The half-edge of the boundary edge between vertices 1 and 2 (the bottom side) of a grid.
fn bottom_boundary_halfedge(he: &HalfEdgeMesh) -> u32 {
    let h = he.find_edge(1, 2);
    if he.is_boundary_edge(h) {
        h
    } else {
        he.opp(h)
    }
}

#[test]
fn a_boundary_edge_collapses_either_way() {
    // A boundary edge of a 3 × 3 grid collapsed the other way round: its target goes, and
    // its origin keeps its index and position and takes both fans.
    let g = grid(3);
    let mut he = HalfEdgeMesh::from_trimesh(&g).unwrap();
    let h = bottom_boundary_halfedge(&he);
    let (a, b) = (he.from(h), he.to(h));
    let (pa, nb) = (he.position(a), he.neighbors(b).len());
    let na = he.neighbors(a).len();
    assert!(he.collapse_topology_ok(h).is_ok());
    he.collapse_keeping_origin(h);
    he.check().unwrap();
    assert!(he.is_vertex_alive(a) && !he.is_vertex_alive(b));
    assert_eq!(he.position(a), pa);
    assert!(he.is_boundary_vertex(a));
    // The merged vertex has both fans but the edge between them and the apex counted once.
    assert_eq!(he.valence(a), na + nb - 3);
    assert_eq!(he.neighbors(a).len(), he.valence(a));
    assert_eq!(he.euler_characteristic(), 1);
    let (t, _) = he.to_trimesh();
    assert_eq!(t.n_vertices(), 15);
    assert_eq!(t.topology().boundary_edge_count(), 11);
}

#[test]
fn collapse_on_boundary_and_link_condition() {
    let g = grid(3);
    let mut he = HalfEdgeMesh::from_trimesh(&g).unwrap();
    let h = bottom_boundary_halfedge(&he);
    let (a, b) = (he.from(h), he.to(h));
    he.set_tag(h, 3);
    assert!(he.collapse_ok(h, he.position(b), 1.5).is_ok());
    he.collapse(h);
    he.check().unwrap();
    assert_eq!(he.euler_characteristic(), 1);
    assert!(he.is_boundary_vertex(b) && !he.is_vertex_alive(a));
    let (t, _) = he.to_trimesh();
    assert_eq!(t.topology().boundary_edge_count(), 11);
    // Interior edge joining two boundary vertices: refused (would pinch).
    let g = grid(1);
    let he = HalfEdgeMesh::from_trimesh(&g).unwrap();
    let diag = he.find_edge(0, 3);
    assert_eq!(
        he.collapse_topology_ok(diag),
        Err(CollapseRejection::BoundaryPinch)
    );
    // Tetrahedron: every collapse would leave a doubled triangle.
    let tet = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    );
    let he = HalfEdgeMesh::from_trimesh(&tet).unwrap();
    for h in 0..12 {
        assert!(he.collapse_topology_ok(h).is_err());
    }
    // Link condition: in a triangular bipyramid (apexes 3, 4 over the triangle 0, 1, 2)
    // the ends of edge 0–1 share vertex 2 besides the apexes: refused. Edge 3–0 passes.
    let bip = TriMesh::new(
        vec![
            [1.0, 0.0, 0.0],
            [-0.5, 0.8, 0.0],
            [-0.5, -0.8, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ],
        vec![
            [3, 0, 1],
            [3, 1, 2],
            [3, 2, 0],
            [4, 1, 0],
            [4, 2, 1],
            [4, 0, 2],
        ],
    );
    let he = HalfEdgeMesh::from_trimesh(&bip).unwrap();
    he.check().unwrap();
    assert_eq!(
        he.collapse_topology_ok(he.find_edge(0, 1)),
        Err(CollapseRejection::LinkCondition)
    );
    let mut he = he;
    let h = he.find_edge(3, 0);
    assert_eq!(he.collapse_topology_ok(h), Ok(()));
    he.collapse(h);
    he.check().unwrap();
    assert_eq!(he.n_live_faces(), 4);
    assert_eq!(he.euler_characteristic(), 2);
}

/// After many splits (each appends its vertex), `compact_by_key` with keys along a Morton
/// curve gives the same surface, tags and boundary with one-rings close together in the
/// numbering; plain `compact` keeps the scattered order.
#[test]
fn compact_by_key_keeps_the_surface_and_gathers_one_rings() {
    let refined = || {
        let g = grid(4);
        let mut he = HalfEdgeMesh::from_trimesh(&g).unwrap();
        // One tagged boundary side, to follow through the renumbering.
        let h = he.find_edge(0, 1);
        let h = if he.is_boundary_edge(h) { h } else { he.opp(h) };
        he.set_tag(h, 7);
        // Three sweeps of midpoint splits over the edges there are at the start of each:
        // the new vertices at the end of the arrays.
        for _ in 0..3 {
            let edges: Vec<u32> = (0..he.n_halfedge_slots() as u32)
                .filter(|&h| he.is_halfedge_alive(h) && he.is_canonical(h))
                .collect();
            for h in edges {
                {
                    let m = vec3::scale(
                        vec3::add(he.position(he.from(h)), he.position(he.to(h))),
                        0.5,
                    );
                    he.split_edge(h, m);
                }
            }
        }
        he.check().unwrap();
        he
    };
    let spread = |he: &HalfEdgeMesh| crate::locality::median_corner_spread(&he.to_trimesh().0);
    let faces = |he: &HalfEdgeMesh| {
        let (t, _) = he.to_trimesh();
        let mut f: Vec<[[u64; 3]; 3]> = t
            .triangles
            .iter()
            .map(|c| {
                // Each face as its corner positions, rotated to start at the smallest.
                let p = c.map(|v| t.positions[v as usize].map(f64::to_bits));
                let k = (0..3).min_by_key(|&k| p[k]).unwrap();
                [p[k], p[(k + 1) % 3], p[(k + 2) % 3]]
            })
            .collect();
        f.sort_unstable();
        f
    };
    let mut plain = refined();
    plain.compact();
    let mut ordered = refined();
    let by_curve = |he: &HalfEdgeMesh| {
        let positions: Vec<V3> = (0..he.n_vertex_slots() as u32)
            .map(|v| he.position(v))
            .collect();
        let mut key = vec![0u64; positions.len()];
        for (rank, v) in crate::locality::morton_order(&positions)
            .into_iter()
            .enumerate()
        {
            key[v as usize] = rank as u64;
        }
        key
    };
    let map = ordered.compact_by_key(&by_curve(&ordered));
    ordered.check().unwrap();
    assert_eq!(ordered.n_vertex_slots(), plain.n_vertex_slots());
    assert!(ordered.n_vertex_slots() > 1000);
    assert_eq!(faces(&ordered), faces(&plain));
    assert_eq!(ordered.euler_characteristic(), 1);
    // A permutation of the vertices, positions carried along.
    let original = refined();
    let mut seen = vec![false; map.len()];
    for (old, &new) in map.iter().enumerate() {
        assert!(!std::mem::replace(&mut seen[new as usize], true));
        assert_eq!(ordered.position(new), original.position(old as u32));
    }
    // The tagged pieces of the split side 0 → 1 keep their tag: as many as before, all on
    // that side, the first starting at old vertex 0.
    let tagged = |he: &HalfEdgeMesh| -> Vec<u32> {
        (0..he.n_halfedge_slots() as u32)
            .filter(|&h| he.is_halfedge_alive(h) && he.tag(h) == 7)
            .collect()
    };
    let pieces = tagged(&ordered);
    assert_eq!(pieces.len(), tagged(&plain).len());
    assert!(pieces.len() > 1);
    for &h in &pieces {
        for v in [ordered.from(h), ordered.to(h)] {
            let p = ordered.position(v);
            assert!(p[1] == 0.0 && (0.0..=0.25).contains(&p[0]), "{p:?}");
        }
    }
    assert!(pieces
        .iter()
        .any(|&h| ordered.from(h) == map[0] || ordered.to(h) == map[0]));
    let (before, after) = (spread(&plain), spread(&ordered));
    assert!(
        before > 200 && after < 40,
        "median corner spread {before} → {after}"
    );
    let mut again = refined();
    again.compact_by_key(&by_curve(&again));
    assert_eq!(again.to_trimesh(), ordered.to_trimesh());
}
