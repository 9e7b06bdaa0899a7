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
//!   after 20 000 settled vertices and counted in `segments_unjoined`). Along each stroke of
//!   the network (its vertices joined through two-edge vertices), detours of the joined paths
//!   that come back to a vertex already passed are cut out.
//!
//! A stretch of curve between two vertices of one boundary follows the boundary instead when
//! that way is at most `BOUNDARY_DETOUR` times as long and stays within
//! `BOUNDARY_FOLLOW_OFFSET` of the stretch's chord: a network of sharp edges and boundaries
//! (`remesh.sharp_edges`, resampled by `scale.conform`) stands for the boundary there, which
//! is kept anyway.
//!
//! The feature edges form a graph. Its *corners* are vertices with a number of feature edges
//! other than two, and two-edge vertices where the feature turns by more than a threshold;
//! between two curve edges, the turn is the network's own at a network vertex snapped there
//! (the edge path's turns do not count); inside a boundary, after [`mark_boundary_corners`],
//! the turn at the scale of the target length. Chains are the feature paths between corners, or
//! closed loops without one. In the output, corners stay where they are, and other feature
//! vertices slide along their chain only.
//!
//! A chain's points are its input vertices, except for a chain of curve edges only (neither
//! boundary nor sharp): an edge path zig-zags around a network edge that cuts across mesh
//! edges, so such a chain takes the network's geometry instead: its two ends, and between
//! them the positions of the network vertices snapped to its vertices. The other path
//! vertices get the arc length of their closest point on the network segment they stand for
//! (never decreasing along the chain) and are slid onto the network's polyline by the
//! remesher.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use crestflow_geom::fcn::SurfacePoint;
use crestflow_geom::mesh::NO_FACE;
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

