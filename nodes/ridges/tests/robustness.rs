//! Bad and tiny inputs: specific errors, never a panic.

mod common;

use common::*;
use crestflow_flow::{Par, Validate};
use crestflow_geom::{CurvatureField, CurveLabel, SurfacePoint, TriMesh};
use crestflow_nodes_ridges::{trace, Definition, TraceError, TraceParams};

fn one_triangle() -> TriMesh {
    TriMesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

fn flat_field(n: usize) -> CurvatureField {
    CurvatureField {
        k_max: vec![1.0; n],
        k_min: vec![0.0; n],
        t_max: vec![[1.0, 0.0, 0.0]; n],
        t_min: vec![[0.0, 1.0, 0.0]; n],
        normal: vec![[0.0, 0.0, 1.0]; n],
        e_max: vec![0.0; n],
        e_min: vec![0.0; n],
        method: "test".into(),
    }
}

fn all_params() -> TraceParams {
    TraceParams {
        min_strength: 0.0,
        min_cyclideness: 0.0,
        min_length: 0.0,
        ..Default::default()
    }
}

#[test]
fn nan_in_the_field_names_quantity_and_vertex() {
    let profile = crease(-1.0, 0.2);
    let mesh = profile.mesh(11, 0.2, 1);
    let mut field = profile.field(&mesh);
    field.e_max[37] = f64::NAN;
    let err = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap_err();
    match &err {
        TraceError::NonFiniteField {
            quantity: "e_max",
            vertex: 37,
            value,
        } => assert!(value.is_nan()),
        other => panic!("{other:?}"),
    }
    assert!(
        err.to_string().contains("e_max") && err.to_string().contains("vertex 37"),
        "{err}"
    );

    let mut field = profile.field(&mesh);
    field.t_min[5][2] = f64::INFINITY;
    match trace(&mesh, &field, &TraceParams::default(), Par::Rayon) {
        Err(TraceError::NonFiniteField {
            quantity: "t_min",
            vertex: 5,
            value,
        }) => assert!(value.is_infinite()),
        other => panic!("{other:?}"),
    }
}

#[test]
fn field_of_the_wrong_size_is_rejected() {
    let mesh = one_triangle();
    let mut field = flat_field(3);
    field.k_min.pop();
    assert_eq!(
        trace(&mesh, &field, &all_params(), Par::Seq).unwrap_err(),
        TraceError::FieldSize {
            quantity: "k_min",
            field: 2,
            mesh: 3
        }
    );
}

#[test]
fn bad_meshes_are_rejected_before_connectivity_is_built() {
    let bad = TriMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2], [2, 1, 7]],
    );
    assert_eq!(
        trace(&bad, &flat_field(3), &all_params(), Par::Seq).unwrap_err(),
        TraceError::FaceIndex {
            face: 1,
            index: 7,
            n_vertices: 3
        }
    );
    let mut nan = one_triangle();
    nan.positions[2][0] = f64::NAN;
    assert!(matches!(
        trace(&nan, &flat_field(3), &all_params(), Par::Seq),
        Err(TraceError::NonFinitePosition { vertex: 2, .. })
    ));
}

#[test]
fn empty_and_tiny_meshes() {
    let empty = TriMesh::new(vec![], vec![]);
    let out = trace(&empty, &flat_field(0), &TraceParams::default(), Par::Rayon).unwrap();
    assert!(out.network.curves.is_empty() && out.network.vertices.is_empty());

    // One triangle, e changes sign on two edges (0-1 and 0-2): one segment, both ends on the
    // boundary edges, ridge since e decreases along t = +x... and +y: use t = (1, 1)/√2.
    let mesh = one_triangle();
    let mut field = flat_field(3);
    let d = std::f64::consts::FRAC_1_SQRT_2;
    field.t_max = vec![[d, d, 0.0]; 3];
    field.t_min = vec![[-d, d, 0.0]; 3];
    field.e_max = vec![1.0, -1.0, -1.0];
    let out = trace(&mesh, &field, &all_params(), Par::Seq).unwrap();
    assert_eq!(out.network.curves.len(), 1);
    let c = &out.network.curves[0];
    assert_eq!(
        (c.vertices.len(), c.closed, c.label),
        (2, false, CurveLabel::Ridge)
    );
    for v in &out.network.vertices {
        let SurfacePoint::Edge { a, b, t } = v.location else {
            panic!()
        };
        assert_eq!(a, 0);
        assert!(b == 1 || b == 2);
        assert!((t - 0.5).abs() < 1e-12);
    }
    // The same with e increasing along t is a minimum of k_max: nothing under Def. 2.2.
    field.e_max = vec![-1.0, 1.0, 1.0];
    assert!(trace(&mesh, &field, &all_params(), Par::Seq)
        .unwrap()
        .network
        .curves
        .is_empty());

    // Vertex 1 against 0 and 2: sign changes on edges 0-1 and 1-2, a maximum along t.
    field.e_max = vec![1.0, -1.0, 1.0];
    let out = trace(&mesh, &field, &all_params(), Par::Seq).unwrap();
    assert_eq!(out.network.curves.len(), 1);
    // Where k_min dominates at the 1-2 crossing (k_max = −1 < |k_min| = 2.5 there) only the
    // 0-1 point remains: an end case, no curve.
    field.k_max = vec![1.0, 1.0, -3.0];
    field.k_min = vec![0.0, 0.0, -5.0];
    let out = trace(&mesh, &field, &all_params(), Par::Seq).unwrap();
    assert!(out.network.curves.is_empty());
    assert_eq!(out.stats.ridge_points, 1);
}

