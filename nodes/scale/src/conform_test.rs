//! `scale.conform` on networks whose answer is known, and `scale.check` on its outputs.

use crate::check::check_absolute;
use crate::check_test::network;
use crate::conflicts::Scale;
use crate::conform::{build_problem, conform, ConformParams, ScaleError, Solver};
use crate::network::Graph;
use crate::network::NetworkError;
use crestflow_flow::Par;
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

/// A mesh with bounding-box diagonal 100 (so relative scale 0.01 is r_min = 1).
fn box_mesh() -> TriMesh {
    TriMesh::new(
        vec![[0.0, 0.0, 0.0], [60.0, 0.0, 0.0], [0.0, 80.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

fn params() -> ConformParams {
    ConformParams {
        scale: 0.01,
        ..Default::default()
    }
}

/// A polyline from `a` to `b` with `n` segments.
fn line(a: V3, b: V3, n: usize) -> Vec<V3> {
    (0..=n)
        .map(|k| vec3::lerp(a, b, k as f64 / n as f64))
        .collect()
}

/// Curves made of the given point lists (open), with one strength per curve.
fn curves(lines: &[(Vec<V3>, f64)]) -> FeatureCurveNetwork {
    let mut pts = Vec::new();
    let mut idx: Vec<Vec<u32>> = Vec::new();
    for (l, _) in lines {
        let base = pts.len() as u32;
        pts.extend_from_slice(l);
        idx.push((0..l.len() as u32).map(|k| base + k).collect());
    }
    let spec: Vec<(&[u32], bool)> = idx.iter().map(|v| (v.as_slice(), false)).collect();
    let mut net = network(&pts, &spec);
    let mut k = 0;
    for (l, s) in lines {
        for _ in 0..l.len() {
            net.vertices[k].strength = *s;
            k += 1;
        }
    }
    net
}

fn assert_conforming(net: &FeatureCurveNetwork, r_min: f64) {
    let r = check_absolute(net, r_min, 1.5, Par::Seq).unwrap();
    assert_eq!(r.violations(), 0, "{}", r.summary());
}

#[test]
fn straight_line_is_resampled_into_scale() {
    // 10 units long, 200 input segments (0.05 each).
    let net = curves(&[(line([10.0, 10.0, 0.0], [20.0, 10.0, 0.0], 200), 1.0)]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    let n = out.stats.output_edges;
    // 10 / 1.5 ≤ n ≤ 10.
    assert!((7..=10).contains(&n), "{n} edges");
    assert_eq!(out.network.curves.len(), 1);
    for v in &out.network.vertices {
        assert!((v.position[1] - 10.0).abs() < 1e-12 && v.position[2] == 0.0);
    }
    // The ends are kept.
    let c = &out.network.curves[0].vertices;
    let ends = [
        out.network.vertices[c[0] as usize].position[0],
        out.network.vertices[*c.last().unwrap() as usize].position[0],
    ];
    assert!(ends.contains(&10.0) && ends.contains(&20.0));
    assert!(out.stats.converged);
    assert_eq!(out.stats.repaired_edges, 0);
}

#[test]
fn the_weaker_of_two_close_parallel_lines_goes() {
    let net = curves(&[
        (line([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], 40), 1.0),
        (line([0.0, 0.3, 0.0], [10.0, 0.3, 0.0], 40), 3.0),
    ]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    assert!(out.stats.output_edges >= 7);
    for v in &out.network.vertices {
        assert!((v.position[1] - 0.3).abs() < 1e-12, "{:?}", v.position);
    }
    // Both far apart: both stay.
    let net = curves(&[
        (line([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], 40), 1.0),
        (line([0.0, 2.0, 0.0], [10.0, 2.0, 0.0], 40), 3.0),
    ]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    assert_eq!(out.network.curves.len(), 2);
}

/// Three parallel lines 0.6 apart (r_min 1): the middle one (strength 2.5) conflicts with both
/// outer ones (strength 2 each), which do not conflict with each other.
fn three_lines() -> FeatureCurveNetwork {
    curves(&[
        (line([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], 40), 2.0),
        (line([0.0, 0.6, 0.0], [10.0, 0.6, 0.0], 40), 2.5),
        (line([0.0, 1.2, 0.0], [10.0, 1.2, 0.0], 40), 2.0),
    ])
}

#[test]
fn a_weak_line_between_two_strong_ones_goes_but_greedy_loses_more() {
    // Middle line (strength 2.5) conflicts with both outer ones (strength 2 each), which do not
    // conflict with each other: the optimum keeps the outer lines, greedy the middle one.
    let net = three_lines();
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    assert!(out.stats.first_objective > out.stats.greedy_objective);
    for v in &out.network.vertices {
        let y = v.position[1];
        assert!(y.abs() < 1e-12 || (y - 1.2).abs() < 1e-12, "{y}");
    }
    let greedy = ConformParams {
        solver: Solver::Greedy,
        ..params()
    };
    let g = conform(&net, &box_mesh(), &greedy, Par::Seq).unwrap();
    assert_conforming(&g.network, 1.0);
    for v in &g.network.vertices {
        assert!((v.position[1] - 0.6).abs() < 1e-12);
    }
}

/// `solver: Highs` gives the same network as microlp where both prove the optimum (with the
/// `highs` feature), and is a parameter error naming the feature without it.
#[test]
fn highs_gives_the_same_network_or_a_parameter_error() {
    use crestflow_flow::Validate;
    let net = three_lines();
    let highs = ConformParams {
        solver: Solver::Highs,
        ..params()
    };
    if cfg!(feature = "highs") {
        assert!(highs.validate().is_empty());
        let h = conform(&net, &box_mesh(), &highs, Par::Seq).unwrap();
        let m = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
        assert_eq!(h.network, m.network);
        assert_eq!(h.stats.unproven_components, 0);
    } else {
        let issues = highs.validate();
        assert_eq!(issues.len(), 1, "{issues:?}");
        assert_eq!(issues[0].field, "solver");
        assert!(issues[0].message.contains("--features highs"), "{issues:?}");
        let err = conform(&net, &box_mesh(), &highs, Par::Seq).unwrap_err();
        assert!(err.to_string().contains("--features highs"), "{err}");
    }
}

#[test]
fn tiny_isolated_curve_disappears() {
    let net = curves(&[
        (line([0.0, 0.0, 0.0], [0.4, 0.0, 0.0], 4), 5.0),
        (line([5.0, 0.0, 0.0], [9.0, 0.0, 0.0], 8), 1.0),
    ]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    assert_eq!(out.network.curves.len(), 1);
    assert!(out.network.vertices.iter().all(|v| v.position[0] >= 5.0));
}

#[test]
fn closed_circle_is_kept_as_a_loop() {
    let n = 100;
    let pts: Vec<V3> = (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            [20.0 + 3.0 * t.cos(), 20.0 + 3.0 * t.sin(), 0.0]
        })
        .collect();
    let idx: Vec<u32> = (0..n as u32).collect();
    let net = network(&pts, &[(&idx, true)]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    assert_eq!(out.network.curves.len(), 1);
    assert!(out.network.curves[0].closed);
    // Circumference 18.85: between 13 and 18 edges of length in [1, 1.5].
    assert!((13..=19).contains(&out.stats.output_edges));
}

/// Random polylines in a box: whatever the input, the output passes the check, and the result
/// does not depend on the thread count.
#[test]
fn random_networks_always_conform() {
    let mut state = 12345u64;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for case in 0..6 {
        let mut lines = Vec::new();
        for _ in 0..12 {
            let mut p = [10.0 * rnd(), 10.0 * rnd(), 2.0 * rnd()];
            let mut pts = vec![p];
            let mut dir = [rnd() - 0.5, rnd() - 0.5, 0.2 * (rnd() - 0.5)];
            for _ in 0..(5 + (rnd() * 30.0) as usize) {
                dir = vec3::normalize([
                    dir[0] + 0.6 * (rnd() - 0.5),
                    dir[1] + 0.6 * (rnd() - 0.5),
                    dir[2] + 0.1 * (rnd() - 0.5),
                ]);
                p = vec3::add(p, vec3::scale(dir, 0.1 + 0.4 * rnd()));
                pts.push(p);
            }
            lines.push((pts, 0.5 + 3.0 * rnd()));
        }
        let mut net = curves(&lines);
        // Join some curves: the end of curve k is the start of curve k + 1.
        for k in (0..net.curves.len() - 1).step_by(3) {
            let end = *net.curves[k].vertices.last().unwrap();
            net.curves[k + 1].vertices[0] = end;
        }
        let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
        assert_conforming(&out.network, 1.0);
        let par = conform(&net, &box_mesh(), &params(), Par::Rayon).unwrap();
        assert_eq!(out, par, "case {case}");
        assert!(out.stats.first_objective >= out.stats.greedy_objective - 1e-9);
    }
}

#[test]
fn bad_input_is_named() {
    let mut net = curves(&[(line([0.0, 0.0, 0.0], [5.0, 0.0, 0.0], 5), 1.0)]);
    net.curves[0].vertices[2] = 99;
    let err = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap_err();
    assert_eq!(
        err,
        ScaleError::Network(NetworkError::CurveIndex {
            curve: 0,
            index: 99,
            n: 6
        })
    );
    let mut net = curves(&[(line([0.0, 0.0, 0.0], [5.0, 0.0, 0.0], 5), 1.0)]);
    net.vertices[3].strength = f64::INFINITY;
    let err = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap_err();
    assert!(
        matches!(
            err,
            ScaleError::Network(NetworkError::NonFiniteStrength { vertex: 3, .. })
        ),
        "{err}"
    );
    let net = curves(&[(line([0.0, 0.0, 0.0], [5.0, 0.0, 0.0], 5), 1.0)]);
    let flat = TriMesh::new(vec![[1.0, 1.0, 1.0]; 3], vec![[0, 1, 2]]);
    let err = conform(&net, &flat, &params(), Par::Seq).unwrap_err();
    assert!(matches!(err, ScaleError::NoExtent { .. }));
    let bad = ConformParams {
        scale: -1.0,
        ..params()
    };
    let err = conform(&net, &box_mesh(), &bad, Par::Seq).unwrap_err();
    assert!(err.to_string().contains("scale"), "{err}");
    let tiny = ConformParams {
        scale: 1e-9,
        ..params()
    };
    let err = conform(&net, &box_mesh(), &tiny, Par::Seq).unwrap_err();
    assert!(matches!(err, ScaleError::TooFine { .. }), "{err}");
    // An empty network is not an error.
    let out = conform(
        &FeatureCurveNetwork::default(),
        &box_mesh(),
        &params(),
        Par::Seq,
    )
    .unwrap();
    assert_eq!(out.stats.output_edges, 0);
}

/// The parallel/orthogonal pair term η_1 cos^{2p}(2θ) (thesis §4.1): 1 for parallel and
/// orthogonal edges within the radius, 0 at 45°, none beyond the radius; smoothness pairs
/// η_0 cos^p(2θ) only at shared vertices with a turn of at most 45°.
#[test]
fn pair_terms() {
    // Edge 0: (0,0)-(1.2,0). Edge 1 parallel 1.2 above; edge 2 perpendicular, 1.2 to the
    // right; edge 3 at 45°, 1.3 below; edge 4 parallel but 5 away. Edge 5 continues edge 0
    // straight on; edge 6 turns 30° from edge 5's far end.
    let a = 30f64.to_radians();
    let pts: Vec<V3> = vec![
        [0.0, 0.0, 0.0],
        [1.2, 0.0, 0.0],
        [0.0, 1.2, 0.0],
        [1.2, 1.2, 0.0],
        [2.4, -0.6, 0.0],
        [2.4, 0.6, 0.0],
        [0.0, -1.3, 0.0],
        [0.85, -2.15, 0.0],
        [0.0, 5.0, 0.0],
        [1.2, 5.0, 0.0],
        [-1.2, 0.0, 0.0],
        [-1.2 - 1.2 * a.cos(), 1.2 * a.sin(), 0.0],
    ];
    let net = network(
        &pts,
        &[
            (&[0, 1], false),
            (&[2, 3], false),
            (&[4, 5], false),
            (&[6, 7], false),
            (&[8, 9], false),
            (&[10, 0], false),
            (&[11, 10], false),
        ],
    );
    let g = Graph::from_network(&net, true).unwrap();
    let s = Scale::new(1.0, 1.5);
    let params = ConformParams {
        eta_parallel: 10.0,
        eta_smooth: 100.0,
        ..Default::default()
    };
    let cw = vec![1.0; net.curves.len()];
    let (p, _, _) = build_problem(&g, &s, &cw, &params, Par::Seq);
    let find = |x: [V3; 2], y: [V3; 2]| {
        let e = |q: [V3; 2]| {
            g.edges
                .iter()
                .position(|&[u, v]| {
                    (g.pos[u as usize], g.pos[v as usize]) == (q[0], q[1])
                        || (g.pos[u as usize], g.pos[v as usize]) == (q[1], q[0])
                })
                .unwrap() as u32
        };
        let (i, j) = (e(x), e(y));
        p.pairs
            .iter()
            .find(|t| (t.0, t.1) == (i.min(j), i.max(j)))
            .map(|t| t.2)
    };
    let e0 = [pts[0], pts[1]];
    assert_eq!(find(e0, [pts[2], pts[3]]), Some(10.0));
    let perp = find(e0, [pts[4], pts[5]]).unwrap();
    assert!((perp - 10.0).abs() < 1e-9);
    assert!(find(e0, [pts[6], pts[7]]).is_none_or(|c| c < 1e-6));
    assert!(find(e0, [pts[8], pts[9]]).is_none());
    // Smoothness: straight continuation 100, a 30° turn 100 cos²(60°) = 25.
    assert!((find(e0, [pts[10], pts[0]]).unwrap() - 100.0).abs() < 1e-9);
    assert!((find([pts[10], pts[0]], [pts[11], pts[10]]).unwrap() - 25.0).abs() < 1e-9);
}

/// A loop of twelve vertices of a sphere mesh around its equator, 0.52 apart, resampled at
/// r_min = 0.15: the new vertices lie between them on the sphere's surface (on the mesh, with
/// a face location), not on the chords, which pass up to 0.034 inside it.
#[test]
fn resampled_vertices_lie_on_the_mesh() {
    let mesh = crestflow_geom::shapes::sphere(1.0, 4).unwrap();
    let bvh = crestflow_geom::bvh::TriangleBvh::new(&mesh);
    let pts: Vec<V3> = (0..12)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / 12.0;
            let want = [t.cos(), t.sin(), 0.0];
            // The mesh vertex nearest to it (so the input lies on the mesh).
            *mesh
                .positions
                .iter()
                .min_by(|a, b| vec3::dist(**a, want).total_cmp(&vec3::dist(**b, want)))
                .unwrap()
        })
        .collect();
    let idx: Vec<u32> = (0..12).collect();
    let net = network(&pts, &[(&idx, true)]);
    let p = ConformParams {
        scale: 0.15,
        relative: false,
        ..Default::default()
    };
    let out = conform(&net, &mesh, &p, Par::Seq).unwrap();
    assert_conforming(&out.network, 0.15);
    // About 6.2 around: at least 28 edges of at most 0.225.
    assert!(
        out.network.vertices.len() >= 28,
        "{}",
        out.network.vertices.len()
    );
    let mut inside = 0;
    for v in &out.network.vertices {
        assert!(bvh.closest(v.position).distance < 1e-12, "{:?}", v.position);
        if !pts.contains(&v.position) {
            inside += 1;
            assert!(
                matches!(v.location, crestflow_geom::fcn::SurfacePoint::Face { .. }),
                "{:?}",
                v.location
            );
        }
    }
    assert!(inside >= 16);
    let again = conform(&net, &mesh, &p, Par::Rayon).unwrap();
    assert_eq!(out.network, again.network);
}

#[test]
fn an_arc_between_r_max_and_two_r_min_is_a_special_long_edge() {
    // r_min 1, r_max 1.5: a straight curve 1.7 long can be neither one edge of S nor two.
    let net = curves(&[(line([10.0, 10.0, 0.0], [11.7, 10.0, 0.0], 17), 1.0)]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_eq!(out.stats.output_edges, 0, "dropped by default");
    assert!(out.stats.long_dropped >= 1);
    // A lone edge (both ends free, as here) is dropped at any length unless kept.
    let keep = ConformParams {
        special_long_edges: true,
        lone_edges: true,
        ..params()
    };
    let out = conform(&net, &box_mesh(), &keep, Par::Seq).unwrap();
    assert_eq!(out.stats.output_edges, 1);
    assert!(out.stats.converged);
    let [a, b] = [0, 1].map(|k| out.network.vertices[k].position);
    assert!((vec3::dist(a, b) - 1.7).abs() < 1e-9);
    // The check accepts it only when told to.
    let s = Scale::new(1.0, 1.5).with_special_long(true);
    let r = crate::check::check_at(&out.network, &s, Par::Seq).unwrap();
    assert_eq!(
        (r.violations(), r.special_long_edges),
        (0, 1),
        "{}",
        r.summary()
    );
    let r = check_absolute(&out.network, 1.0, 1.5, Par::Seq).unwrap();
    assert_eq!((r.long_edges, r.special_long_edges), (1, 0));
}

#[test]
fn a_lone_edge_goes_unless_kept_but_a_spur_or_a_longer_curve_stays() {
    // r_min 1, r_max 1.5: a free curve 1.2 long is one edge of S with two free ends.
    let lone = (line([10.0, 20.0, 0.0], [11.2, 20.0, 0.0], 12), 1.0);
    let out = conform(
        &curves(std::slice::from_ref(&lone)),
        &box_mesh(),
        &params(),
        Par::Seq,
    )
    .unwrap();
    assert_eq!(out.stats.output_edges, 0);
    assert_eq!(out.stats.lone_dropped, 1);
    assert_eq!(out.stats.long_dropped, 0);
    let keep = ConformParams {
        lone_edges: true,
        ..params()
    };
    let out = conform(&curves(&[lone]), &box_mesh(), &keep, Par::Seq).unwrap();
    assert_eq!(out.stats.output_edges, 1);
    assert_eq!(out.stats.lone_dropped, 0);
    let [a, b] = [0, 1].map(|k| out.network.vertices[k].position);
    assert!((vec3::dist(a, b) - 1.2).abs() < 1e-12);

    // A free curve of two edges, and a spur of one edge at the middle of a long line (a
    // junction, so one end is not free), stay.
    let net = curves(&[
        (line([10.0, 20.0, 0.0], [12.4, 20.0, 0.0], 24), 1.0),
        (line([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], 40), 1.0),
        (line([5.0, 0.0, 0.0], [5.0, 1.2, 0.0], 12), 1.0),
    ]);
    let out = conform(&net, &box_mesh(), &params(), Par::Seq).unwrap();
    assert_conforming(&out.network, 1.0);
    assert_eq!(out.stats.lone_dropped, 0);
    let spur_tip = out
        .network
        .vertices
        .iter()
        .filter(|v| v.position == [5.0, 1.2, 0.0])
        .count();
    let pair_ends = out
        .network
        .vertices
        .iter()
        .filter(|v| v.position == [10.0, 20.0, 0.0] || v.position == [12.4, 20.0, 0.0])
        .count();
    assert_eq!((spur_tip, pair_ends), (1, 2));
}
