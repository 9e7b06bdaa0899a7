//! A synthetic smooth crease z = ∓sqrt(x² + δ²) on a jittered open grid: one ridge (or ravine)
//! along x = 0 from boundary to boundary, with strength 1/δ.

mod common;

use common::*;
use crestflow_flow::Par;
use crestflow_geom::{CurveLabel, SurfacePoint};
use crestflow_nodes_ridges::{trace, Families, TraceParams};

const N: usize = 41;
const DELTA: f64 = 0.2;

fn check_single_curve_on_axis(s: f64, label: CurveLabel) {
    let profile = crease(s, DELTA);
    let mesh = profile.mesh(N, 0.3, 3);
    let field = profile.field(&mesh);
    let h = 2.0 / (N - 1) as f64;
    let out = trace(&mesh, &field, &TraceParams::default(), Par::Rayon).unwrap();
    let net = &out.network;
    assert_eq!(net.curves.len(), 1, "{:?}", out.stats);
    let curve = &net.curves[0];
    assert_eq!(curve.label, label);
    assert!(!curve.closed);
    // Ends on the boundary y = ±1 (the open grid's boundary edges carry the end points).
    let first = net.vertices[curve.vertices[0] as usize].position;
    let last = net.vertices[*curve.vertices.last().unwrap() as usize].position;
    assert!((first[1].abs() - 1.0).abs() < 1e-9 && (last[1].abs() - 1.0).abs() < 1e-9);
    assert!(first[1] * last[1] < 0.0);
    // On the axis: each point sits on an edge straddling x = 0, within the error bound of
    // linear interpolation of e along that edge.
    for v in &net.vertices {
        let SurfacePoint::Edge { a, b, .. } = v.location else {
            panic!("{:?}", v.location)
        };
        let (xa, xb) = (mesh.positions[a as usize][0], mesh.positions[b as usize][0]);
        assert!(
            xa * xb < 0.0,
            "edge ({xa}, {xb}) does not straddle the crease"
        );
        let bound = profile.interpolation_bound(xa, xb, 0.0);
        let x = v.position[0];
        assert!(
            x.abs() <= bound * 1.01 + 1e-12,
            "x = {x}, bound {bound} (h = {h})"
        );
        // The strength interpolates |κ| between the edge's ends: at most the crest value 1/δ,
        // at least the smaller end value.
        let lo = profile.kappa(xa).abs().min(profile.kappa(xb).abs());
        let k0 = 1.0 / DELTA;
        assert!(
            v.strength <= k0 * (1.0 + 1e-9) && v.strength >= lo * (1.0 - 1e-9),
            "strength {}",
            v.strength
        );
    }
    // Covers the whole axis: its length is at least the grid's height.
    assert!(out.stats.ridge_length + out.stats.ravine_length >= 2.0);
    // The other family (and the other label) is empty.
    let only_other = TraceParams {
        families: if label == CurveLabel::Ridge {
            Families::Ravines
        } else {
            Families::Ridges
        },
        ..Default::default()
    };
    assert!(trace(&mesh, &field, &only_other, Par::Seq)
        .unwrap()
        .network
        .curves
        .is_empty());
}

#[test]
fn convex_crease_is_one_ridge() {
    check_single_curve_on_axis(-1.0, CurveLabel::Ridge);
}

#[test]
fn concave_crease_is_one_ravine() {
    check_single_curve_on_axis(1.0, CurveLabel::Ravine);
}

/// Two creases, a sharp one at x = −0.5 (|κ| = 1/0.05) and a soft one at x = +0.5 (1/0.3).
fn two_creases() -> Profile<impl Fn(f64) -> (f64, f64, f64)> {
    Profile(|x: f64| {
        let (d1, d2) = (0.05, 0.3);
        let (u, w) = (x + 0.5, x - 0.5);
        let (r1, r2) = ((u * u + d1 * d1).sqrt(), (w * w + d2 * d2).sqrt());
        (
            -r1 - r2,
            -u / r1 - w / r2,
            -d1 * d1 / r1.powi(3) - d2 * d2 / r2.powi(3),
        )
    })
}

#[test]
fn strength_filter_keeps_the_sharp_crease() {
    let profile = two_creases();
    let mesh = profile.mesh(61, 0.3, 9);
    let field = profile.field(&mesh);
    let all = trace(
        &mesh,
        &field,
        &TraceParams {
            min_strength: 0.0,
            min_cyclideness: 0.0,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    // The true ridges: maxima of κ, shifted from ±0.5 by the slope of the other crease.
    let maxima = profile.extrema();
    assert_eq!(maxima.len(), 2, "{maxima:?}");
    let h = 2.0 / 60.0;
    let xs: Vec<f64> = all
        .network
        .curves
        .iter()
        .map(|c| all.network.vertices[c.vertices[0] as usize].position[0])
        .collect();
    assert_eq!(xs.len(), 2, "{:?}", all.stats);
    for m in &maxima {
        assert!(
            xs.iter().any(|x| (x - m).abs() < 0.5 * h),
            "no curve at {m}: {xs:?}"
        );
    }

    // A threshold between the two sharpnesses (≈20 and ≈3.3), in units of the median.
    let scale = all.stats.curvature_scale;
    let strong = trace(
        &mesh,
        &field,
        &TraceParams {
            min_strength: 8.0 / scale,
            min_cyclideness: 0.0,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    assert_eq!(strong.network.curves.len(), 1);
    assert_eq!(strong.stats.removed_weak, 1);
    let x = strong.network.vertices[0].position[0];
    assert!(
        (x - maxima[0]).abs() < 0.5 * h,
        "kept the curve at x = {x}, sharp crease at {}",
        maxima[0]
    );

    // Cyclideness: the sharp crease changes curvature far faster across itself, so a
    // threshold of 8 keeps it and drops the soft one.
    let p = TraceParams {
        min_strength: 0.0,
        min_cyclideness: 8.0,
        ..Default::default()
    };
    let cyc = trace(&mesh, &field, &p, Par::Rayon).unwrap();
    assert_eq!(
        (cyc.network.curves.len(), cyc.stats.removed_cyclide),
        (1, 1)
    );
    let x = cyc.network.vertices[0].position[0];
    assert!((x - maxima[0]).abs() < 0.5 * h);
    let huge = trace(
        &mesh,
        &field,
        &TraceParams {
            min_strength: 0.0,
            min_cyclideness: 1e9,
            ..Default::default()
        },
        Par::Rayon,
    )
    .unwrap();
    assert!(huge.network.curves.is_empty());
    assert_eq!(huge.stats.removed_cyclide, 2);
}

#[test]
fn min_length_removes_curves_shorter_than_asked() {
    let profile = crease(-1.0, DELTA);
    let mesh = profile.mesh(N, 0.3, 3);
    let field = profile.field(&mesh);
    let mean_edge = mesh.mean_edge_length();
    // The crease is about 2 long: kept at 2/mean_edge · 0.9, removed at · 1.1.
    let l = 2.0 / mean_edge;
    let keep = trace(
        &mesh,
        &field,
        &TraceParams {
            min_length: 0.9 * l,
            ..Default::default()
        },
        Par::Seq,
    )
    .unwrap();
    assert_eq!(keep.network.curves.len(), 1);
    let len = keep.stats.ridge_length;
    let drop = trace(
        &mesh,
        &field,
        &TraceParams {
            min_length: 1.01 * len / mean_edge,
            ..Default::default()
        },
        Par::Seq,
    )
    .unwrap();
    assert!(drop.network.curves.is_empty());
    assert_eq!(drop.stats.removed_short, 1);
}
