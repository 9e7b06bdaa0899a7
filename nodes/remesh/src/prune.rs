//! Removing the parts of a feature-edge graph that lie below a length scale (thesis §4.3:
//! a network can only be represented at scale r_min by features at least that long).
//!
//! On coarsely tessellated CAD meshes the edges sharper than a threshold are not a few crease
//! lines: where a crease cuts across triangles they zig-zag on both sides of it, forming small
//! cycles (ladders) with spurs hanging off them. Every junction of that graph ends an arc, so
//! the arcs are shorter than any useful scale and a scale-conforming selection
//! (`scale.conform`) can keep little of the creases. [`prune_below_scale`] reduces the graph
//! to its lines: it drops dangling branches shorter than the scale and, weakest first, every
//! branch that closes a cycle shorter than twice the scale through a junction (a closed curve
//! on its own, which has none, stays). What remains is the same feature at the same place,
//! with the arcs between real junctions.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crestflow_geom::graph::{extract_arcs, incidence};
use crestflow_geom::vec3::{self, V3};

use crate::features::Ord64;

/// Most vertices one search for a short cycle settles. On a dense feature graph (a low
/// dihedral threshold on a scan) and a scale of a good part of the model, an unbounded search
/// per branch would visit most of the graph; a branch whose search runs out is kept, as if no
/// short cycle closed it.
const MAX_SETTLED: usize = 512;

/// A maximal path of the graph whose inner vertices have two edges.
struct Branch {
    edges: Vec<u32>,
    /// Compact vertex ids of its ends.
    ends: [u32; 2],
    length: f64,
    /// Length-weighted mean of the edge weights.
    weight: f64,
}

/// The live graph: edges on compact vertex ids, incident edges per vertex (CSR, in edge
/// order), live degrees.
struct Live<'a> {
    ends: Vec<[u32; 2]>,
    len: Vec<f64>,
    weight: &'a [f64],
    start: Vec<usize>,
    inc: Vec<u32>,
    alive: Vec<bool>,
    degree: Vec<u32>,
}

impl Live<'_> {
    fn incident(&self, v: u32) -> &[u32] {
        &self.inc[self.start[v as usize]..self.start[v as usize + 1]]
    }
    fn other(&self, e: u32, v: u32) -> u32 {
        let [a, b] = self.ends[e as usize];
        if a == v {
            b
        } else {
            a
        }
    }
    fn set_alive(&mut self, e: u32, on: bool) {
        if self.alive[e as usize] != on {
            self.alive[e as usize] = on;
            let [a, b] = self.ends[e as usize];
            for v in [a, b] {
                if on {
                    self.degree[v as usize] += 1;
                } else {
                    self.degree[v as usize] -= 1;
                }
            }
        }
    }
}

