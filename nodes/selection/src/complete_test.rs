//! Unit tests of `selection.complete` and its parts: grid origins, gaps, consolidation, and a
//! gapped 1-D grid completed from clusters given directly.

use std::collections::BTreeSet;

use crestflow_flow::Par;
use crestflow_geom::vec3::{dist, V3};
use crestflow_geom::{CurveLabel, FeatureCurveNetwork};
use crestflow_nodes_symmetry::{Generator, Orbit, Orbits};

use crate::complete::{best_offset, complete, gaps, CompleteError, CompleteParams};
use crate::consolidate::{consolidate, Poly};
use crate::curves::polyline_length;
use crate::model::{select_model, ModelParams, SelectedModel};
use crate::model_test::{add_curve, grid_clusters, shifted, wiggle, H};

#[test]
fn grid_origin_avoids_the_occupied_offsets() {
    // Points at fractional offsets 0.2..0.6 of the step: the emptiest bin is outside.
    let vals: Vec<f64> = (0..100)
        .map(|i| 3.0 + 0.2 + 0.4 * i as f64 / 100.0)
        .collect();
    let z = best_offset(&vals, 20);
    assert!(!(0.2..=0.6).contains(&z), "{z}");
}

#[test]
fn gaps_single_and_split() {
    let cells: BTreeSet<[i64; 2]> = [[0, 0], [1, 0], [3, 0], [6, 0]].into_iter().collect();
    let (empty, splits, singles) = gaps(&cells, 1, 0);
    // Empty: 2 (single gap between 1 and 3), 4 and 5 (a run of two: one split).
    assert_eq!(empty, 3);
    assert_eq!(singles, vec![[2, 0]]);
    assert_eq!(splits, 1);
    // A rotation of order 5 with cells 0, 1, 3: cells 2 and 4 are single gaps (4 wraps to 0).
    let cells: BTreeSet<[i64; 2]> = [[0, 0], [1, 0], [3, 0]].into_iter().collect();
    let (empty, _, singles) = gaps(&cells, 1, 5);
    assert_eq!(empty, 2);
    assert_eq!(singles, vec![[2, 0], [4, 0]]);
}

fn poly(pts: Vec<V3>) -> Poly {
    let n = pts.len();
    Poly {
        pts,
        strength: vec![1.0; n],
        closed: false,
        label: CurveLabel::Ridge,
    }
}

#[test]
fn consolidation_joins_overlapping_pieces_into_one_curve() {
    // The x axis from 0 to 10 in three overlapping noisy pieces; the longest shortest path
    // runs from 0 to 10, the rest is redundant.
    let line = |a: f64, b: f64, y: f64| -> Vec<V3> {
        let n = ((b - a) / 0.1).round() as usize;
        (0..=n).map(|i| [a + 0.1 * i as f64, y, 0.0]).collect()
    };
    let polys = vec![
        poly(line(0.0, 4.0, 0.02)),
        poly(line(3.0, 7.5, -0.03)),
        poly(line(6.0, 10.0, 0.01)),
        poly(line(2.0, 5.0, 0.0)),
    ];
    let out = consolidate(&polys, 0.2, 0.5);
    assert_eq!(out.len(), 1, "{out:?}");
    let p = &out[0].pts;
    let (a, b) = (
        p[0][0].min(p[p.len() - 1][0]),
        p[0][0].max(p[p.len() - 1][0]),
    );
    assert!(a < 0.05 && b > 9.95, "{a} {b}");
    let l = polyline_length(p, false);
    assert!((l - 10.0).abs() < 0.3, "{l}");
}

#[test]
fn consolidation_keeps_separate_curves_apart() {
    let line = |y: f64| -> Vec<V3> { (0..=50).map(|i| [0.1 * i as f64, y, 0.0]).collect() };
    let out = consolidate(&[poly(line(0.0)), poly(line(1.0))], 0.2, 0.5);
    assert_eq!(out.len(), 2);
}

/// Four copies of the wiggle and a second curve per cell along g = (0, 2, 0); copy 1 of the
/// wiggle is cut in two with a gap, copy 2 of the second curve is missing; two noise curves.
fn gapped_network() -> (FeatureCurveNetwork, Vec<Vec<V3>>) {
    let w = wiggle();
    let second: Vec<V3> = (0..=80)
        .map(|i| {
            let s = i as f64 * 0.05;
            [
                0.5 + 0.8 * s,
                0.6 + 0.2 * (1.7 * s).sin(),
                0.9 + 0.3 * (1.1 * s).cos(),
            ]
        })
        .collect();
    let mut net = FeatureCurveNetwork::default();
    let mut truth = Vec::new();
    for k in 0..4 {
        let t = [0.0, 2.0 * k as f64, 0.0];
        let a = shifted(&w, t);
        let b = shifted(&second, t);
        truth.push(a.clone());
        truth.push(b.clone());
        if k == 1 {
            add_curve(&mut net, &a[..40], 1.0);
            add_curve(&mut net, &a[55..], 1.0);
        } else {
            add_curve(&mut net, &a, 1.0);
        }
        if k != 2 {
            add_curve(&mut net, &b, 0.5);
        }
    }
    add_curve(&mut net, &[[1.0, -1.0, 0.0], [1.2, -1.0, 0.05]], 2.0);
    add_curve(
        &mut net,
        &[[3.0, 9.0, 0.0], [3.1, 9.2, 0.0], [3.2, 9.3, 0.1]],
        0.1,
    );
    (net, truth)
}

