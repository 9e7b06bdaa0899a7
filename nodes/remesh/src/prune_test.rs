//! Unit tests of `prune.rs`.

use super::*;

/// Edges of the polyline through `ids`.
fn path(ids: &[u32]) -> Vec<[u32; 2]> {
    ids.windows(2).map(|w| [w[0], w[1]]).collect()
}

/// Length of the shortest path from `a` to `b` over the kept edges other than `skip`.
fn shortest(edges: &[[u32; 2]], keep: &[bool], pos: &[V3], a: u32, b: u32, skip: usize) -> f64 {
    let mut dist = vec![f64::INFINITY; pos.len()];
    dist[a as usize] = 0.0;
    // Bellman–Ford: the graphs here are tiny.
    for _ in 0..pos.len() {
        for (e, &[x, y]) in edges.iter().enumerate() {
            if !keep[e] || e == skip {
                continue;
            }
            let l = vec3::dist(pos[x as usize], pos[y as usize]);
            for (u, v) in [(x, y), (y, x)] {
                if dist[u as usize] + l < dist[v as usize] {
                    dist[v as usize] = dist[u as usize] + l;
                }
            }
        }
    }
    dist[b as usize]
}

#[test]
fn a_short_spur_goes_and_the_line_stays() {
    // A line of 11 unit-spaced vertices along x; a spur of 0.5 at x = 5 and one of 3 at x = 8.
    let mut pos: Vec<V3> = (0..11).map(|i| [i as f64, 0.0, 0.0]).collect();
    pos.push([5.0, 0.5, 0.0]); // 11
    pos.push([8.0, 3.0, 0.0]); // 12
    let mut edges = path(&(0..11).collect::<Vec<_>>());
    edges.push([5, 11]);
    edges.push([8, 12]);
    let w = vec![1.0; edges.len()];
    let fixed = vec![false; edges.len()];
    let keep = prune_below_scale(&edges, &pos, &w, &fixed, 1.0);
    assert!(keep[..10].iter().all(|&k| k), "the line is kept");
    assert!(!keep[10], "the spur of 0.5 is below the scale");
    assert!(keep[11], "the spur of 3 is a feature of its own");
    // Scale 0 (or NaN) changes nothing; a fixed short spur stays.
    assert!(prune_below_scale(&edges, &pos, &w, &fixed, 0.0)
        .iter()
        .all(|&k| k));
    assert!(prune_below_scale(&edges, &pos, &w, &fixed, f64::NAN)
        .iter()
        .all(|&k| k));
    let mut fixed_spur = fixed.clone();
    fixed_spur[10] = true;
    assert!(prune_below_scale(&edges, &pos, &w, &fixed_spur, 1.0)[10]);
}

#[test]
fn a_closed_ladder_keeps_its_outline_and_no_short_cycle() {
    // Two rails of 12 edges of 0.4 (weights 1 and 0.5), 0.1 apart, joined by 13 rungs of
    // weight 0.3: every square is a cycle of 1.0, below 2 × scale = 2.
    let n = 13u32;
    let mut pos = Vec::new();
    for y in [0.0, 0.1] {
        for i in 0..n {
            pos.push([0.4 * i as f64, y, 0.0]);
        }
    }
    let mut edges = path(&(0..n).collect::<Vec<_>>());
    edges.extend(path(&(n..2 * n).collect::<Vec<_>>()));
    let rungs = edges.len();
    edges.extend((0..n).map(|i| [i, i + n]));
    let mut w = vec![1.0; 12];
    w.extend(vec![0.5; 12]);
    w.extend(vec![0.3; n as usize]);
    let fixed = vec![false; edges.len()];
    let keep = prune_below_scale(&edges, &pos, &w, &fixed, 1.0);
    assert!(keep[..24].iter().all(|&k| k), "both rails are whole");
    // The inner rungs are the lightest branches and go while a rung nearby closes a cycle
    // below 2. The end rungs lie inside the branches that run from a rail's second vertex
    // around the end to the other rail's (the end vertices have two edges): once the inner
    // rungs are gone the rails and end rungs form one loop of 9.8, which stays.
    let kept_rungs: Vec<usize> = (0..n as usize).filter(|&i| keep[rungs + i]).collect();
    assert_eq!(kept_rungs, [0, n as usize - 1]);
    // No kept edge lies on a cycle shorter than 2 × scale.
    for (e, &[a, b]) in edges.iter().enumerate() {
        if keep[e] {
            let l = vec3::dist(pos[a as usize], pos[b as usize]);
            let around = shortest(&edges, &keep, &pos, a, b, e);
            assert!(
                l + around >= 2.0,
                "edge {e} closes a cycle of {}",
                l + around
            );
        }
    }
}

#[test]
fn a_small_loop_hanging_off_a_line_goes() {
    // A line of 6 unit edges; at x = 3 a triangle of perimeter 0.9 hangs below it, joined by
    // a stem of 0.2. The loop is below 2 × scale and goes; then the stem is a short spur.
    let mut pos: Vec<V3> = (0..7).map(|i| [i as f64, 0.0, 0.0]).collect();
    pos.push([3.0, -0.2, 0.0]); // 7
    pos.push([2.85, -0.46, 0.0]); // 8
    pos.push([3.15, -0.46, 0.0]); // 9
    let mut edges = path(&(0..7).collect::<Vec<_>>());
    edges.extend([[3, 7], [7, 8], [8, 9], [9, 7]]);
    let w = vec![1.0; edges.len()];
    let keep = prune_below_scale(&edges, &pos, &w, &vec![false; edges.len()], 1.0);
    assert_eq!(keep, [vec![true; 6], vec![false; 4]].concat());
}
