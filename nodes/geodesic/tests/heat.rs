//! Heat-method distances against analytic distances (sphere great circles, plane Euclidean).

use crestflow_flow::Par;
use crestflow_geom::fcn::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crestflow_geom::mesh::TriMesh;
use crestflow_geom::shapes::sphere;
use crestflow_geom::vec3::{dot, norm};
use crestflow_nodes_geodesic::{heat_distance, HeatError, HeatParams, HeatSolver, HeatSource};

fn grid(nx: usize, ny: usize, size: f64) -> TriMesh {
    let mut pos = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            pos.push([
                size * i as f64 / nx as f64,
                size * j as f64 / ny as f64,
                0.0,
            ]);
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut tris = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh::new(pos, tris)
}

/// Mean relative error of the heat distance from vertex 0 against great-circle distance.
fn sphere_error(level: u32) -> (f64, f64) {
    let mesh = sphere(1.0, level).unwrap();
    let solver = HeatSolver::new(&mesh, 1.0, Par::Rayon).unwrap();
    let d = solver
        .distance(&HeatSource::vertices(&[0]), Par::Rayon)
        .unwrap();
    let p0 = mesh.positions[0];
    let (mut sum, mut cnt, mut max_abs) = (0.0, 0usize, 0.0f64);
    for (v, p) in mesh.positions.iter().enumerate() {
        let exact = (dot(*p, p0) / (norm(*p) * norm(p0)))
            .clamp(-1.0, 1.0)
            .acos();
        max_abs = max_abs.max((d.values[v] - exact).abs());
        if exact > 0.1 {
            sum += (d.values[v] - exact).abs() / exact;
            cnt += 1;
        }
    }
    (sum / cnt as f64, max_abs)
}

#[test]
fn sphere_matches_great_circle_distance() {
    let (rel3, abs3) = sphere_error(3);
    let (rel4, abs4) = sphere_error(4);
    eprintln!("icosphere level 3: mean rel {rel3:.4}, max abs {abs3:.4}");
    eprintln!("icosphere level 4: mean rel {rel4:.4}, max abs {abs4:.4}");
    assert!(rel4 < 0.02, "mean relative error {rel4}");
    assert!(abs4 < 0.1, "max abs error {abs4}");
    // Refinement improves the result.
    assert!(rel4 < rel3);
}

#[test]
fn grid_matches_euclidean_distance() {
    let mesh = grid(40, 40, 1.0);
    // Source at the centre vertex.
    let c = (20 * 41 + 20) as u32;
    let params = HeatParams {
        vertices: vec![c],
        ..Default::default()
    };
    let d = heat_distance(&mesh, None, &params, Par::Seq).unwrap();
    let pc = mesh.positions[c as usize];
    let mut sum = 0.0;
    let mut cnt = 0;
    for (v, p) in mesh.positions.iter().enumerate() {
        let exact = ((p[0] - pc[0]).powi(2) + (p[1] - pc[1]).powi(2)).sqrt();
        if exact > 0.1 {
            sum += (d.values[v] - exact).abs() / exact;
            cnt += 1;
        }
    }
    let rel = sum / cnt as f64;
    eprintln!("grid 40x40: mean rel {rel:.4}");
    assert!(rel < 0.05, "mean relative error {rel}");
    assert_eq!(d.values[c as usize], 0.0);
}