/// Which of `edges` (vertex pairs into `positions`) survive the pruning at `scale`.
/// `weight` orders the cycle breaking (the lightest branch of a cycle goes); edges with
/// `fixed` set are never removed (boundaries). Deterministic: ties go by edge index.
pub fn prune_below_scale(
    edges: &[[u32; 2]],
    positions: &[V3],
    weight: &[f64],
    fixed: &[bool],
    scale: f64,
) -> Vec<bool> {
    if !(scale > 0.0) || edges.is_empty() {
        return vec![true; edges.len()];
    }
    // Compact vertex ids in increasing order of the input ids; loops (a == b) take no part.
    let mut verts: Vec<u32> = edges.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let id = |v: u32| verts.binary_search(&v).unwrap_or(0) as u32;
    let ends: Vec<[u32; 2]> = edges.iter().map(|&[a, b]| [id(a), id(b)]).collect();
    let nv = verts.len();
    let alive: Vec<bool> = ends.iter().map(|&[a, b]| a != b).collect();
    let (start, inc) = incidence(nv, &ends, &alive);
    let degree: Vec<u32> = (0..nv).map(|v| (start[v + 1] - start[v]) as u32).collect();
    let mut g = Live {
        len: edges
            .iter()
            .map(|&[a, b]| vec3::dist(positions[a as usize], positions[b as usize]))
            .collect(),
        ends,
        weight,
        start,
        inc,
        alive,
        degree,
    };
    let mut search = Search::new(nv);
    // Each round removes spurs, then breaks short cycles; a removal can turn a junction into
    // a path vertex and lengthen branches, so rounds repeat until nothing changes.
    for _ in 0..edges.len() {
        let mut changed = false;
        loop {
            let mut removed = false;
            for b in branches(&g) {
                // Both ends as they were when the branch was found: a free end, and a
                // junction or a second free end (a removal at the junction merges the rest
                // into a longer branch, which the next pass measures anew).
                let [d0, d1] = b.ends.map(|v| g.degree[v as usize]);
                let dangling = b.ends[0] != b.ends[1] && (d0 == 1 || d1 == 1) && d0 != 2 && d1 != 2;
                if dangling && b.length < scale && b.edges.iter().all(|&e| !fixed[e as usize]) {
                    b.edges.iter().for_each(|&e| g.set_alive(e, false));
                    removed = true;
                }
            }
            if !removed {
                break;
            }
            changed = true;
        }
        let mut order = branches(&g);
        order.sort_by(|x, y| {
            x.weight
                .total_cmp(&y.weight)
                .then(x.edges[0].cmp(&y.edges[0]))
        });
        for b in &order {
            if b.edges
                .iter()
                .any(|&e| fixed[e as usize] || !g.alive[e as usize])
            {
                continue;
            }
            let budget = 2.0 * scale - b.length;
            if !(budget >= 0.0) {
                continue;
            }
            let [u, v] = b.ends;
            // A short loop hanging off a junction, or a branch whose ends are joined by
            // another path short enough to close a cycle below 2 × scale, goes. A closed curve
            // on its own stays: it splits no line into short arcs (scale.conform resamples or
            // drops it).
            let closes = if u == v {
                g.degree[u as usize] > 2
            } else {
                b.edges.iter().for_each(|&e| g.set_alive(e, false));
                let near = search.reachable_within(&g, u, v, budget);
                b.edges.iter().for_each(|&e| g.set_alive(e, true));
                near
            };
            if closes {
                b.edges.iter().for_each(|&e| g.set_alive(e, false));
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    g.alive
}

/// The branches of the live graph ([`extract_arcs`]: from the vertices with other than two
/// live edges in vertex order, then the loops), with their lengths and weights.
fn branches(g: &Live) -> Vec<Branch> {
    extract_arcs(g.degree.len(), &g.ends, &g.alive)
        .into_iter()
        .map(|arc| {
            let length: f64 = arc.edges.iter().map(|&e| g.len[e as usize]).sum();
            let weighted: f64 = arc
                .edges
                .iter()
                .map(|&e| g.len[e as usize] * g.weight[e as usize])
                .sum();
            let first = arc.nodes[0];
            Branch {
                ends: [
                    first,
                    if arc.closed {
                        first
                    } else {
                        arc.nodes[arc.nodes.len() - 1]
                    },
                ],
                weight: if length > 0.0 { weighted / length } else { 0.0 },
                length,
                edges: arc.edges,
            }
        })
        .collect()
}

/// Dijkstra cut off at a distance budget, reusing its arrays between searches.
struct Search {
    dist: Vec<f64>,
    touched: Vec<u32>,
    heap: BinaryHeap<Reverse<(Ord64, u32)>>,
}

impl Search {
    fn new(n: usize) -> Self {
        Search {
            dist: vec![f64::INFINITY; n],
            touched: Vec::new(),
            heap: BinaryHeap::new(),
        }
    }

    /// Whether `to` is within `budget` of `from` over live edges (at most [`MAX_SETTLED`]
    /// vertices settled; false when the search runs out).
    fn reachable_within(&mut self, g: &Live, from: u32, to: u32, budget: f64) -> bool {
        let found = self.run(g, from, to, budget);
        for &v in &self.touched {
            self.dist[v as usize] = f64::INFINITY;
        }
        self.touched.clear();
        self.heap.clear();
        found
    }

    fn run(&mut self, g: &Live, from: u32, to: u32, budget: f64) -> bool {
        self.dist[from as usize] = 0.0;
        self.touched.push(from);
        self.heap.push(Reverse((Ord64(0.0), from)));
        let mut settled = 0;
        while let Some(Reverse((Ord64(d), v))) = self.heap.pop() {
            if v == to {
                return true;
            }
            if d > self.dist[v as usize] {
                continue;
            }
            settled += 1;
            if settled > MAX_SETTLED {
                return false;
            }
            for &e in g.incident(v) {
                if !g.alive[e as usize] {
                    continue;
                }
                let w = g.other(e, v);
                let nd = d + g.len[e as usize];
                if nd <= budget && nd < self.dist[w as usize] {
                    if self.dist[w as usize] == f64::INFINITY {
                        self.touched.push(w);
                    }
                    self.dist[w as usize] = nd;
                    self.heap.push(Reverse((Ord64(nd), w)));
                }
            }
        }
        false
    }
}

#[cfg(test)]
#[path = "prune_test.rs"]
mod tests;
