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
    // The same triangle on its own is a closed curve without a junction: it stays.
    let alone = [[7, 8], [8, 9], [9, 7]];
    let keep = prune_below_scale(&alone, &pos, &[1.0; 3], &[false; 3], 1.0);
    assert_eq!(keep, [true; 3]);
}

/// All edges of an n × n vertex grid of unit spacing, and the vertex positions.
fn grid_graph(n: u32) -> (Vec<V3>, Vec<[u32; 2]>) {
    let pos: Vec<V3> = (0..n * n)
        .map(|i| [(i % n) as f64, (i / n) as f64, 0.0])
        .collect();
    let mut edges = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = j * n + i;
            if i + 1 < n {
                edges.push([v, v + 1]);
            }
            if j + 1 < n {
                edges.push([v, v + n]);
            }
        }
    }
    (pos, edges)
}

#[test]
fn a_dense_grid_is_pruned_by_its_cycle_length() {
    // A grid's shortest cycles are its squares, of length 4.
    let (pos, edges) = grid_graph(15);
    let w: Vec<f64> = (0..edges.len()).map(|e| 1.0 + (e % 7) as f64).collect();
    let free = vec![false; edges.len()];
    // Below 2 (2 × scale < 4) nothing goes.
    assert!(prune_below_scale(&edges, &pos, &w, &free, 1.9)
        .iter()
        .all(|&k| k));
    // At 2.5 every square is broken, and nothing that remains closes a cycle below 5.
    let keep = prune_below_scale(&edges, &pos, &w, &free, 2.5);
    let kept = keep.iter().filter(|&&k| k).count();
    assert!(kept > 0 && kept < edges.len(), "{kept} of {}", edges.len());
    for (e, &[a, b]) in edges.iter().enumerate() {
        if keep[e] {
            let around = shortest(&edges, &keep, &pos, a, b, e);
            assert!(
                1.0 + around >= 5.0,
                "edge {e} closes a cycle of {}",
                1.0 + around
            );
        }
    }
}

#[test]
fn a_large_dense_grid_at_a_scale_above_its_size_is_removed_whole() {
    // 7320 edges at a scale of 1000: weakest first, every edge that closes a cycle goes (the
    // searches are bounded, MAX_SETTLED; an edge whose search runs out stays for now), then
    // what is left dangles and is shorter than the scale, round after round, until nothing
    // is left.
    let (pos, edges) = grid_graph(61);
    let w: Vec<f64> = (0..edges.len()).map(|e| 1.0 + (e % 7) as f64).collect();
    let keep = prune_below_scale(&edges, &pos, &w, &vec![false; edges.len()], 1000.0);
    assert_eq!(keep.iter().filter(|&&k| k).count(), 0);
    // With the grid's outline fixed, the outline stays, and no free end: what else stays
    // closes cycles through the outline that the bounded searches did not find.
    let outline: Vec<bool> = edges
        .iter()
        .map(|&[a, b]| {
            let on = |v: u32| {
                let (x, y) = (v % 61, v / 61);
                x == 0 || y == 0 || x == 60 || y == 60
            };
            on(a) && on(b)
        })
        .collect();
    let keep = prune_below_scale(&edges, &pos, &w, &outline, 1000.0);
    assert!((0..edges.len()).all(|e| keep[e] || !outline[e]));
    let mut degree = vec![0; pos.len()];
    for (e, &[a, b]) in edges.iter().enumerate() {
        if keep[e] {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
    }
    assert!(degree.iter().all(|&d| d != 1), "a free end is left");
}