use crate::bvh::closest_on_segment;
use crate::project::Projector;

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
    /// Marked by the curves only (neither boundary nor sharp).
    pub from_curve: Vec<bool>,
    /// Per input vertex that a network vertex snaps to: that network vertex's position and
    /// the cosine of the network's turning angle there (-2 where the network has a number of
    /// edges other than two; the smallest when several network vertices snap to one vertex).
    pub anchor: Vec<Option<(V3, f64)>>,
    /// Sharp edges dropped by [`prune_short_sharp_chains`].
    pub pruned: usize,
    /// Curve edges dropped by [`trim_curve_ends_near`].
    pub trimmed: usize,
    pub boundary: usize,
    /// Per input vertex, set by [`mark_boundary_corners`]: whether a vertex inside a boundary
    /// (two boundary edges and no other feature edge) is a corner. Empty: such vertices follow
    /// the per-vertex turning rule of [`build_chains`].
    pub boundary_corner: Vec<bool>,
    /// Chains of curve edges take the edge path's geometry, not the network's: set when no
    /// relaxation will move the path's vertices onto the network's polyline (see
    /// [`build_chains`]).
    pub curves_on_path: bool,
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
/// A straight network edge that strays farther than `stray` from the input surface (a chord
/// across it) is not followed: the vertices of its edge path become reference points of the
/// chain, at their own positions ([`f64::INFINITY`]: every network edge is followed).
pub fn mark_features(
    mesh: &TriMesh,
    sharp_angle_deg: Option<f64>,
    curves: Option<&FeatureCurveNetwork>,
    surface: &Projector,
    stray: f64,
) -> Result<FeatureEdges, FeatureError> {
    let topo = mesh.topology();
    let ne = topo.edges.len();
    let mut fe = FeatureEdges {
        is_feature: vec![false; ne],
        sharp_only: vec![false; ne],
        from_curve: vec![false; ne],
        anchor: vec![None; mesh.n_vertices()],
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
        let snapped = snap_vertices(mesh, net, surface)?;
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
        }
        // Network neighbours of each network vertex, for its turning angle.
        let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); net.vertices.len()];
        for (a, b) in net.edges() {
            nbrs[a as usize].push(b);
            nbrs[b as usize].push(a);
        }
        // Cosine of the network's turning angle at each network vertex (-2 where it has a
        // number of edges other than two).
        let turn_cos: Vec<f64> = nbrs
            .iter()
            .enumerate()
            .map(|(i, ns)| {
                let q = |k: u32| net.vertices[k as usize].position;
                let pi = net.vertices[i].position;
                if ns.len() != 2 {
                    return -2.0;
                }
                let (d1, d2) = (vec3::sub(pi, q(ns[0])), vec3::sub(q(ns[1]), pi));
                let (n1, n2) = (vec3::norm(d1), vec3::norm(d2));
                if n1 > 0.0 && n2 > 0.0 {
                    vec3::dot(d1, d2) / (n1 * n2)
                } else {
                    1.0
                }
            })
            .collect();
        for stroke in strokes(net) {
            // The stroke's edge path as (mesh vertex, network vertex or NONE_NET) pairs, in
            // pieces between segments that could not be joined.
            let mut pieces: Vec<Vec<(u32, u32)>> = Vec::new();
            let closed = stroke.len() > 2 && stroke[0] == stroke[stroke.len() - 1];
            let v0 = stroke[0];
            let mut seq = vec![(snapped[v0 as usize], v0)];
            for ab in stroke.windows(2) {
                let (a, b) = (ab[0], ab[1]);
                let (u, w) = (snapped[a as usize], snapped[b as usize]);
                if u == w {
                    continue;
                }
                let path = shortest_path(mesh, u, w).map(|path| {
                    // A stretch of curve between two vertices of one boundary follows the
                    // boundary where that is not much longer: it stands for the boundary (a
                    // network of sharp edges and boundaries, resampled at scale), which is kept
                    // anyway, and a shortcut across its ragged bends would keep a second chain
                    // one triangle inside it.
                    let len = path_length(mesh, &path);
                    boundary_path(mesh, u, w, BOUNDARY_DETOUR * len).unwrap_or(path)
                });
                match path {
                    Some(path) => {
                        let n = path.len();
                        let (pa, pb) = (
                            net.vertices[a as usize].position,
                            net.vertices[b as usize].position,
                        );
                        let inner = if chord_strays(mesh, surface, &path, pa, pb, stray) {
                            ON_PATH
                        } else {
                            NONE_NET
                        };
                        seq.extend(
                            path.into_iter()
                                .enumerate()
                                .skip(1)
                                .map(|(i, x)| (x, if i + 1 == n { b } else { inner })),
                        );
                    }
                    None => {
                        fe.segments_unjoined += 1;
                        pieces.push(std::mem::replace(&mut seq, vec![(w, b)]));
                    }
                }
            }
            pieces.push(seq);
            let loop_closes = closed && pieces.len() == 1;
            for piece in pieces {
                let path = erase_loops(piece, loop_closes);
                let mut mark = |x: u32, y: u32| {
                    if let Some(e) = topo.find_edge(x, y) {
                        fe.sharp_only[e as usize] = false;
                        if !fe.is_feature[e as usize] {
                            fe.is_feature[e as usize] = true;
                            fe.from_curve[e as usize] = true;
                            fe.from_curves += 1;
                        }
                    }
                };
                for w in path.windows(2) {
                    mark(w[0].0, w[1].0);
                }
                if loop_closes && path.len() > 2 {
                    mark(path[path.len() - 1].0, path[0].0);
                }
                for &(m, n) in &path {
                    if n == NONE_NET {
                        continue;
                    }
                    // A path vertex of a straying chord stands for itself, and never makes
                    // a corner by its turn.
                    let (pn, cos) = if n == ON_PATH {
                        (mesh.positions[m as usize], 1.0)
                    } else {
                        (net.vertices[n as usize].position, turn_cos[n as usize])
                    };
                    let slot = &mut fe.anchor[m as usize];
                    *slot = Some(match *slot {
                        None => (pn, cos),
                        Some((p, c)) => (p, c.min(cos)),
                    });
                }
            }
        }
    }
    Ok(fe)
}

/// The network's edges as strokes: lists of network vertices joined through vertices with
/// two edges, from one vertex with another number of edges to the next (across curves that
/// meet end to end), then the loops that remain (first vertex repeated at the end).
fn strokes(net: &FeatureCurveNetwork) -> Vec<Vec<u32>> {
    let edges = net.edges();
    let mut adj: Vec<Vec<(u32, usize)>> = vec![Vec::new(); net.vertices.len()];
    for (e, &(a, b)) in edges.iter().enumerate() {
        adj[a as usize].push((b, e));
        adj[b as usize].push((a, e));
    }
    let mut used = vec![false; edges.len()];
    let mut out = Vec::new();
    let walk = |v: u32, used: &mut [bool], out: &mut Vec<Vec<u32>>| {
        for k in 0..adj[v as usize].len() {
            let (mut u, mut e) = adj[v as usize][k];
            if used[e] {
                continue;
            }
            let mut stroke = vec![v];
            loop {
                used[e] = true;
                stroke.push(u);
                if adj[u as usize].len() != 2 {
                    break;
                }
                match adj[u as usize].iter().find(|&&(_, f)| !used[f]) {
                    Some(&(w, f)) => (u, e) = (w, f),
                    None => break,
                }
            }
            out.push(stroke);
        }
    };
    for v in 0..net.vertices.len() as u32 {
        if adj[v as usize].len() != 2 {
            walk(v, &mut used, &mut out);
        }
    }
    for v in 0..net.vertices.len() as u32 {
        if adj[v as usize].len() == 2 {
            walk(v, &mut used, &mut out);
        }
    }
    out
}

