//! Unit tests of `eval_correspondence.rs`.

use super::*;
use crestflow_geom::shapes::sphere;
use crestflow_geom::vec3::{dist, scale};

fn nearest_vertex(mesh: &TriMesh, p: [f64; 3]) -> u32 {
    (0..mesh.n_vertices())
        .min_by(|&a, &b| dist(mesh.positions[a], p).total_cmp(&dist(mesh.positions[b], p)))
        .unwrap() as u32
}

#[test]
fn identity_has_zero_error() {
    let mesh = sphere(1.0, 2).unwrap();
    let pm = PointMap {
        target_to_source: (0..mesh.n_vertices() as u32).collect(),
        n_source: mesh.n_vertices(),
    };
    let r = evaluate_correspondence(
        &mesh,
        &pm,
        None,
        &EvalCorrespondenceParams::default(),
        Par::Rayon,
        &|| false,
    )
    .unwrap();
    assert_eq!(r.num("mean"), Some(0.0));
    assert_eq!(r.num("exact"), Some(1.0));
    assert_eq!(r.num("cum_0.025"), Some(1.0));
    assert_eq!(r.num("queries"), Some(mesh.n_vertices() as f64));
}

#[test]
fn antipodal_map_error_is_half_the_great_circle() {
    // Every vertex sent to its antipode: geodesic error π on the unit sphere, normalised by
    // √(area) = √(4π) (the mesh area is slightly smaller; the heat method is approximate).
    let mesh = sphere(1.0, 3).unwrap();
    let map: Vec<u32> = mesh
        .positions
        .iter()
        .map(|&p| nearest_vertex(&mesh, scale(p, -1.0)))
        .collect();
    let pm = PointMap {
        target_to_source: map,
        n_source: mesh.n_vertices(),
    };
    let params = EvalCorrespondenceParams {
        max_queries: 100,
        label: "anti".into(),
        ..Default::default()
    };
    let r = evaluate_correspondence(&mesh, &pm, None, &params, Par::Seq, &|| false).unwrap();
    let want = std::f64::consts::PI / mesh.total_area().sqrt();
    let mean = r.num("anti.mean").unwrap();
    assert!((mean - want).abs() < 0.03 * want, "{mean} vs {want}");
    assert_eq!(r.num("anti.queries"), Some(100.0));
    assert_eq!(r.num("anti.cum_0.25"), Some(0.0));
    assert_eq!(r.num("anti.exact"), Some(0.0));
    let curve = r.text("anti.curve").unwrap();
    assert_eq!(curve.split(',').count(), 26);
}

#[test]
fn one_ring_shift_error_is_about_an_edge() {
    // Each vertex sent to its first neighbour: the error is one edge length (the heat method
    // approximates it within a few per cent on this resolution).
    let mesh = sphere(1.0, 3).unwrap();
    let topo = mesh.topology();
    let map: Vec<u32> = (0..mesh.n_vertices() as u32)
        .map(|v| topo.neighbors(v)[0])
        .collect();
    let pm = PointMap {
        target_to_source: map.clone(),
        n_source: mesh.n_vertices(),
    };
    let r = evaluate_correspondence(
        &mesh,
        &pm,
        None,
        &EvalCorrespondenceParams::default(),
        Par::Rayon,
        &|| false,
    )
    .unwrap();
    let want: f64 = map
        .iter()
        .enumerate()
        .map(|(v, &w)| dist(mesh.positions[v], mesh.positions[w as usize]))
        .sum::<f64>()
        / map.len() as f64
        / mesh.total_area().sqrt();
    let mean = r.num("mean").unwrap();
    assert!((mean - want).abs() < 0.15 * want, "{mean} vs {want}");
}

#[test]
fn ground_truth_errors_name_the_line() {
    let e = parse_ground_truth("1\n2\n\n99\n", "gt.txt", 50).unwrap_err();
    assert_eq!(
        e.to_string(),
        "gt.txt:4: ground-truth source vertex 99 is out of range (the source has 50 vertices)"
    );
    let e = parse_ground_truth("1\nx\n", "gt.txt", 50).unwrap_err();
    assert!(matches!(e, FmapError::Parse { line: 2, .. }), "{e}");
    assert_eq!(
        parse_ground_truth("3\n4\n", "gt.txt", 50).unwrap(),
        vec![3, 4]
    );
}

#[test]
fn size_mismatches_are_errors() {
    let mesh = sphere(1.0, 1).unwrap();
    let n = mesh.n_vertices();
    let pm = PointMap {
        target_to_source: vec![0; 10],
        n_source: n,
    };
    let e = evaluate_correspondence(
        &mesh,
        &pm,
        Some(&[0, 1, 2]),
        &EvalCorrespondenceParams::default(),
        Par::Seq,
        &|| false,
    )
    .unwrap_err();
    assert!(
        matches!(e, FmapError::GroundTruthSize { have: 3, want: 10 }),
        "{e}"
    );
    let bad = PointMap {
        target_to_source: vec![0, 1, 500],
        n_source: n,
    };
    let e = evaluate_correspondence(
        &mesh,
        &bad,
        Some(&[0, 1, 2]),
        &EvalCorrespondenceParams::default(),
        Par::Seq,
        &|| false,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::PointMapOutOfRange {
                target: 2,
                source_vertex: 500,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn maps_measured_together_get_the_figures_of_separate_evaluations() {
    // The antipodal map and the one-ring shift, one ground truth (a half-turn about z), on
    // one set of distance fields.
    let mesh = sphere(1.0, 3).unwrap();
    let n = mesh.n_vertices();
    let topo = mesh.topology();
    let gt: Vec<u32> = mesh
        .positions
        .iter()
        .map(|&p| nearest_vertex(&mesh, [-p[0], -p[1], p[2]]))
        .collect();
    let anti = PointMap {
        target_to_source: mesh
            .positions
            .iter()
            .map(|&p| nearest_vertex(&mesh, scale(p, -1.0)))
            .collect(),
        n_source: n,
    };
    let ring = PointMap {
        target_to_source: gt.iter().map(|&g| topo.neighbors(g)[0]).collect(),
        n_source: n,
    };
    let params = EvalCorrespondenceParams {
        max_queries: 300,
        ..Default::default()
    };
    let alone = |pm: &PointMap, label: &str| {
        let p = EvalCorrespondenceParams {
            label: label.into(),
            ..params.clone()
        };
        evaluate_correspondence(&mesh, pm, Some(&gt), &p, Par::Seq, &|| false).unwrap()
    };
    let mut separate = alone(&anti, "anti");
    separate.values.extend(alone(&ring, "ring").values);
    let together = evaluate_correspondences(
        &mesh,
        &[(&anti, "anti"), (&ring, "ring")],
        Some(&gt),
        &params,
        Par::Rayon,
        &|| false,
    )
    .unwrap();
    assert_eq!(together, separate);
    // And the figures differ between the maps (the report is not one map's twice).
    let (a, r) = (
        together.num("anti.mean").unwrap(),
        together.num("ring.mean").unwrap(),
    );
    assert!(a > 5.0 * r && r > 0.0, "anti {a}, ring {r}");
    // Maps of different sizes are an error.
    let short = PointMap {
        target_to_source: vec![0; n - 1],
        n_source: n,
    };
    assert!(evaluate_correspondences(
        &mesh,
        &[(&anti, "anti"), (&short, "short")],
        Some(&gt),
        &params,
        Par::Seq,
        &|| false,
    )
    .is_err());
}
