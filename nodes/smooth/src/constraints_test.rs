//! Unit tests of `constraints.rs`.

use super::*;
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve};

fn strip() -> TriMesh {
    // Two triangles: 0-1-2 and 1-3-2.
    TriMesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [1, 3, 2]],
    )
}

fn net(locs: &[(SurfacePoint, V3)]) -> FeatureCurveNetwork {
    FeatureCurveNetwork {
        vertices: locs
            .iter()
            .map(|&(location, position)| FcnVertex {
                position,
                location,
                strength: 1.0,
            })
            .collect(),
        curves: vec![FeatureCurve {
            vertices: (0..locs.len() as u32).collect(),
            closed: false,
            label: CurveLabel::Ridge,
        }],
    }
}

#[test]
fn rule_on_each_location_kind() {
    let m = strip();
    let cases: [(SurfacePoint, Vec<bool>); 6] = [
        (SurfacePoint::Vertex(3), vec![false, false, false, true]),
        // Middle of edge (1, 2): both ends.
        (
            SurfacePoint::Edge { a: 1, b: 2, t: 0.5 },
            vec![false, true, true, false],
        ),
        // Near a: only a.
        (
            SurfacePoint::Edge { a: 1, b: 2, t: 0.1 },
            vec![false, true, false, false],
        ),
        // Near b: only b.
        (
            SurfacePoint::Edge { a: 0, b: 1, t: 0.9 },
            vec![false, true, false, false],
        ),
        // Face centre: all three corners.
        (
            SurfacePoint::Face {
                f: 1,
                bary: [1.0 / 3.0; 3],
            },
            vec![false, true, true, true],
        ),
        // Close to corner 0 of face 0 (vertex 0): only it.
        (
            SurfacePoint::Face {
                f: 0,
                bary: [0.8, 0.1, 0.1],
            },
            vec![true, false, false, false],
        ),
    ];
    for (loc, want) in cases {
        let (got, free) = curve_fixed_vertices(&m, &net(&[(loc, [0.0; 3])]), 0.25).unwrap();
        assert_eq!(got, want, "{loc:?}");
        assert_eq!(free, 0);
    }
    // A free point snaps to the nearest vertex.
    let (got, free) =
        curve_fixed_vertices(&m, &net(&[(SurfacePoint::Free, [0.9, 0.95, 0.1])]), 0.25).unwrap();
    assert_eq!(got, vec![false, false, false, true]);
    assert_eq!(free, 1);
    // min_weight = 1: only the nearest corner even in the middle of an edge.
    let (got, _) = curve_fixed_vertices(
        &m,
        &net(&[(SurfacePoint::Edge { a: 1, b: 2, t: 0.4 }, [0.0; 3])]),
        1.0,
    )
    .unwrap();
    assert_eq!(got, vec![false, true, false, false]);
}

#[test]
fn grid_nearest_equals_brute_force() {
    let m = crestflow_geom::shapes::ellipsoid(1.0, 0.6, 0.4, 3, 0.3, 3).unwrap();
    let g = VertexGrid::new(&m);
    let mut s = 12345u64;
    for _ in 0..300 {
        let mut p = [0.0; 3];
        for c in p.iter_mut() {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *c = ((s >> 11) as f64 / (1u64 << 53) as f64) * 3.0 - 1.5;
        }
        let want = (0..m.n_vertices() as u32)
            .min_by(|&a, &b| {
                vec3::dist(m.positions[a as usize], p)
                    .total_cmp(&vec3::dist(m.positions[b as usize], p))
                    .then(a.cmp(&b))
            })
            .unwrap();
        assert_eq!(g.nearest(p), Some(want), "{p:?}");
    }
}

#[test]
fn bad_locations_are_named() {
    let m = strip();
    assert_eq!(
        curve_fixed_vertices(&m, &net(&[(SurfacePoint::Vertex(7), [0.0; 3])]), 0.25).unwrap_err(),
        ConstraintError::VertexOutOfRange {
            vertex: 0,
            index: 7,
            n_vertices: 4
        }
    );
    let e = curve_fixed_vertices(
        &m,
        &net(&[
            (SurfacePoint::Vertex(1), [0.0; 3]),
            (
                SurfacePoint::Face {
                    f: 2,
                    bary: [0.3; 3],
                },
                [0.0; 3],
            ),
        ]),
        0.25,
    )
    .unwrap_err();
    assert!(e.to_string().contains("curve vertex 1 lies on mesh face 2"));
    let e = curve_fixed_vertices(
        &m,
        &net(&[(
            SurfacePoint::Edge {
                a: 0,
                b: 1,
                t: f64::NAN,
            },
            [0.0; 3],
        )]),
        0.25,
    )
    .unwrap_err();
    assert!(matches!(e, ConstraintError::NonFinite { vertex: 0, .. }));
    let mut n = net(&[(SurfacePoint::Vertex(1), [0.0; 3])]);
    n.curves[0].vertices.push(5);
    assert!(matches!(
        curve_fixed_vertices(&m, &n, 0.25).unwrap_err(),
        ConstraintError::CurveIndex {
            curve: 0,
            index: 5,
            ..
        }
    ));
}