/// No network vertex at this path vertex.
const NONE_NET: u32 = u32::MAX;
/// No network vertex at this path vertex, which is a reference point of the chain itself (its
/// network edge strays from the surface: [`chord_strays`]).
const ON_PATH: u32 = u32::MAX - 1;

/// Whether the straight network edge `pa`–`pb` strays farther than `stray` from the input
/// surface, at points `stray` apart along it (at most 256). The edge path `path` between its
/// ends lies on the surface, so a point within `stray` of it is settled without asking the
/// BVH. A chord across the model (a network made at a scale far above the target: the
/// fuzz run with seed 1209, run 107, `scale.conform` at 30 % and the remesh at 1 %) would
/// otherwise put its feature vertices up to 7 L off the surface.
fn chord_strays(
    mesh: &TriMesh,
    surface: &Projector,
    path: &[u32],
    pa: V3,
    pb: V3,
    stray: f64,
) -> bool {
    if !(stray > 0.0 && stray.is_finite()) {
        return false;
    }
    let n = (vec3::dist(pa, pb) / stray).ceil().clamp(1.0, 256.0) as usize;
    (1..n).any(|k| {
        let q = vec3::lerp(pa, pb, k as f64 / n as f64);
        let near_path = path.windows(2).any(|w| {
            let (a, b) = (mesh.positions[w[0] as usize], mesh.positions[w[1] as usize]);
            vec3::dist(q, closest_on_segment(q, a, b).0) <= stray
        });
        !near_path && surface.project(q, u32::MAX, stray).hit.dist2 > stray * stray
    })
}

/// How much longer than the shortest edge path between two boundary vertices the way along
/// the boundary may be for a curve stretch between them to follow the boundary (a boundary
/// that steps at right angles across a grid is twice as long as the straight path).
const BOUNDARY_DETOUR: f64 = 2.5;

/// How far from the straight segment between its ends, relative to that segment's length,
/// the way along the boundary may stray for a curve stretch to follow it: a boundary that
/// bends away (a rounded end, a corner a crease cuts off) is not the curve.
const BOUNDARY_FOLLOW_OFFSET: f64 = 0.3;

/// Length of an edge path.
fn path_length(mesh: &TriMesh, path: &[u32]) -> f64 {
    path.windows(2)
        .map(|w| vec3::dist(mesh.positions[w[0] as usize], mesh.positions[w[1] as usize]))
        .sum()
}

/// The shorter way from `u` to `w` along boundary edges, through vertices with two boundary
/// edges only, if one is at most `max_len` long and no vertex of it lies farther from the
/// segment `u`–`w` than [`BOUNDARY_FOLLOW_OFFSET`] times its length.
fn boundary_path(mesh: &TriMesh, u: u32, w: u32, max_len: f64) -> Option<Vec<u32>> {
    let topo = mesh.topology();
    let boundary_neighbors = |v: u32| {
        topo.neighbors(v).iter().copied().filter(move |&x| {
            topo.find_edge(v, x)
                .is_some_and(|e| topo.is_boundary_edge(e))
        })
    };
    let mut best: Option<(f64, Vec<u32>)> = None;
    for first in boundary_neighbors(u) {
        let (mut prev, mut cur) = (u, first);
        let mut path = vec![u];
        let mut len = 0.0;
        loop {
            len += vec3::dist(mesh.positions[prev as usize], mesh.positions[cur as usize]);
            if len > max_len || best.as_ref().is_some_and(|b| len >= b.0) {
                break;
            }
            path.push(cur);
            if cur == w {
                best = Some((len, path));
                break;
            }
            let mut next = boundary_neighbors(cur).filter(|&x| x != prev);
            match (next.next(), next.next()) {
                (Some(x), None) if x != u && boundary_neighbors(cur).count() == 2 => {
                    (prev, cur) = (cur, x)
                }
                _ => break,
            }
        }
    }
    let (pu, pw) = (mesh.positions[u as usize], mesh.positions[w as usize]);
    let limit = BOUNDARY_FOLLOW_OFFSET * vec3::dist(pu, pw);
    best.map(|(_, p)| p).filter(|p| {
        p.iter().all(|&x| {
            let q = mesh.positions[x as usize];
            vec3::dist(q, closest_on_segment(q, pu, pw).0) <= limit
        })
    })
}

