//! Consolidation of overlaid reoccurrences into template curves (thesis §4.2.3.2, "Connected
//! Component Completion"): the reoccurrences of a curve, moved into one grid cell, overlap and
//! complement each other. They form a graph: consecutive samples of each polyline are joined,
//! and each end point of a polyline is joined to its nearest neighbour on every other polyline
//! within ε. Start and end points are the end points that project onto end points only (or onto
//! nothing), not onto an inner point of another reoccurrence. The longest shortest path between
//! two of them is one consolidated curve; every point within ε of it is redundant and removed,
//! and the search repeats (now from the points that lost their neighbours) until the longest
//! path is shorter than the minimal length. Closed reoccurrences are taken whole first.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crestflow_geom::vec3::{dist, V3};
use crestflow_geom::CurveLabel;

/// A polyline with per-point strength and its label.
#[derive(Clone, Debug, PartialEq)]
pub struct Poly {
    pub pts: Vec<V3>,
    pub strength: Vec<f64>,
    pub closed: bool,
    pub label: CurveLabel,
}

#[derive(Clone, Copy, PartialEq)]
struct Key(f64);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Key {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

struct Node {
    p: V3,
    s: f64,
    label: CurveLabel,
}

/// Consolidates overlaid polylines (see the module docs); `eps` and `min_length` in mesh units.
pub fn consolidate(polys: &[Poly], eps: f64, min_length: f64) -> Vec<Poly> {
    let mut nodes: Vec<Node> = Vec::new();
    let mut first: Vec<usize> = Vec::new();
    for pl in polys {
        first.push(nodes.len());
        for (p, s) in pl.pts.iter().zip(&pl.strength) {
            nodes.push(Node {
                p: *p,
                s: *s,
                label: pl.label,
            });
        }
    }
    let n = nodes.len();
    let mut adj: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    let link = |a: usize, b: usize, adj: &mut Vec<Vec<(usize, f64)>>| {
        if a != b && !adj[a].iter().any(|e| e.0 == b) {
            let w = dist(nodes[a].p, nodes[b].p);
            adj[a].push((b, w));
            adj[b].push((a, w));
        }
    };
    for (k, pl) in polys.iter().enumerate() {
        let m = pl.pts.len();
        for i in 1..m {
            link(first[k] + i - 1, first[k] + i, &mut adj);
        }
        if pl.closed && m > 2 {
            link(first[k] + m - 1, first[k], &mut adj);
        }
    }
    // End points projected onto the other reoccurrences.
    let mut terminal = vec![false; n];
    for (k, pl) in polys.iter().enumerate() {
        if pl.closed || pl.pts.is_empty() {
            continue;
        }
        let m = pl.pts.len();
        for end in [0, m - 1] {
            let a = first[k] + end;
            let mut inner = false;
            for (k2, pl2) in polys.iter().enumerate() {
                if k2 == k || pl2.pts.is_empty() {
                    continue;
                }
                let (i2, d) = pl2
                    .pts
                    .iter()
                    .enumerate()
                    .map(|(i, q)| (i, dist(*q, nodes[a].p)))
                    .min_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)))
                    .unwrap_or((0, f64::INFINITY));
                if d <= eps {
                    link(a, first[k2] + i2, &mut adj);
                    let is_end = !pl2.closed && (i2 == 0 || i2 + 1 == pl2.pts.len());
                    if !is_end {
                        inner = true;
                    }
                }
            }
            terminal[a] = !inner;
        }
    }
    let mut alive = vec![true; n];
    let mut out = Vec::new();
    let kill_near = |path: &[usize], alive: &mut Vec<bool>| {
        for (v, a) in alive.iter_mut().enumerate() {
            if *a && path.iter().any(|&u| dist(nodes[u].p, nodes[v].p) <= eps) {
                *a = false;
            }
        }
    };
    // Closed reoccurrences first, longest first.
    let mut closed: Vec<usize> = (0..polys.len())
        .filter(|&k| polys[k].closed && polys[k].pts.len() > 2)
        .collect();
    closed.sort_by(|&a, &b| {
        crate::curves::polyline_length(&polys[b].pts, true)
            .total_cmp(&crate::curves::polyline_length(&polys[a].pts, true))
            .then(a.cmp(&b))
    });
    for k in closed {
        let idx: Vec<usize> = (first[k]..first[k] + polys[k].pts.len()).collect();
        if !idx.iter().all(|&i| alive[i]) {
            continue;
        }
        if crate::curves::polyline_length(&polys[k].pts, true) < min_length {
            continue;
        }
        out.push(polys[k].clone());
        kill_near(&idx, &mut alive);
    }
    let mut first_round = true;
    loop {
        let terms: Vec<usize> = (0..n)
            .filter(|&v| {
                alive[v]
                    && if first_round {
                        terminal[v]
                    } else {
                        adj[v].iter().filter(|e| alive[e.0]).count() <= 1
                    }
            })
            .collect();
        first_round = false;
        if terms.is_empty() {
            break;
        }
        // Longest shortest path between two terminals.
        let mut best: Option<(f64, usize, usize, Vec<usize>)> = None;
        for &s in &terms {
            let (d, prev) = dijkstra(&adj, &alive, s);
            for &t in &terms {
                if t == s || !d[t].is_finite() {
                    continue;
                }
                if best.as_ref().is_none_or(|b| d[t] > b.0) {
                    best = Some((d[t], s, t, prev.clone()));
                }
            }
        }
        let Some((len, s, t, prev)) = best else { break };
        if len < min_length {
            break;
        }
        let mut path = vec![t];
        let mut v = t;
        while v != s {
            v = prev[v];
            path.push(v);
        }
        path.reverse();
        let mut label_votes = [0usize; 3];
        for &u in &path {
            label_votes[label_index(nodes[u].label)] += 1;
        }
        let li = (0..3)
            .max_by_key(|&i| (label_votes[i], Reverse(i)))
            .unwrap_or(0);
        out.push(Poly {
            pts: path.iter().map(|&u| nodes[u].p).collect(),
            strength: path.iter().map(|&u| nodes[u].s).collect(),
            closed: false,
            label: [CurveLabel::Ridge, CurveLabel::Ravine, CurveLabel::Other][li],
        });
        kill_near(&path, &mut alive);
    }
    out
}

fn label_index(l: CurveLabel) -> usize {
    match l {
        CurveLabel::Ridge => 0,
        CurveLabel::Ravine => 1,
        CurveLabel::Other => 2,
    }
}

/// Shortest path distances from `s` over alive nodes, and predecessors.
fn dijkstra(adj: &[Vec<(usize, f64)>], alive: &[bool], s: usize) -> (Vec<f64>, Vec<usize>) {
    let n = adj.len();
    let mut d = vec![f64::INFINITY; n];
    let mut prev: Vec<usize> = (0..n).collect();
    let mut heap = BinaryHeap::new();
    d[s] = 0.0;
    heap.push(Reverse((Key(0.0), s)));
    while let Some(Reverse((Key(dv), v))) = heap.pop() {
        if dv > d[v] {
            continue;
        }
        for &(u, w) in &adj[v] {
            if !alive[u] {
                continue;
            }
            let nd = dv + w;
            if nd < d[u] {
                d[u] = nd;
                prev[u] = v;
                heap.push(Reverse((Key(nd), u)));
            }
        }
    }
    (d, prev)
}
