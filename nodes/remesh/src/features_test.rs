use super::*;
use crestflow_geom::fcn::{CurveLabel, FcnVertex, FeatureCurve};

const N: u32 = NONE_NET;

#[test]
fn a_detour_is_cut_out_and_its_network_vertex_moves_to_where_it_starts() {
    // 1 → 2 → 3 (network vertex 7) → 4 → 2 → 5: the detour 3, 4 returns to 2.
    let seq = vec![(1, 0), (2, N), (3, 7), (4, N), (2, N), (5, 9)];
    assert_eq!(erase_loops(seq, false), vec![(1, 0), (2, 7), (5, 9)]);
    // A vertex that has a network vertex keeps it.
    let seq = vec![(1, 0), (2, 6), (3, 7), (2, N), (5, 9)];
    assert_eq!(erase_loops(seq, false), vec![(1, 0), (2, 6), (5, 9)]);
    // A path without detours is unchanged.
    let seq = vec![(1, 0), (2, N), (3, 7)];
    assert_eq!(erase_loops(seq.clone(), false), seq);
}

#[test]
fn a_closed_stroke_keeps_its_loop() {
    // 1 → 2 → 3 → 1: the return to the start closes the loop, it is no detour.
    let seq = vec![(1, 0), (2, 4), (3, 5), (1, 0)];
    assert_eq!(erase_loops(seq, true), vec![(1, 0), (2, 4), (3, 5)]);
}

fn vertex(x: f64) -> FcnVertex {
    FcnVertex {
        position: [x, 0.0, 0.0],
        location: SurfacePoint::Free,
        strength: 1.0,
    }
}

#[test]
fn strokes_run_across_curves_that_meet_end_to_end() {
    // Curves 0-1-2 and 2-3, and a triangle loop 4-5-6; vertex 2 joins two curves but has two
    // edges, so 0-1-2-3 is one stroke.
    let curve = |v: Vec<u32>, closed: bool| FeatureCurve {
        vertices: v,
        closed,
        label: CurveLabel::Other,
    };
    let net = FeatureCurveNetwork {
        vertices: (0..7).map(|i| vertex(i as f64)).collect(),
        curves: vec![
            curve(vec![0, 1, 2], false),
            curve(vec![2, 3], false),
            curve(vec![4, 5, 6], true),
        ],
    };
    assert_eq!(strokes(&net), vec![vec![0, 1, 2, 3], vec![4, 5, 6, 4]]);
}