/// The path `seq` without the detours that come back to a vertex already on it (the edge
/// paths of two consecutive network edges may overlap, or touch, near the network vertex
/// between them): each detour is cut out, and the first network vertex on it moves to the
/// vertex where it starts (unless that one has a network vertex already). On a closed curve
/// (`closed`), the last vertex repeats the first and is left out.
fn erase_loops(mut seq: Vec<(u32, u32)>, closed: bool) -> Vec<(u32, u32)> {
    if closed && seq.len() > 1 && seq[0].0 == seq[seq.len() - 1].0 {
        let (_, n) = seq.pop().unwrap_or((0, NONE_NET));
        if seq[0].1 == NONE_NET {
            seq[0].1 = n;
        }
    }
    let mut out: Vec<(u32, u32)> = Vec::with_capacity(seq.len());
    let mut at: HashMap<u32, usize> = HashMap::new();
    for (m, n) in seq {
        match at.get(&m) {
            Some(&i) => {
                // Earliest network vertex on the detour (popped in reverse order), or `n`.
                let mut carried = n;
                while out.len() > i + 1 {
                    let (pm, pn) = out.pop().unwrap_or((0, NONE_NET));
                    at.remove(&pm);
                    if pn != NONE_NET {
                        carried = pn;
                    }
                }
                if out[i].1 == NONE_NET {
                    out[i].1 = carried;
                }
            }
            None => {
                at.insert(m, out.len());
                out.push((m, n));
            }
        }
    }
    out
}

/// The mesh vertex of each network vertex (see the module docs for the rule).
fn snap_vertices(
    mesh: &TriMesh,
    net: &FeatureCurveNetwork,
    surface: &Projector,
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
                let hit = surface.bvh().closest(v.position);
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
pub(crate) struct Ord64(pub(crate) f64);
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
    /// Per chain: made of curve edges only; its points are then the network's own (the
    /// chain's ends and the network vertices in between), not the edge path's.
    pub from_curves: Vec<bool>,
    /// Per chain: made of boundary edges (a chain is either all boundary or none: a vertex
    /// with a boundary edge and another feature edge is a corner).
    pub on_boundary: Vec<bool>,
}

