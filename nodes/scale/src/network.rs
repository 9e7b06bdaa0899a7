//! A feature curve network as a plain edge graph (the working form of `scale.conform` and
//! `scale.check`): conversion from and to [`FeatureCurveNetwork`], input validation, and arcs
//! (maximal paths between extraordinary vertices, or closed loops).

use crestflow_geom::fcn::SurfacePoint;
use crestflow_geom::vec3::V3;
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork};

use crate::conflicts::incidence;

/// Why a network cannot be processed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NetworkError {
    #[error("curve {curve} references network vertex {index} but the network has {n} vertices")]
    CurveIndex { curve: usize, index: u32, n: usize },
    #[error("network vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition { vertex: usize, position: V3 },
    #[error("network vertex {vertex} has a non-finite strength {strength}")]
    NonFiniteStrength { vertex: usize, strength: f64 },
}

/// The network as vertices and edges. Edges are undirected, without repeats or self-loops.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Graph {
    pub pos: Vec<V3>,
    pub strength: Vec<f64>,
    pub location: Vec<SurfacePoint>,
    pub edges: Vec<[u32; 2]>,
    /// The input curve each edge comes from.
    pub src: Vec<u32>,
}

/// Checks the indices and numbers of `net`.
pub fn validate(net: &FeatureCurveNetwork) -> Result<(), NetworkError> {
    let n = net.vertices.len();
    for (vertex, v) in net.vertices.iter().enumerate() {
        if !v.position.iter().all(|c| c.is_finite()) {
            return Err(NetworkError::NonFinitePosition {
                vertex,
                position: v.position,
            });
        }
        if !v.strength.is_finite() {
            return Err(NetworkError::NonFiniteStrength {
                vertex,
                strength: v.strength,
            });
        }
    }
    for (curve, c) in net.curves.iter().enumerate() {
        if let Some(&index) = c.vertices.iter().find(|&&i| i as usize >= n) {
            return Err(NetworkError::CurveIndex { curve, index, n });
        }
    }
    Ok(())
}

impl Graph {
    /// The edges of `net` (validated first). With `weld`, vertices at exactly the same position
    /// become one vertex (the one with the lowest index), so curves meeting at a point are
    /// connected. Self-loops are dropped and repeated edges kept once (the first curve wins).
    pub fn from_network(net: &FeatureCurveNetwork, weld: bool) -> Result<Graph, NetworkError> {
        validate(net)?;
        let n = net.vertices.len();
        let mut rep: Vec<u32> = (0..n as u32).collect();
        if weld {
            let mut order: Vec<u32> = (0..n as u32).collect();
            let key = |i: u32| net.vertices[i as usize].position.map(f64::to_bits);
            order.sort_by(|&a, &b| key(a).cmp(&key(b)).then(a.cmp(&b)));
            for w in 1..order.len() {
                if key(order[w]) == key(order[w - 1]) {
                    rep[order[w] as usize] = rep[order[w - 1] as usize];
                }
            }
        }
        let mut seen = std::collections::BTreeSet::new();
        let mut edges = Vec::new();
        let mut src = Vec::new();
        for c in 0..net.curves.len() {
            for (a, b) in net.curve_edges(c) {
                let (a, b) = (rep[a as usize], rep[b as usize]);
                if a == b || !seen.insert((a.min(b), a.max(b))) {
                    continue;
                }
                edges.push([a, b]);
                src.push(c as u32);
            }
        }
        Ok(Graph {
            pos: net.vertices.iter().map(|v| v.position).collect(),
            strength: net.vertices.iter().map(|v| v.strength).collect(),
            location: net.vertices.iter().map(|v| v.location).collect(),
            edges,
            src,
        }
        .compact())
    }