fn grid_orbit(g: V3) -> Orbits {
    Orbits {
        orbits: vec![Orbit {
            generator: Generator::Translation { steps: vec![g] },
            instances: 4,
            clusters: vec![0, 1, 2, 3],
            curves: vec![],
            support: 500.0,
        }],
    }
}

/// Length of `a` within `tol` of the polylines `b` (sampled every 0.01).
fn covered(a: &[Vec<V3>], b: &[Vec<V3>], tol: f64) -> (f64, f64) {
    let mut total = 0.0;
    let mut hit = 0.0;
    for pl in a {
        for w in pl.windows(2) {
            let l = dist(w[0], w[1]);
            let mid = [
                0.5 * (w[0][0] + w[1][0]),
                0.5 * (w[0][1] + w[1][1]),
                0.5 * (w[0][2] + w[1][2]),
            ];
            total += l;
            if b.iter().any(|q| q.iter().any(|p| dist(*p, mid) <= tol)) {
                hit += l;
            }
        }
    }
    (hit, total)
}

fn model_for(net: &FeatureCurveNetwork, g: V3) -> SelectedModel {
    let orbits = grid_orbit(g);
    select_model(
        net,
        &grid_clusters(g),
        Some(&orbits),
        &ModelParams::default(),
        Par::Seq,
    )
    .unwrap()
}

#[test]
fn gapped_grid_is_completed_and_noise_removed() {
    let (net, truth) = gapped_network();
    let g = [0.0, 2.0, 0.0];
    let model = model_for(&net, g);
    let c = complete(&net, &model, &CompleteParams::default(), Par::Seq).unwrap();
    // The two noise curves and the first piece of the cut copy (about 21 h, below l0 = 25 h;
    // the second piece is just long enough to reoccur).
    assert_eq!(c.noise_curves_removed, 3);
    assert_eq!(model.assignment[2], None);
    assert!(model.assignment[3].is_some());
    assert_eq!(c.strong_curves_kept, 0);
    assert_eq!(c.per_template.len(), 1);
    let t = &c.per_template[0];
    assert_eq!(t.cells.len(), 4, "{:?}", t.cells);
    assert_eq!(t.curves.curves.len(), 2, "{:?}", t.curves.curves.len());
    assert_eq!(c.network.curves.len(), 8);
    let out: Vec<Vec<V3>> = (0..c.network.curves.len())
        .map(|k| c.network.curve_points(k))
        .collect();
    let (hit, total) = covered(&truth, &out, 2.0 * H);
    assert!(hit / total > 0.97, "recall {}", hit / total);
    let (hit, total) = covered(&out, &truth, 2.0 * H);
    assert!(hit / total > 0.97, "precision {}", hit / total);
}

#[test]
fn sequential_and_parallel_agree() {
    let (net, _) = gapped_network();
    let model = model_for(&net, [0.0, 2.0, 0.0]);
    let a = complete(&net, &model, &CompleteParams::default(), Par::Seq).unwrap();
    let b = complete(&net, &model, &CompleteParams::default(), Par::Rayon).unwrap();
    assert_eq!(a, b);
}

#[test]
fn errors_name_the_problem() {
    let (net, _) = gapped_network();
    let model = model_for(&net, [0.0, 2.0, 0.0]);
    let p = CompleteParams {
        epsilon: 0.0,
        ..Default::default()
    };
    let e = complete(&net, &model, &p, Par::Seq).unwrap_err();
    assert!(
        matches!(e, CompleteError::Params(ref s) if s.contains("epsilon")),
        "{e}"
    );

    let mut fewer = net.clone();
    fewer.curves.pop();
    let e = complete(&fewer, &model, &CompleteParams::default(), Par::Seq).unwrap_err();
    assert_eq!(
        e,
        CompleteError::CurveCount {
            model: net.curves.len(),
            network: net.curves.len() - 1
        }
    );

    let mut bad = model.clone();
    bad.assignment[0] = Some(7);
    let e = complete(&net, &bad, &CompleteParams::default(), Par::Seq).unwrap_err();
    assert_eq!(
        e,
        CompleteError::Candidate {
            curve: 0,
            candidate: 7,
            n: 1
        }
    );

    let mut bad = model.clone();
    let m = net.curves.len();
    bad.partners[1][0].curve = 99;
    let e = complete(&net, &bad, &CompleteParams::default(), Par::Seq).unwrap_err();
    assert_eq!(
        e,
        CompleteError::Partner {
            curve: 1,
            partner: 99,
            n: m
        }
    );

    let mut bad = model;
    bad.unit = f64::NAN;
    let e = complete(&net, &bad, &CompleteParams::default(), Par::Seq).unwrap_err();
    assert!(matches!(e, CompleteError::NoScale(_)), "{e}");
}

