use super::*;
use crestflow_geom::fcn::{CurveLabel, FcnVertex, FeatureCurve};

const N: u32 = NONE_NET;

#[test]
fn a_detour_is_cut_out_and_its_network_vertex_moves_to_where_it_starts() {
    // 1 → 2 → 3 (network vertex 7) → 4 → 2 → 5: the detour 3, 4 returns to 2.
    let seq = vec![(1, 0), (2, N), (3, 7), (4, N), (2, N), (5, 9)];
    assert_eq!(erase_loops(seq, false), vec![(1, 0), (2, 7), (5, 9)]);
    // A vertex that has a network vertex keeps it.
    let seq = vec![(1, 0), (2, 6), (3, 7), (2, N), (5, 9)];
    assert_eq!(erase_loops(seq, false), vec![(1, 0), (2, 6), (5, 9)]);
    // A path without detours is unchanged.
    let seq = vec![(1, 0), (2, N), (3, 7)];
    assert_eq!(erase_loops(seq.clone(), false), seq);
}

#[test]
fn a_closed_stroke_keeps_its_loop() {
    // 1 → 2 → 3 → 1: the return to the start closes the loop, it is no detour.
    let seq = vec![(1, 0), (2, 4), (3, 5), (1, 0)];
    assert_eq!(erase_loops(seq, true), vec![(1, 0), (2, 4), (3, 5)]);
}

fn vertex(x: f64) -> FcnVertex {
    FcnVertex {
        position: [x, 0.0, 0.0],
        location: SurfacePoint::Free,
        strength: 1.0,
    }
}

#[test]
fn strokes_run_across_curves_that_meet_end_to_end() {
    // Curves 0-1-2 and 2-3, and a triangle loop 4-5-6; vertex 2 joins two curves but has two
    // edges, so 0-1-2-3 is one stroke.
    let curve = |v: Vec<u32>, closed: bool| FeatureCurve {
        vertices: v,
        closed,
        label: CurveLabel::Other,
    };
    let net = FeatureCurveNetwork {
        vertices: (0..7).map(|i| vertex(i as f64)).collect(),
        curves: vec![
            curve(vec![0, 1, 2], false),
            curve(vec![2, 3], false),
            curve(vec![4, 5, 6], true),
        ],
    };
    assert_eq!(strokes(&net), vec![vec![0, 1, 2, 3], vec![4, 5, 6, 4]]);
}

/// A (n + 1) × (n + 1) grid of vertices on the unit square, two triangles per cell.
fn unit_grid(n: u32) -> TriMesh {
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            pos.push([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    let mut tri = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            tri.push([v, v + 1, v + n + 2]);
            tri.push([v, v + n + 2, v + n + 1]);
        }
    }
    TriMesh::new(pos, tri)
}

#[test]
fn a_curve_loop_is_the_networks_own_polygon() {
    // A 21 × 21 grid on the unit square and a closed curve: a square whose vertices lie off
    // the grid vertices, its edge path on grid lines. With a corner angle above its 90°
    // turns it is one loop, whose reference polyline must be the network's own square, the
    // first point included: the mesh vertex standing in for the start would add a short
    // segment and a false bend there.
    let mesh = unit_grid(20);
    let square: Vec<V3> = vec![
        [0.213, 0.207, 0.0],
        [0.813, 0.207, 0.0],
        [0.813, 0.807, 0.0],
        [0.213, 0.807, 0.0],
    ];
    let net = FeatureCurveNetwork::from_polylines(&square, &[(&[0, 1, 2, 3], true)]);
    let proj = Projector::new(&mesh);
    let fe = mark_features(&mesh, None, Some(&net), &proj, f64::INFINITY).unwrap();
    let chains = build_chains(&mesh, &fe, 100.0);
    // Two loops: the grid's boundary (boundary edges are features) and the curve.
    assert_eq!(chains.points.len(), 2);
    let c = (0..2)
        .find(|&c| chains.from_curves[c])
        .expect("the curve's chain");
    assert!(chains.closed[c] && !chains.from_curves[1 - c]);
    let pts = &chains.points[c];
    assert_eq!(pts.len(), 5, "{pts:?}");
    for p in pts {
        assert!(square.contains(p), "{p:?} is not a vertex of the network");
    }
    assert_eq!(pts[0], pts[4]);
}