/// Mean relative error of the distance from the segment y = 0.49, x in [1/6, 5/6] on an
/// `n × n` grid of the unit square, the segment crossing vertical mesh edges.
fn segment_error(n: u32) -> f64 {
    let mesh = grid(n as usize, n as usize, 1.0);
    let row = (0.49 * n as f64).floor() as u32;
    let t = 0.49 * n as f64 - row as f64;
    let mut net = FeatureCurveNetwork::default();
    let mut ids = Vec::new();
    for i in n / 6..=5 * n / 6 {
        let a = row * (n + 1) + i;
        let b = (row + 1) * (n + 1) + i;
        net.vertices.push(FcnVertex {
            position: [mesh.positions[a as usize][0], 0.49, 0.0],
            location: SurfacePoint::Edge { a, b, t },
            strength: 1.0,
        });
        ids.push(ids.len() as u32);
    }
    let (x0, x1) = ((n / 6) as f64 / n as f64, (5 * n / 6) as f64 / n as f64);
    net.curves.push(FeatureCurve {
        vertices: ids,
        closed: false,
        label: CurveLabel::Other,
    });
    let d = heat_distance(&mesh, Some(&net), &HeatParams::default(), Par::Rayon).unwrap();
    let mut sum = 0.0;
    let mut cnt = 0;
    for (v, p) in mesh.positions.iter().enumerate() {
        let x = p[0].clamp(x0, x1);
        let exact = ((p[0] - x).powi(2) + (p[1] - 0.49).powi(2)).sqrt();
        if exact > 0.1 {
            sum += (d.values[v] - exact).abs() / exact;
            cnt += 1;
        }
    }
    sum / cnt as f64
}

#[test]
fn straight_curve_source_gives_distance_to_segment() {
    // The heat method smooths the distance within ~h of the source, which shifts the whole
    // field by O(h) (measured: 8.7% at 30x30, 5.4% at 60x60): the error must drop with
    // refinement.
    let e30 = segment_error(30);
    let e60 = segment_error(60);
    eprintln!("segment source: mean rel {e30:.4} (30x30), {e60:.4} (60x60)");
    assert!(e60 < 0.06, "mean relative error {e60}");
    assert!(e60 < 0.7 * e30, "{e60} vs {e30}");
}

#[test]
fn batched_equals_single_and_seq_equals_rayon() {
    let mesh = sphere(1.0, 3).unwrap();
    let solver = HeatSolver::new(&mesh, 1.0, Par::Seq).unwrap();
    let sources: Vec<HeatSource> = (0..11).map(|k| HeatSource::vertices(&[k * 7])).collect();
    let seq = solver.distances(&sources, Par::Seq).unwrap();
    let par = solver.distances(&sources, Par::Rayon).unwrap();
    assert_eq!(seq, par);
    let single = solver.distance(&sources[5], Par::Seq).unwrap();
    assert_eq!(single, seq[5]);
    // Symmetry of the sphere: the distance from 35 to 0 equals the distance from 0 to 35.
    assert!((seq[0].values[35] - seq[5].values[0]).abs() < 0.02);
}

#[test]
fn split_solves_and_boundaries_give_the_same_bits_at_any_thread_count() {
    // A sphere with a polar cap cut off: a boundary (Neumann and Dirichlet heat solves), and
    // large enough for the triangular solves to be split over subtrees.
    let full = sphere(1.0, 5).unwrap();
    let triangles: Vec<[u32; 3]> = full
        .triangles
        .iter()
        .copied()
        .filter(|t| t.iter().any(|&v| full.positions[v as usize][2] < 0.8))
        .collect();
    let mesh = TriMesh::new(full.positions.clone(), triangles);
    let a = HeatSolver::new(&mesh, 1.0, Par::Seq).unwrap();
    let b = HeatSolver::new(&mesh, 1.0, Par::Rayon).unwrap();
    let sources: Vec<HeatSource> = (0..5)
        .map(|k| HeatSource::vertices(&[k * 1999 % 9000]))
        .collect();
    let seq = a.distances(&sources, Par::Seq).unwrap();
    let par = b.distances(&sources, Par::Rayon).unwrap();
    assert_eq!(seq, par);
    for (k, src) in sources.iter().enumerate() {
        assert_eq!(b.distance(src, Par::Rayon).unwrap(), seq[k]);
    }
    // The cut-off vertices are unreachable; the distances elsewhere are finite and positive.
    let d = &seq[0].values;
    assert!(d.iter().filter(|v| v.is_finite()).count() > 9000);
    assert!(d.iter().any(|v| v.is_infinite()));
}

