//! Which input edges constrain the remeshing (thesis §5.1.1: the feature network is kept in the
//! output), and how they split into chains.
//!
//! Feature edges of the input mesh are the union of
//! - boundary edges (always: boundaries are preserved);
//! - sharp edges, whose two face normals differ by more than a dihedral threshold (optional);
//! - the edges of a [`FeatureCurveNetwork`] snapped to the mesh. **Snapping rule:** each curve
//!   vertex becomes one mesh vertex: `Vertex(v)` is v, `Edge { a, b, t }` the nearer end
//!   (a when t < 0.5), `Face { f, bary }` the corner with the largest barycentric weight,
//!   `Free` the nearest corner of the closest face. Consecutive snapped vertices are joined by
//!   the shortest path over mesh edges (Dijkstra, Euclidean edge lengths; a path is given up
//!   after 20 000 settled vertices and counted in `segments_unjoined`).
//!
//! The feature edges form a graph. Its *corners* are vertices with a number of feature edges
//! other than two, and two-edge vertices where the feature turns by more than a threshold.
//! Chains are the feature paths between corners, or closed loops without one. In the output,
//! corners stay where they are, and other feature vertices slide along their chain only.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use crestflow_geom::fcn::SurfacePoint;
use crestflow_geom::mesh::NO_FACE;
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

use crate::bvh::Bvh;

/// Where a network vertex lies on a mesh element that does not exist.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FeatureError {
    #[error("curve {curve} references network vertex {index} but the network has {n} vertices")]
    CurveIndex { curve: usize, index: u32, n: usize },
    #[error(
        "network vertex {vertex} lies on mesh {element} {index}, but the mesh has {n} of them"
    )]
    Location {
        vertex: usize,
        element: &'static str,
        index: u32,
        n: usize,
    },
}

/// Feature edges of the input mesh, in [`crestflow_geom::Topology::edges`] order.
#[derive(Clone, Debug, Default)]
pub struct FeatureEdges {
    pub is_feature: Vec<bool>,
    /// Marked by the dihedral angle only (neither boundary nor curve).
    pub sharp_only: Vec<bool>,
    /// Sharp edges dropped by [`prune_short_sharp_chains`].
    pub pruned: usize,
    pub boundary: usize,
    pub sharp: usize,
    pub from_curves: usize,
    pub segments_unjoined: usize,
}

impl FeatureEdges {
    pub fn count(&self) -> usize {
        self.is_feature.iter().filter(|&&x| x).count()
    }
}

/// Marks boundary edges, sharp edges (if `sharp_angle_deg` is `Some`) and the snapped curves.
pub fn mark_features(
    mesh: &TriMesh,
    sharp_angle_deg: Option<f64>,
    curves: Option<&FeatureCurveNetwork>,
    bvh: &Bvh,
) -> Result<FeatureEdges, FeatureError> {
    let topo = mesh.topology();
    let ne = topo.edges.len();
    let mut fe = FeatureEdges {
        is_feature: vec![false; ne],
        sharp_only: vec![false; ne],
        ..Default::default()
    };
    let normals = mesh.face_normals();
    let cos_sharp = sharp_angle_deg.map(|a| a.to_radians().cos());
    for e in 0..ne {
        let [f0, f1] = topo.edge_faces[e];
        if f1 == NO_FACE {
            fe.is_feature[e] = true;
            fe.boundary += 1;
        } else if let Some(c) = cos_sharp {
            if vec3::dot(normals[f0 as usize], normals[f1 as usize]) < c {
                fe.is_feature[e] = true;
                fe.sharp_only[e] = true;
                fe.sharp += 1;
            }
        }
    }
    if let Some(net) = curves {
        let snapped = snap_vertices(mesh, net, bvh)?;
        for (ci, curve) in net.curves.iter().enumerate() {
            if let Some(&index) = curve
                .vertices
                .iter()
                .find(|&&i| i as usize >= net.vertices.len())
            {
                return Err(FeatureError::CurveIndex {
                    curve: ci,
                    index,
                    n: net.vertices.len(),
                });
            }
            for (a, b) in net.curve_edges(ci) {
                let (u, w) = (snapped[a as usize], snapped[b as usize]);
                if u == w {
                    continue;
                }
                match shortest_path(mesh, u, w) {
                    Some(path) => {
                        for p in path.windows(2) {
                            if let Some(e) = topo.find_edge(p[0], p[1]) {
                                fe.sharp_only[e as usize] = false;
                                if !fe.is_feature[e as usize] {
                                    fe.is_feature[e as usize] = true;
                                    fe.from_curves += 1;
                                }
                            }
                        }
                    }
                    None => fe.segments_unjoined += 1,
                }
            }
        }
    }
    Ok(fe)
}

