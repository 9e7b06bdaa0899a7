//! Bad input gives typed errors naming the element, never a panic.

use crestflow_flow::{Par, Validate};
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crestflow_nodes_symmetry::{
    blast_with_unit, cluster, orbits, BlastError, BlastParams, ClusterError, ClusterParams,
    CurveMatches, OrbitError, OrbitParams, TransformClusters,
};

fn line(n: usize) -> FeatureCurveNetwork {
    FeatureCurveNetwork {
        vertices: (0..n)
            .map(|i| FcnVertex {
                position: [i as f64, (i as f64 * 0.3).sin(), 0.0],
                location: SurfacePoint::Free,
                strength: 1.0,
            })
            .collect(),
        curves: vec![FeatureCurve {
            vertices: (0..n as u32).collect(),
            closed: false,
            label: CurveLabel::Ridge,
        }],
    }
}

#[test]
fn curve_index_out_of_range_is_named() {
    let mut net = line(10);
    net.curves[0].vertices.push(99);
    let e = blast_with_unit(&net, 0.1, &BlastParams::default(), Par::Seq).unwrap_err();
    assert_eq!(
        e,
        BlastError::VertexIndex {
            curve: 0,
            index: 99,
            n: 10
        }
    );
    assert!(e.to_string().contains("network vertex 99"));
}

#[test]
fn non_finite_position_is_named() {
    let mut net = line(10);
    net.vertices[4].position[1] = f64::NAN;
    let e = blast_with_unit(&net, 0.1, &BlastParams::default(), Par::Seq).unwrap_err();
    assert!(
        matches!(e, BlastError::NonFinite { vertex: 4, .. }),
        "{e:?}"
    );
}

#[test]
fn zero_unit_and_bad_params_are_rejected() {
    let net = line(10);
    assert_eq!(
        blast_with_unit(&net, 0.0, &BlastParams::default(), Par::Seq).unwrap_err(),
        BlastError::NoScale(0.0)
    );
    let p = BlastParams {
        t_low: 3.0,
        t_high: 2.0,
        ..Default::default()
    };
    let issues = p.validate();
    assert_eq!(issues.len(), 1);
    assert_eq!(issues[0].field, "t_high");
    assert!(matches!(
        blast_with_unit(&net, 0.1, &p, Par::Seq),
        Err(BlastError::Params(_))
    ));
    let c = ClusterParams {
        max_angle_deg: f64::NAN,
        ..Default::default()
    };
    assert_eq!(c.validate()[0].field, "max_angle_deg");
    let c = ClusterParams {
        max_error: 0.0,
        consolidate_angle_deg: 100.0,
        ..Default::default()
    };
    let fields: Vec<String> = c.validate().into_iter().map(|i| i.field).collect();
    assert_eq!(fields, vec!["max_error", "consolidate_angle_deg"]);
    let o = OrbitParams {
        min_relative_support: 2.0,
        ..Default::default()
    };
    assert_eq!(o.validate()[0].field, "min_relative_support");
}

#[test]
fn empty_inputs_give_empty_outputs_or_scale_errors() {
    // A network without curves: nothing to match, no error.
    let m = blast_with_unit(
        &FeatureCurveNetwork::default(),
        0.1,
        &BlastParams::default(),
        Par::Seq,
    )
    .unwrap();
    assert!(m.matches.is_empty());
    let c = cluster(&m, &ClusterParams::default(), Par::Seq).unwrap();
    assert!(c.clusters.is_empty());
    assert!(orbits(&c, &OrbitParams::default(), Par::Seq)
        .unwrap()
        .orbits
        .is_empty());
    // Hand-made values without a unit are rejected.
    assert_eq!(
        cluster(
            &CurveMatches::default(),
            &ClusterParams::default(),
            Par::Seq
        )
        .unwrap_err(),
        ClusterError::NoScale(0.0)
    );
    assert_eq!(
        orbits(
            &TransformClusters::default(),
            &OrbitParams::default(),
            Par::Seq
        )
        .unwrap_err(),
        OrbitError::NoScale(0.0)
    );
}
