//! Unit tests of `selection.model` on networks built here: copies of an asymmetric curve
//! placed by known translations, clusters given directly.

use crestflow_flow::Par;
use crestflow_geom::vec3::V3;
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crestflow_nodes_symmetry::{
    ClusterMember, Generator, Orbit, Orbits, RigidTransform, TransformCluster, TransformClusters,
};

use crate::model::{select_model, ModelError, ModelParams};

/// Unit (mean edge length) of the tests.
pub(crate) const H: f64 = 0.1;

/// A bent, non-planar curve of length about 6 (60 h), sampled every 0.05.
pub(crate) fn wiggle() -> Vec<V3> {
    (0..=100)
        .map(|i| {
            let s = i as f64 * 0.05;
            [s, 0.4 * (1.3 * s).sin(), 0.3 * (0.7 * s + 0.4).cos()]
        })
        .collect()
}

pub(crate) fn add_curve(net: &mut FeatureCurveNetwork, pts: &[V3], strength: f64) {
    let start = net.vertices.len() as u32;
    for p in pts {
        net.vertices.push(FcnVertex {
            position: *p,
            location: SurfacePoint::Free,
            strength,
        });
    }
    net.curves.push(FeatureCurve {
        vertices: (start..start + pts.len() as u32).collect(),
        closed: false,
        label: CurveLabel::Ridge,
    });
}

pub(crate) fn shifted(pts: &[V3], t: V3) -> Vec<V3> {
    pts.iter()
        .map(|p| [p[0] + t[0], p[1] + t[1], p[2] + t[2]])
        .collect()
}

pub(crate) fn cluster_of(t: V3, support: f64) -> TransformCluster {
    TransformCluster {
        mirrored: false,
        transform: RigidTransform::translation(t),
        members: vec![ClusterMember {
            match_index: 0,
            inverse: false,
            from: 0,
            to: 1,
            affinity: support,
            residual: 0.0,
        }],
        support,
        pairs: 1,
    }
}

/// Four copies of the wiggle along g = (0, 2, 0), and one short noise curve.
pub(crate) fn grid_network() -> (FeatureCurveNetwork, V3) {
    let g = [0.0, 2.0, 0.0];
    let mut net = FeatureCurveNetwork::default();
    for k in 0..4 {
        add_curve(
            &mut net,
            &shifted(&wiggle(), [0.0, 2.0 * k as f64, 0.0]),
            1.0,
        );
    }
    add_curve(&mut net, &[[0.0, -1.0, 0.0], [0.2, -1.0, 0.05]], 1.0);
    (net, g)
}

/// Clusters ±g, ±2g.
pub(crate) fn grid_clusters(g: V3) -> TransformClusters {
    let s = |k: f64| [g[0] * k, g[1] * k, g[2] * k];
    TransformClusters {
        unit: H,
        mirror_x: 0.0,
        clusters: vec![
            cluster_of(s(1.0), 150.0),
            cluster_of(s(-1.0), 150.0),
            cluster_of(s(2.0), 100.0),
            cluster_of(s(-2.0), 100.0),
        ],
    }
}

#[test]
fn redundant_powers_are_removed_and_generators_kept() {
    let (net, g) = grid_network();
    let clusters = grid_clusters(g);
    let p = ModelParams {
        min_support: 1.0,
        ..Default::default()
    };
    let s = select_model(&net, &clusters, None, &p, Par::Seq).unwrap();
    assert_eq!(s.candidates.len(), 4);
    // Each candidate holds its cluster's transformation and the inverse (±g, ±g, ±2g, ±2g).
    assert!(s.candidates.iter().all(|c| c.transforms.len() == 2));
    // ±2g and the duplicate −g explain nothing that g (with g⁻¹) does not: removed with K = 1,
    // least cluster support first; removing g then leaves two end copies unexplained: K ≫ 10.
    assert_eq!(s.kept, vec![0], "{:?}", s.steps);
    let removed: Vec<u32> = s.steps.iter().map(|x| x.candidate).collect();
    assert_eq!(removed, vec![3, 2, 1, 0]);
    assert!(s.steps[..3]
        .iter()
        .all(|x| x.removed && x.log10_k.abs() < 1e-9));
    assert!(
        !s.steps[3].removed && s.steps[3].log10_k > 1.0,
        "{:?}",
        s.steps
    );
    // Every copy reoccurs; the noise curve does not.
    for c in 0..4 {
        assert!(s.assignment[c].is_some(), "curve {c}: {:?}", s.assignment);
        assert!(s.log_likelihood[c] > s.log_null);
    }
    assert_eq!(s.assignment[4], None);
    assert_eq!(s.log_likelihood[4], s.log_null);
    // The first copy is explained by g⁻¹, the last by g: both belong to candidate 0.
    assert_eq!(s.assignment[0], Some(0));
    assert_eq!(s.assignment[3], Some(0));
    // w(T, c) of an exact copy of length L is L (distance 0): ln L ≈ ln(length) for the
    // curve's samples; the wiggle is about 5.6 long.
    let len = net.curve_length(0);
    assert!(
        (s.log_likelihood[0] - len.ln()).abs() < 0.1,
        "{} vs {}",
        s.log_likelihood[0],
        len.ln()
    );
    // T_null: l0 e⁻² with l0 = 25 h.
    assert!((s.log_null - (25.0 * H * (-2.0f64).exp()).ln()).abs() < 1e-12);
    // Partners of copy 1 under +g: copy 0.
    assert!(s.partners[1].iter().any(|p| p.curve == 0));
}

