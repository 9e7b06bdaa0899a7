//! `smooth.laplacian` on shapes whose answer is known.

mod common;

use common::{add_noise, cube, cube_distance, tilted_plane};
use crestflow_flow::{Par, Validate};
use crestflow_geom::shapes::sphere;
use crestflow_geom::vec3;
use crestflow_geom::{
    CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint, TriMesh,
};
use crestflow_nodes_smooth::{
    laplacian_smooth, ConstraintError, LaplacianParams, SmoothError, Step, Weights,
};
use crestflow_nodes_spectral::sparse::{laplacian_and_mass, LaplacianOptions, MassKind};

const COMBOS: [(Weights, Step); 4] = [
    (Weights::Uniform, Step::Explicit),
    (Weights::Cotan, Step::Explicit),
    (Weights::Uniform, Step::Implicit),
    (Weights::Cotan, Step::Implicit),
];

fn params(weights: Weights, step: Step, iterations: u32) -> LaplacianParams {
    LaplacianParams {
        weights,
        step,
        iterations,
        ..Default::default()
    }
}

/// Mean distance of the vertices from the sphere of radius r.
fn sphere_error(m: &TriMesh, r: f64) -> f64 {
    m.positions
        .iter()
        .map(|&p| (vec3::norm(p) - r).abs())
        .sum::<f64>()
        / m.n_vertices() as f64
}

/// A network with one curve through the given mesh vertices.
fn vertex_curve(mesh: &TriMesh, verts: &[u32]) -> FeatureCurveNetwork {
    FeatureCurveNetwork {
        vertices: verts
            .iter()
            .map(|&v| FcnVertex {
                position: mesh.positions[v as usize],
                location: SurfacePoint::Vertex(v),
                strength: 1.0,
            })
            .collect(),
        curves: vec![FeatureCurve {
            vertices: (0..verts.len() as u32).collect(),
            closed: false,
            label: CurveLabel::Other,
        }],
    }
}

#[test]
fn smoothing_a_noisy_sphere_approaches_the_sphere() {
    // Noise of 0.15 mean edge lengths per coordinate. A few steps remove most of it; many
    // steps would shrink the sphere (a known property of Laplacian smoothing), so the step
    // counts are those of a light denoising.
    let clean = sphere(1.0, 5).unwrap();
    let noisy = add_noise(&clean, 0.15 * clean.mean_edge_length(), 42);
    let before = sphere_error(&noisy, 1.0);
    let spread = |m: &TriMesh| {
        let r: Vec<f64> = m.positions.iter().map(|&p| vec3::norm(p)).collect();
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        r.iter().map(|x| (x - mean).abs()).sum::<f64>() / r.len() as f64
    };
    let spread_before = spread(&noisy);
    for (w, s) in COMBOS {
        let (iterations, time_step) = match (w, s) {
            (_, Step::Explicit) => (3, 1.0),
            (Weights::Uniform, Step::Implicit) => (3, 0.5),
            (Weights::Cotan, Step::Implicit) => (1, 0.5),
        };
        let p = LaplacianParams {
            time_step,
            ..params(w, s, iterations)
        };
        let out = laplacian_smooth(&noisy, None, &p, Par::Rayon).unwrap();
        let after = sphere_error(&out.mesh, 1.0);
        assert!(
            after < 0.55 * before,
            "{w:?} {s:?}: mean sphere distance {after} vs noisy {before}"
        );
        // Radii scatter less around their mean: the noise, not only the scale, changed.
        assert!(spread(&out.mesh) < 0.45 * spread_before, "{w:?} {s:?}");
        assert_eq!(out.stats.fixed_by_curves, 0);
        assert_eq!(out.stats.fixed_boundary, 0);
    }
}

