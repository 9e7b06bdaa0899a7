//! The angle intervals and the configuration tests of Fig. 4.9 on hand-computed cases.

use crate::conflicts::{
    find_conflicts, nonadjacent_conflict, segment_distance, ConflictKind, Scale,
};
use crestflow_flow::Par;

fn deg(x: f64) -> f64 {
    x.to_radians()
}

#[test]
fn angle_intervals_for_aspect_1_5_merge_into_one() {
    let s = Scale::new(1.0, 1.5);
    // θ_min from triangle type (b): 2 asin(1/3) = 38.94°; θ_max = 2 asin(0.75) = 97.18°.
    assert!((s.theta_min - 2.0 * (1.0f64 / 3.0).asin()).abs() < 1e-12);
    assert!((s.theta_max - 2.0 * 0.75f64.asin()).abs() < 1e-12);
    assert_eq!(s.angles.len(), 1);
    assert!((s.angles[0].1 - std::f64::consts::PI).abs() < 1e-12);
    assert!(!s.angle_ok(deg(38.0)) && s.angle_ok(deg(39.0)) && s.angle_ok(deg(180.0)));
}

#[test]
fn angle_intervals_for_aspect_1_1_are_three() {
    let s = Scale::new(2.0, 1.1);
    // θ_min = min(acos 0.55, 2 asin(1/2.2)) = 54.071°, θ_max = 2 asin 0.55 = 66.734°.
    assert!((s.theta_min.to_degrees() - 54.07138).abs() < 1e-4);
    assert!((s.theta_max.to_degrees() - 66.73403).abs() < 1e-4);
    assert_eq!(s.angles.len(), 3);
    for (a, ok) in [
        (60.0, true),
        (90.0, false),
        (120.0, true),
        (150.0, false),
        (170.0, true),
    ] {
        assert_eq!(s.angle_ok(deg(a)), ok, "{a}°");
    }
}

#[test]
fn segment_distances() {
    // Skew perpendicular segments crossing 0.3 apart.
    let d = segment_distance(
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [1.0, -1.0, 0.3],
        [1.0, 1.0, 0.3],
    );
    assert!((d - 0.3).abs() < 1e-12);
    // Collinear with a gap of 0.5.
    let d = segment_distance(
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.5, 0.0, 0.0],
        [3.0, 0.0, 0.0],
    );
    assert!((d - 0.5).abs() < 1e-12);
    // Parallel, overlapping, 0.25 apart.
    let d = segment_distance(
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.5, 0.25, 0.0],
        [1.5, 0.25, 0.0],
    );
    assert!((d - 0.25).abs() < 1e-12);
    // Endpoint to interior: (3, 1) is 1 above the segment's end region.
    let d = segment_distance(
        [0.0, 0.0, 0.0],
        [4.0, 0.0, 0.0],
        [3.0, 1.0, 0.0],
        [3.0, 2.0, 0.0],
    );
    assert!((d - 1.0).abs() < 1e-12);
}

#[test]
fn configurations_c_and_d() {
    let s = Scale::new(1.0, 1.5);
    let z = 0.0;
    // Parallel 0.3 apart: no triangulation with edges ≥ r_min.
    assert!(nonadjacent_conflict(
        &s,
        [0.0, 0.0, z],
        [1.2, 0.0, z],
        [0.0, 0.3, z],
        [1.2, 0.3, z]
    ));
    // Staggered by half an edge, 0.9 apart: the strip a-b-d-c with diagonal (b, c) has all
    // edges ≥ 1 (configuration (c)).
    assert!(!nonadjacent_conflict(
        &s,
        [0.0, 0.0, z],
        [1.0, 0.0, z],
        [0.5, 0.9, z],
        [1.5, 0.9, z]
    ));
    // Crossing (0.2 apart in z): every strip folds, no fan has β ≥ 2 θ_min.
    assert!(nonadjacent_conflict(
        &s,
        [0.0, 0.0, 0.0],
        [1.4, 0.0, 0.0],
        [0.7, -0.7, 0.2],
        [0.7, 0.7, 0.2]
    ));
    // T: the end (1, 0.75) of a perpendicular edge 0.75 above the middle of a 1.5 edge: apex
    // edges 1.06 and angles β = 135° ≥ 2 θ_min (configuration (d)).
    assert!(!nonadjacent_conflict(
        &s,
        [0.0, 0.0, z],
        [1.5, 0.0, z],
        [0.75, 0.75, z],
        [0.75, 2.0, z]
    ));
    // The same edge turned towards the base's end: β = 14° < 2 θ_min, its far end is 0.5 from
    // the base's end and the only strip with long enough sides folds.
    assert!(nonadjacent_conflict(
        &s,
        [0.0, 0.0, z],
        [1.5, 0.0, z],
        [0.75, 0.75, z],
        [2.0, 0.0, z]
    ));
}