/// The mesh vertex of each network vertex (see the module docs for the rule).
fn snap_vertices(
    mesh: &TriMesh,
    net: &FeatureCurveNetwork,
    bvh: &Bvh,
) -> Result<Vec<u32>, FeatureError> {
    let (nv, nf) = (mesh.n_vertices() as u32, mesh.n_faces() as u32);
    let bad = |vertex: usize, element: &'static str, index: u32, n: u32| FeatureError::Location {
        vertex,
        element,
        index,
        n: n as usize,
    };
    let nearest_corner = |f: u32, p: V3| {
        let t = mesh.triangles[f as usize];
        let mut best = t[0];
        for &c in &t[1..] {
            if vec3::dist(mesh.positions[c as usize], p)
                < vec3::dist(mesh.positions[best as usize], p)
            {
                best = c;
            }
        }
        best
    };
    net.vertices
        .iter()
        .enumerate()
        .map(|(i, v)| match v.location {
            SurfacePoint::Vertex(x) if x < nv => Ok(x),
            SurfacePoint::Vertex(x) => Err(bad(i, "vertex", x, nv)),
            SurfacePoint::Edge { a, b, t } => {
                if a >= nv {
                    Err(bad(i, "vertex", a, nv))
                } else if b >= nv {
                    Err(bad(i, "vertex", b, nv))
                } else if t < 0.5 {
                    Ok(a)
                } else {
                    Ok(b)
                }
            }
            SurfacePoint::Face { f, bary } => {
                if f >= nf {
                    return Err(bad(i, "face", f, nf));
                }
                let t = mesh.triangles[f as usize];
                let k = if bary[0] >= bary[1] && bary[0] >= bary[2] {
                    0
                } else if bary[1] >= bary[2] {
                    1
                } else {
                    2
                };
                Ok(t[k])
            }
            SurfacePoint::Free => {
                let hit = bvh.closest(v.position);
                Ok(nearest_corner(hit.face, v.position))
            }
        })
        .collect()
}

/// Vertices of the shortest edge path from `u` to `w` (both included), `None` when the search
/// gives up (see the module docs).
fn shortest_path(mesh: &TriMesh, u: u32, w: u32) -> Option<Vec<u32>> {
    const MAX_SETTLED: usize = 20_000;
    let topo = mesh.topology();
    let mut dist: HashMap<u32, (f64, u32)> = HashMap::new();
    let mut heap = BinaryHeap::new();
    dist.insert(u, (0.0, u32::MAX));
    heap.push(Reverse((Ord64(0.0), u)));
    let mut settled = 0;
    while let Some(Reverse((Ord64(d), v))) = heap.pop() {
        if dist.get(&v).is_some_and(|&(dv, _)| d > dv) {
            continue;
        }
        if v == w {
            let mut path = vec![w];
            let mut x = w;
            while let Some(&(_, p)) = dist.get(&x) {
                if p == u32::MAX {
                    break;
                }
                path.push(p);
                x = p;
            }
            path.reverse();
            return Some(path);
        }
        settled += 1;
        if settled > MAX_SETTLED {
            return None;
        }
        let pv = mesh.positions[v as usize];
        for &n in topo.neighbors(v) {
            let nd = d + vec3::dist(pv, mesh.positions[n as usize]);
            let better = match dist.get(&n) {
                None => true,
                Some(&(old, _)) => nd < old,
            };
            if better {
                dist.insert(n, (nd, v));
                heap.push(Reverse((Ord64(nd), n)));
            }
        }
    }
    None
}