#[test]
fn cotan_steps_keep_a_plane_in_place() {
    // The cotangent Laplacian is exact on linear functions (linear precision): with its
    // boundary held, a planar mesh is a fixed point of cotangent smoothing. Uniform weights
    // keep it planar but move vertices within the plane.
    let plane = tilted_plane(12, 0.6, 5);
    let off_plane = |m: &TriMesh| {
        m.positions
            .iter()
            .map(|p| (p[2] - 0.3 * p[0] - 0.2 * p[1]).abs())
            .fold(0.0, f64::max)
    };
    let moved = |m: &TriMesh| {
        m.positions
            .iter()
            .zip(&plane.positions)
            .map(|(a, b)| vec3::dist(*a, *b))
            .fold(0.0, f64::max)
    };
    for (w, s) in COMBOS {
        let out = laplacian_smooth(&plane, None, &params(w, s, 10), Par::Seq).unwrap();
        assert!(off_plane(&out.mesh) < 1e-12, "{w:?} {s:?} left the plane");
        if w == Weights::Cotan {
            assert!(
                moved(&out.mesh) < 1e-10,
                "{w:?} {s:?} moved {}",
                moved(&out.mesh)
            );
        } else {
            assert!(
                moved(&out.mesh) > 1e-3,
                "{w:?} {s:?} should drift tangentially"
            );
        }
        assert_eq!(out.stats.fixed_boundary, 48);
    }
}

#[test]
fn fixed_vertices_do_not_move() {
    let m = add_noise(&sphere(1.0, 3).unwrap(), 0.01, 1);
    let held: Vec<u32> = (0..m.n_vertices() as u32).step_by(7).collect();
    let net = vertex_curve(&m, &held);
    for (w, s) in COMBOS {
        let out = laplacian_smooth(&m, Some(&net), &params(w, s, 5), Par::Rayon).unwrap();
        for v in 0..m.n_vertices() {
            if held.contains(&(v as u32)) {
                assert_eq!(out.mesh.positions[v], m.positions[v], "vertex {v} moved");
                assert!(out.fixed[v]);
            } else {
                assert_ne!(
                    out.mesh.positions[v], m.positions[v],
                    "vertex {v} did not move"
                );
            }
        }
        assert_eq!(out.stats.fixed_by_curves, held.len());
    }
    // Boundary vertices of an open mesh stay put unless told otherwise.
    let plane = add_noise(&tilted_plane(8, 0.5, 2), 0.01, 3);
    let topo = plane.topology();
    let held = laplacian_smooth(
        &plane,
        None,
        &params(Weights::Uniform, Step::Explicit, 3),
        Par::Seq,
    )
    .unwrap();
    let loose = laplacian_smooth(
        &plane,
        None,
        &LaplacianParams {
            fix_boundary: false,
            ..params(Weights::Uniform, Step::Explicit, 3)
        },
        Par::Seq,
    )
    .unwrap();
    for v in 0..plane.n_vertices() {
        if topo.is_boundary_vertex[v] {
            assert_eq!(held.mesh.positions[v], plane.positions[v]);
            assert_ne!(loose.mesh.positions[v], plane.positions[v]);
        }
    }
}

