//! Curve descriptors on shapes with known answers.

use crestflow_flow::Par;
use crestflow_geom::fcn::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crestflow_geom::mesh::TriMesh;
use crestflow_geom::shapes::sphere;
use crestflow_nodes_descriptors::curve_hks::curve_hks_from_basis;
use crestflow_nodes_descriptors::{curve_gics, CurveGicsParams, CurveHksParams, Sampling};
use crestflow_nodes_spectral::laplacian::{laplacian, LaplacianParams};
use crestflow_nodes_spectral::{eigenbasis, EigenbasisParams};

/// The circle z = z0 on a unit icosphere, as points on the mesh edges it crosses, ordered by
/// azimuth.
fn latitude_circle(mesh: &TriMesh, z0: f64) -> FeatureCurveNetwork {
    let topo = mesh.topology();
    let mut pts = Vec::new();
    for e in &topo.edges {
        let (a, b) = (e[0], e[1]);
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        if (pa[2] - z0) * (pb[2] - z0) < 0.0 {
            let t = (z0 - pa[2]) / (pb[2] - pa[2]);
            let p = [pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]), z0];
            pts.push((
                p[1].atan2(p[0]),
                FcnVertex {
                    position: p,
                    location: SurfacePoint::Edge { a, b, t },
                    strength: 1.0,
                },
            ));
        }
    }
    pts.sort_by(|x, y| x.0.total_cmp(&y.0));
    let vertices: Vec<FcnVertex> = pts.into_iter().map(|x| x.1).collect();
    let ids = (0..vertices.len() as u32).collect();
    FeatureCurveNetwork {
        vertices,
        curves: vec![FeatureCurve {
            vertices: ids,
            closed: true,
            label: CurveLabel::Other,
        }],
    }
}

#[test]
fn gics_of_a_latitude_circle_on_the_sphere() {
    // Circle at polar angle θ0: points at distance r < θ0 lie on the circles at θ0 ± r, of
    // total length 2π (sin(θ0 − r) + sin(θ0 + r)); beyond θ0 only θ0 + r remains, up to
    // d_max = π − θ0.
    let mesh = sphere(1.0, 5).unwrap();
    let theta0: f64 = 1.0;
    let net = latitude_circle(&mesh, theta0.cos());
    let p = CurveGicsParams {
        radii: 20,
        sampling: Sampling::Linear,
        ..Default::default()
    };
    let g = curve_gics(&mesh, &net, &p, Par::Rayon).unwrap();
    let d = &g.curves[0];
    let pi = std::f64::consts::PI;
    eprintln!("d_max {:.4} (exact {:.4})", d.d_max, pi - theta0);
    assert!((d.d_max - (pi - theta0)).abs() < 0.05);
    let mut worst: f64 = 0.0;
    for (r, l) in d.samples.iter().zip(&d.values) {
        let exact = if *r < theta0 {
            2.0 * pi * ((theta0 - r).sin() + (theta0 + r).sin())
        } else {
            2.0 * pi * (theta0 + r).sin()
        };
        // Skip the last radii, where the contour shrinks to a point and the field's small
        // offset dominates.
        if *r < 0.85 * d.d_max {
            let rel = (l - exact).abs() / exact;
            eprintln!("r {r:.3}: l {l:.4} exact {exact:.4} rel {rel:.4}");
            worst = worst.max(rel);
        }
    }
    assert!(worst < 0.05, "worst relative contour length error {worst}");
}

#[test]
fn curve_hks_equals_the_double_sum_of_the_definition() {
    let mesh = sphere(1.0, 3).unwrap();
    let net = latitude_circle(&mesh, 0.3);
    let op = laplacian(&mesh, &LaplacianParams::default(), Par::Rayon).unwrap();
    let basis = eigenbasis(
        &op,
        &EigenbasisParams {
            k: 30,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    let params = CurveHksParams { times: 5, k: 30 };
    let h = curve_hks_from_basis(&mesh, &net, &basis, &params, Par::Seq).unwrap();
    let h_par = curve_hks_from_basis(&mesh, &net, &basis, &params, Par::Rayon).unwrap();
    assert_eq!(h, h_par);
    // Brute force: Σ_{v1} Σ_{v2} w1 w2 Σ_i e^{−λt} φ_i(v1) φ_i(v2), with w the normalised
    // half-segment lengths and φ interpolated on the edges.
    let c = &net.curves[0];
    let pts: Vec<_> = c
        .vertices
        .iter()
        .map(|&v| net.vertices[v as usize].clone())
        .collect();
    let m = pts.len();
    let mut w = vec![0.0; m];
    for s in 0..m {
        let (a, b) = (&pts[s].position, &pts[(s + 1) % m].position);
        let l = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        w[s] += 0.5 * l;
        w[(s + 1) % m] += 0.5 * l;
    }
    let total: f64 = w.iter().sum();
    let phi = |i: usize, p: &FcnVertex| match p.location {
        SurfacePoint::Edge { a, b, t } => {
            (1.0 - t) * basis.vector(i)[a as usize] + t * basis.vector(i)[b as usize]
        }
        _ => unreachable!("the test builds edge points only"),
    };
    for (ti, &t) in h.curves[0].samples.iter().enumerate() {
        let mut sum = 0.0;
        for v1 in 0..m {
            for v2 in 0..m {
                let k: f64 = (0..basis.k())
                    .map(|i| (-basis.values[i] * t).exp() * phi(i, &pts[v1]) * phi(i, &pts[v2]))
                    .sum();
                sum += w[v1] / total * w[v2] / total * k;
            }
        }
        let got = h.curves[0].values[ti];
        assert!(
            (got - sum).abs() <= 1e-10 * sum.abs(),
            "t {t}: {got} vs {sum}"
        );
    }
    // Heat leaves the curve: the signature decreases with time.
    let v = &h.curves[0].values;
    assert!(v.windows(2).all(|x| x[1] < x[0]));
}