#[test]
fn curve_ends_beside_a_point_are_trimmed_back_to_the_clearance() {
    // On a 21 × 21 grid (spacing 0.05), a straight curve along y = 0.5 from x = 0.2 to
    // x = 0.8 (on grid vertices), and a point at (0.86, 0.5): with a clearance of 0.2, the
    // curve gives up its edges from x = 0.8 back to x = 0.65 (the first vertex farther
    // than 0.2), 3 edges; the end at x = 0.2 is far and stays. The boundary is a feature as
    // well and is never trimmed, though the point lies within 0.2 of it.
    let mesh = unit_grid(20);
    let line: Vec<V3> = vec![[0.2, 0.5, 0.0], [0.8, 0.5, 0.0]];
    let net = FeatureCurveNetwork::from_polylines(&line, &[(&[0, 1], false)]);
    let proj = Projector::new(&mesh);
    let mut fe = mark_features(&mesh, None, Some(&net), &proj, f64::INFINITY).unwrap();
    assert_eq!(fe.from_curves, 12);
    let boundary = fe.boundary;
    let chains = build_chains(&mesh, &fe, 100.0);
    let near_boundary = [0.85, 0.95, 0.0];
    let chains = trim_curve_ends_near(
        &mesh,
        &mut fe,
        chains,
        &[[0.86, 0.5, 0.0], near_boundary],
        0.2,
        100.0,
    );
    assert_eq!(fe.trimmed, 3);
    let topo = mesh.topology();
    let kept: Vec<[V3; 2]> = (0..topo.edges.len())
        .filter(|&e| fe.is_feature[e] && !topo.is_boundary_edge(e as u32))
        .map(|e| topo.edges[e].map(|v| mesh.positions[v as usize]))
        .collect();
    assert_eq!(kept.len(), 9);
    let xmax = kept
        .iter()
        .flat_map(|e| e.iter().map(|p| p[0]))
        .fold(0.0, f64::max);
    assert!(
        (xmax - 0.65).abs() < 1e-12,
        "the curve now ends at x = {xmax}"
    );
    let count_boundary = (0..topo.edges.len())
        .filter(|&e| fe.is_feature[e] && topo.is_boundary_edge(e as u32))
        .count();
    assert_eq!(count_boundary, boundary);
    // The rebuilt chains (corner angle above the boundary's 90° turns): the boundary loop
    // and the shorter curve, whose end is a corner.
    assert_eq!(chains.points.len(), 2);
    let end = 10 * 21 + 13; // (0.65, 0.5)
    assert!(chains.is_corner[end]);
    // Nothing within reach: nothing changes.
    let before = fe.trimmed;
    let chains = trim_curve_ends_near(&mesh, &mut fe, chains, &[[0.5, 0.1, 0.0]], 0.2, 100.0);
    assert_eq!(fe.trimmed, before);
    assert_eq!(chains.points.len(), 2);
}

