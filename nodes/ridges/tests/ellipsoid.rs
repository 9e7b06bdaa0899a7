//! Ridges of a triaxial ellipsoid x²/a² + y²/b² + z²/c² = 1 (a > b > c) from its exact
//! curvature field.
//!
//! The three principal ellipses are its extremal lines; which of them Def. 2.2 accepts follows
//! from the curvatures at the axis points (outward normals, both curvatures positive):
//!
//! - z = 0 (semi-axes a, b): the crossing direction z carries k_max everywhere (at (a,0,0):
//!   a/c² across vs a/b² along), and across the ellipse k_max is largest on it (the y = 0 and
//!   x = 0 sections are most curved at their a- and b-ends). Positive maxima of k_max with
//!   k_max > |k_min|: a **ridge** of Def. 2.2, the whole ellipse.
//! - y = 0 (semi-axes a, c): holds the four umbilics. Near (±a,0,0) the crossing direction y
//!   carries k_min, which is *largest* there (a maximum of k_min); near (0,0,±c) it carries
//!   k_max, which is *smallest* there (c/b² is the flattest point of the x = 0 section). Neither
//!   is a positive maximum of k_max nor a negative minimum of k_min: not a feature of Def. 2.2.
//! - x = 0 (semi-axes b, c): the crossing direction x carries k_min, smallest there but
//!   positive: a minimum of k_min that is not negative, so not a ravine of Def. 2.2.
//!
//! So Def. 2.2 yields one ridge (the a-b ellipse) and no ravines; the general `Extrema`
//! definition (every extremum of either curvature) yields all three ellipses: the a-b one as an
//! extremum of k_max, the b-c one as an extremum of k_min, and the a-c one split at the
//! umbilics into k_max-extremum arcs (around the c-axis) and k_min-extremum arcs (around the
//! a-axis).

mod common;

use std::f64::consts::PI;

use common::*;
use crestflow_flow::Par;
use crestflow_geom::shapes::{analytic_curvature_field, AnalyticShape};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{CurvatureField, CurveLabel, SurfacePoint, TriMesh};
use crestflow_nodes_ridges::{trace, Definition, TraceParams};

const A: f64 = 3.0;
const B: f64 = 2.0;
const C: f64 = 1.0;

fn ellipse(axis_a: usize, sa: f64, axis_b: usize, sb: f64) -> Vec<V3> {
    let n = 4000;
    (0..n)
        .map(|i| {
            let t = 2.0 * PI * i as f64 / n as f64;
            let mut p = [0.0; 3];
            p[axis_a] = sa * t.cos();
            p[axis_b] = sb * t.sin();
            p
        })
        .collect()
}

fn setup() -> (TriMesh, CurvatureField) {
    let shape = AnalyticShape::Ellipsoid { a: A, b: B, c: C };
    // Irregular sampling: jittered icosphere, no vertex exactly on a symmetry plane.
    let mesh = shape.mesh(10242, 0.3, 11).unwrap();
    let field = analytic_curvature_field(&mesh, &shape);
    (mesh, field)
}

/// The same ellipsoid seen from inside (normals flipped): curvatures change sign and swap.
fn inside_out(field: &CurvatureField) -> CurvatureField {
    CurvatureField {
        k_max: field.k_min.iter().map(|k| -k).collect(),
        k_min: field.k_max.iter().map(|k| -k).collect(),
        t_max: field.t_min.clone(),
        t_min: field.t_max.clone(),
        normal: field.normal.iter().map(|&n| vec3::scale(n, -1.0)).collect(),
        e_max: field.e_min.iter().map(|e| -e).collect(),
        e_min: field.e_max.iter().map(|e| -e).collect(),
        method: "analytic.inside_out".into(),
    }
}

#[test]
fn thesis_definition_gives_exactly_the_ab_ellipse_as_ridge() {
    let (mesh, field) = setup();
    let tol = 0.01 * mesh.bbox_diagonal();
    let xy = ellipse(0, A, 1, B);
    let out = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap();
    let net = &out.network;

    assert_eq!(
        out.stats.ravines, 0,
        "a convex surface has no ravines under Def. 2.2"
    );
    let ridges = segments(net, Some(CurveLabel::Ridge));
    let cov = coverage(&xy, &ridges, tol);
    assert!(cov >= 0.9, "a-b ellipse covered {cov}");
    // Every traced point lies on that ellipse (none on the other two).
    for v in &net.vertices {
        let d = dist_to_polyline(v.position, &xy);
        assert!(
            d <= tol,
            "vertex {:?} is {d} from the a-b ellipse",
            v.position
        );
        assert!(matches!(
            v.location,
            SurfacePoint::Edge { .. } | SurfacePoint::Face { .. }
        ));
    }
    assert!(coverage(&ellipse(0, A, 2, C), &ridges, tol) < 0.1);
    assert!(coverage(&ellipse(1, B, 2, C), &ridges, tol) < 0.1);
    // Its length is the ellipse's (Ramanujan: 15.865 for 3, 2) within the tolerance band.
    let h = ((A - B) / (A + B)).powi(2);
    let perimeter = PI * (A + B) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()));
    let len = out.stats.ridge_length;
    assert!(
        (len - perimeter).abs() < 0.02 * perimeter,
        "ridge length {len} vs {perimeter}"
    );
    // The strength along it is k_max there: between the curvatures across at its ends.
    for v in &net.vertices {
        let (lo, hi) = (B / (C * C) * 0.98, A / (C * C) * 1.02);
        assert!(
            v.strength > lo && v.strength < hi,
            "strength {}",
            v.strength
        );
    }
}