#[test]
fn sheared_basis_is_reduced() {
    let r = crate::curves::reduce_basis(&[[-6.0, 5.0, 0.0], [12.0, -5.0, 0.0]]);
    let mut n: Vec<(f64, f64)> = r.iter().map(|v| (v[0].abs(), v[1].abs())).collect();
    n.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(n, vec![(0.0, 5.0), (6.0, 0.0)]);
    // A genuinely sheared lattice stays sheared (already reduced).
    let r = crate::curves::reduce_basis(&[[3.1, 0.0, 0.0], [0.3, 3.4, 0.0]]);
    assert_eq!(r, vec![[3.1, 0.0, 0.0], [0.3, 3.4, 0.0]]);
}

#[test]
fn mirrored_pair_completes_the_broken_copy() {
    use crestflow_nodes_symmetry::{RigidTransform, TransformCluster, TransformClusters};
    // A = wiggle moved to x in [1, 6]; B = its mirror image in the plane x = 0, with a gap.
    let a = shifted(&wiggle(), [1.0, 0.0, 0.0]);
    let b: Vec<V3> = a.iter().map(|p| [-p[0], p[1], p[2]]).collect();
    let mut net = FeatureCurveNetwork::default();
    add_curve(&mut net, &a, 1.0);
    add_curve(&mut net, &b[..45], 1.0);
    add_curve(&mut net, &b[60..], 1.0);
    // The reflection as the symmetry family stores it: identity ∘ M with M the mirror x = 0.
    let clusters = TransformClusters {
        unit: H,
        mirror_x: 0.0,
        clusters: vec![TransformCluster {
            mirrored: true,
            transform: RigidTransform::identity(),
            members: vec![],
            support: 100.0,
            pairs: 1,
        }],
    };
    let orbits = Orbits {
        orbits: vec![Orbit {
            generator: Generator::Reflection {
                normal: [1.0, 0.0, 0.0],
                offset: 0.0,
            },
            instances: 2,
            clusters: vec![0],
            curves: vec![],
            support: 100.0,
        }],
    };
    let p = ModelParams {
        l0: 10.0,
        ..Default::default()
    };
    let model = select_model(&net, &clusters, Some(&orbits), &p, Par::Seq).unwrap();
    assert_eq!(model.kept, vec![0]);
    assert!(
        model.assignment.iter().all(|a| *a == Some(0)),
        "{:?}",
        model.assignment
    );
    let c = complete(&net, &model, &CompleteParams::default(), Par::Seq).unwrap();
    assert_eq!(c.per_template.len(), 1);
    assert_eq!(c.per_template[0].cells.len(), 2);
    let out: Vec<Vec<V3>> = (0..c.network.curves.len())
        .map(|k| c.network.curve_points(k))
        .collect();
    let truth = vec![a.clone(), b.clone()];
    let (hit, total) = covered(&truth, &out, 2.0 * H);
    assert!(hit / total > 0.97, "recall {}", hit / total);
    let (hit, total) = covered(&out, &truth, 2.0 * H);
    assert!(hit / total > 0.97, "precision {}", hit / total);
}

#[test]
fn copies_reaching_into_neighbouring_cells_are_merged() {
    use crate::complete::{make_cells, place_template};
    // A rotation of order 10 about the z axis; the template holds a ring around the axis
    // (every copy lies on it) and one short arc per tooth, 0.3 away from the ring.
    let gen = Generator::Rotation {
        axis: [0.0, 0.0, 1.0],
        center: [0.0, 0.0, 0.0],
        angle_deg: 36.0,
        order: 10,
    };
    let ring: Vec<V3> = (0..360)
        .map(|i| {
            let a = (i as f64).to_radians();
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    let arc: Vec<V3> = (0..=20)
        .map(|i| {
            let a = (5.0 + 0.5 * i as f64).to_radians();
            [1.3 * a.cos(), 1.3 * a.sin(), 0.0]
        })
        .collect();
    let cells = make_cells(Some(&gen), &arc, 36);
    let mut closed_ring = poly(ring);
    closed_ring.closed = true;
    let template = vec![closed_ring, poly(arc)];
    let all: Vec<[i64; 2]> = (0..10).map(|k| [k, 0]).collect();
    let placed = place_template(&template, &cells, all.into_iter(), 0.05, 0.1);
    // One ring (not ten on top of each other) and ten arcs.
    let on_circle = |p: &&Poly, r: f64| {
        p.pts
            .iter()
            .all(|q| ((q[0] * q[0] + q[1] * q[1]).sqrt() - r).abs() < 1e-9)
    };
    let rings = placed.iter().filter(|p| on_circle(p, 1.0)).count();
    let arcs = placed.iter().filter(|p| on_circle(p, 1.3)).count();
    assert_eq!((rings, arcs, placed.len()), (1, 10, 11));
    let ring_len: f64 = placed
        .iter()
        .filter(|p| on_circle(p, 1.0))
        .map(|p| polyline_length(&p.pts, p.closed))
        .sum();
    assert!(
        (ring_len - std::f64::consts::TAU).abs() < 0.02,
        "{ring_len}"
    );
}
