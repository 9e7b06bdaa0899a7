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