#[test]
fn trisector_joins_three_points_at_their_centroid() {
    // Directions 120° apart: aligning them flips e on every edge, so each edge has a sign
    // change and the face is a trisector.
    let mesh = one_triangle();
    let mut field = flat_field(3);
    let dir = |deg: f64| [deg.to_radians().cos(), deg.to_radians().sin(), 0.0];
    field.t_max = vec![dir(0.0), dir(120.0), dir(240.0)];
    field.t_min = vec![dir(90.0), dir(210.0), dir(330.0)];
    field.e_max = vec![1.0, 1.0, 1.0];
    let p = TraceParams {
        definition: Definition::Extrema,
        ..all_params()
    };
    let out = trace(&mesh, &field, &p, Par::Seq).unwrap();
    assert_eq!(out.stats.trisectors, 1);
    assert_eq!(out.network.curves.len(), 3);
    let net = &out.network;
    // Three one-segment arcs between an edge point (valence 1) and the shared centre
    // (valence 3).
    let val = net.valence();
    let centre = (0..net.vertices.len())
        .find(|&v| val[v] == 3)
        .expect("a valence-3 vertex") as u32;
    assert!(net
        .curves
        .iter()
        .all(|c| c.vertices.len() == 2 && c.vertices.contains(&centre)));
    assert_eq!(net.valence()[centre as usize], 3);
    let cv = &net.vertices[centre as usize];
    let SurfacePoint::Face { f: 0, bary } = cv.location else {
        panic!("{:?}", cv.location)
    };
    assert!((bary.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    let from_bary = [0, 1, 2].map(|k| (0..3).map(|i| bary[i] * mesh.positions[i][k]).sum::<f64>());
    let mut centroid = [0.0; 3];
    for c in &net.curves {
        let end = if c.vertices[0] == centre {
            c.vertices[1]
        } else {
            c.vertices[0]
        };
        let p = net.vertices[end as usize].position;
        for k in 0..3 {
            centroid[k] += p[k] / 3.0;
        }
    }
    for k in 0..3 {
        assert!((from_bary[k] - cv.position[k]).abs() < 1e-12);
        assert!((centroid[k] - cv.position[k]).abs() < 1e-12);
    }
}

#[test]
fn params_are_validated() {
    let p = TraceParams {
        min_strength: -1.0,
        min_length: f64::NAN,
        umbilic_tolerance: 2.0,
        ..Default::default()
    };
    let fields: Vec<String> = p.validate().into_iter().map(|i| i.field).collect();
    assert_eq!(
        fields,
        vec!["min_strength", "min_length", "umbilic_tolerance"]
    );
    assert!(TraceParams::default().validate().is_empty());
    // Unknown fields are rejected when a pipeline file is read.
    assert!(ron::from_str::<TraceParams>("(min_strenght: 1.0)").is_err());
    let parsed: TraceParams = ron::from_str("(families: Ridges, definition: Extrema)").unwrap();
    assert_eq!(parsed.definition, Definition::Extrema);
}

#[test]
fn nonmanifold_and_degenerate_faces_do_not_break_tracing() {
    // Three triangles share edge 0-1 (a non-manifold fin) and e changes sign across that edge
    // (vertex 0 vs 1): one feature point on the shared edge, three segments leave it.
    let mesh = TriMesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],
            [0.5, -1.0, 0.0],
            [0.5, 0.0, 1.0],
        ],
        vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [2, 2, 4]],
    );
    assert_eq!(mesh.topology().nonmanifold_edges.len(), 1);
    let mut field = flat_field(5);
    // t along +x everywhere; e decreasing along x: vertex 0 positive, all others negative.
    field.e_max = vec![1.0, -1.0, -1.0, -1.0, -1.0];
    let out = trace(&mesh, &field, &all_params(), Par::Seq).unwrap();
    let val = out.network.valence();
    assert_eq!(
        val.iter().filter(|&&v| v == 3).count(),
        1,
        "{:?}",
        out.network
    );
    assert_eq!(out.network.curves.len(), 3);
    // Seq and Rayon agree here too.
    assert_eq!(
        out,
        trace(&mesh, &field, &all_params(), Par::Rayon).unwrap()
    );
}