#[test]
fn a_trimmed_end_next_to_a_network_vertex_is_trimmed_to_it() {
    // As above, but the network has a vertex at x = 0.6: trimming back to the clearance
    // stops at x = 0.65, 0.05 from that vertex, which would leave an edge between two fixed
    // vertices far shorter than the collapse length. The stub goes too: the curve ends at
    // the network vertex, 4 edges trimmed.
    let mesh = unit_grid(20);
    let line: Vec<V3> = vec![[0.2, 0.5, 0.0], [0.6, 0.5, 0.0], [0.8, 0.5, 0.0]];
    let net = FeatureCurveNetwork::from_polylines(&line, &[(&[0, 1, 2], false)]);
    let proj = Projector::new(&mesh);
    let mut fe = mark_features(&mesh, None, Some(&net), &proj, f64::INFINITY).unwrap();
    let chains = build_chains(&mesh, &fe, 100.0);
    let chains = trim_curve_ends_near(&mesh, &mut fe, chains, &[[0.86, 0.5, 0.0]], 0.2, 100.0);
    assert_eq!(fe.trimmed, 4);
    let topo = mesh.topology();
    let xmax = (0..topo.edges.len())
        .filter(|&e| fe.is_feature[e] && !topo.is_boundary_edge(e as u32))
        .flat_map(|e| topo.edges[e].map(|v| mesh.positions[v as usize][0]))
        .fold(0.0, f64::max);
    assert!(
        (xmax - 0.6).abs() < 1e-12,
        "the curve now ends at x = {xmax}"
    );
    assert!(chains.is_corner[10 * 21 + 12]); // (0.6, 0.5)
}

/// `unit_grid(n)` below a staircase: column i keeps the rows j < n/2 + (i mod 2) (a right
/// angle at every vertex of the top boundary). Unused vertices stay (they carry no edge).
fn staircase(n: u32) -> TriMesh {
    let grid = unit_grid(n);
    let tri = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .filter(|&(i, j)| j < n / 2 + i % 2)
        .flat_map(|(i, j)| {
            let f = 2 * (j * n + i) as usize;
            [grid.triangles[f], grid.triangles[f + 1]]
        })
        .collect();
    TriMesh::new(grid.positions.clone(), tri)
}

#[test]
fn boundary_corners_are_found_at_the_scale() {
    let n = 48;
    let mesh = staircase(n);
    let proj = Projector::new(&mesh);
    let mut fe = mark_features(&mesh, None, None, &proj, f64::INFINITY).unwrap();
    let corners_at = |fe: &FeatureEdges| -> Vec<V3> {
        let chains = build_chains(&mesh, fe, 60.0);
        (0..mesh.n_vertices())
            .filter(|&v| chains.is_corner[v])
            .map(|v| mesh.positions[v])
            .collect()
    };
    // Per vertex, every step of the staircase turns by 90°: 96 corners on top, 4 below.
    assert_eq!(corners_at(&fe).len(), 2 * n as usize + 2);
    // At the scale of ten cells only the region's four corners turn by more than 60°: one
    // vertex each, the sharpest turn at that scale, which on the steps may lie a step away.
    mark_boundary_corners(&mesh, &mut fe, 10.0 / n as f64, 60.0);
    let top = (n / 2 + 1) as f64 / n as f64;
    let found = corners_at(&fe);
    assert_eq!(found.len(), 4, "{found:?}");
    let cell = 1.0 / n as f64;
    for (c, f) in [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.5, 0.0],
        [1.0, top, 0.0],
    ]
    .iter()
    .zip(&found)
    {
        assert!(
            vec3::dist(*c, *f) < 1.5 * cell,
            "corner {c:?} found at {f:?}"
        );
    }
    // At the scale of one cell every step stands out again.
    mark_boundary_corners(&mesh, &mut fe, 0.9 / n as f64, 60.0);
    assert_eq!(corners_at(&fe).len(), 2 * n as usize + 2);
}