#[test]
fn bad_inputs_are_typed_errors() {
    let mesh = sphere(1.0, 1).unwrap();
    let n = mesh.n_vertices();
    let solver = HeatSolver::new(&mesh, 1.0, Par::Seq).unwrap();
    let err = solver
        .distance(&HeatSource::vertices(&[n as u32 + 3]), Par::Seq)
        .unwrap_err();
    assert_eq!(
        err,
        HeatError::SourceOutOfRange {
            source_index: 0,
            vertex: n as u32 + 3,
            n_vertices: n
        }
    );
    assert_eq!(
        heat_distance(&mesh, None, &HeatParams::default(), Par::Seq).unwrap_err(),
        HeatError::NoSources
    );
    let net = FeatureCurveNetwork {
        vertices: vec![FcnVertex {
            position: mesh.positions[0],
            location: SurfacePoint::Vertex(0),
            strength: 1.0,
        }],
        curves: vec![FeatureCurve {
            vertices: vec![0],
            closed: false,
            label: CurveLabel::Other,
        }],
    };
    let params = HeatParams {
        curve_ids: vec![3],
        ..Default::default()
    };
    assert_eq!(
        heat_distance(&mesh, Some(&net), &params, Par::Seq).unwrap_err(),
        HeatError::NoSuchCurve {
            curve: 3,
            n_curves: 1
        }
    );
    let mut off = net.clone();
    off.vertices[0].location = SurfacePoint::Edge {
        a: 0,
        b: n as u32,
        t: 0.5,
    };
    let err = heat_distance(&mesh, Some(&off), &HeatParams::default(), Par::Seq).unwrap_err();
    assert_eq!(
        err,
        HeatError::CurveOffMesh {
            curve: 0,
            vertex: 0,
            mesh_vertex: n as u32,
            n_vertices: n
        }
    );
    // The message points at the usual cause: a network traced on another mesh.
    assert!(err.to_string().contains("traced on another mesh"), "{err}");
    off.vertices[0].location = SurfacePoint::Free;
    assert_eq!(
        heat_distance(&mesh, Some(&off), &HeatParams::default(), Par::Seq).unwrap_err(),
        HeatError::FreeCurveVertex {
            curve: 0,
            vertex: 0
        }
    );
    // A one-point curve on a vertex is the same source as that vertex.
    let from_curve = heat_distance(&mesh, Some(&net), &HeatParams::default(), Par::Seq).unwrap();
    let from_vertex = solver
        .distance(&HeatSource::vertices(&[0]), Par::Seq)
        .unwrap();
    assert_eq!(from_curve, from_vertex);
    assert!(matches!(
        HeatSolver::new(&TriMesh::new(vec![], vec![]), 1.0, Par::Seq).unwrap_err(),
        HeatError::NoTriangles
    ));
    assert!(matches!(
        HeatSolver::new(&mesh, f64::NAN, Par::Seq).unwrap_err(),
        HeatError::BadTimeFactor(x) if x.is_nan()
    ));
}

#[test]
fn second_component_without_source_is_unreachable() {
    let a = sphere(1.0, 2).unwrap();
    let na = a.n_vertices() as u32;
    let mut pos = a.positions.clone();
    pos.extend(a.positions.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
    let mut tris = a.triangles.clone();
    tris.extend(
        a.triangles
            .iter()
            .map(|t| [t[0] + na, t[1] + na, t[2] + na]),
    );
    let mesh = TriMesh::new(pos, tris);
    let solver = HeatSolver::new(&mesh, 1.0, Par::Seq).unwrap();
    let d = solver
        .distance(&HeatSource::vertices(&[0]), Par::Seq)
        .unwrap();
    assert!(d.values[..na as usize].iter().all(|x| x.is_finite()));
    assert!(d.values[na as usize..].iter().all(|x| x.is_infinite()));
    // Same distances as the single sphere.
    let single = HeatSolver::new(&a, 1.0, Par::Seq)
        .unwrap()
        .distance(&HeatSource::vertices(&[0]), Par::Seq)
        .unwrap();
    for v in 0..na as usize {
        assert!((d.values[v] - single.values[v]).abs() < 1e-9);
    }
}
