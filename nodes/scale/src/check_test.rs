//! `scale.check` on hand-made networks with exactly one kind of violation each.

use crate::check::{check, check_absolute, CheckParams, CheckResult};
use crate::conform::ScaleError;
use crate::network::NetworkError;
use crestflow_flow::Par;
use crestflow_geom::vec3::V3;
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

/// A network of polylines (`closed` per curve) over the given points.
pub(crate) fn network(points: &[V3], curves: &[(&[u32], bool)]) -> FeatureCurveNetwork {
    FeatureCurveNetwork::from_polylines(points, curves)
}

fn run(net: &FeatureCurveNetwork, aspect: f64) -> CheckResult {
    let a = check_absolute(net, 1.0, aspect, Par::Seq).unwrap();
    assert_eq!(a, check_absolute(net, 1.0, aspect, Par::Rayon).unwrap());
    a
}

fn counts(r: &CheckResult) -> [usize; 5] {
    [
        r.short_edges,
        r.long_edges,
        r.angle_violations,
        r.proximity_violations,
        r.vertex_conflicts,
    ]
}

#[test]
fn square_loop_conforms() {
    let net = network(
        &[
            [0.0, 0.0, 0.0],
            [1.2, 0.0, 0.0],
            [1.2, 1.2, 0.0],
            [0.0, 1.2, 0.0],
        ],
        &[(&[0, 1, 2, 3], true)],
    );
    let r = run(&net, 1.5);
    assert_eq!(counts(&r), [0; 5]);
    assert_eq!(r.violations(), 0);
    assert_eq!(r.edges, 4);
    assert!((r.min_length_rel - 1.2).abs() < 1e-12);
}

#[test]
fn short_edge() {
    let net = network(
        &[[0.0, 0.0, 0.0], [1.2, 0.0, 0.0], [1.7, 0.0, 0.0]],
        &[(&[0, 1, 2], false)],
    );
    assert_eq!(counts(&run(&net, 1.5)), [1, 0, 0, 0, 0]);
}

#[test]
fn long_edge() {
    let net = network(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[(&[0, 1], false)]);
    let r = run(&net, 1.5);
    assert_eq!(counts(&r), [0, 1, 0, 0, 0]);
    assert!((r.max_length_rel - 2.0).abs() < 1e-12);
}

#[test]
fn angle_violation() {
    // Aspect 1.1 represents no right angle ([54°, 67°] ∪ [108°, 133°] ∪ [162°, 180°]).
    let net = network(
        &[[1.05, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.05, 0.0]],
        &[(&[0, 1, 2], false)],
    );
    assert_eq!(counts(&run(&net, 1.1)), [0, 0, 1, 0, 0]);
    // Aspect 1.5 does.
    assert_eq!(counts(&run(&net, 1.5)), [0; 5]);
}

#[test]
fn proximity_violation() {
    // Two edges crossing 0.2 apart, all end points at least r_min from each other.
    let net = network(
        &[
            [0.0, 0.0, 0.0],
            [1.4, 0.0, 0.0],
            [0.7, -0.7, 0.2],
            [0.7, 0.7, 0.2],
        ],
        &[(&[0, 1], false), (&[2, 3], false)],
    );
    assert_eq!(counts(&run(&net, 1.5)), [0, 0, 0, 1, 0]);
}

#[test]
fn vertex_conflict() {
    // Two curve ends 0.5 apart; the edges themselves have a valid strip between them.
    let net = network(
        &[
            [0.0, 0.0, 0.0],
            [1.2, 0.0, 0.0],
            [1.2, 0.5, 0.0],
            [2.4, 0.5, 0.0],
        ],
        &[(&[0, 1], false), (&[2, 3], false)],
    );
    let r = run(&net, 1.5);
    assert_eq!(counts(&r), [0, 0, 0, 0, 1]);
    assert_eq!(r.near_pairs_resolved, 1);
}

fn unit_mesh() -> TriMesh {
    TriMesh::new(
        vec![[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

#[test]
fn relative_scale_and_failure_mode() {
    // Diagonal 5: scale 0.2 is r_min 1.
    let net = network(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[(&[0, 1], false)]);
    let p = CheckParams {
        scale: 0.2,
        ..Default::default()
    };
    let r = check(&net, &unit_mesh(), &p, Par::Seq).unwrap();
    assert!((r.r_min - 1.0).abs() < 1e-12);
    assert_eq!(r.long_edges, 1);
    let strict = CheckParams {
        fail_on_violation: true,
        ..p
    };
    let err = check(&net, &unit_mesh(), &strict, Par::Seq).unwrap_err();
    assert!(matches!(err, ScaleError::NotConforming(_)));
    assert!(err.to_string().contains("1 long edges"), "{err}");
}

#[test]
fn bad_input_is_named() {
    let mut net = network(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[(&[0, 1], false)]);
    net.curves[0].vertices.push(7);
    let err = check_absolute(&net, 1.0, 1.5, Par::Seq).unwrap_err();
    assert_eq!(
        err,
        ScaleError::Network(NetworkError::CurveIndex {
            curve: 0,
            index: 7,
            n: 2
        })
    );
    let mut net = network(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[(&[0, 1], false)]);
    net.vertices[1].position[2] = f64::NAN;
    let err = check_absolute(&net, 1.0, 1.5, Par::Seq).unwrap_err();
    assert!(err.to_string().contains("network vertex 1"), "{err}");
    let flat = TriMesh::new(vec![[1.0, 1.0, 1.0]; 3], vec![[0, 1, 2]]);
    let err = check(&net, &flat, &CheckParams::default(), Par::Seq).unwrap_err();
    assert!(matches!(err, ScaleError::NoExtent { .. }) || matches!(err, ScaleError::Network(_)));
    let net = network(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[(&[0, 1], false)]);
    let err = check(&net, &flat, &CheckParams::default(), Par::Seq).unwrap_err();
    assert!(matches!(err, ScaleError::NoExtent { diagonal } if diagonal == 0.0));
    let bad = CheckParams {
        aspect: 0.5,
        ..Default::default()
    };
    let err = check(&net, &unit_mesh(), &bad, Par::Seq).unwrap_err();
    assert!(err.to_string().contains("aspect"), "{err}");
}
