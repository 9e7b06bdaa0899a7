//! Consistent orientation of principal directions (thesis §2.5.1.1 step 2; Ohtake, Belyaev,
//! Seidel 2004 \[OBS04\]).
//!
//! Principal directions are line fields: each vertex's t_max is only defined up to sign, and the
//! extremality coefficient e_max = ∇k_max · t_max flips with it. Ridge detection looks for sign
//! changes of e_max along edges, so neighbouring directions must not make obtuse angles.
//!
//! A line field around an umbilic cannot be oriented globally, so some edges must keep an
//! obtuse pair. We choose which: directions are propagated along a maximum spanning tree of the
//! mesh edges weighted by |t_u · t_w| (Prim's algorithm with weights quantised to 1024 levels,
//! one tree per connected component, roots in vertex order), so flips are decided across the edges where
//! the directions agree best, and the unavoidable seams fall where they agree least — near
//! umbilics and in noise. The walk is sequential and deterministic.

use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{CurvatureField, TriMesh};

/// Flips `t_max` (with `e_max`) along a maximum spanning tree as described in the module docs,
/// then sets `t_min = normal × t_max`, flipping `e_min` where that reverses `t_min`.
/// Returns the number of edges left with an obtuse angle between their t_max (the seams).
pub fn orient_directions(mesh: &TriMesh, field: &mut CurvatureField) -> usize {
    let n = mesh.n_vertices().min(field.len());
    let topo = mesh.topology();
    let mut done = vec![false; n];
    let mut queue = BucketQueue::new();
    let t = &mut field.t_max;
    let e = &mut field.e_max;
    for root in 0..n {
        if done[root] {
            continue;
        }
        done[root] = true;
        push_edges(
            topo.neighbors(root as u32),
            root as u32,
            t,
            &done,
            &mut queue,
        );
        while let Some((from, w)) = queue.pop() {
            let w_us = w as usize;
            if done[w_us] {
                continue;
            }
            done[w_us] = true;
            if vec3::dot(t[from as usize], t[w_us]) < 0.0 {
                t[w_us] = vec3::scale(t[w_us], -1.0);
                e[w_us] = -e[w_us];
            }
            push_edges(topo.neighbors(w), w, t, &done, &mut queue);
        }
    }
    for v in 0..n {
        let t_min = vec3::cross(field.normal[v], field.t_max[v]);
        if vec3::dot(t_min, field.t_min[v]) < 0.0 {
            field.e_min[v] = -field.e_min[v];
        }
        field.t_min[v] = t_min;
    }
    topo.edges
        .iter()
        .filter(|e| {
            let (a, b) = (e[0] as usize, e[1] as usize);
            a < n && b < n && vec3::dot(field.t_max[a], field.t_max[b]) < 0.0
        })
        .count()
}

/// Number of weight levels of the priority queue.
const LEVELS: usize = 1024;

/// A max-priority queue of edges with weights in [0, 1], quantised to [`LEVELS`] buckets:
/// O(1) push and amortised O(1) pop, where a binary heap would cost O(log E) per edge. Within
/// a bucket the last edge pushed comes out first; the order is fully deterministic.
struct BucketQueue {
    buckets: Vec<Vec<(u32, u32)>>,
    top: usize,
}

impl BucketQueue {
    fn new() -> Self {
        BucketQueue {
            buckets: vec![Vec::new(); LEVELS],
            top: 0,
        }
    }
    fn push(&mut self, weight: f64, from: u32, to: u32) {
        let level =
            ((weight.clamp(0.0, 1.0) * (LEVELS - 1) as f64).round() as usize).min(LEVELS - 1);
        self.buckets[level].push((from, to));
        self.top = self.top.max(level);
    }
    fn pop(&mut self) -> Option<(u32, u32)> {
        loop {
            if let Some(x) = self.buckets[self.top].pop() {
                return Some(x);
            }
            if self.top == 0 {
                return None;
            }
            self.top -= 1;
        }
    }
}

fn push_edges(neighbours: &[u32], from: u32, t: &[V3], done: &[bool], queue: &mut BucketQueue) {
    let tf = t[from as usize];
    for &w in neighbours {
        if (w as usize) < done.len() && !done[w as usize] {
            // NaN-free: directions are finite; a zero direction gives weight 0.
            queue.push(vec3::dot(tf, t[w as usize]).abs(), from, w);
        }
    }
}

#[cfg(test)]
#[path = "orient_test.rs"]
mod tests;