/// Decides which vertices inside boundaries are corners, at the scale `scale` (an arc length,
/// the remesher's target length): the boundary's turn at a vertex is measured between the
/// chords to the points `scale` back and ahead along the boundary (or to the nearest vertex
/// where the boundary meets another feature edge, if closer), and a vertex is a corner when
/// that turn exceeds `corner_angle_deg` and no vertex within `scale` along the boundary turns
/// more (ties: the lower index) and no corner by its feature edges (a crease or curve meeting
/// the boundary) lies within `scale` along it: that one takes the bend's place, since two fixed
/// vertices closer than the target would pin a needle (cgal_blade's rim wall, 0.025 L thick,
/// ends at the boundary beside such a bend). Per input edge a scan's boundary zig-zags by a right angle
/// at almost every vertex; at the scale of the output only its real corners stand out, and a
/// bend narrower than the scale (a blade's end, two close corners) becomes one corner.
/// Vertices elsewhere keep the per-vertex rule of [`build_chains`].
pub fn mark_boundary_corners(
    mesh: &TriMesh,
    fe: &mut FeatureEdges,
    scale: f64,
    corner_angle_deg: f64,
) {
    let topo = mesh.topology();
    let nv = mesh.n_vertices();
    // The two boundary neighbours of each vertex inside a boundary (no other feature edge).
    // The walks below stop at every other vertex, so `nbr` is read only where it is whole.
    let mut degree = vec![0u32; nv];
    let mut nbr = vec![[u32::MAX; 2]; nv];
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if !fe.is_feature[e] {
            continue;
        }
        let boundary = topo.is_boundary_edge(e as u32);
        for (v, w) in [(a, b), (b, a)] {
            let d = &mut degree[v as usize];
            if boundary && *d < 2 {
                nbr[v as usize][*d as usize] = w;
            }
            // Other feature edges count three, so that such vertices never pass as inside.
            *d += if boundary { 1 } else { 3 };
        }
    }
    let inside = |v: u32| degree[v as usize] == 2;
    let p = |v: u32| mesh.positions[v as usize];
    // From `v` towards its neighbour `first`: the point at arc length `scale`, and the
    // vertices passed before it (inside the boundary, `v` excluded), with their arc lengths.
    // Also whether the walk met such a vertex (a corner by its feature edges) before `scale`.
    let walk = |v: u32, first: u32, passed: &mut Vec<u32>| -> (V3, bool) {
        passed.clear();
        let (mut prev, mut cur, mut s) = (v, first, 0.0);
        loop {
            let len = vec3::dist(p(prev), p(cur));
            if s + len >= scale {
                let t = if len > 0.0 { (scale - s) / len } else { 1.0 };
                return (vec3::lerp(p(prev), p(cur), t), false);
            }
            s += len;
            if cur == v || !inside(cur) {
                return (p(cur), cur != v);
            }
            passed.push(cur);
            let [x, y] = nbr[cur as usize];
            (prev, cur) = (cur, if x == prev { y } else { x });
        }
    };
    // Cosine of the turn at scale (1 = straight) of every vertex inside a boundary.
    let mut passed = Vec::new();
    let cos_turn: Vec<f64> = (0..nv as u32)
        .map(|v| {
            if !inside(v) {
                return 1.0;
            }
            let [x, y] = nbr[v as usize];
            let (back, _) = walk(v, x, &mut passed);
            let (ahead, _) = walk(v, y, &mut passed);
            let (d0, d1) = (vec3::sub(p(v), back), vec3::sub(ahead, p(v)));
            let l = vec3::norm(d0) * vec3::norm(d1);
            if l > 0.0 {
                vec3::dot(d0, d1) / l
            } else {
                1.0
            }
        })
        .collect();
    let cos_corner = corner_angle_deg.to_radians().cos();
    let mut corner = vec![false; nv];
    for v in 0..nv as u32 {
        let c = cos_turn[v as usize];
        if !inside(v) || !(c < cos_corner) {
            continue;
        }
        let sharper = |w: u32| {
            let cw = cos_turn[w as usize];
            cw < c || (cw == c && w < v)
        };
        let [x, y] = nbr[v as usize];
        let mut beaten = false;
        for first in [x, y] {
            // A corner by its feature edges within the scale stands for this bend.
            let (_, junction) = walk(v, first, &mut passed);
            beaten |= junction || passed.iter().any(|&w| w != v && sharper(w));
        }
        corner[v as usize] = !beaten;
    }
    fe.boundary_corner = corner;
}