#[test]
fn find_conflicts_kinds() {
    let s = Scale::new(1.0, 1.5);
    // A sharp V (30° < θ_min) at vertex 0, and a separate edge crossing under edge 0 at 0.2.
    let a = 30f64.to_radians();
    let pos = vec![
        [0.0, 0.0, 0.0],
        [1.2, 0.0, 0.0],
        [1.2 * a.cos(), 1.2 * a.sin(), 0.0],
        [0.6, -0.7, -0.2],
        [0.6, 0.7, -0.2],
    ];
    let edges = vec![[0, 1], [0, 2], [3, 4]];
    let c = find_conflicts(&s, &pos, &edges, Par::Seq);
    assert!(c.edge_pairs.contains(&(0, 1, ConflictKind::Angle)));
    assert!(c.edge_pairs.contains(&(0, 2, ConflictKind::Proximity)));
    // Ends 1 and 2 (valence 1) are 0.62 apart.
    assert!(c.vertex_pairs.contains(&(1, 2)));
    assert_eq!(c, find_conflicts(&s, &pos, &edges, Par::Rayon));
}

#[test]
fn edges_across_a_short_edge_are_tested_by_angle() {
    let s = Scale::new(1.0, 1.5);
    // 1-2 is short (0.3); edges 0-1 and 2-3 meet at 20° as if 1 and 2 were one vertex.
    let a = 20f64.to_radians();
    let pos = vec![
        [-1.2 * a.cos(), 1.2 * a.sin(), 0.0],
        [0.0, 0.0, 0.0],
        [-0.3, 0.0, 0.0],
        [-1.5, 0.0, 0.0],
    ];
    let edges = vec![[0, 1], [1, 2], [2, 3]];
    let c = find_conflicts(&s, &pos, &edges, Par::Seq);
    assert!(c
        .edge_pairs
        .contains(&(0, 2, ConflictKind::AngleAcrossShort)));
}

#[test]
fn a_special_long_edges_middle_counts_in_the_proximity_test() {
    // r_min 1: a special long edge (0,0)–(1.7,0) and a curve ending 0.6 above its middle.
    // As one edge the pair is resolved (the triangle of the long edge and the curve's end has
    // sides 1.7, 1.04, 1.04); the remesher puts a vertex at the middle, 0.6 from that end, so
    // with special long edges the pair conflicts.
    let pos = [
        [0.0, 0.0, 0.0],
        [1.7, 0.0, 0.0],
        [0.85, 0.6, 0.0],
        [0.85, 5.0, 0.0],
    ];
    let edges = [[0, 1], [2, 3]];
    let off = find_conflicts(&Scale::new(1.0, 1.5), &pos, &edges, Par::Seq);
    assert!(off.edge_pairs.is_empty(), "{:?}", off.edge_pairs);
    assert_eq!(off.near_resolved, 1);
    let s = Scale::new(1.0, 1.5).with_special_long(true);
    assert!(s.is_special_long(1.7) && !s.is_special_long(1.4) && !s.is_special_long(2.1));
    let on = find_conflicts(&s, &pos, &edges, Par::Seq);
    assert_eq!(on.edge_pairs, vec![(0, 1, ConflictKind::Proximity)]);
}
