//! Ridge tracing on curvature *estimated* by `curvature.polynomial` (not the exact field):
//! noise lines on surfaces without ridges are filtered out by default, and the ellipsoid's
//! ridge survives estimation.

mod common;

use common::*;
use crestflow_flow::Par;
use crestflow_geom::shapes::AnalyticShape;
use crestflow_geom::CurveLabel;
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};

#[test]
fn no_ridges_on_estimated_sphere_cylinder_torus() {
    let shapes = [
        AnalyticShape::Sphere { radius: 1.0 },
        AnalyticShape::Cylinder {
            radius: 1.0,
            height: 3.0,
        },
        AnalyticShape::Torus {
            major: 2.0,
            minor: 0.7,
        },
    ];
    for shape in shapes {
        let mesh = shape.mesh(4000, 0.3, 21).unwrap();
        let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
            .unwrap()
            .field;
        let raw = trace(
            &mesh,
            &field,
            &TraceParams {
                min_strength: 0.0,
                min_cyclideness: 0.0,
                min_length: 0.0,
                ..Default::default()
            },
            Par::Rayon,
        )
        .unwrap();
        let out = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap();
        println!(
            "{shape:?}: unfiltered {:?}\n  default {:?}",
            raw.stats, out.stats
        );
        assert!(out.network.curves.is_empty(), "{shape:?}: {:?}", out.stats);
        // Either filter alone removes them: the lines are not sharper than the surface around
        // them, and the surface is a Dupin cyclide (small cyclideness integral).
        let by_cyclideness = trace(
            &mesh,
            &field,
            &TraceParams {
                min_strength: 0.0,
                ..Default::default()
            },
            Par::Rayon,
        )
        .unwrap();
        assert!(
            by_cyclideness.network.curves.is_empty(),
            "{shape:?}: {:?}",
            by_cyclideness.stats
        );
        if raw.network.curves.is_empty() {
            // The sphere: every vertex is (numerically) umbilic and skipped.
            assert_eq!(raw.stats.ridge_points + raw.stats.ravine_points, 0);
        }
    }
}

#[test]
fn estimated_ellipsoid_ridge_is_the_ab_ellipse() {
    let (a, b, c) = (3.0, 2.0, 1.0);
    let shape = AnalyticShape::Ellipsoid { a, b, c };
    let mesh = shape.mesh(10242, 0.3, 11).unwrap();
    let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
        .unwrap()
        .field;
    let out = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap();
    let tol = 0.01 * mesh.bbox_diagonal();
    let n = 4000;
    let xy: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            [a * t.cos(), b * t.sin(), 0.0]
        })
        .collect();
    let ridges = segments(&out.network, Some(CurveLabel::Ridge));
    let cov = coverage(&xy, &ridges, tol);
    let far = out
        .network
        .vertices
        .iter()
        .filter(|v| dist_to_polyline(v.position, &xy) > tol)
        .count();
    println!(
        "{:?}\ncoverage {cov}, far {far} of {}",
        out.stats,
        out.network.vertices.len()
    );
    assert!(cov >= 0.9, "coverage {cov}");
    assert_eq!(far, 0);
}
