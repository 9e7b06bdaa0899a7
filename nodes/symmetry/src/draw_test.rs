use super::*;
use crate::cluster::{ClusterMember, TransformCluster};
use crate::orbits::{Generator, Orbit};
use crate::transform::RigidTransform;
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve, SurfacePoint};

/// Three curves of two vertices each along x at heights 0, 1, 2.
fn net() -> FeatureCurveNetwork {
    let mut n = FeatureCurveNetwork::default();
    for c in 0..3u32 {
        for k in 0..2 {
            n.vertices.push(FcnVertex {
                position: [k as f64, c as f64, 0.0],
                location: SurfacePoint::Free,
                strength: 1.0,
            });
        }
        n.curves.push(FeatureCurve {
            vertices: vec![2 * c, 2 * c + 1],
            closed: false,
            label: CurveLabel::Ridge,
        });
    }
    n
}

fn orbit(curves: Vec<u32>) -> Orbit {
    Orbit {
        generator: Generator::Translation {
            steps: vec![[0.0, 1.0, 0.0]],
        },
        instances: curves.len(),
        clusters: vec![0],
        curves,
        support: 1.0,
    }
}

fn member(from: u32, to: u32) -> ClusterMember {
    ClusterMember {
        match_index: 0,
        inverse: false,
        from,
        to,
        affinity: 1.0,
        residual: 0.0,
    }
}

#[test]
fn strongest_orbit_wins_and_ungrouped_curves_are_left_out() {
    let o = Orbits {
        orbits: vec![orbit(vec![1, 2]), orbit(vec![0, 1])],
    };
    assert_eq!(
        orbit_groups(3, &o).unwrap(),
        vec![Some(1), Some(0), Some(0)]
    );
    let groups = vec![Some(0), None, Some(3)];
    let ply = colored_ply(&net(), &groups);
    // 6 vertices, 2 edges (curves 0 and 2); curve 1's vertices stay grey
    assert!(ply.contains("element vertex 6\n") && ply.contains("element edge 2\n"));
    let body: Vec<&str> = ply.split("end_header\n").nth(1).unwrap().lines().collect();
    assert_eq!(body.len(), 8);
    let c0 = PALETTE[0];
    let c3 = PALETTE[3];
    assert_eq!(body[0], format!("0 0 0 {} {} {}", c0[0], c0[1], c0[2]));
    assert_eq!(body[2], "0 1 0 160 160 160");
    assert_eq!(body[6], format!("0 1 0 {} {} {}", c0[0], c0[1], c0[2]));
    assert_eq!(body[7], format!("4 5 3 {} {} {}", c3[0], c3[1], c3[2]));
}

#[test]
fn clusters_beyond_the_limit_are_not_coloured() {
    let cl = |from, to| TransformCluster {
        mirrored: false,
        transform: RigidTransform::identity(),
        members: vec![member(from, to)],
        support: 1.0,
        pairs: 1,
    };
    let c = TransformClusters {
        unit: 1.0,
        mirror_x: 0.0,
        clusters: vec![cl(0, 1), cl(1, 2)],
    };
    assert_eq!(
        cluster_groups(3, &c, 1).unwrap(),
        vec![Some(0), Some(0), None]
    );
    assert_eq!(
        cluster_groups(3, &c, 2).unwrap(),
        vec![Some(0), Some(0), Some(1)]
    );
}

#[test]
fn bad_references_are_named() {
    let o = Orbits {
        orbits: vec![orbit(vec![0, 7])],
    };
    let e = orbit_groups(3, &o).unwrap_err();
    assert!(
        matches!(e, DrawError::CurveIndex { curve: 7, n: 3, .. }),
        "{e}"
    );
    let mut n = net();
    n.curves[1].vertices[1] = 99;
    let e = check_network(&n).unwrap_err();
    assert!(
        matches!(
            e,
            DrawError::VertexIndex {
                curve: 1,
                index: 99,
                ..
            }
        ),
        "{e}"
    );
    let mut n = net();
    n.vertices[4].position[2] = f64::NAN;
    assert!(matches!(
        check_network(&n).unwrap_err(),
        DrawError::NonFinite { vertex: 4, .. }
    ));
    let empty = TriMesh::new(vec![[0.0; 3]], vec![]);
    assert!(matches!(
        draw_png(&empty, &net(), &[None; 3], &DrawParams::default(), Par::Seq).unwrap_err(),
        DrawError::Mesh(_)
    ));
    assert!(!DrawParams {
        width: 4,
        ..Default::default()
    }
    .validate()
    .is_empty());
}

#[test]
fn png_shows_the_group_colour() {
    // a unit square of two triangles in the z = 0 plane, seen from +z; one curve across it
    let mesh = TriMesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let mut n = FeatureCurveNetwork::default();
    for p in [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0]] {
        n.vertices.push(FcnVertex {
            position: p,
            location: SurfacePoint::Free,
            strength: 1.0,
        });
    }
    n.curves.push(FeatureCurve {
        vertices: vec![0, 1],
        closed: false,
        label: CurveLabel::Ridge,
    });
    let params = DrawParams {
        width: 64,
        height: 64,
        azimuth: 0.0,
        elevation: 0.0,
        up: UpAxis::Y,
        line_width: 4.0,
        ..Default::default()
    };
    let img = draw_png(&mesh, &n, &[Some(1)], &params, Par::Seq).unwrap();
    assert_eq!(img.get(32, 32), PALETTE[1]);
    // the surface away from the curve is grey, not the curve colour
    let g = img.get(32, 10);
    assert_ne!(g, PALETTE[1]);
    assert_ne!(g, [255, 255, 255]);
}
