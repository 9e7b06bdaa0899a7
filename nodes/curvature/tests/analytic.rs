//! Both estimators against closed-form curvature on analytic shapes (sphere, open cylinder,
//! irregularly sampled torus, ellipsoid), invariances, and determinism across thread counts.

use crestflow_flow::Par;
use crestflow_geom::shapes::{analytic_curvature_field, AnalyticShape};
use crestflow_geom::vec3;
use crestflow_geom::{CurvatureField, TriMesh};
use crestflow_nodes_curvature::{
    polynomial_curvature, shape_operator_curvature, PolynomialParams, ShapeOperatorParams,
};

/// Error figures of an estimate against the exact field, over interior vertices.
#[derive(Debug)]
struct Errors {
    /// mean |k − k_true| / |k_true| over vertices where |k_true| > 1e-3 RMS(k_true).
    k_max_rel: f64,
    k_min_rel: f64,
    /// mean over both curvatures of |k − k_true|, divided by RMS(k_true).
    rel_mae: f64,
    /// mean angle (degrees) between estimated and exact t_max lines where
    /// (k_max − k_min) > 0.05 RMS(k_true).
    dir_deg: f64,
    /// mean |e − e_true| (e taken along the exact direction's orientation), divided by
    /// RMS(k_true)² (e has units of curvature per length).
    e_max_mae: f64,
    e_min_mae: f64,
    /// mean |n − n_true|.
    normal_err: f64,
}

fn errors(mesh: &TriMesh, est: &CurvatureField, exact: &CurvatureField) -> Errors {
    let topo = mesh.topology();
    let interior: Vec<usize> = (0..mesh.n_vertices())
        .filter(|&v| !topo.is_boundary_vertex[v])
        .collect();
    let m = interior.len() as f64;
    let rms = (interior
        .iter()
        .map(|&v| 0.5 * (exact.k_max[v].powi(2) + exact.k_min[v].powi(2)))
        .sum::<f64>()
        / m)
        .sqrt();
    let rel = |k: &[f64], t: &[f64]| {
        let vals: Vec<f64> = interior
            .iter()
            .filter(|&&v| t[v].abs() > 1e-3 * rms)
            .map(|&v| (k[v] - t[v]).abs() / t[v].abs())
            .collect();
        if vals.is_empty() {
            0.0
        } else {
            vals.iter().sum::<f64>() / vals.len() as f64
        }
    };
    let mut abs_sum = 0.0;
    let mut dir_sum = 0.0;
    let mut dir_n = 0usize;
    let mut e_max = 0.0;
    let mut e_min = 0.0;
    let mut normal_err = 0.0;
    for &v in &interior {
        abs_sum += (est.k_max[v] - exact.k_max[v]).abs() + (est.k_min[v] - exact.k_min[v]).abs();
        if (exact.k_max[v] - exact.k_min[v]) > 0.05 * rms {
            let c = vec3::dot(est.t_max[v], exact.t_max[v]).abs().min(1.0);
            dir_sum += c.acos().to_degrees();
            dir_n += 1;
        }
        let s_max = vec3::dot(est.t_max[v], exact.t_max[v]).signum();
        let s_min = vec3::dot(est.t_min[v], exact.t_min[v]).signum();
        e_max += (s_max * est.e_max[v] - exact.e_max[v]).abs();
        e_min += (s_min * est.e_min[v] - exact.e_min[v]).abs();
        normal_err += vec3::dist(est.normal[v], exact.normal[v]);
    }
    Errors {
        k_max_rel: rel(&est.k_max, &exact.k_max),
        k_min_rel: rel(&est.k_min, &exact.k_min),
        rel_mae: abs_sum / (2.0 * m) / rms,
        dir_deg: if dir_n > 0 {
            dir_sum / dir_n as f64
        } else {
            0.0
        },
        e_max_mae: e_max / m / (rms * rms),
        e_min_mae: e_min / m / (rms * rms),
        normal_err: normal_err / m,
    }
}

fn poly(mesh: &TriMesh) -> CurvatureField {
    polynomial_curvature(mesh, &PolynomialParams::default(), Par::Rayon)
        .unwrap()
        .field
}

fn shape_op(mesh: &TriMesh) -> CurvatureField {
    shape_operator_curvature(mesh, &ShapeOperatorParams::default(), Par::Rayon)
        .unwrap()
        .field
}

fn case(shape: &AnalyticShape, vertices: usize, jitter: f64) -> (TriMesh, CurvatureField) {
    let mesh = shape.mesh(vertices, jitter, 42).unwrap();
    let exact = analytic_curvature_field(&mesh, shape);
    (mesh, exact)
}

