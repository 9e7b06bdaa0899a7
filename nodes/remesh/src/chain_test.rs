use super::*;

/// An L: (0,0,0) -> (2,0,0) -> (2,1,0), arc length 3.
fn ell() -> Chain {
    Chain::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
        ],
        false,
    )
}

/// The unit square as a loop, arc length 4.
fn square() -> Chain {
    Chain::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0],
        ],
        true,
    )
}

#[test]
fn points_by_arc_length() {
    let c = ell();
    assert_eq!(c.total(), 3.0);
    assert_eq!(c.point_at(0.5), [0.5, 0.0, 0.0]);
    assert_eq!(c.point_at(2.5), [2.0, 0.5, 0.0]);
    assert_eq!(c.point_at(3.0), [2.0, 1.0, 0.0]);
    // Clamped on an open chain, wrapped on a loop.
    assert_eq!(c.point_at(7.0), [2.0, 1.0, 0.0]);
    assert_eq!(square().point_at(4.5), [0.5, 0.0, 0.0]);
    assert_eq!(square().point_at(-0.5), [0.0, 0.5, 0.0]);
}

#[test]
fn straight_stretches_have_no_deviation_and_bends_do() {
    let c = ell();
    let p = |s| c.point_at(s);
    // Straight: (0.2 .. 1.8) passes the inner point (1,0,0) exactly on the segment.
    assert!(c.deviation(0.2, 1.8, p(0.2), p(1.8)) < 1e-15);
    // Across the bend at (2,0,0): the chord from (1.5,0,0) to (2,0.5,0) misses it by
    // 0.5/sqrt(2)/... = the distance of (2,0) to the line x - y = 1.5: 0.5/sqrt(2).
    let d = c.deviation(1.5, 2.5, p(1.5), p(2.5));
    assert!((d - 0.5 / 2f64.sqrt()).abs() < 1e-12, "{d}");
    // Order of the two ends does not matter.
    assert_eq!(c.deviation(2.5, 1.5, p(2.5), p(1.5)), d);
}

#[test]
fn loops_take_the_shorter_way_round() {
    let c = square();
    assert_eq!(c.interval(1.5, 2.5), (1.5, 2.5));
    assert_eq!(c.interval(3.5, 0.5), (3.5, 4.5));
    assert_eq!(c.interval(0.25, 3.75), (3.75, 4.25));
    assert_eq!(c.middle(0.25, 3.75), 0.0);
    // From (0,0.5) over the corner (0,0) to (0.5,0): the corner is 0.5/sqrt(2) off the chord.
    let (a, b) = (3.5, 0.5);
    let d = c.deviation(a, b, c.point_at(a), c.point_at(b));
    assert!((d - 0.5 / 2f64.sqrt()).abs() < 1e-12, "{d}");
}

#[test]
fn edge_capacity_is_the_longest_straight_chord_through_each_point() {
    // The L: (0,0)-(1,0)-(2,0) is straight (a chord of 2 covers points 0..2); the last
    // segment turns by 90°, so only its own length 1 is allowed there.
    let c = ell();
    assert_eq!(c.edge_capacity(1e-9, 10.0), vec![2.0, 2.0, 2.0, 1.0]);
    // The cap bounds every value.
    assert_eq!(c.edge_capacity(1e-9, 1.5), vec![1.0, 1.0, 1.0, 1.0]);
    // A tolerance above the bend's deviation from the chord (1,0)-(2,1) (1/sqrt(2)) lets that
    // chord through, but not the one from (0,0) to (2,1), which misses (2,0) by 2/sqrt(5).
    let h = c.edge_capacity(0.75, 10.0);
    assert_eq!(h[3], 2.0);
    assert_eq!(h[0], 2.0);
    // A unit square loop at a tolerance below 1/sqrt(2)·0.5: only single sides fit, and the
    // wrap-around point gets the same as the first.
    let sq = square();
    let h = sq.edge_capacity(0.1, 10.0);
    assert!(h.iter().all(|&x| x == 1.0), "{h:?}");
}

#[test]
fn sharpest_between_picks_the_largest_turn_inside_the_stretch() {
    // An open polyline turning by 10° at x = 1, by 40° at x = 2, by 80° at x = 3.
    let mut pts = vec![[0.0, 0.0, 0.0]];
    let mut dir: f64 = 0.0;
    for turn in [10.0f64, 40.0, 80.0, 0.0] {
        let p: V3 = pts[pts.len() - 1];
        pts.push([p[0] + dir.cos(), p[1] + dir.sin(), 0.0]);
        dir += turn.to_radians();
    }
    let ch = Chain::new(pts, false);
    // Points 1..=3 at arc lengths 1, 2, 3.
    assert_eq!(ch.sharpest_between(0.5, 2.5), Some(2.0));
    assert_eq!(ch.sharpest_between(2.5, 0.5), Some(2.0));
    assert_eq!(ch.sharpest_between(0.5, 3.5), Some(3.0));
    assert_eq!(ch.sharpest_between(0.5, 1.5), Some(1.0));
    // The ends of the stretch are not inside it; nothing lies strictly inside (1, 2).
    assert_eq!(ch.sharpest_between(1.0, 2.0), None);
    // On a loop (a square) the stretch may wrap past the first point, which is a corner too.
    let sq = square();
    assert_eq!(sq.sharpest_between(3.5, 0.5), Some(0.0));
    assert_eq!(sq.sharpest_between(1.5, 2.5), Some(2.0));
}

#[test]
fn a_stretch_through_a_point_may_be_the_longer_way_round() {
    let c = square();
    // From 0.5 to 3.5: the shorter way passes 0 (the corner (0,0)), the longer one 2.
    assert_eq!(c.interval(0.5, 3.5), (3.5, 4.5));
    assert_eq!(c.interval_through(0.5, 3.5, 0.1), (3.5, 4.5));
    assert_eq!(c.interval_through(3.5, 0.5, 3.9), (3.5, 4.5));
    assert_eq!(c.interval_through(0.5, 3.5, 2.0), (0.5, 3.5));
    assert_eq!(c.interval_avoiding(0.5, 3.5, 2.0), (3.5, 4.5));
    assert_eq!(c.interval_avoiding(0.5, 3.5, 0.1), (0.5, 3.5));
    // The longer way's middle is the far corner (1,1), 0.75·sqrt(2) from the chord's middle.
    let (lo, hi) = c.interval_through(0.5, 3.5, 2.0);
    assert_eq!(c.point_at(0.5 * (lo + hi)), [1.0, 1.0, 0.0]);
    let d = c.deviation_over(lo, hi, c.point_at(0.5), c.point_at(3.5));
    assert!((d - 0.75 * 2f64.sqrt()).abs() < 1e-12, "{d}");
    // An open chain has one stretch between two points.
    let e = ell();
    assert_eq!(e.interval_through(2.5, 0.5, 1.0), (0.5, 2.5));
    assert_eq!(e.interval_avoiding(2.5, 0.5, 1.0), (0.5, 2.5));
}

#[test]
fn a_point_at_an_end_of_both_stretches_takes_the_shorter() {
    // Curve chains repeat parameters: a vertex at its neighbour's parameter lies strictly
    // inside neither way round, and gets the shorter one, as `interval` gives it.
    let c = square();
    assert_eq!(c.interval_through(0.5, 3.5, 0.5), (3.5, 4.5));
    assert_eq!(c.interval_through(0.5, 3.5, 3.5), (3.5, 4.5));
    assert_eq!(c.interval_avoiding(0.5, 3.5, 0.5), (3.5, 4.5));
}