/// Splits the feature edges into chains; `corner_angle_deg` is the turning angle above which a
/// two-edge feature vertex is a corner. A chain of curve edges has the network's points (its
/// path vertices get parameters on them and are moved there by the remesher's relaxation),
/// or, with [`FeatureEdges::curves_on_path`], the path's own.
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
    let curve_edge = |e: u32| fe.from_curve.get(e as usize).copied().unwrap_or(false);
    let is_corner: Vec<bool> = (0..nv as u32)
        .map(|v| {
            let es = &inc[v as usize];
            match es.len() {
                0 => false,
                // Inside a curve, the network decides: its turns, not those of the edge path.
                2 if curve_edge(es[0]) && curve_edge(es[1]) => match fe.anchor.get(v as usize) {
                    Some(Some((_, cos))) => *cos < cos_corner,
                    _ => false,
                },
                2 if !fe.boundary_corner.is_empty()
                    && topo.is_boundary_edge(es[0])
                    && topo.is_boundary_edge(es[1]) =>
                {
                    fe.boundary_corner[v as usize]
                }
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
    let mut from_curves = Vec::new();
    // Walk from every corner along each of its feature edges, then the loops that remain.
    let mut walk = |start: u32,
                    first: u32,
                    edge_chain: &mut Vec<u32>,
                    vertex_chain: &mut Vec<u32>,
                    vertex_param: &mut Vec<f64>| {
        let id = points.len() as u32;
        let mut vs = vec![start];
        let (mut v, mut e) = (start, first);
        let mut all_curve = true;
        loop {
            edge_chain[e as usize] = id;
            all_curve &= curve_edge(e);
            let w = other(e, v);
            vs.push(w);
            if w == start || is_corner[w as usize] {
                break;
            }
            vertex_chain[w as usize] = id;
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
        }
        let last = vs.len() - 1;
        // Vertices that get a parameter: all but the ends, and the last one when the walk
        // stopped at an edge already taken rather than at a corner or back at the start.
        let inside = |i: usize| i < last || (vs[i] != start && !is_corner[vs[i] as usize]);
        let pts = if all_curve && !fe.curves_on_path {
            // The network's own geometry: the chain's ends, and the network vertices in
            // between; each path vertex between two of them gets the parameter of its closest
            // point on the segment joining them (never decreasing along the chain).
            // A loop starts at a vertex of the network where it can (see the walks below):
            // then its first and last reference point is that network vertex, not the mesh
            // vertex standing in for it, which would add a short segment and a false bend.
            let first = if vs[last] == vs[0] && !is_corner[vs[0] as usize] {
                fe.anchor
                    .get(vs[0] as usize)
                    .copied()
                    .flatten()
                    .map_or(p(vs[0]), |a| a.0)
            } else {
                p(vs[0])
            };
            let mut pts = vec![first];
            for (i, &w) in vs.iter().enumerate().skip(1) {
                let anchor = if i == last {
                    Some(if w == vs[0] { first } else { p(w) })
                } else {
                    fe.anchor.get(w as usize).copied().flatten().map(|a| a.0)
                };
                // Anchors are marked with their reference index, other vertices with NaN.
                if inside(i) {
                    vertex_param[w as usize] = if anchor.is_some() {
                        pts.len() as f64
                    } else {
                        f64::NAN
                    };
                }
                if let Some(q) = anchor {
                    pts.push(q);
                }
            }
            // Parameters: anchors at their reference point, path vertices between two at the
            // closest point of the segment joining them, never decreasing along the chain.
            let mut prev: f64 = 0.0;
            let mut k = 0; // index of the reference segment [pts[k], pts[k + 1]]
            let mut cums = vec![0.0; pts.len()];
            for j in 1..pts.len() {
                cums[j] = cums[j - 1] + vec3::dist(pts[j - 1], pts[j]);
            }
            for (i, &w) in vs.iter().enumerate().skip(1) {
                if !inside(i) {
                    continue;
                }
                let s = vertex_param[w as usize];
                let s = if s.is_nan() {
                    let (a, b) = (pts[k], pts[(k + 1).min(pts.len() - 1)]);
                    let d = vec3::sub(b, a);
                    let len2 = vec3::dot(d, d);
                    let t = if len2 > 0.0 {
                        (vec3::dot(vec3::sub(p(w), a), d) / len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    cums[k] + t * len2.sqrt()
                } else {
                    k += 1;
                    cums[k]
                };
                prev = s.max(prev);
                vertex_param[w as usize] = prev;
            }
            pts
        } else {
            let mut pts = vec![p(vs[0])];
            let mut s = 0.0;
            for (i, &w) in vs.iter().enumerate().skip(1) {
                s += vec3::dist(p(vs[i - 1]), p(w));
                pts.push(p(w));
                if inside(i) {
                    vertex_param[w as usize] = s;
                }
            }
            pts
        };
        if !is_corner[start as usize] {
            vertex_param[start as usize] = 0.0;
        }
        closed.push(!is_corner[start as usize]);
        points.push(pts);
        from_curves.push(all_curve);
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
    // Loops: those through a network vertex start at one (the first in vertex order), the
    // others at their first vertex.
    for anchored in [true, false] {
        for v in 0..nv as u32 {
            let has_anchor = fe.anchor.get(v as usize).is_some_and(|a| a.is_some());
            if anchored && !has_anchor {
                continue;
            }
            if !is_corner[v as usize] && inc[v as usize].len() == 2 {
                let e = inc[v as usize][0];
                if edge_chain[e as usize] == u32::MAX {
                    walk(v, e, &mut edge_chain, &mut vertex_chain, &mut vertex_param);
                }
            }
        }
    }
    let mut on_boundary = vec![false; points.len()];
    for (e, &c) in edge_chain.iter().enumerate() {
        if c != u32::MAX && topo.is_boundary_edge(e as u32) {
            on_boundary[c as usize] = true;
        }
    }
    Chains {
        is_corner,
        vertex_chain,
        edge_chain,
        points,
        vertex_param,
        on_boundary,
        closed,
        from_curves,
    }
}

/// Curve chains that stand for a boundary: both ends on the boundary and their polyline
/// (sampled every `tol` / 2, at most 64 points a segment) nowhere farther than `tol` from the input's boundary
/// edges. Their edges stop being features; the boundary between their ends is kept anyway,
/// resampled within the same tolerance, and the two would meet: a curve vertex slid onto the
/// network's chord between two corners lies on the boundary edge that joins them once the
/// boundary is resampled (a flat triangle). Then the boundary corners are found again at
/// `scale` and the chains rebuilt. Returns the chains and how many edges were dropped.
pub fn drop_curves_along_boundaries(
    mesh: &TriMesh,
    fe: &mut FeatureEdges,
    chains: Chains,
    tol: f64,
    scale: f64,
    corner_angle_deg: f64,
) -> (Chains, usize) {
    let topo = mesh.topology();
    let boundary: Vec<(V3, V3)> = (0..topo.edges.len())
        .filter(|&e| topo.is_boundary_edge(e as u32))
        .map(|e| {
            let [a, b] = topo.edges[e];
            (mesh.positions[a as usize], mesh.positions[b as usize])
        })
        .collect();
    if boundary.is_empty() || !(tol > 0.0) {
        return (chains, 0);
    }
    // The boundary edges by the cells of points along them, the cells' side at least 2 tol
    // (and a sixteenth of the longest boundary edge, which bounds the work when `tol` is tiny),
    // the points at most 2 (side - tol) apart: a point within `tol` of an edge lies within
    // `side` of one of those points, so it finds the edge in its own cell or a neighbouring one.
    let longest = boundary
        .iter()
        .map(|&(a, b)| vec3::dist(a, b))
        .fold(0.0, f64::max);
    let side = (2.0 * tol).max(longest / 16.0);
    let cell = |p: V3| p.map(|x| (x / side).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, &(a, b)) in boundary.iter().enumerate() {
        let steps = (vec3::dist(a, b) / (2.0 * (side - tol))).ceil().max(1.0) as usize;
        let mut last = None;
        for k in 0..=steps {
            let c = cell(vec3::lerp(a, b, k as f64 / steps as f64));
            if last != Some(c) {
                let list = grid.entry(c).or_default();
                if list.last() != Some(&(i as u32)) {
                    list.push(i as u32);
                }
                last = Some(c);
            }
        }
    }
    let near_boundary = |p: V3| {
        let [x, y, z] = cell(p);
        (x - 1..=x + 1).any(|cx| {
            (y - 1..=y + 1).any(|cy| {
                (z - 1..=z + 1).any(|cz| {
                    grid.get(&[cx, cy, cz]).is_some_and(|edges| {
                        edges.iter().any(|&i| {
                            let (a, b) = boundary[i as usize];
                            vec3::dist(p, closest_on_segment(p, a, b).0) <= tol
                        })
                    })
                })
            })
        })
    };
    // The end vertices of each chain (the corners its edges reach).
    let mut ends: Vec<Vec<u32>> = vec![Vec::new(); chains.points.len()];
    for (e, &c) in chains.edge_chain.iter().enumerate() {
        if c == u32::MAX {
            continue;
        }
        for v in topo.edges[e] {
            if chains.is_corner[v as usize] && !ends[c as usize].contains(&v) {
                ends[c as usize].push(v);
            }
        }
    }
    let mut drop = vec![false; chains.points.len()];
    for (c, ends) in ends.iter().enumerate() {
        let on_boundary_ends =
            !ends.is_empty() && ends.iter().all(|&v| topo.is_boundary_vertex[v as usize]);
        if !chains.from_curves[c] || chains.closed[c] || !on_boundary_ends {
            continue;
        }
        let pts = &chains.points[c];
        let along = pts.windows(2).all(|w| {
            // Every tol / 2, at most 64 points a segment (a tiny `tol` keeps the boundary as
            // it is; no curve stands for it then).
            let steps = (2.0 * vec3::dist(w[0], w[1]) / tol).ceil().clamp(1.0, 64.0) as usize;
            (0..=steps).all(|i| near_boundary(vec3::lerp(w[0], w[1], i as f64 / steps as f64)))
        });
        drop[c] = along;
    }
    let mut dropped = 0;
    for (e, &c) in chains.edge_chain.iter().enumerate() {
        if c != u32::MAX && drop[c as usize] && fe.from_curve[e] {
            fe.is_feature[e] = false;
            fe.from_curve[e] = false;
            fe.from_curves -= 1;
            dropped += 1;
        }
    }
    if dropped == 0 {
        return (chains, 0);
    }
    mark_boundary_corners(mesh, fe, scale, corner_angle_deg);
    (build_chains(mesh, fe, corner_angle_deg), dropped)
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
    let count = feature_degrees(mesh, fe);
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

/// Number of feature edges at each vertex.
fn feature_degrees(mesh: &TriMesh, fe: &FeatureEdges) -> Vec<u32> {
    let mut degree = vec![0u32; mesh.n_vertices()];
    for (e, &[a, b]) in mesh.topology().edges.iter().enumerate() {
        if fe.is_feature[e] {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
        }
    }
    degree
}

/// Drops the free ends of curves that come within `clearance` of one of `points` (tips kept
/// as fixed vertices): from a vertex with one feature edge, curve edges are unmarked while
/// the free end lies within `clearance` of that point, up to a vertex with more feature
/// edges, and on to the network vertex behind the new end when that is nearer than
/// `clearance`. A curve ending beside a tip would leave two fixed vertices closer than the
/// collapse length (on the armadillo at 2 %, its ridges end 0.09 L from fingertips: triangles
/// of 8°). Sharp and boundary edges are kept. Returns the chains rebuilt (unchanged when
/// nothing was dropped).
pub fn trim_curve_ends_near(
    mesh: &TriMesh,
    fe: &mut FeatureEdges,
    chains: Chains,
    points: &[V3],
    clearance: f64,
    corner_angle_deg: f64,
) -> Chains {
    if points.is_empty() || !fe.from_curve.iter().any(|&c| c) {
        return chains;
    }
    let topo = mesh.topology();
    let mut degree = feature_degrees(mesh, fe);
    let near = |p: V3| {
        points
            .iter()
            .copied()
            .find(|&q| vec3::dist(p, q) <= clearance)
    };
    let before = fe.trimmed;
    for v in 0..mesh.n_vertices() as u32 {
        if degree[v as usize] != 1 {
            continue;
        }
        let Some(q) = near(mesh.positions[v as usize]) else {
            continue;
        };
        let mut end = v;
        while degree[end as usize] == 1 && vec3::dist(mesh.positions[end as usize], q) <= clearance
        {
            let Some((e, w)) = topo.neighbors(end).iter().find_map(|&w| {
                topo.find_edge(end, w)
                    .filter(|&e| fe.is_feature[e as usize])
                    .map(|e| (e, w))
            }) else {
                break;
            };
            if !fe.from_curve[e as usize] {
                break;
            }
            fe.is_feature[e as usize] = false;
            fe.from_curve[e as usize] = false;
            fe.trimmed += 1;
            degree[end as usize] -= 1;
            degree[w as usize] -= 1;
            end = w;
        }
        if end == v {
            continue;
        }
        // The new end lies inside an edge of the network (on its mesh path). When the
        // network vertex behind it is less than `clearance` away along the path, the stub up
        // to it goes too: both ends would be fixed (a free end, and a network vertex that is
        // a corner), an edge no collapse could remove (on the armadillo's scale-conforming
        // curves at 2 %: 0.33 L, triangles of 20°).
        let mut stub = Vec::new();
        let (mut at, mut length) = (end, 0.0);
        while fe.anchor[at as usize].is_none() && length < clearance {
            let next = topo.neighbors(at).iter().find_map(|&w| {
                topo.find_edge(at, w)
                    .filter(|&e| fe.is_feature[e as usize] && !stub.contains(&e))
                    .map(|e| (e, w))
            });
            let Some((e, w)) = next else {
                break;
            };
            if !fe.from_curve[e as usize] || (at != end && degree[at as usize] != 2) {
                break;
            }
            length += vec3::dist(mesh.positions[at as usize], mesh.positions[w as usize]);
            stub.push(e);
            at = w;
        }
        if fe.anchor[at as usize].is_some() && length < clearance && at != end {
            for &e in &stub {
                fe.is_feature[e as usize] = false;
                fe.from_curve[e as usize] = false;
                fe.trimmed += 1;
                let [a, b] = topo.edges[e as usize];
                degree[a as usize] -= 1;
                degree[b as usize] -= 1;
            }
        }
    }
    if fe.trimmed == before {
        return chains;
    }
    build_chains(mesh, fe, corner_angle_deg)
}

#[cfg(test)]
#[path = "features_test.rs"]
mod tests;