#[test]
fn sphere_both_methods() {
    let shape = AnalyticShape::Sphere { radius: 1.5 };
    let (mesh, exact) = case(&shape, 2562, 0.3);
    let p = errors(&mesh, &poly(&mesh), &exact);
    let s = errors(&mesh, &shape_op(&mesh), &exact);
    eprintln!("sphere\n  poly {p:?}\n  so   {s:?}");
    assert!(p.k_max_rel < 2e-3 && p.k_min_rel < 2e-3, "{p:?}");
    assert!(p.e_max_mae < 0.02 && p.e_min_mae < 0.02, "{p:?}");
    assert!(p.normal_err < 1e-4, "{p:?}");
    // With Max-weighted normals (exact on a sphere) the normal differences along every edge
    // are exactly e/r, so the discrete shape operator is exact up to rounding.
    assert!(s.k_max_rel < 1e-9 && s.k_min_rel < 1e-9, "{s:?}");
    assert!(s.e_max_mae < 1e-9 && s.e_min_mae < 1e-9, "{s:?}");
}

#[test]
fn open_cylinder_both_methods() {
    let shape = AnalyticShape::Cylinder {
        radius: 1.0,
        height: 4.0,
    };
    let (mesh, exact) = case(&shape, 3000, 0.3);
    let pf = poly(&mesh);
    let p = errors(&mesh, &pf, &exact);
    let s = errors(&mesh, &shape_op(&mesh), &exact);
    eprintln!("cylinder\n  poly {p:?}\n  so   {s:?}");
    assert!(p.k_max_rel < 5e-3 && p.rel_mae < 5e-3, "{p:?}");
    assert!(p.dir_deg < 0.5, "{p:?}");
    assert!(s.k_max_rel < 0.2 && s.dir_deg < 6.0, "{s:?}");
    // Rim vertices (one-sided neighbourhoods) still get finite values of the right sign.
    let topo = mesh.topology();
    for v in (0..mesh.n_vertices()).filter(|&v| topo.is_boundary_vertex[v]) {
        assert!(
            pf.k_max[v].is_finite() && pf.k_max[v] > 0.5,
            "rim vertex {v}: {}",
            pf.k_max[v]
        );
    }
}

#[test]
fn irregular_torus_both_methods() {
    let shape = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let (mesh, exact) = case(&shape, 6000, 0.35);
    let p = errors(&mesh, &poly(&mesh), &exact);
    let s = errors(&mesh, &shape_op(&mesh), &exact);
    eprintln!("torus\n  poly {p:?}\n  so   {s:?}");
    assert!(p.k_max_rel < 5e-3 && p.rel_mae < 5e-3, "{p:?}");
    assert!(p.dir_deg < 0.3, "{p:?}");
    assert!(p.e_max_mae < 0.05 && p.e_min_mae < 0.05, "{p:?}");
    assert!(s.rel_mae < 0.15 && s.dir_deg < 5.0, "{s:?}");
    // The polynomial fit beats the first-order operator on irregular samples by far.
    assert!(p.rel_mae * 10.0 < s.rel_mae);
}

#[test]
fn regular_torus_shape_operator_is_accurate() {
    // On a regular grid the per-face normal differences are symmetric and the shape operator
    // becomes accurate (errors cancel); this catches errors in the tensor rotation/weights.
    let shape = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let (mesh, exact) = case(&shape, 6000, 0.0);
    let s = errors(&mesh, &shape_op(&mesh), &exact);
    eprintln!("regular torus so {s:?}");
    assert!(s.rel_mae < 3e-3 && s.dir_deg < 0.2, "{s:?}");
}

#[test]
fn ellipsoid_curvature_and_extremality() {
    let shape = AnalyticShape::Ellipsoid {
        a: 3.0,
        b: 2.0,
        c: 1.0,
    };
    let (mesh, exact) = case(&shape, 10_242, 0.3);
    let pf = poly(&mesh);
    let p = errors(&mesh, &pf, &exact);
    let s = errors(&mesh, &shape_op(&mesh), &exact);
    eprintln!("ellipsoid\n  poly {p:?}\n  so   {s:?}");
    assert!(p.k_max_rel < 3e-3 && p.k_min_rel < 3e-3, "{p:?}");
    assert!(p.dir_deg < 0.2, "{p:?}");
    assert!(s.k_max_rel < 0.1 && s.dir_deg < 4.0, "{s:?}");
    // Extremality: compare with the exact e_max where it is large enough to have a sign.
    let rms_e = (exact.e_max.iter().map(|e| e * e).sum::<f64>() / exact.len() as f64).sqrt();
    let mut agree = 0usize;
    let mut total = 0usize;
    let mut rel_err = 0.0;
    for v in 0..mesh.n_vertices() {
        if exact.e_max[v].abs() > 0.2 * rms_e && !shape.is_umbilic(mesh.positions[v], 0.05) {
            let s = vec3::dot(pf.t_max[v], exact.t_max[v]).signum();
            total += 1;
            if (s * pf.e_max[v]) * exact.e_max[v] > 0.0 {
                agree += 1;
            }
            rel_err += (s * pf.e_max[v] - exact.e_max[v]).abs() / exact.e_max[v].abs();
        }
    }
    let rel_err = rel_err / total as f64;
    eprintln!("e_max sign agreement {agree}/{total}, mean rel error {rel_err}");
    assert!(total > 5000);
    assert_eq!(agree, total);
    assert!(rel_err < 0.05, "mean relative e_max error {rel_err}");
}

