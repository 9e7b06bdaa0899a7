//! Unit tests of `shortest_path.rs`.

use super::*;
use crestflow_geom::shapes::{sphere, torus};

fn lm(pairs: &[[u32; 2]]) -> LandmarkPairs {
    LandmarkPairs {
        pairs: pairs.to_vec(),
        lines: (1..=pairs.len()).collect(),
        origin: "lm.txt".into(),
    }
}

/// All-pairs shortest edge paths by Floyd–Warshall (brute force reference).
fn floyd(mesh: &TriMesh) -> Vec<Vec<f64>> {
    let n = mesh.n_vertices();
    let mut d = vec![vec![f64::INFINITY; n]; n];
    for (i, row) in d.iter_mut().enumerate() {
        row[i] = 0.0;
    }
    for e in &mesh.topology().edges {
        let l = dist(mesh.positions[e[0] as usize], mesh.positions[e[1] as usize]);
        d[e[0] as usize][e[1] as usize] = l;
        d[e[1] as usize][e[0] as usize] = l;
    }
    for k in 0..n {
        for i in 0..n {
            for j in 0..n {
                let via = d[i][k] + d[k][j];
                if via < d[i][j] {
                    d[i][j] = via;
                }
            }
        }
    }
    d
}

#[test]
fn dijkstra_paths_are_shortest_edge_paths() {
    let mesh = torus(2.0, 0.7, 12, 8, 0.2, 3).unwrap();
    let d = floyd(&mesh);
    let topo = mesh.topology();
    for (a, b) in [(0u32, 50u32), (3, 90), (17, 18), (5, 5)] {
        let path = dijkstra_path(&mesh, a, b, &|x, y| {
            dist(mesh.positions[x as usize], mesh.positions[y as usize])
        })
        .unwrap();
        assert_eq!(path[0], a);
        assert_eq!(*path.last().unwrap(), b);
        let mut len = 0.0;
        for w in path.windows(2) {
            assert!(topo.neighbors(w[0]).contains(&w[1]), "not an edge: {w:?}");
            len += dist(mesh.positions[w[0] as usize], mesh.positions[w[1] as usize]);
        }
        assert!(
            (len - d[a as usize][b as usize]).abs() < 1e-12,
            "{len} vs {}",
            d[a as usize][b as usize]
        );
    }
}

#[test]
fn chain_pairs_and_cut() {
    assert_eq!(
        curve_pairs(3, &[], 0).unwrap(),
        vec![[0, 1], [1, 2], [2, 0]]
    );
    assert_eq!(curve_pairs(2, &[], 0).unwrap(), vec![[0, 1]]);
    assert_eq!(curve_pairs(5, &[], 2).unwrap(), vec![[0, 1], [1, 2]]);
    assert_eq!(curve_pairs(5, &[[4, 0]], 0).unwrap(), vec![[4, 0]]);
    let e = curve_pairs(5, &[[1, 7]], 0).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::PairOutOfRange {
                pair: 0,
                index: 7,
                count: 5
            }
        ),
        "{e}"
    );
    let e = curve_pairs(3, &[], 4).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::TooManyCurves {
                asked: 4,
                available: 3,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn both_sides_join_the_same_landmarks() {
    let mesh = sphere(1.0, 2).unwrap();
    let l = lm(&[[0, 10], [20, 30], [40, 50]]);
    let p = |side| ShortestPathParams {
        side,
        ..Default::default()
    };
    let s = shortest_paths(&mesh, &l, None, &p(Side::Source), Par::Seq).unwrap();
    let t = shortest_paths(&mesh, &l, None, &p(Side::Target), Par::Rayon).unwrap();
    assert_eq!(s.curves.len(), 3);
    assert_eq!(t.curves.len(), 3);
    let ends = |net: &FeatureCurveNetwork, c: usize| {
        let v = &net.curves[c].vertices;
        let f = |i: u32| match net.vertices[i as usize].location {
            SurfacePoint::Vertex(v) => v,
            _ => unreachable!(),
        };
        (f(v[0]), f(*v.last().unwrap()))
    };
    assert_eq!(ends(&s, 0), (0, 20));
    assert_eq!(ends(&s, 2), (40, 0));
    assert_eq!(ends(&t, 1), (30, 50));
    // Deterministic at any thread count.
    let s2 = shortest_paths(&mesh, &l, None, &p(Side::Source), Par::Rayon).unwrap();
    assert_eq!(s, s2);
}

#[test]
fn out_of_range_landmark_names_the_line() {
    let mesh = sphere(1.0, 1).unwrap(); // 42 vertices
    let l = lm(&[[0, 1], [2, 3], [5, 900]]);
    let p = ShortestPathParams {
        side: Side::Target,
        ..Default::default()
    };
    let e = shortest_paths(&mesh, &l, None, &p, Par::Seq).unwrap_err();
    assert_eq!(
        e.to_string(),
        "lm.txt:3: target vertex 900 is out of range: the target mesh has 42 vertices"
    );
    // The source side of the same file is fine.
    assert!(shortest_paths(&mesh, &l, None, &ShortestPathParams::default(), Par::Seq).is_ok());
}

#[test]
fn anisotropic_needs_curvature() {
    let mesh = sphere(1.0, 1).unwrap();
    let p = ShortestPathParams {
        weight: EdgeWeight::Anisotropic { beta: 1.0 },
        ..Default::default()
    };
    let e = shortest_paths(&mesh, &lm(&[[0, 0], [9, 9]]), None, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::Param {
                field: "weight",
                ..
            }
        ),
        "{e}"
    );
}

