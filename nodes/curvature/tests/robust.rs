//! Awkward and bad inputs: isolated vertices, tiny open meshes, degenerate faces, bad indices,
//! non-finite coordinates, bad params; the node wrappers; a real mesh.

use std::path::Path;

use crestflow_flow::{CancelToken, Ctx, Inputs, NodeKind, Par, ProgressSink, Validate};
use crestflow_geom::shapes::AnalyticShape;
use crestflow_geom::{CurvatureField, TriMesh};
use crestflow_nodes_curvature::local::MeshInputError;
use crestflow_nodes_curvature::polynomial::PolynomialError;
use crestflow_nodes_curvature::shape_operator::ShapeOperatorError;
use crestflow_nodes_curvature::{
    polynomial_curvature, shape_operator_curvature, PolynomialNode, PolynomialParams,
    ShapeOperatorNode, ShapeOperatorParams,
};

fn all_finite(f: &CurvatureField) -> bool {
    (0..f.len()).all(|v| {
        [f.k_max[v], f.k_min[v], f.e_max[v], f.e_min[v]]
            .iter()
            .all(|x| x.is_finite())
            && f.t_max[v]
                .iter()
                .chain(&f.t_min[v])
                .chain(&f.normal[v])
                .all(|x| x.is_finite())
    })
}

#[test]
fn isolated_vertex_tiny_patch_and_degenerate_face() {
    // A 3x3 grid patch (boundary everywhere), one isolated vertex, one zero-area face whose
    // corners coincide with grid vertices' positions.
    let mut positions = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            positions.push([i as f64, j as f64, 0.1 * (i * j) as f64]);
        }
    }
    positions.push([10.0, 10.0, 10.0]); // isolated: 9
    positions.push([0.0, 0.0, 0.0]); // duplicate of vertex 0: 10
    let mut triangles = Vec::new();
    for j in 0..2u32 {
        for i in 0..2u32 {
            let a = j * 3 + i;
            triangles.push([a, a + 1, a + 4]);
            triangles.push([a, a + 4, a + 3]);
        }
    }
    triangles.push([0, 10, 1]); // degenerate: 0 and 10 coincide... area 0
    let mesh = TriMesh::new(positions, triangles);
    let p = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Seq).unwrap();
    assert_eq!(p.field.len(), 11);
    assert!(all_finite(&p.field));
    assert_eq!(p.field.k_max[9], 0.0);
    // Vertex 9 has no neighbours, vertex 10 only a zero-area face (no normal): both fail.
    assert_eq!(p.stats.failed, 2, "{:?}", p.stats);
    assert_eq!(p.field.k_max[10], 0.0);
    // The grid vertices are fitted: the patch z = 0.1 x y has K < 0 at its centre (vertex 4).
    assert!(p.field.gaussian(4) < 0.0);
    let s = shape_operator_curvature(&mesh, &ShapeOperatorParams::default(), Par::Seq).unwrap();
    assert_eq!(s.isolated, 2);
    assert!(all_finite(&s.field));
}

#[test]
fn single_triangle_and_empty_mesh() {
    let tri = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let p = polynomial_curvature(&tri, &PolynomialParams::default(), Par::Seq).unwrap();
    assert!(all_finite(&p.field));
    // Two neighbours and their normals: a plane, curvature zero.
    assert!(p.field.k_max.iter().all(|&k| k.abs() < 1e-12));
    let s = shape_operator_curvature(&tri, &ShapeOperatorParams::default(), Par::Seq).unwrap();
    assert!(s.field.k_max.iter().all(|&k| k.abs() < 1e-12));
    let empty = TriMesh::new(vec![], vec![]);
    assert!(
        polynomial_curvature(&empty, &PolynomialParams::default(), Par::Seq)
            .unwrap()
            .field
            .is_empty()
    );
}

