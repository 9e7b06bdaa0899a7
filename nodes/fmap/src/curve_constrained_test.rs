//! Unit tests of `curve_constrained.rs`.

use super::*;
use crate::shortest_path::{shortest_paths, ShortestPathParams, Side};
use crate::types::LandmarkPairs;
use crestflow_geom::shapes::{ellipsoid, sphere, torus};
use crestflow_nodes_spectral::{eigenbasis, laplacian, EigenbasisParams, LaplacianParams};

pub(crate) fn basis_of(mesh: &TriMesh, k: usize) -> EigenBasis {
    let op = laplacian(mesh, &LaplacianParams::default(), Par::Rayon).unwrap();
    eigenbasis(
        &op,
        &EigenbasisParams {
            k,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap()
}

fn landmarks(v: &[u32]) -> LandmarkPairs {
    LandmarkPairs {
        pairs: v.iter().map(|&x| [x, x]).collect(),
        lines: (1..=v.len()).collect(),
        origin: "test".into(),
    }
}

fn curves(mesh: &TriMesh, lm: &LandmarkPairs, side: Side) -> FeatureCurveNetwork {
    shortest_paths(
        mesh,
        lm,
        None,
        &ShortestPathParams {
            side,
            ..Default::default()
        },
        Par::Seq,
    )
    .unwrap()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn same_shape_gives_the_identity_map() {
    // Identical bases and curves: C = I has zero energy and H is positive definite, so the
    // minimiser is exactly I, on a shape without (torus) and with (sphere) repeated
    // eigenvalues.
    for mesh in [
        torus(2.0, 0.8, 24, 12, 0.2, 1).unwrap(),
        sphere(1.0, 3).unwrap(),
    ] {
        let eb = basis_of(&mesh, 30);
        let lm = landmarks(&[0, 77, 150, 233]);
        let n1 = curves(&mesh, &lm, Side::Source);
        let params = CurveConstrainedParams {
            k: 30,
            tol: 1e-12,
            ..Default::default()
        };
        let m =
            curve_constrained(&eb, &eb, &mesh, &mesh, &n1, &n1, None, &params, Par::Seq).unwrap();
        let mut id = vec![0.0; 30 * 30];
        for i in 0..30 {
            id[i * 30 + i] = 1.0;
        }
        let err = max_abs_diff(&m.matrix, &id);
        assert!(err < 1e-8, "max |C − I| = {err}");
        assert!(
            m.energy.abs() < 1e-12 * n1.curves.len() as f64 * 64.0,
            "{}",
            m.energy
        );
    }
}

#[test]
fn cg_equals_the_direct_dense_solve() {
    // Source and target differ (an ellipsoid and a sphere), so C is far from the identity.
    let m1 = ellipsoid(1.3, 1.0, 0.6, 3, 0.2, 7).unwrap();
    let m2 = sphere(1.0, 3).unwrap();
    let e1 = basis_of(&m1, 25);
    let e2 = basis_of(&m2, 25);
    let lm = landmarks(&[0, 40, 300, 500, 611]);
    let n1 = curves(&m1, &lm, Side::Source);
    let n2 = curves(&m2, &lm, Side::Target);
    let cg = CurveConstrainedParams {
        k: 25,
        tol: 1e-13,
        ..Default::default()
    };
    let direct = CurveConstrainedParams {
        solver: CurveMapSolver::Direct,
        ..cg.clone()
    };
    let plain = CurveConstrainedParams {
        precondition: false,
        max_iterations: 100_000,
        ..cg.clone()
    };
    let a = curve_constrained(&e1, &e2, &m1, &m2, &n1, &n2, None, &cg, Par::Seq).unwrap();
    let b = curve_constrained(&e1, &e2, &m1, &m2, &n1, &n2, None, &direct, Par::Rayon).unwrap();
    let c = curve_constrained(&e1, &e2, &m1, &m2, &n1, &n2, None, &plain, Par::Seq).unwrap();
    // The same bits at any thread count.
    let a_par = curve_constrained(&e1, &e2, &m1, &m2, &n1, &n2, None, &cg, Par::Rayon).unwrap();
    assert_eq!(a.matrix, a_par.matrix);
    let scale = b.matrix.iter().map(|x| x.abs()).fold(0.0, f64::max);
    assert!(max_abs_diff(&a.matrix, &b.matrix) < 1e-8 * scale);
    assert!(max_abs_diff(&c.matrix, &b.matrix) < 1e-7 * scale);
    // And the direct solution is the minimiser of the k²-dimensional normal equations built
    // entry by entry (H as a dense k² × k² matrix, solved by Cholesky).
    let (b1, b2) = bases(&e1, &e2, 25).unwrap();
    let sys = build_system(&b1, &b2, &m1, &m2, &n1, &n2, &cg, Par::Seq).unwrap();
    let k = 25;
    let kk = k * k;
    let mut h = vec![0.0; kk * kk];
    for col in 0..kk {
        let mut e = vec![0.0; kk];
        e[col] = 1.0;
        let he = sys.apply(&e);
        h[col * kk..(col + 1) * kk].copy_from_slice(&he);
    }
    let x = crate::dense::spd_solve(&h, kk, &sys.b, 0).unwrap();
    assert!(max_abs_diff(&x, &b.matrix) < 1e-9 * scale);
    // Energy at the optimum is below the energy of small perturbations.
    let e0 = sys.energy(&b.matrix);
    let mut p = b.matrix.clone();
    p[7] += 1e-3;
    assert!(sys.energy(&p) > e0);
}

#[test]
fn adding_a_pair_warm_starts_from_the_previous_map() {
    let m1 = ellipsoid(1.3, 1.0, 0.6, 3, 0.2, 7).unwrap();
    let m2 = ellipsoid(1.0, 1.1, 0.8, 3, 0.1, 9).unwrap();
    let e1 = basis_of(&m1, 20);
    let e2 = basis_of(&m2, 20);
    let lm = landmarks(&[0, 40, 300, 500, 611, 90]);
    let n1 = curves(&m1, &lm, Side::Source);
    let n2 = curves(&m2, &lm, Side::Target);
    let params = CurveConstrainedParams {
        k: 20,
        tol: 1e-12,
        ..Default::default()
    };
    let (b1, b2) = bases(&e1, &e2, 20).unwrap();
    let mut few1 = n1.clone();
    let mut few2 = n2.clone();
    few1.curves.truncate(5);
    few2.curves.truncate(5);
    let mut sys = build_system(&b1, &b2, &m1, &m2, &few1, &few2, &params, Par::Seq).unwrap();
    let prev = solve_system(&sys, None, &params, Par::Seq).unwrap();
    // Restarting from the solution needs no iteration.
    let again = solve_system(&sys, Some(&prev), &params, Par::Seq).unwrap();
    assert_eq!(again.iterations, 0);
    assert_eq!(again.matrix, prev.matrix);
    // Add the sixth pair and warm-start: same answer as solving all six from scratch.
    let s = params.samples;
    sys.add_pair(
        &restrict(&b1, &m1, &n1, 5, s, "source").unwrap(),
        &restrict(&b2, &m2, &n2, 5, s, "target").unwrap(),
        s,
    );
    let warm = solve_system(&sys, Some(&prev), &params, Par::Seq).unwrap();
    let full = curve_constrained(&e1, &e2, &m1, &m2, &n1, &n2, None, &params, Par::Seq).unwrap();
    let scale = full.matrix.iter().map(|x| x.abs()).fold(0.0, f64::max);
    assert!(max_abs_diff(&warm.matrix, &full.matrix) < 1e-8 * scale);
    assert!(warm.iterations > 0);
}

#[test]
fn restriction_interpolates_linearly_along_the_curve() {
    // On a sphere, φ₁..φ₃ are linear in the coordinates; sampling a one-edge curve at 3
    // points gives the endpoints and the midpoint average.
    let mesh = sphere(1.0, 2).unwrap();
    let eb = basis_of(&mesh, 4);
    let b = Basis::new(&eb, 4, "source").unwrap();
    let (a, c) = (0u32, mesh.topology().neighbors(0)[0]);
    let net = FeatureCurveNetwork {
        vertices: [a, c]
            .iter()
            .map(|&v| crestflow_geom::FcnVertex {
                position: mesh.positions[v as usize],
                location: SurfacePoint::Vertex(v),
                strength: 0.0,
            })
            .collect(),
        curves: vec![crestflow_geom::FeatureCurve {
            vertices: vec![0, 1],
            closed: false,
            label: crestflow_geom::CurveLabel::Other,
        }],
    };
    let r = restrict(&b, &mesh, &net, 0, 3, "source").unwrap();
    for j in 0..4 {
        let (fa, fc) = (b.at(a as usize, j), b.at(c as usize, j));
        assert!((r[j * 3] - fa).abs() < 1e-14);
        assert!((r[j * 3 + 1] - 0.5 * (fa + fc)).abs() < 1e-14);
        assert!((r[j * 3 + 2] - fc).abs() < 1e-14);
    }
}

#[test]
fn errors_name_the_problem() {
    let mesh = sphere(1.0, 2).unwrap();
    let eb = basis_of(&mesh, 10);
    let lm = landmarks(&[0, 40, 80]);
    let n1 = curves(&mesh, &lm, Side::Source);
    let p = CurveConstrainedParams {
        k: 10,
        ..Default::default()
    };
    // Mismatched k: more functions asked than the basis has.
    let big = CurveConstrainedParams {
        k: 12,
        ..Default::default()
    };
    let e = curve_constrained(&eb, &eb, &mesh, &mesh, &n1, &n1, None, &big, Par::Seq).unwrap_err();
    assert_eq!(
        e.to_string(),
        "the source eigenbasis has 10 functions but k = 12 is asked"
    );
    // Different curve counts.
    let mut n2 = n1.clone();
    n2.curves.pop();
    let e = curve_constrained(&eb, &eb, &mesh, &mesh, &n1, &n2, None, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::CurveCountMismatch {
                source_count: 3,
                target: 2
            }
        ),
        "{e}"
    );
    // A basis of another mesh.
    let other = sphere(1.0, 1).unwrap();
    let e = curve_constrained(&eb, &eb, &other, &mesh, &n1, &n1, None, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(e, FmapError::BasisMeshMismatch { side: "source", .. }),
        "{e}"
    );
    // A curve point off the mesh.
    let mut bad = n1.clone();
    bad.vertices[0].location = SurfacePoint::Vertex(100_000);
    let e = curve_constrained(&eb, &eb, &mesh, &mesh, &bad, &n1, None, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::CurveVertexOutOfRange {
                side: "source",
                curve: 0,
                vertex: 100_000,
                ..
            }
        ),
        "{e}"
    );
    // A curve of zero length.
    let mut flat = n1.clone();
    let v0 = flat.curves[1].vertices[0];
    flat.curves[1].vertices = vec![v0, v0];
    let e = curve_constrained(&eb, &eb, &mesh, &mesh, &n1, &flat, None, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(
            e,
            FmapError::DegenerateCurve {
                side: "target",
                curve: 1
            }
        ),
        "{e}"
    );
    // A warm start of the wrong shape.
    let bad_init = FunctionalMap {
        k_source: 3,
        k_target: 3,
        matrix: vec![0.0; 4],
        energy: 0.0,
        iterations: 0,
    };
    let e = curve_constrained(
        &eb,
        &eb,
        &mesh,
        &mesh,
        &n1,
        &n1,
        Some(&bad_init),
        &p,
        Par::Seq,
    )
    .unwrap_err();
    assert!(matches!(e, FmapError::MapSizeMismatch { .. }), "{e}");
}