#[test]
fn cube_edges_survive_when_constrained() {
    // Holding the 12 edges of a cube keeps every face flat and the cube intact; without
    // them the corners round off.
    let c = cube(8);
    let on_edge: Vec<u32> = (0..c.n_vertices() as u32)
        .filter(|&v| {
            let p = c.positions[v as usize];
            p.iter().filter(|&&x| x == 0.0 || x == 1.0).count() >= 2
        })
        .collect();
    assert_eq!(on_edge.len(), 12 * 7 + 8);
    let net = vertex_curve(&c, &on_edge);
    for (w, s) in COMBOS {
        // Unconstrained implicit cotangent steps shrink the cube to a point by a total time of
        // about (side/2)²/4 (mean curvature flow): stay below it.
        let p = params(w, s, if s == Step::Implicit { 3 } else { 50 });
        let free = laplacian_smooth(&c, None, &p, Par::Rayon).unwrap();
        let kept = laplacian_smooth(&c, Some(&net), &p, Par::Rayon).unwrap();
        let worst = |m: &TriMesh| {
            m.positions
                .iter()
                .map(|&q| cube_distance(q))
                .fold(0.0, f64::max)
        };
        assert!(
            worst(&kept.mesh) < 1e-12,
            "{w:?} {s:?}: {}",
            worst(&kept.mesh)
        );
        assert!(
            worst(&free.mesh) > 0.05,
            "{w:?} {s:?}: {}",
            worst(&free.mesh)
        );
    }
    // With noise, the constrained result is closer to the clean cube than the noisy input,
    // and than unconstrained smoothing.
    let noisy = add_noise(&c, 0.01, 9);
    let mean = |m: &TriMesh| {
        m.positions.iter().map(|&q| cube_distance(q)).sum::<f64>() / m.n_vertices() as f64
    };
    let net = vertex_curve(&c, &on_edge);
    let p = params(Weights::Cotan, Step::Explicit, 20);
    let kept = laplacian_smooth(&noisy, Some(&net), &p, Par::Rayon).unwrap();
    let free = laplacian_smooth(&noisy, None, &p, Par::Rayon).unwrap();
    assert!(mean(&kept.mesh) < 0.6 * mean(&noisy));
    assert!(mean(&kept.mesh) < mean(&free.mesh));
}

#[test]
fn implicit_step_solves_the_reduced_system() {
    // One implicit cotangent step against a dense solve of (M + τL) x' = M x with the held
    // rows replaced by x'_i = x_i.
    let m = add_noise(&sphere(1.0, 1).unwrap(), 0.02, 4);
    let n = m.n_vertices();
    let held = [0u32, 5, 17];
    let net = vertex_curve(&m, &held);
    let p = LaplacianParams {
        time_step: 0.7,
        ..params(Weights::Cotan, Step::Implicit, 1)
    };
    let out = laplacian_smooth(&m, Some(&net), &p, Par::Seq).unwrap();
    let opts = LaplacianOptions {
        mass: MassKind::Barycentric,
        ..Default::default()
    };
    let (l, mass) = laplacian_and_mass(&m, &opts, Par::Seq).unwrap();
    let h = m.mean_edge_length();
    let tau = 0.7 * h * h;
    for c in 0..3 {
        let mut a = vec![vec![0.0; n + 1]; n];
        for i in 0..n {
            if held.contains(&(i as u32)) {
                a[i][i] = 1.0;
                a[i][n] = m.positions[i][c];
            } else {
                for (j, v) in l.row(i) {
                    a[i][j] += tau * v;
                }
                a[i][i] += mass[i];
                a[i][n] = mass[i] * m.positions[i][c];
            }
        }
        // Gaussian elimination with partial pivoting.
        for k in 0..n {
            let piv = (k..n)
                .max_by(|&x, &y| a[x][k].abs().total_cmp(&a[y][k].abs()))
                .unwrap();
            a.swap(k, piv);
            let pivot_row = a[k].clone();
            for row in a.iter_mut().skip(k + 1) {
                let f = row[k] / pivot_row[k];
                for (q, v) in row.iter_mut().enumerate().skip(k) {
                    *v -= f * pivot_row[q];
                }
            }
        }
        let mut x = vec![0.0; n];
        for k in (0..n).rev() {
            let s: f64 = (k + 1..n).map(|q| a[k][q] * x[q]).sum();
            x[k] = (a[k][n] - s) / a[k][k];
        }
        for (i, (p, want)) in out.mesh.positions.iter().zip(&x).enumerate() {
            assert!(
                (p[c] - want).abs() < 1e-12,
                "vertex {i} coord {c}: {} vs {want}",
                p[c]
            );
        }
    }
}

