//! Unit tests of `sharp_edges.rs`.

use super::*;
use crestflow_geom::shapes::cylinder;

/// A closed prism over a regular `k`-gon (radius 1, height 1), caps fanned from a centre.
fn prism(k: usize) -> TriMesh {
    let mut p = Vec::new();
    for z in [0.0, 1.0] {
        for i in 0..k {
            let a = 2.0 * std::f64::consts::PI * i as f64 / k as f64;
            p.push([a.cos(), a.sin(), z]);
        }
    }
    p.push([0.0, 0.0, 0.0]);
    p.push([0.0, 0.0, 1.0]);
    let (cb, ct) = (2 * k as u32, 2 * k as u32 + 1);
    let mut t = Vec::new();
    for i in 0..k as u32 {
        let j = (i + 1) % k as u32;
        let (b0, b1, t0, t1) = (i, j, i + k as u32, j + k as u32);
        t.push([b0, b1, t1]);
        t.push([b0, t1, t0]);
        t.push([cb, b1, b0]);
        t.push([ct, t0, t1]);
    }
    TriMesh::new(p, t)
}

#[test]
fn hexagonal_prism_gives_its_18_creases() {
    let out = sharp_edges(&prism(6), &SharpEdgesParams::default()).unwrap();
    // 6 vertical edges (normals 60° apart) and 12 rim edges (90°); the fan and side
    // diagonals are flat. Every rim vertex has three creases: a corner, so each crease is
    // its own curve.
    assert_eq!(out.network.curves.len(), 18);
    assert_eq!(out.report.num("sharp_edges"), Some(18.0));
    assert_eq!(out.report.num("corners"), Some(12.0));
    let mut vertical = 0;
    for (c, curve) in out.network.curves.iter().enumerate() {
        assert_eq!(curve.vertices.len(), 2);
        assert!(!curve.closed);
        let (a, b) = (
            &out.network.vertices[curve.vertices[0] as usize],
            &out.network.vertices[curve.vertices[1] as usize],
        );
        // Rim vertices carry the sharpest crease at them: 90°.
        assert!((a.strength - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        if (a.position[2] - b.position[2]).abs() > 0.5 {
            vertical += 1;
            assert!((out.network.curve_length(c) - 1.0).abs() < 1e-12);
        }
    }
    assert_eq!(vertical, 6);
    // A blunter threshold keeps only the rims: 60° normals are not above 60°.
    let rims = sharp_edges(
        &prism(6),
        &SharpEdgesParams {
            angle_deg: 60.5,
            corner_angle_deg: 75.0,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(rims.report.num("sharp_edges"), Some(12.0));
    // The rims alone are two hexagons whose vertices turn by 60°, below a corner angle of
    // 75°: two closed curves of six vertices each.
    assert_eq!(rims.network.curves.len(), 2);
    for c in &rims.network.curves {
        assert!(c.closed);
        assert_eq!(c.vertices.len(), 6);
    }
}

#[test]
fn open_cylinder_rims_are_closed_boundary_loops() {
    let mesh = cylinder(1.0, 2.0, 32, 8, 0.0, 1).unwrap();
    let out = sharp_edges(&mesh, &SharpEdgesParams::default()).unwrap();
    assert_eq!(out.report.num("sharp_edges"), Some(0.0));
    assert_eq!(out.report.num("boundary_edges"), Some(64.0));
    assert_eq!(out.network.curves.len(), 2);
    for (c, curve) in out.network.curves.iter().enumerate() {
        assert!(curve.closed);
        assert_eq!(curve.vertices.len(), 32);
        let perimeter = 64.0 * (std::f64::consts::PI / 32.0).sin();
        assert!((out.network.curve_length(c) - perimeter).abs() < 1e-9);
    }
    let none = sharp_edges(
        &mesh,
        &SharpEdgesParams {
            boundaries: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(none.network.curves.is_empty());
    // Short chains go: a prism's single-edge creases are all below two edges.
    let long_only = sharp_edges(
        &prism(6),
        &SharpEdgesParams {
            min_edges: 2,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(long_only.network.curves.is_empty());
    assert_eq!(long_only.report.num("curves_dropped_short"), Some(18.0));
}

#[test]
fn bad_meshes_are_named() {
    let empty = TriMesh::new(vec![[0.0; 3]; 3], vec![]);
    assert_eq!(
        sharp_edges(&empty, &SharpEdgesParams::default()).unwrap_err(),
        SharpEdgesError::Empty { vertices: 3 }
    );
    let mut nan = prism(4);
    nan.positions[5][1] = f64::NAN;
    assert!(matches!(
        sharp_edges(&nan, &SharpEdgesParams::default()).unwrap_err(),
        SharpEdgesError::NonFinite { vertex: 5, .. }
    ));
    let mut bad = prism(4);
    bad.triangles[3][2] = 99;
    assert_eq!(
        sharp_edges(&bad, &SharpEdgesParams::default()).unwrap_err(),
        SharpEdgesError::BadIndex {
            face: 3,
            index: 99,
            n: 10
        }
    );
    let issues = SharpEdgesParams {
        angle_deg: 0.0,
        min_edges: 0,
        ..Default::default()
    }
    .validate();
    assert_eq!(issues.len(), 2, "{issues:?}");
    // A join angle of 180° would join a chain to its own reversal: out of range, named.
    for join in [-1.0, 180.0, f64::NAN] {
        let issues = SharpEdgesParams {
            join_angle_deg: join,
            ..Default::default()
        }
        .validate();
        assert_eq!(issues.len(), 1, "{join}: {issues:?}");
        assert_eq!(issues[0].field, "join_angle_deg");
    }
}

#[test]
fn joining_through_corners_closes_the_prism_rims() {
    // At each rim vertex of a hexagonal prism the rim turns by 60° and the vertical edge
    // leaves at 90°: below a join angle of 75° the rim chains join into two closed hexagons
    // and the verticals stay single edges; below 45° nothing joins.
    let params = |join| SharpEdgesParams {
        join_angle_deg: join,
        ..Default::default()
    };
    let out = sharp_edges(&prism(6), &params(75.0)).unwrap();
    assert_eq!(out.report.num("joins"), Some(10.0));
    assert_eq!(out.network.curves.len(), 8);
    let closed: Vec<_> = out.network.curves.iter().filter(|c| c.closed).collect();
    assert_eq!(closed.len(), 2);
    for c in &closed {
        assert_eq!(c.vertices.len(), 6);
        // A loop visits each of its six rim vertices once, all at one height.
        let z: Vec<f64> = c
            .vertices
            .iter()
            .map(|&v| out.network.vertices[v as usize].position[2])
            .collect();
        assert!(z.iter().all(|&h| h == z[0]));
        let mut vs = c.vertices.clone();
        vs.sort_unstable();
        vs.dedup();
        assert_eq!(vs.len(), 6);
    }
    assert_eq!(
        out.network
            .curves
            .iter()
            .filter(|c| !c.closed && c.vertices.len() == 2)
            .count(),
        6
    );
    let none = sharp_edges(&prism(6), &params(45.0)).unwrap();
    assert_eq!(none.network.curves.len(), 18);
    assert_eq!(none.report.num("joins"), Some(0.0));
    // Above 90° the straightest pairs still come first: rims pair (60°) before a rim and a
    // vertical (90°), and with three ends at a vertex one stays free.
    let wide = sharp_edges(&prism(6), &params(120.0)).unwrap();
    assert_eq!(wide.network.curves.len(), 8);
}

#[test]
fn joined_open_path_runs_corner_to_corner() {
    // Chains along the x axis 0-1-2, 3-2 (stored reversed), 3-5, and a branch 2-4 along y.
    // Joined below 45°: one open curve 0-1-2-3-5 (the reversed chain turned round), the
    // branch alone.
    let pos: Vec<V3> = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [3.0, 0.0, 0.0],
        [2.0, 1.0, 0.0],
        [4.0, 0.1, 0.0],
    ];
    let chains = vec![
        (vec![0, 1, 2], false),
        (vec![3, 2], false),
        (vec![2, 4], false),
        (vec![3, 5], false),
    ];
    let joined = join_at_corners(chains.clone(), &pos, 45.0);
    assert_eq!(
        joined,
        vec![(vec![0, 1, 2, 3, 5], false), (vec![2, 4], false)]
    );
    // Below 5° the 5.7° bend at vertex 3 stays a break.
    let joined = join_at_corners(chains, &pos, 5.0);
    assert_eq!(
        joined,
        vec![
            (vec![0, 1, 2, 3], false),
            (vec![2, 4], false),
            (vec![3, 5], false)
        ]
    );
}

#[test]
fn pruning_breaks_the_prisms_short_cycles_at_its_weakest_creases() {
    // Side quads are cycles of 4 (two 90° rims, two 60° verticals); the rim hexagons are
    // cycles of 6. The bounding-box diagonal is √8.
    let diag = 8f64.sqrt();
    let run = |scale: f64| {
        sharp_edges(
            &prism(6),
            &SharpEdgesParams {
                prune_scale: scale / diag,
                ..Default::default()
            },
        )
        .unwrap()
    };
    // At scale 1.9 no cycle is shorter than 2 × 1.9: nothing goes.
    let kept = run(1.9);
    assert_eq!(kept.report.num("pruned_edges"), Some(0.0));
    assert_eq!(kept.network.curves.len(), 18);
    // At 2.5 the quads (4 < 5) lose their verticals, weakest first, until the last vertical
    // closes no cycle; the hexagons (6 > 5) stay: 12 rim edges and one vertical.
    let pruned = run(2.5);
    assert_eq!(pruned.report.num("sharp_edges"), Some(18.0));
    assert_eq!(pruned.report.num("pruned_edges"), Some(5.0));
    let edges: usize = pruned
        .network
        .curves
        .iter()
        .map(|c| c.vertices.len() - usize::from(!c.closed))
        .sum();
    assert_eq!(edges, 13);
    let net = &pruned.network;
    let rim_edges = net
        .curves
        .iter()
        .flat_map(|c| {
            let n = c.vertices.len();
            let m = if c.closed { n } else { n - 1 };
            (0..m).map(move |i| [c.vertices[i], c.vertices[(i + 1) % n]])
        })
        .filter(|&[a, b]| {
            let (p, q) = (
                net.vertices[a as usize].position,
                net.vertices[b as usize].position,
            );
            (p[2] - q[2]).abs() < 0.5
        })
        .count();
    assert_eq!(
        rim_edges, 12,
        "the 90° rims are stronger than the 60° verticals"
    );
    // A prune scale outside [0, 1] is a parameter error.
    let bad = SharpEdgesParams {
        prune_scale: -0.1,
        ..Default::default()
    };
    assert!(bad.validate().iter().any(|i| i.field == "prune_scale"));
}