#[test]
fn inside_out_ellipsoid_gives_the_ab_ellipse_as_ravine() {
    let (mesh, field) = setup();
    let tol = 0.01 * mesh.bbox_diagonal();
    let out = trace(
        &mesh,
        &inside_out(&field),
        &TraceParams::default(),
        Par::Rayon,
    )
    .unwrap();
    assert_eq!(out.stats.ridges, 0);
    let ravines = segments(&out.network, Some(CurveLabel::Ravine));
    let xy = ellipse(0, A, 1, B);
    assert!(coverage(&xy, &ravines, tol) >= 0.9);
    assert!(out
        .network
        .vertices
        .iter()
        .all(|v| dist_to_polyline(v.position, &xy) <= tol));
}

#[test]
fn extrema_definition_gives_all_three_principal_ellipses() {
    let (mesh, field) = setup();
    let tol = 0.01 * mesh.bbox_diagonal();
    let params = TraceParams {
        definition: Definition::Extrema,
        min_strength: 0.0,
        min_cyclideness: 0.0,
        ..Default::default()
    };
    let out = trace(&mesh, &field, &params, Par::Rayon).unwrap();
    let net = &out.network;
    let ells = [
        ellipse(0, A, 1, B),
        ellipse(0, A, 2, C),
        ellipse(1, B, 2, C),
    ];
    let all = segments(net, None);
    for (i, e) in ells.iter().enumerate() {
        let cov = coverage(e, &all, tol);
        assert!(cov >= 0.9, "ellipse {i} covered {cov}");
    }
    for v in &net.vertices {
        let d = ells
            .iter()
            .map(|e| dist_to_polyline(v.position, e))
            .fold(f64::INFINITY, f64::min);
        assert!(
            d <= tol,
            "vertex {:?} is {d} from every principal ellipse",
            v.position
        );
    }
    // Which family traces which ellipse.
    let ridges = segments(net, Some(CurveLabel::Ridge));
    let ravines = segments(net, Some(CurveLabel::Ravine));
    assert!(
        coverage(&ells[0], &ridges, tol) >= 0.9,
        "a-b: extremum of k_max"
    );
    assert!(
        coverage(&ells[2], &ravines, tol) >= 0.9,
        "b-c: extremum of k_min"
    );
    let (r, v) = (
        coverage(&ells[1], &ridges, tol),
        coverage(&ells[1], &ravines, tol),
    );
    assert!(
        r > 0.2 && v > 0.2,
        "a-c is split between the families: {r} / {v}"
    );
}

#[test]
fn sequential_and_parallel_agree_bit_for_bit() {
    let (mesh, field) = setup();
    for definition in [Definition::Thesis, Definition::Extrema] {
        let p = TraceParams {
            definition,
            min_strength: 0.0,
            min_cyclideness: 0.0,
            min_length: 0.0,
            ..Default::default()
        };
        let seq = trace(&mesh, &field, &p, Par::Seq).unwrap();
        let par = trace(&mesh, &field, &p, Par::Rayon).unwrap();
        assert!(!seq.network.curves.is_empty());
        assert_eq!(seq, par);
        let bits = |o: &crestflow_nodes_ridges::TraceOutput| -> Vec<u64> {
            o.network
                .vertices
                .iter()
                .flat_map(|v| {
                    v.position
                        .map(f64::to_bits)
                        .into_iter()
                        .chain([v.strength.to_bits()])
                })
                .collect()
        };
        assert_eq!(bits(&seq), bits(&par));
    }
}

#[test]
fn exact_sphere_and_cylinder_have_no_ridges() {
    // Every point of a sphere is umbilic; the cylinder's curvatures are constant along its
    // curvature lines (e = 0): neither has an extremum to trace.
    for shape in [
        AnalyticShape::Sphere { radius: 1.5 },
        AnalyticShape::Cylinder {
            radius: 1.0,
            height: 3.0,
        },
    ] {
        let mesh = shape.mesh(3000, 0.3, 5).unwrap();
        let field = analytic_curvature_field(&mesh, &shape);
        let p = TraceParams {
            min_strength: 0.0,
            min_cyclideness: 0.0,
            min_length: 0.0,
            ..Default::default()
        };
        let out = trace(&mesh, &field, &p, Par::Rayon).unwrap();
        assert!(out.network.curves.is_empty(), "{shape:?}: {:?}", out.stats);
    }
}