    /// Drops the vertices no edge uses (keeping the order of the others).
    pub fn compact(mut self) -> Graph {
        let mut used = vec![false; self.pos.len()];
        for &[a, b] in &self.edges {
            used[a as usize] = true;
            used[b as usize] = true;
        }
        let mut map = vec![u32::MAX; self.pos.len()];
        let mut k = 0u32;
        for (v, &u) in used.iter().enumerate() {
            if u {
                map[v] = k;
                k += 1;
            }
        }
        let keep = |v: &Vec<bool>, i: usize| v[i];
        let mut i = 0;
        self.pos.retain(|_| {
            i += 1;
            keep(&used, i - 1)
        });
        i = 0;
        self.strength.retain(|_| {
            i += 1;
            keep(&used, i - 1)
        });
        i = 0;
        self.location.retain(|_| {
            i += 1;
            keep(&used, i - 1)
        });
        for e in &mut self.edges {
            *e = [map[e[0] as usize], map[e[1] as usize]];
        }
        self
    }

    pub fn n_vertices(&self) -> usize {
        self.pos.len()
    }

    /// Arcs: paths between extraordinary vertices (valence ≠ 2), then closed loops, in a
    /// deterministic order.
    pub fn arcs(&self) -> Vec<Arc> {
        let inc = incidence(self.pos.len(), &self.edges);
        let extra = |v: u32| inc[v as usize].len() != 2;
        let mut used = vec![false; self.edges.len()];
        let mut arcs = Vec::new();
        let other = |e: u32, v: u32| {
            let [a, b] = self.edges[e as usize];
            if a == v {
                b
            } else {
                a
            }
        };
        let walk = |start: u32, e0: u32, used: &mut Vec<bool>| -> Arc {
            let mut verts = vec![start];
            let mut es = vec![e0];
            used[e0 as usize] = true;
            let mut cur = other(e0, start);
            let mut e = e0;
            loop {
                if cur == start && !extra(cur) {
                    return Arc {
                        verts,
                        edges: es,
                        closed: true,
                    };
                }
                verts.push(cur);
                if extra(cur) {
                    return Arc {
                        verts,
                        edges: es,
                        closed: false,
                    };
                }
                let next = inc[cur as usize]
                    .iter()
                    .copied()
                    .find(|&f| f != e && !used[f as usize]);
                match next {
                    Some(f) => {
                        used[f as usize] = true;
                        es.push(f);
                        e = f;
                        cur = other(f, cur);
                    }
                    None => {
                        return Arc {
                            verts,
                            edges: es,
                            closed: false,
                        }
                    }
                }
            }
        };
        for v in 0..self.pos.len() as u32 {
            if !extra(v) {
                continue;
            }
            for &e in &inc[v as usize] {
                if !used[e as usize] {
                    arcs.push(walk(v, e, &mut used));
                }
            }
        }
        for e in 0..self.edges.len() as u32 {
            if !used[e as usize] {
                let start = self.edges[e as usize][0];
                arcs.push(walk(start, e, &mut used));
            }
        }
        arcs
    }

    /// The network: one curve per arc, labelled after the input curve of its first edge.
    pub fn to_network(&self, labels: &[CurveLabel]) -> FeatureCurveNetwork {
        let vertices = (0..self.pos.len())
            .map(|v| FcnVertex {
                position: self.pos[v],
                location: self.location[v],
                strength: self.strength[v],
            })
            .collect();
        let curves = self
            .arcs()
            .into_iter()
            .map(|a| FeatureCurve {
                label: labels
                    .get(self.src[a.edges[0] as usize] as usize)
                    .copied()
                    .unwrap_or(CurveLabel::Other),
                vertices: a.verts,
                closed: a.closed,
            })
            .collect();
        FeatureCurveNetwork { vertices, curves }
    }
}

/// A path of the graph: `verts` has one more entry than `edges` for an open arc, as many for a
/// closed one (the first vertex is not repeated).
#[derive(Clone, Debug, PartialEq)]
pub struct Arc {
    pub verts: Vec<u32>,
    pub edges: Vec<u32>,
    pub closed: bool,
}