/// A flat n × n grid in the xy plane, each square split along its diagonal.
fn grid(n: usize) -> TriMesh {
    let mut pos = Vec::new();
    for j in 0..n {
        for i in 0..n {
            pos.push([i as f64, j as f64, 0.0]);
        }
    }
    let mut tris = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = (j * n + i) as u32;
            let n = n as u32;
            tris.push([v, v + 1, v + n + 1]);
            tris.push([v, v + n + 1, v + n]);
        }
    }
    TriMesh::new(pos, tris)
}

#[test]
fn anisotropic_weights_follow_the_low_cost_direction() {
    // k_max = 1 along x: the normal curvature across an edge along y is 1 (cheap), across an
    // edge along x it is 0 (full length). Anisotropic paths run along y more than geodesic ones.
    let n = 12;
    let mesh = grid(n);
    let nv = mesh.n_vertices();
    let k = CurvatureField {
        k_max: vec![1.0; nv],
        k_min: vec![0.0; nv],
        t_max: vec![[1.0, 0.0, 0.0]; nv],
        t_min: vec![[0.0, 1.0, 0.0]; nv],
        normal: vec![[0.0, 0.0, 1.0]; nv],
        e_max: vec![0.0; nv],
        e_min: vec![0.0; nv],
        method: "test".into(),
    };
    // From (0, 0) to (11, 5).
    let l = lm(&[[0, 0], [(5 * n + 11) as u32, 0]]);
    let y_steps = |net: &FeatureCurveNetwork| {
        net.curve_edges(0)
            .iter()
            .filter(|&&(a, b)| {
                let (pa, pb) = (
                    net.vertices[a as usize].position,
                    net.vertices[b as usize].position,
                );
                pa[0] == pb[0]
            })
            .count()
    };
    let geo = shortest_paths(&mesh, &l, None, &ShortestPathParams::default(), Par::Seq).unwrap();
    let p0 = ShortestPathParams {
        weight: EdgeWeight::Anisotropic { beta: 0.0 },
        ..Default::default()
    };
    assert_eq!(
        shortest_paths(&mesh, &l, Some(&k), &p0, Par::Seq).unwrap(),
        geo
    );
    let p = ShortestPathParams {
        weight: EdgeWeight::Anisotropic { beta: 20.0 },
        ..Default::default()
    };
    let ani = shortest_paths(&mesh, &l, Some(&k), &p, Par::Seq).unwrap();
    let x_steps = |net: &FeatureCurveNetwork| {
        net.curve_edges(0)
            .iter()
            .filter(|&&(a, b)| {
                net.vertices[a as usize].position[1] == net.vertices[b as usize].position[1]
            })
            .count()
    };
    // The geodesic path takes 5 diagonal steps and 6 along x, none along y.
    assert_eq!((x_steps(&geo), y_steps(&geo)), (6, 0));
    // Anisotropic costs: x step 1, diagonal √2/(1 + 20·0.5) ≈ 0.129, y step 1/21. The optimum
    // avoids x steps entirely: 11 diagonals (up to row 11) and 6 y steps back down to row 5
    // (cost ≈ 1.70, against ≥ 6 for any path with 6 x steps).
    assert_eq!((x_steps(&ani), y_steps(&ani)), (0, 6));
    assert_eq!(ani.curves[0].vertices.len(), 18);
}