#[test]
fn scaling_and_rotation_act_as_expected() {
    // Scaling by s divides k by s and e by s²; a rotation rotates directions and normals.
    let shape = AnalyticShape::Ellipsoid {
        a: 1.5,
        b: 1.0,
        c: 0.6,
    };
    let mesh = shape.mesh(2562, 0.25, 9).unwrap();
    let base = poly(&mesh);
    let s = 7.0;
    let (c, sn) = (0.6f64, 0.8f64);
    let rot = |p: [f64; 3]| [c * p[0] - sn * p[1], sn * p[0] + c * p[1], p[2]];
    let moved = TriMesh::new(
        mesh.positions
            .iter()
            .map(|&p| vec3::scale(rot(p), s))
            .collect(),
        mesh.triangles.clone(),
    );
    let f = poly(&moved);
    for v in 0..mesh.n_vertices() {
        assert!((f.k_max[v] * s - base.k_max[v]).abs() < 1e-6 * base.k_max[v].abs().max(1.0));
        assert!((f.k_min[v] * s - base.k_min[v]).abs() < 1e-6 * base.k_max[v].abs().max(1.0));
        assert!(vec3::dist(f.normal[v], rot(base.normal[v])) < 1e-6);
        let d = vec3::dot(f.t_max[v], rot(base.t_max[v]));
        // Directions are lines; compare the extremality along the same orientation.
        assert!(d.abs() > 1.0 - 1e-6 || (base.k_max[v] - base.k_min[v]).abs() < 1e-3);
        if d.abs() > 1.0 - 1e-6 {
            let e = f.e_max[v] * d.signum() * s * s;
            assert!(
                (e - base.e_max[v]).abs() < 1e-5 * base.e_max[v].abs().max(1.0),
                "vertex {v}"
            );
        }
    }
}

#[test]
fn sequential_and_parallel_agree_bit_for_bit() {
    let shape = AnalyticShape::Torus {
        major: 2.0,
        minor: 0.8,
    };
    let mesh = shape.mesh(4000, 0.3, 3).unwrap();
    let p = PolynomialParams::default();
    let a = polynomial_curvature(&mesh, &p, Par::Seq).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let b = pool.install(|| polynomial_curvature(&mesh, &p, Par::Rayon).unwrap());
    assert_eq!(a, b);
    let q = ShapeOperatorParams::default();
    let a = shape_operator_curvature(&mesh, &q, Par::Seq).unwrap();
    let b = pool.install(|| shape_operator_curvature(&mesh, &q, Par::Rayon).unwrap());
    assert_eq!(a, b);
}

#[test]
fn directions_are_oriented_consistently() {
    // The torus' principal directions are orientable: after orientation no edge may join
    // vertices whose t_max point in opposite directions, unless the estimate itself is far off
    // there (a noisy direction cannot be made to agree with all its neighbours).
    let shape = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let mesh = shape.mesh(3000, 0.35, 4).unwrap();
    let exact = analytic_curvature_field(&mesh, &shape);
    let off = |f: &CurvatureField, v: usize| {
        vec3::dot(f.t_max[v], exact.t_max[v])
            .abs()
            .min(1.0)
            .acos()
            .to_degrees()
            > 30.0
    };
    let p = poly(&mesh);
    let s = shape_op(&mesh);
    for f in [&p, &s] {
        let obtuse: Vec<[u32; 2]> = mesh
            .topology()
            .edges
            .iter()
            .filter(|e| vec3::dot(f.t_max[e[0] as usize], f.t_max[e[1] as usize]) < 0.0)
            .copied()
            .collect();
        eprintln!("{}: {} obtuse edges", f.method, obtuse.len());
        for e in &obtuse {
            assert!(
                off(f, e[0] as usize) || off(f, e[1] as usize),
                "{} edge {e:?}",
                f.method
            );
        }
        for v in 0..f.len() {
            let frame = vec3::dot(vec3::cross(f.t_max[v], f.t_min[v]), f.normal[v]);
            assert!((frame - 1.0).abs() < 1e-9, "{} vertex {v}", f.method);
        }
    }
    assert!(mesh
        .topology()
        .edges
        .iter()
        .all(|e| vec3::dot(p.t_max[e[0] as usize], p.t_max[e[1] as usize]) > 0.0));
}