#[test]
fn frozen_weights_factorise_once_and_differ_from_updated_ones() {
    let m = add_noise(&sphere(1.0, 3).unwrap(), 0.01, 8);
    let upd = params(Weights::Cotan, Step::Implicit, 4);
    let frozen = LaplacianParams {
        update_weights: false,
        ..upd.clone()
    };
    let a = laplacian_smooth(&m, None, &upd, Par::Seq).unwrap();
    let b = laplacian_smooth(&m, None, &frozen, Par::Seq).unwrap();
    // The first step is the same; later ones use different operators.
    let one = laplacian_smooth(
        &m,
        None,
        &LaplacianParams {
            iterations: 1,
            ..upd.clone()
        },
        Par::Seq,
    )
    .unwrap();
    let one_f = laplacian_smooth(
        &m,
        None,
        &LaplacianParams {
            iterations: 1,
            ..frozen
        },
        Par::Seq,
    )
    .unwrap();
    assert_eq!(one.mesh, one_f.mesh);
    assert_ne!(a.mesh, b.mesh);
}

#[test]
fn sequential_equals_parallel() {
    let m = add_noise(&sphere(1.0, 4).unwrap(), 0.01, 11);
    let net = vertex_curve(&m, &(0..200).collect::<Vec<_>>());
    for (w, s) in COMBOS {
        let p = params(w, s, 5);
        let a = laplacian_smooth(&m, Some(&net), &p, Par::Seq).unwrap();
        let b = laplacian_smooth(&m, Some(&net), &p, Par::Rayon).unwrap();
        assert_eq!(a, b, "{w:?} {s:?}");
    }
}

#[test]
fn bad_inputs_are_named() {
    let good = sphere(1.0, 1).unwrap();
    let p = LaplacianParams::default();
    let mut pos = good.positions.clone();
    pos[3][1] = f64::INFINITY;
    let e = laplacian_smooth(
        &TriMesh::new(pos, good.triangles.clone()),
        None,
        &p,
        Par::Seq,
    )
    .unwrap_err();
    assert!(matches!(e, SmoothError::NonFinite { vertex: 3, .. }), "{e}");
    let mut tris = good.triangles.clone();
    tris[7][2] = 1000;
    let e = laplacian_smooth(
        &TriMesh::new(good.positions.clone(), tris),
        None,
        &p,
        Par::Seq,
    )
    .unwrap_err();
    assert_eq!(
        e,
        SmoothError::IndexOutOfRange {
            face: 7,
            index: 1000,
            n_vertices: 42
        }
    );
    let mut tris = good.triangles.clone();
    tris[2] = [4, 9, 4];
    let e = laplacian_smooth(
        &TriMesh::new(good.positions.clone(), tris),
        None,
        &p,
        Par::Seq,
    )
    .unwrap_err();
    assert_eq!(e, SmoothError::RepeatedVertex { face: 2, vertex: 4 });
    let e =
        laplacian_smooth(&TriMesh::new(vec![[0.0; 3]], vec![]), None, &p, Par::Seq).unwrap_err();
    assert_eq!(e, SmoothError::NoFaces { vertices: 1 });
    let mut net = vertex_curve(&good, &[1, 2]);
    net.vertices[1].location = SurfacePoint::Vertex(500);
    let e = laplacian_smooth(&good, Some(&net), &p, Par::Seq).unwrap_err();
    assert_eq!(
        e,
        SmoothError::Curves(ConstraintError::VertexOutOfRange {
            vertex: 1,
            index: 500,
            n_vertices: 42
        })
    );
    assert!(e
        .to_string()
        .contains("curve vertex 1 lies on mesh vertex 500"));
    let bad = LaplacianParams {
        lambda: 0.0,
        time_step: f64::NAN,
        ..Default::default()
    };
    assert_eq!(bad.validate().len(), 2);
    assert!(matches!(
        laplacian_smooth(&good, None, &bad, Par::Seq),
        Err(SmoothError::Params(_))
    ));
}

#[test]
fn zero_iterations_return_the_input() {
    let m = add_noise(&sphere(1.0, 2).unwrap(), 0.01, 2);
    for (w, s) in COMBOS {
        let out = laplacian_smooth(&m, None, &params(w, s, 0), Par::Seq).unwrap();
        assert_eq!(out.mesh, m);
    }
}