#[test]
fn a_curve_along_a_ragged_boundary_follows_it() {
    // The staircase's top steps at every cell, so the straight edge path between two of its
    // vertices on the same row cuts through the inside, and the way along the boundary is
    // twice as long but never farther than a cell from the segment: the curve stands for the
    // boundary and takes its edges (which are features anyway), adding none inside.
    let n = 48;
    let mesh = staircase(n);
    let at = |i: u32, j: u32| [i as f64 / n as f64, j as f64 / n as f64, 0.0];
    let proj = Projector::new(&mesh);
    let along = FeatureCurveNetwork::from_polylines(&[at(4, 24), at(16, 24)], &[(&[0, 1], false)]);
    let fe = mark_features(&mesh, None, Some(&along), &proj, f64::INFINITY).unwrap();
    assert_eq!(fe.from_curves, 0);
    assert_eq!(fe.count(), mesh.topology().boundary_edge_count());
    // A curve from the left side to the bottom across the corner at the origin: the way
    // along the boundary bends away from it (half its length at the corner), so it stays a
    // curve of inside edges.
    let across = FeatureCurveNetwork::from_polylines(&[at(0, 8), at(8, 0)], &[(&[0, 1], false)]);
    let fe = mark_features(&mesh, None, Some(&across), &proj, f64::INFINITY).unwrap();
    assert!(fe.from_curves >= 8, "{} curve edges", fe.from_curves);
}

#[test]
fn a_crease_end_takes_the_place_of_a_boundary_corner_within_the_scale() {
    // A curve meets the staircase's bottom side three cells from the corner at the origin:
    // that end is a corner by its feature edges, and at the scale of ten cells it stands for
    // the origin's bend too (two fixed vertices closer than L would pin a needle). The corner
    // at (1, 0), far from it, stays.
    let n = 48;
    let mesh = staircase(n);
    let at = |i: u32, j: u32| [i as f64 / n as f64, j as f64 / n as f64, 0.0];
    let net = FeatureCurveNetwork::from_polylines(&[at(3, 10), at(3, 0)], &[(&[0, 1], false)]);
    let proj = Projector::new(&mesh);
    let mut fe = mark_features(&mesh, None, Some(&net), &proj, f64::INFINITY).unwrap();
    mark_boundary_corners(&mesh, &mut fe, 10.0 / n as f64, 60.0);
    let chains = build_chains(&mesh, &fe, 60.0);
    let corner_at = |p: V3| {
        let v = mesh.positions.iter().position(|&q| q == p).unwrap();
        chains.is_corner[v]
    };
    assert!(corner_at(at(3, 0)));
    assert!(!corner_at(at(0, 0)));
    assert!(corner_at(at(n, 0)));
}

#[test]
fn curves_along_a_boundary_give_way_to_it() {
    // A curve chain one cell below the staircase's lowest top row, from its left side to its
    // right side: both ends on the boundary and every point of it within two cells of the
    // boundary. With a tolerance of 2.5 cells it is dropped (its edges stop being features,
    // the chains are rebuilt without it); with half a cell it stays.
    let n = 48;
    let mesh = staircase(n);
    let topo = mesh.topology();
    let proj = Projector::new(&mesh);
    let row = n / 2 - 1;
    let with_curve = || {
        let mut fe = mark_features(&mesh, None, None, &proj, f64::INFINITY).unwrap();
        for (e, &[a, b]) in topo.edges.iter().enumerate() {
            if a / (n + 1) == row && b / (n + 1) == row {
                fe.is_feature[e] = true;
                fe.from_curve[e] = true;
                fe.from_curves += 1;
            }
        }
        fe
    };
    let cell = 1.0 / n as f64;
    let mut fe = with_curve();
    let chains = build_chains(&mesh, &fe, 60.0);
    assert_eq!(chains.from_curves.iter().filter(|&&c| c).count(), 1);
    let (kept, dropped) = drop_curves_along_boundaries(
        &mesh,
        &mut fe,
        chains.clone(),
        0.5 * cell,
        10.0 * cell,
        60.0,
    );
    assert_eq!(dropped, 0);
    assert_eq!(kept.from_curves.iter().filter(|&&c| c).count(), 1);
    let (rebuilt, dropped) =
        drop_curves_along_boundaries(&mesh, &mut fe, chains, 2.5 * cell, 10.0 * cell, 60.0);
    assert_eq!(dropped, n as usize);
    assert_eq!(fe.from_curves, 0);
    assert!(rebuilt.from_curves.iter().all(|&c| !c));
    assert_eq!(fe.count(), topo.boundary_edge_count());
}