/// f64 ordered by `total_cmp` (ties broken by the vertex index in the heap tuple).
#[derive(Clone, Copy, PartialEq)]
struct Ord64(f64);
impl Eq for Ord64 {}
impl PartialOrd for Ord64 {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Ord64 {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// Feature chains: polylines of input vertices between corners (or closed loops).
#[derive(Clone, Debug, Default)]
pub struct Chains {
    /// Per input vertex: a corner of the feature graph.
    pub is_corner: Vec<bool>,
    /// Per input vertex: the chain it lies inside of (`u32::MAX` for corners and non-feature
    /// vertices).
    pub vertex_chain: Vec<u32>,
    /// Per input edge: its chain (`u32::MAX` for non-feature edges).
    pub edge_chain: Vec<u32>,
    /// Points of each chain in order (a closed chain repeats its first point at the end).
    pub points: Vec<Vec<V3>>,
    /// Per input vertex inside a chain: its arc length from the chain's first point.
    pub vertex_param: Vec<f64>,
    /// Per chain: a loop without a corner (its parameter wraps around).
    pub closed: Vec<bool>,
}

/// Splits the feature edges into chains; `corner_angle_deg` is the turning angle above which a
/// two-edge feature vertex is a corner.
pub fn build_chains(mesh: &TriMesh, fe: &FeatureEdges, corner_angle_deg: f64) -> Chains {
    let topo = mesh.topology();
    let nv = mesh.n_vertices();
    // Feature edges at each vertex (input edge indices, in vertex-neighbour order).
    let mut inc: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if fe.is_feature[e] {
            inc[a as usize].push(e as u32);
            inc[b as usize].push(e as u32);
        }
    }
    let other = |e: u32, v: u32| {
        let [a, b] = topo.edges[e as usize];
        if a == v {
            b
        } else {
            a
        }
    };
    let cos_corner = corner_angle_deg.to_radians().cos();
    let p = |v: u32| mesh.positions[v as usize];
    let is_corner: Vec<bool> = (0..nv as u32)
        .map(|v| {
            let es = &inc[v as usize];
            match es.len() {
                0 => false,
                2 => {
                    let (x, y) = (other(es[0], v), other(es[1], v));
                    let d1 = vec3::normalize(vec3::sub(p(v), p(x)));
                    let d2 = vec3::normalize(vec3::sub(p(y), p(v)));
                    vec3::dot(d1, d2) < cos_corner
                }
                _ => true,
            }
        })
        .collect();
    let mut edge_chain = vec![u32::MAX; topo.edges.len()];
    let mut vertex_chain = vec![u32::MAX; nv];
    let mut vertex_param = vec![0.0; nv];
    let mut closed = Vec::new();
    let mut points = Vec::new();
    // Walk from every corner along each of its feature edges, then the loops that remain.
    let mut walk = |start: u32,
                    first: u32,
                    edge_chain: &mut Vec<u32>,
                    vertex_chain: &mut Vec<u32>,
                    vertex_param: &mut Vec<f64>| {
        let id = points.len() as u32;
        let mut pts = vec![p(start)];
        let (mut v, mut e) = (start, first);
        let mut s = 0.0;
        loop {
            edge_chain[e as usize] = id;
            let w = other(e, v);
            s += vec3::dist(p(v), p(w));
            pts.push(p(w));
            if w == start || is_corner[w as usize] {
                break;
            }
            vertex_chain[w as usize] = id;
            vertex_param[w as usize] = s;
            let es = &inc[w as usize];
            let next = if es[0] == e { es[1] } else { es[0] };
            if edge_chain[next as usize] != u32::MAX {
                break;
            }
            v = w;
            e = next;
        }
        if !is_corner[start as usize] {
            vertex_chain[start as usize] = id;
            vertex_param[start as usize] = 0.0;
        }
        closed.push(!is_corner[start as usize]);
        points.push(pts);
    };
    for v in 0..nv as u32 {
        if is_corner[v as usize] {
            for &e in &inc[v as usize].clone() {
                if edge_chain[e as usize] == u32::MAX {
                    walk(v, e, &mut edge_chain, &mut vertex_chain, &mut vertex_param);
                }
            }
        }
    }
    for v in 0..nv as u32 {
        if !is_corner[v as usize] && inc[v as usize].len() == 2 {
            let e = inc[v as usize][0];
            if edge_chain[e as usize] == u32::MAX {
                walk(v, e, &mut edge_chain, &mut vertex_chain, &mut vertex_param);
            }
        }
    }
    Chains {
        is_corner,
        vertex_chain,
        edge_chain,
        points,
        vertex_param,
        closed,
    }
}

/// Drops chains made of sharp edges only that end freely at both ends (a feature endpoint, not
/// a junction) and are shorter than `min_length`: a crease shorter than the target edge length
/// cannot be kept without slivers, and it is not part of a larger feature. Returns the
/// chains rebuilt without them.
pub fn prune_short_sharp_chains(
    mesh: &TriMesh,
    fe: &mut FeatureEdges,
    chains: Chains,
    min_length: f64,
    corner_angle_deg: f64,
) -> Chains {
    if !(min_length > 0.0) {
        return chains;
    }
    let topo = mesh.topology();
    let mut count = vec![0u32; mesh.n_vertices()];
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if fe.is_feature[e] {
            count[a as usize] += 1;
            count[b as usize] += 1;
        }
    }
    let n_chains = chains.points.len();
    let mut length = vec![0.0; n_chains];
    let mut all_sharp = vec![true; n_chains];
    let mut free_ends = vec![0u32; n_chains];
    for (e, &c) in chains.edge_chain.iter().enumerate() {
        if c == u32::MAX {
            continue;
        }
        let [a, b] = topo.edges[e];
        length[c as usize] += vec3::dist(mesh.positions[a as usize], mesh.positions[b as usize]);
        all_sharp[c as usize] &= fe.sharp_only[e];
        free_ends[c as usize] += (count[a as usize] == 1) as u32 + (count[b as usize] == 1) as u32;
    }
    let drop: Vec<bool> = (0..n_chains)
        .map(|c| all_sharp[c] && free_ends[c] >= 2 && length[c] < min_length)
        .collect();
    if !drop.iter().any(|&d| d) {
        return chains;
    }
    for (e, &c) in chains.edge_chain.iter().enumerate() {
        if c != u32::MAX && drop[c as usize] {
            fe.is_feature[e] = false;
            fe.sharp_only[e] = false;
            fe.pruned += 1;
        }
    }
    build_chains(mesh, fe, corner_angle_deg)
}