#[test]
fn bad_indices_and_coordinates_are_reported() {
    let bad = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 7]],
    );
    assert_eq!(
        polynomial_curvature(&bad, &PolynomialParams::default(), Par::Seq).unwrap_err(),
        PolynomialError::Mesh(MeshInputError::IndexOutOfRange {
            face: 0,
            index: 7,
            n_vertices: 3
        })
    );
    let nan = TriMesh::new(
        vec![[0.0; 3], [1.0, f64::NAN, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let err =
        shape_operator_curvature(&nan, &ShapeOperatorParams::default(), Par::Seq).unwrap_err();
    assert!(matches!(
        err,
        ShapeOperatorError::Mesh(MeshInputError::NonFinite { vertex: 1, .. })
    ));
    assert!(err.to_string().contains("vertex 1"));
}

#[test]
fn params_are_validated() {
    let p = PolynomialParams {
        rings: 0,
        degree: 5,
        ..Default::default()
    };
    let issues = p.validate();
    let fields: Vec<&str> = issues.iter().map(|i| i.field.as_str()).collect();
    assert_eq!(fields, ["rings", "degree"]);
    let mesh = AnalyticShape::default().mesh(100, 0.0, 0).unwrap();
    assert!(matches!(
        polynomial_curvature(&mesh, &p, Par::Seq),
        Err(PolynomialError::Params(m)) if m.contains("rings")
    ));
}

struct Sink(std::sync::Mutex<Vec<String>>);
impl ProgressSink for Sink {
    fn progress(&self, _node: &str, _fraction: f32) {}
    fn warn(&self, _node: &str, message: &str) {
        self.0.lock().unwrap().push(message.to_string());
    }
}

#[test]
fn node_wrappers_produce_a_curvature_field() {
    let mesh = AnalyticShape::Sphere { radius: 2.0 }
        .mesh(642, 0.0, 0)
        .unwrap();
    let sink = Sink(std::sync::Mutex::new(Vec::new()));
    let cancel = CancelToken::new();
    let ctx = Ctx {
        node: "curv",
        par: Par::Seq,
        base_dir: Path::new("."),
        cancel: &cancel,
        sink: &sink,
    };
    let inputs = Inputs::new().with("mesh", mesh);
    assert_eq!(PolynomialNode::outputs()[0].ty.name, "CurvatureField");
    for out in [
        PolynomialNode::run(&PolynomialParams::default(), &inputs, &ctx).unwrap(),
        ShapeOperatorNode::run(&ShapeOperatorParams::default(), &inputs, &ctx).unwrap(),
    ] {
        let f = out
            .get("field")
            .unwrap()
            .downcast_ref::<CurvatureField>()
            .unwrap();
        assert_eq!(f.len(), 642);
        let mean = f.k_max.iter().sum::<f64>() / 642.0;
        assert!((mean - 0.5).abs() < 0.01, "{} mean k_max {mean}", f.method);
    }
    assert!(sink.0.lock().unwrap().is_empty());
    // A mesh with an isolated vertex makes the node warn, not fail.
    let with_isolated = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 5.0]],
        vec![[0, 1, 2]],
    );
    let inputs = Inputs::new().with("mesh", with_isolated);
    ShapeOperatorNode::run(&ShapeOperatorParams::default(), &inputs, &ctx).unwrap();
    assert!(sink
        .0
        .lock()
        .unwrap()
        .iter()
        .any(|m| m.contains("1 vertices have no face")));
    cancel.cancel();
    match PolynomialNode::run(&PolynomialParams::default(), &inputs, &ctx) {
        Err(e) => assert_eq!(e.kind, crestflow_flow::ErrorKind::Cancelled),
        Ok(_) => panic!("a cancelled run must not produce outputs"),
    }
}

/// A minimal OFF reader for the test mesh.
fn read_off(path: &Path) -> TriMesh {
    let text = std::fs::read_to_string(path).unwrap();
    let mut it = text
        .split_whitespace()
        .skip(1)
        .map(|t| t.parse::<f64>().unwrap());
    let (nv, nf) = (it.next().unwrap() as usize, it.next().unwrap() as usize);
    it.next();
    let positions = (0..nv)
        .map(|_| [it.next().unwrap(), it.next().unwrap(), it.next().unwrap()])
        .collect();
    let triangles = (0..nf)
        .map(|_| {
            assert_eq!(it.next().unwrap(), 3.0);
            [
                it.next().unwrap() as u32,
                it.next().unwrap() as u32,
                it.next().unwrap() as u32,
            ]
        })
        .collect();
    TriMesh::new(positions, triangles)
}

#[test]
fn real_mesh_methods_agree_on_mean_curvature() {
    // The armadillo-free, smooth CC0 elephant: both estimators should see the same bumps.
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/meshes/organic/cgal_elephant.off");
    let mesh = read_off(&path);
    let p = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon).unwrap();
    let s = shape_operator_curvature(&mesh, &ShapeOperatorParams::default(), Par::Rayon).unwrap();
    assert_eq!(p.stats.failed, 0);
    assert!(all_finite(&p.field) && all_finite(&s.field));
    let n = mesh.n_vertices();
    let hp: Vec<f64> = (0..n).map(|v| p.field.mean(v)).collect();
    let hs: Vec<f64> = (0..n).map(|v| s.field.mean(v)).collect();
    let corr = pearson(&hp, &hs);
    eprintln!("elephant: pearson(H_poly, H_so) = {corr}");
    assert!(corr > 0.8, "mean curvatures disagree: r = {corr}");
    // A closed surface with outward normals has positive total mean curvature.
    let areas = mesh.vertex_areas();
    let total: f64 = (0..n).map(|v| hp[v] * areas[v]).sum();
    assert!(total > 0.0);
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}