#[test]
fn orbit_is_one_candidate_summing_its_transformations() {
    let (net, g) = grid_network();
    let clusters = grid_clusters(g);
    let orbits = Orbits {
        orbits: vec![Orbit {
            generator: Generator::Translation { steps: vec![g] },
            instances: 4,
            clusters: vec![0, 1, 2, 3],
            curves: vec![0, 1, 2, 3],
            support: 500.0,
        }],
    };
    let s = select_model(
        &net,
        &clusters,
        Some(&orbits),
        &ModelParams::default(),
        Par::Seq,
    )
    .unwrap();
    assert_eq!(s.candidates.len(), 1);
    assert_eq!(s.kept, vec![0]);
    // Copy 1 is hit by g (copy 0), −g (copy 2) and −2g (copy 3): three full matches summed.
    let len = net.curve_length(0);
    assert!(
        (s.log_likelihood[1] - (3.0 * len).ln()).abs() < 0.1,
        "{} vs {}",
        s.log_likelihood[1],
        (3.0 * len).ln()
    );
    assert_eq!(s.assignment[4], None);
}

#[test]
fn short_matches_fall_back_to_null() {
    // Two copies of a curve shorter than l0: their match is below the minimal length.
    let mut net = FeatureCurveNetwork::default();
    let short: Vec<V3> = wiggle().into_iter().take(30).collect(); // about 1.5 = 15 h
    add_curve(&mut net, &short, 1.0);
    add_curve(&mut net, &shifted(&short, [0.0, 2.0, 0.0]), 1.0);
    let clusters = TransformClusters {
        unit: H,
        mirror_x: 0.0,
        clusters: vec![cluster_of([0.0, 2.0, 0.0], 100.0)],
    };
    let p = ModelParams {
        min_support: 1.0,
        ..Default::default()
    };
    let s = select_model(&net, &clusters, None, &p, Par::Seq).unwrap();
    assert_eq!(s.assignment, vec![None, None]);
    // With l0 = 10 h the match counts.
    let p = ModelParams {
        l0: 10.0,
        min_support: 1.0,
        ..Default::default()
    };
    let s = select_model(&net, &clusters, None, &p, Par::Seq).unwrap();
    // Each copy is the other's image under T or T⁻¹.
    assert_eq!(s.assignment, vec![Some(0), Some(0)]);
}

#[test]
fn sequential_and_parallel_agree() {
    let (net, g) = grid_network();
    let clusters = grid_clusters(g);
    let p = ModelParams {
        min_support: 1.0,
        ..Default::default()
    };
    let a = select_model(&net, &clusters, None, &p, Par::Seq).unwrap();
    let b = select_model(&net, &clusters, None, &p, Par::Rayon).unwrap();
    assert_eq!(a, b);
}

#[test]
fn errors_name_the_problem() {
    let (mut net, g) = grid_network();
    let mut clusters = grid_clusters(g);
    let p = ModelParams {
        t_high: 0.5,
        ..Default::default()
    };
    let e = select_model(&net, &clusters, None, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(e, ModelError::Params(ref s) if s.contains("t_high")),
        "{e}"
    );

    clusters.unit = 0.0;
    let e = select_model(&net, &clusters, None, &ModelParams::default(), Par::Seq).unwrap_err();
    assert_eq!(e, ModelError::NoScale(0.0));
    clusters.unit = H;

    clusters.clusters[2].transform.translation[1] = f64::NAN;
    let e = select_model(&net, &clusters, None, &ModelParams::default(), Par::Seq).unwrap_err();
    assert_eq!(e, ModelError::NonFiniteTransform { index: 2 });
    clusters = grid_clusters(g);

    let orbits = Orbits {
        orbits: vec![Orbit {
            generator: Generator::Translation { steps: vec![g] },
            instances: 2,
            clusters: vec![0, 9],
            curves: vec![],
            support: 1.0,
        }],
    };
    let e = select_model(
        &net,
        &clusters,
        Some(&orbits),
        &ModelParams::default(),
        Par::Seq,
    )
    .unwrap_err();
    assert_eq!(
        e,
        ModelError::ClusterIndex {
            orbit: 0,
            cluster: 9,
            n: 4
        }
    );

    net.vertices[7].position[2] = f64::INFINITY;
    let e = select_model(&net, &clusters, None, &ModelParams::default(), Par::Seq).unwrap_err();
    assert!(matches!(e, ModelError::NonFinite { vertex: 7, .. }), "{e}");
    let (mut net, _) = grid_network();
    net.curves[3].vertices.push(10_000);
    let e = select_model(&net, &clusters, None, &ModelParams::default(), Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            ModelError::VertexIndex {
                curve: 3,
                index: 10_000,
                ..
            }
        ),
        "{e}"
    );
}
