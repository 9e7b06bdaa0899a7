//! Removing the parts of a feature-edge graph that lie below a length scale (thesis §4.3:
//! a network can only be represented at scale r_min by features at least that long).
//!
//! On coarsely tessellated CAD meshes the edges sharper than a threshold are not a few crease
//! lines: where a crease cuts across triangles they zig-zag on both sides of it, forming small
//! cycles (ladders) with spurs hanging off them. Every junction of that graph ends an arc, so
//! the arcs are shorter than any useful scale and a scale-conforming selection
//! (`scale.conform`) can keep little of the creases. [`prune_below_scale`] reduces the graph
//! to its lines: it drops dangling branches shorter than the scale and, weakest first, every
//! branch that closes a cycle shorter than twice the scale. What remains is the same feature
//! at the same place, with the arcs between real junctions.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};

use crestflow_geom::vec3::{self, V3};

/// A maximal path of the graph whose inner vertices have two edges.
struct Branch {
    edges: Vec<u32>,
    ends: [u32; 2],
    length: f64,
    /// Length-weighted mean of the edge weights.
    weight: f64,
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
    let mut alive = vec![true; edges.len()];
    if !(scale > 0.0) || edges.is_empty() {
        return alive;
    }
    let len: Vec<f64> = edges
        .iter()
        .map(|&[a, b]| vec3::dist(positions[a as usize], positions[b as usize]))
        .collect();
    // Incident edges per vertex, in a fixed order.
    let mut inc: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for (e, &[a, b]) in edges.iter().enumerate() {
        if a != b {
            inc.entry(a).or_default().push(e as u32);
            inc.entry(b).or_default().push(e as u32);
        }
    }
    // Each round removes spurs, then breaks short cycles; a removal can turn a junction into
    // a path vertex and lengthen branches, so rounds repeat until nothing changes.
    for _ in 0..edges.len() {
        let mut changed = false;
        loop {
            let branches = branches(edges, &alive, &inc, &len, weight);
            let mut removed = false;
            for b in &branches {
                // Both ends as they were when the branch was found: a free end, and a
                // junction or a second free end (a removal at the junction merges the rest
                // into a longer branch, which the next pass measures anew).
                let [d0, d1] = b.ends.map(|v| live_degree(&inc, &alive, v));
                let dangling = b.ends[0] != b.ends[1] && (d0 == 1 || d1 == 1) && d0 != 2 && d1 != 2;
                if dangling && b.length < scale && b.edges.iter().all(|&e| !fixed[e as usize]) {
                    b.edges.iter().for_each(|&e| alive[e as usize] = false);
                    removed = true;
                }
            }
            if !removed {
                break;
            }
            changed = true;
        }
        let mut order: Vec<Branch> = branches(edges, &alive, &inc, &len, weight);
        order.sort_by(|x, y| {
            x.weight
                .total_cmp(&y.weight)
                .then(x.edges[0].cmp(&y.edges[0]))
        });
        for b in &order {
            if b.edges
                .iter()
                .any(|&e| fixed[e as usize] || !alive[e as usize])
            {
                continue;
            }
            let budget = 2.0 * scale - b.length;
            if !(budget >= 0.0) {
                continue;
            }
            let [u, v] = b.ends;
            // A branch that is a whole short loop, or whose ends are joined by another path
            // short enough to close a cycle below 2 × scale, goes.
            let closes = if u == v {
                live_degree(&inc, &alive, u) > 2
            } else {
                b.edges.iter().for_each(|&e| alive[e as usize] = false);
                let near = reachable_within(edges, &alive, &inc, &len, u, v, budget);
                b.edges.iter().for_each(|&e| alive[e as usize] = true);
                near
            };
            if closes {
                b.edges.iter().for_each(|&e| alive[e as usize] = false);
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    alive
}

fn live_degree(inc: &BTreeMap<u32, Vec<u32>>, alive: &[bool], v: u32) -> usize {
    inc.get(&v)
        .map_or(0, |es| es.iter().filter(|&&e| alive[e as usize]).count())
}

/// The branches of the live graph: walks from every vertex with other than two live edges,
/// then the cycles without such a vertex.
fn branches(
    edges: &[[u32; 2]],
    alive: &[bool],
    inc: &BTreeMap<u32, Vec<u32>>,
    len: &[f64],
    weight: &[f64],
) -> Vec<Branch> {
    let mut used = vec![false; edges.len()];
    let mut out = Vec::new();
    let other = |e: u32, v: u32| {
        let [a, b] = edges[e as usize];
        if a == v {
            b
        } else {
            a
        }
    };
    let walk = |start: u32, first: u32, used: &mut Vec<bool>| -> Branch {
        let mut path = vec![first];
        used[first as usize] = true;
        let mut cur = other(first, start);
        let mut last = first;
        while cur != start && live_degree(inc, alive, cur) == 2 {
            let Some(&next) = inc[&cur].iter().find(|&&e| alive[e as usize] && e != last) else {
                break;
            };
            if used[next as usize] {
                break;
            }
            used[next as usize] = true;
            path.push(next);
            last = next;
            cur = other(next, cur);
        }
        let length: f64 = path.iter().map(|&e| len[e as usize]).sum();
        let weighted: f64 = path
            .iter()
            .map(|&e| len[e as usize] * weight[e as usize])
            .sum();
        Branch {
            ends: [start, cur],
            weight: if length > 0.0 { weighted / length } else { 0.0 },
            length,
            edges: path,
        }
    };
    for (&v, es) in inc {
        if live_degree(inc, alive, v) == 2 {
            continue;
        }
        for &e in es {
            if alive[e as usize] && !used[e as usize] {
                out.push(walk(v, e, &mut used));
            }
        }
    }
    for (&v, es) in inc {
        for &e in es {
            if alive[e as usize] && !used[e as usize] {
                out.push(walk(v, e, &mut used));
            }
        }
    }
    out
}

/// Whether `to` is within `budget` of `from` over live edges (Dijkstra cut off at the budget).
fn reachable_within(
    edges: &[[u32; 2]],
    alive: &[bool],
    inc: &BTreeMap<u32, Vec<u32>>,
    len: &[f64],
    from: u32,
    to: u32,
    budget: f64,
) -> bool {
    let mut dist: BTreeMap<u32, f64> = BTreeMap::new();
    let mut heap = BinaryHeap::new();
    dist.insert(from, 0.0);
    heap.push(Reverse((Key(0.0), from)));
    while let Some(Reverse((Key(d), v))) = heap.pop() {
        if v == to {
            return true;
        }
        if d > dist[&v] {
            continue;
        }
        for &e in inc.get(&v).into_iter().flatten() {
            if !alive[e as usize] {
                continue;
            }
            let [a, b] = edges[e as usize];
            let w = if a == v { b } else { a };
            let nd = d + len[e as usize];
            if nd <= budget && dist.get(&w).is_none_or(|&old| nd < old) {
                dist.insert(w, nd);
                heap.push(Reverse((Key(nd), w)));
            }
        }
    }
    false
}

/// A total order on finite distances for the heap.
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

#[cfg(test)]
#[path = "prune_test.rs"]
mod tests;
