//! Ground truth on feature curve networks built directly: copies of an asymmetric template
//! placed by known transformations must give exactly those generators.

use crestflow_flow::Par;
use crestflow_geom::vec3::{dist, norm, V3};
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crestflow_nodes_symmetry::{
    blast_with_unit, cluster, orbits, BlastParams, ClusterParams, Generator, OrbitParams, Orbits,
    RigidTransform,
};

const H: f64 = 0.1;

/// Two curves with no symmetry of their own and no long self-similar stretch (a spiral whose
/// radius wobbles, so that it does not match itself after a slide, and a bent wiggle), both
/// far from planar: a planar curve is congruent to its own mirror image by a rotation.
fn template() -> Vec<Vec<V3>> {
    let a: Vec<V3> = (0..=160)
        .map(|i| {
            let s = i as f64 * 0.025;
            let r = 1.0 + 0.4 * s + 0.25 * (3.0 * s).sin();
            [r * s.cos(), r * s.sin(), 0.9 * (2.0 * s).sin()]
        })
        .collect();
    let b: Vec<V3> = (0..=120)
        .map(|i| {
            let s = i as f64 * 0.03;
            [
                0.5 + s,
                -1.5 + 0.4 * (3.0 * s).sin(),
                0.5 * (2.0 * s + 0.7).cos(),
            ]
        })
        .collect();
    vec![a, b]
}

fn network(
    copies: &[RigidTransform],
    mirror_too: Option<&dyn Fn(V3) -> V3>,
) -> FeatureCurveNetwork {
    let mut net = FeatureCurveNetwork::default();
    let mut add = |pts: Vec<V3>| {
        let start = net.vertices.len() as u32;
        for p in &pts {
            net.vertices.push(FcnVertex {
                position: *p,
                location: SurfacePoint::Free,
                strength: 1.0,
            });
        }
        net.curves.push(FeatureCurve {
            vertices: (start..start + pts.len() as u32).collect(),
            closed: false,
            label: CurveLabel::Ridge,
        });
    };
    for t in copies {
        for c in template() {
            add(c.iter().map(|p| t.apply(*p)).collect());
        }
    }
    if let Some(m) = mirror_too {
        for c in template() {
            // reversed as well, as a tracer may run the other way
            add(c.iter().rev().map(|p| m(*p)).collect());
        }
    }
    net
}

fn run(net: &FeatureCurveNetwork, par: Par) -> Orbits {
    let m = blast_with_unit(net, H, &BlastParams::default(), par).unwrap();
    let c = cluster(&m, &ClusterParams::default(), par).unwrap();
    orbits(&c, &OrbitParams::default(), par).unwrap()
}

#[test]
fn one_dimensional_translation_grid() {
    let g = [2.93, 0.41, -0.2];
    let copies: Vec<RigidTransform> = (0..4)
        .map(|k| RigidTransform::translation([g[0] * k as f64, g[1] * k as f64, g[2] * k as f64]))
        .collect();
    let o = run(&network(&copies, None), Par::Seq);
    println!("{o:#?}");
    assert_eq!(o.orbits.len(), 1, "{o:#?}");
    let orb = &o.orbits[0];
    assert_eq!(orb.instances, 4);
    let Generator::Translation { steps } = &orb.generator else {
        panic!("not a translation: {orb:?}")
    };
    assert_eq!(steps.len(), 1);
    let s = steps[0];
    let err = dist(s, g).min(dist(s, [-g[0], -g[1], -g[2]]));
    assert!(err < 0.01 * H, "step {s:?} vs {g:?}");
}

#[test]
fn two_dimensional_translation_grid() {
    let g1 = [3.1, 0.0, 0.0];
    let g2 = [0.3, 3.4, 0.0];
    let mut copies = Vec::new();
    for i in 0..3 {
        for j in 0..2 {
            let (i, j) = (i as f64, j as f64);
            copies.push(RigidTransform::translation([
                i * g1[0] + j * g2[0],
                i * g1[1] + j * g2[1],
                0.0,
            ]));
        }
    }
    let o = run(&network(&copies, None), Par::Seq);
    assert_eq!(o.orbits.len(), 1, "{o:#?}");
    let orb = &o.orbits[0];
    assert_eq!(orb.instances, 6);
    let Generator::Translation { steps } = &orb.generator else {
        panic!("not a translation: {orb:?}")
    };
    assert_eq!(steps.len(), 2);
    // The lattice basis found must span the same lattice: each true generator is an integer
    // combination with small residual.
    for g in [g1, g2] {
        let ok = (-2i32..=2).any(|i| {
            (-2i32..=2).any(|j| {
                let f = [
                    i as f64 * steps[0][0] + j as f64 * steps[1][0],
                    i as f64 * steps[0][1] + j as f64 * steps[1][1],
                    i as f64 * steps[0][2] + j as f64 * steps[1][2],
                ];
                dist(f, g) < 0.01 * H
            })
        });
        assert!(ok, "{g:?} not in the lattice of {steps:?}");
    }
}

#[test]
fn rotation_orbit_of_order_seven() {
    let axis = [0.1, 0.2, 1.0];
    let center = [0.5, -0.3, 0.0];
    let n = 7;
    let copies: Vec<RigidTransform> = (0..n)
        .map(|k| {
            let r = RigidTransform::rotation_about(
                axis,
                2.0 * std::f64::consts::PI * k as f64 / n as f64,
                center,
            );
            // move the template away from the axis first
            r.compose(&RigidTransform::translation([4.0, 0.0, 0.0]))
        })
        .collect();
    let o = run(&network(&copies, None), Par::Seq);
    assert_eq!(o.orbits.len(), 1, "{o:#?}");
    let orb = &o.orbits[0];
    let Generator::Rotation {
        axis: a,
        angle_deg,
        order,
        center: c,
    } = &orb.generator
    else {
        panic!("not a rotation: {orb:?}")
    };
    assert_eq!(*order, 7);
    assert_eq!(orb.instances, 7);
    assert!((angle_deg - 360.0 / 7.0).abs() < 1.0, "{angle_deg}");
    let an = norm(axis);
    let cosang = (a[0] * axis[0] + a[1] * axis[1] + a[2] * axis[2]).abs() / an;
    assert!(cosang.acos().to_degrees() < 1.0);
    // the centre lies on the true axis
    let d = [c[0] - center[0], c[1] - center[1], c[2] - center[2]];
    let along = (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]) / (an * an);
    let off = dist(d, [along * axis[0], along * axis[1], along * axis[2]]);
    assert!(off < 0.01 * H, "axis offset {off}");
}

#[test]
fn mirror_symmetric_pair() {
    // plane 0.6 x + 0.8 z = 1.5
    let n = [0.6, 0.0, 0.8];
    let d = 1.5;
    let m = move |p: V3| {
        let s = 2.0 * (p[0] * n[0] + p[1] * n[1] + p[2] * n[2] - d);
        [p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2]]
    };
    let o = run(&network(&[RigidTransform::identity()], Some(&m)), Par::Seq);
    assert_eq!(o.orbits.len(), 1, "{o:#?}");
    let Generator::Reflection { normal, offset } = &o.orbits[0].generator else {
        panic!("not a reflection: {o:?}")
    };
    let s = if normal[0] * n[0] + normal[2] * n[2] < 0.0 {
        -1.0
    } else {
        1.0
    };
    let cosang = s * (normal[0] * n[0] + normal[1] * n[1] + normal[2] * n[2]);
    assert!(cosang.clamp(-1.0, 1.0).acos().to_degrees() < 1.0);
    assert!((s * offset - d).abs() < 0.01 * H, "offset {offset}");
}

#[test]
fn sequential_and_parallel_agree_bit_for_bit() {
    let copies: Vec<RigidTransform> = (0..5)
        .map(|k| {
            RigidTransform::rotation_about([0.0, 0.0, 1.0], 1.2566370614359172 * k as f64, [0.0; 3])
                .compose(&RigidTransform::translation([4.0, 0.0, 0.0]))
        })
        .collect();
    let net = network(&copies, None);
    let p = BlastParams::default();
    let a = blast_with_unit(&net, H, &p, Par::Seq).unwrap();
    let b = blast_with_unit(&net, H, &p, Par::Rayon).unwrap();
    assert!(!a.matches.is_empty());
    assert_eq!(a, b);
    let ca = cluster(&a, &ClusterParams::default(), Par::Seq).unwrap();
    let cb = cluster(&b, &ClusterParams::default(), Par::Rayon).unwrap();
    assert_eq!(ca, cb);
}

/// Many copies of one feature: 40 000 matches between circles on a 100 × 100 grid, all with
/// one of four grid steps (and tiny jitter). Every match of a step must land in that step's
/// cluster: the merging of near-equal transformations and the candidate index must not lose
/// or split any. (Its time, which was quadratic in the matches before that merging, is
/// measured on cgal_cheese in docs/symmetry.md, not here.)
#[test]
fn many_equal_translations_cluster_by_step() {
    use crestflow_nodes_symmetry::blast::{CurveMatch, CurveMatches};
    let h = 0.01;
    let circle = |c: V3| -> Vec<V3> {
        (0..8)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 8.0;
                [c[0] + 0.1 * a.cos(), c[1] + 0.1 * a.sin(), c[2]]
            })
            .collect()
    };
    let steps: [V3; 4] = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, -1.0, 0.0],
    ];
    let mut matches = Vec::new();
    let mut jitter = 0u64;
    for i in 0..100u32 {
        for j in 0..100u32 {
            let c = [i as f64, j as f64, 0.0];
            for s in steps {
                jitter = jitter
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let e = ((jitter >> 40) as f64 / (1u64 << 24) as f64 - 0.5) * 0.02 * h;
                let t = [s[0] + e, s[1] - e, 0.0];
                let src = circle(c);
                let dst: Vec<V3> = src
                    .iter()
                    .map(|p| [p[0] + t[0], p[1] + t[1], p[2]])
                    .collect();
                matches.push(CurveMatch {
                    curve_a: i * 100 + j,
                    curve_b: i * 100 + j + 1,
                    mirrored: false,
                    transform: RigidTransform::translation(t),
                    votes: 10.0,
                    matched_length: 0.6,
                    mean_distance: 0.0,
                    affinity: 0.6,
                    correspondences: src.into_iter().zip(dst).map(|(p, q)| [p, q]).collect(),
                });
            }
        }
    }
    let matches = CurveMatches {
        unit: h,
        matches,
        ..Default::default()
    };
    let c = cluster(&matches, &ClusterParams::default(), Par::Rayon).expect("cluster");
    // Each step and its inverse: eight clusters of 10 000 members each.
    assert_eq!(c.clusters.len(), 8, "{} clusters", c.clusters.len());
    for cl in &c.clusters {
        assert_eq!(cl.members.len(), 10_000);
        let t = cl.transform.translation;
        let on_step = steps
            .iter()
            .any(|s| dist(t, *s) < 1e-3 || dist(t, [-s[0], -s[1], -s[2]]) < 1e-3);
        assert!(on_step, "{t:?}");
    }
}
