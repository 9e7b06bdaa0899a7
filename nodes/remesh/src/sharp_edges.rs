//! `remesh.sharp_edges`: the sharp edges and boundaries of a mesh as a feature curve network,
//! split into chains exactly as `remesh.isotropic` keeps them ([`crate::features`]).
//!
//! On CAD meshes the creases are the features (thesis §2.5: on piecewise smooth surfaces
//! curvature-based ridges degenerate at sharp edges, where the normal jumps). A chain runs
//! between *corners*: vertices with a number of sharp edges other than two, or where the
//! chain turns by more than `corner_angle_deg`; a loop without a corner is a closed curve.
//! Each curve vertex is a mesh vertex (`SurfacePoint::Vertex`); its strength is the largest
//! dihedral angle (radians) of its feature edges, π/2 on boundaries, so sharper creases weigh
//! more in the length-weighted averages of the symmetry and selection nodes.
//!
//! Optionally (`join_angle_deg`) chains are joined through corners along the straightest
//! continuation, as a ridge tracer continues through a junction: an octagonal nut's creases
//! are then two octagon loops per end and bent vertical curves, not 56 straight segments.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, ParamIssue, Port, Report,
    Validate,
};
use crestflow_geom::fcn::{CurveLabel, FcnVertex, FeatureCurve, SurfacePoint};
use crestflow_geom::mesh::NO_FACE;
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};

use crate::features::{build_chains, mark_features, FeatureError};
use crate::project::Projector;
use crate::prune::prune_below_scale;

/// Parameters of `remesh.sharp_edges`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SharpEdgesParams {
    /// Angle between the two face normals above which an edge is sharp, in degrees (default
    /// 30, range [1, 179]).
    pub angle_deg: f64,
    /// A two-edge chain vertex turning by more than this (degrees) ends a curve (default 60,
    /// range [0, 180]).
    pub corner_angle_deg: f64,
    /// Whether boundary edges are features too (default true).
    pub boundaries: bool,
    /// Curves with fewer mesh edges than this are left out (default 1, range 1..=1000000).
    pub min_edges: usize,
    /// At a corner, two chains that continue each other by a turn below this angle (degrees)
    /// become one curve, the straightest pairs first (default 0: every chain its own curve;
    /// range [0, 180)). Straight creases fix a rigid transformation only up to a spin about
    /// themselves; joined through their corners (an octagon's outline) they fix it fully.
    pub join_angle_deg: f64,
    /// Removes the parts of the sharp-edge graph below this length, as a fraction of the
    /// bounding-box diagonal (default 0: none): dangling branches shorter than it and, weakest
    /// first, branches closing a cycle shorter than twice it through a junction
    /// ([`crate::prune`]). Boundaries and closed curves on their own stay. Set it to the `scale` of a following `scale.conform`, so that the zig-zags and
    /// ladders of creases that cut across coarse triangles reach it as crease lines.
    pub prune_scale: f64,
}

impl Default for SharpEdgesParams {
    fn default() -> Self {
        SharpEdgesParams {
            angle_deg: 30.0,
            corner_angle_deg: 60.0,
            boundaries: true,
            min_edges: 1,
            join_angle_deg: 0.0,
            prune_scale: 0.0,
        }
    }
}

impl Validate for SharpEdgesParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "angle_deg", self.angle_deg, 1.0, 179.0);
        check_range(
            &mut v,
            "corner_angle_deg",
            self.corner_angle_deg,
            0.0,
            180.0,
        );
        check_range(&mut v, "min_edges", self.min_edges, 1, 1_000_000);
        check_range(&mut v, "join_angle_deg", self.join_angle_deg, 0.0, 179.999);
        check_range(&mut v, "prune_scale", self.prune_scale, 0.0, 1.0);
        v
    }
}

/// Why the sharp edges could not be extracted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SharpEdgesError {
    #[error("the mesh has no faces ({vertices} vertices)")]
    Empty { vertices: usize },
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite { vertex: usize, position: V3 },
    #[error("face {face} references vertex {index}, but the mesh has {n} vertices")]
    BadIndex { face: usize, index: u32, n: usize },
    #[error("{0}")]
    Features(#[from] FeatureError),
}

/// The network and its counts.
#[derive(Clone, Debug)]
pub struct SharpEdgesOutput {
    pub network: FeatureCurveNetwork,
    pub report: Report,
}

/// The sharp-edge (and boundary) chains of `mesh` as curves.
pub fn sharp_edges(
    mesh: &TriMesh,
    params: &SharpEdgesParams,
) -> Result<SharpEdgesOutput, SharpEdgesError> {
    if mesh.triangles.is_empty() {
        return Err(SharpEdgesError::Empty {
            vertices: mesh.n_vertices(),
        });
    }
    let n = mesh.n_vertices();
    for (face, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
            return Err(SharpEdgesError::BadIndex { face, index, n });
        }
    }
    if let Some((vertex, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
    {
        return Err(SharpEdgesError::NonFinite {
            vertex,
            position: *p,
        });
    }
    let proj = Projector::new(mesh);
    let mut fe = mark_features(mesh, Some(params.angle_deg), None, &proj, f64::INFINITY)?;
    let topo = mesh.topology();
    if !params.boundaries {
        for (e, &[_, f1]) in topo.edge_faces.iter().enumerate() {
            if f1 == NO_FACE {
                fe.is_feature[e] = false;
            }
        }
    }
    let normals = mesh.face_normals();
    let dihedral = |e: usize| {
        let [f0, f1] = topo.edge_faces[e];
        if f1 == NO_FACE {
            std::f64::consts::FRAC_PI_2
        } else {
            vec3::dot(normals[f0 as usize], normals[f1 as usize])
                .clamp(-1.0, 1.0)
                .acos()
        }
    };
    let mut pruned = 0usize;
    if params.prune_scale > 0.0 {
        let ids: Vec<usize> = (0..topo.edges.len())
            .filter(|&e| fe.is_feature[e])
            .collect();
        let pairs: Vec<[u32; 2]> = ids.iter().map(|&e| topo.edges[e]).collect();
        let weight: Vec<f64> = ids.iter().map(|&e| dihedral(e)).collect();
        let fixed: Vec<bool> = ids
            .iter()
            .map(|&e| topo.edge_faces[e][1] == NO_FACE)
            .collect();
        let scale = params.prune_scale * mesh.bbox_diagonal();
        let alive = prune_below_scale(&pairs, &mesh.positions, &weight, &fixed, scale);
        for (k, &e) in ids.iter().enumerate() {
            if !alive[k] {
                fe.is_feature[e] = false;
                fe.sharp_only[e] = false;
                pruned += 1;
            }
        }
    }
    let chains = build_chains(mesh, &fe, params.corner_angle_deg);

    // Per vertex: the sharpest feature edge at it.
    let mut strength = vec![0.0f64; n];
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if !fe.is_feature[e] {
            continue;
        }
        let angle = dihedral(e);
        for v in [a, b] {
            strength[v as usize] = strength[v as usize].max(angle);
        }
    }

    // Walk each chain's edges from an end (or anywhere on a loop) to get its vertex order.
    let n_chains = chains.points.len();
    let mut chain_edges: Vec<Vec<u32>> = vec![Vec::new(); n_chains];
    for (e, &c) in chains.edge_chain.iter().enumerate() {
        if c != u32::MAX {
            chain_edges[c as usize].push(e as u32);
        }
    }
    let mut net = FeatureCurveNetwork::default();
    let mut net_index = vec![u32::MAX; n];
    let mut add_vertex = |net: &mut FeatureCurveNetwork, v: u32| -> u32 {
        if net_index[v as usize] == u32::MAX {
            net_index[v as usize] = net.vertices.len() as u32;
            net.vertices.push(FcnVertex {
                position: mesh.positions[v as usize],
                location: SurfacePoint::Vertex(v),
                strength: strength[v as usize],
            });
        }
        net_index[v as usize]
    };
    let mut curves: Vec<(Vec<u32>, bool)> = chain_edges
        .iter()
        .filter(|edges| !edges.is_empty())
        .map(|edges| chain_vertex_order(&topo.edges, edges))
        .collect();
    let mut joins = 0usize;
    if params.join_angle_deg > 0.0 {
        let before = curves.len();
        curves = join_at_corners(curves, &mesh.positions, params.join_angle_deg);
        joins = before - curves.len();
    }
    let mut dropped = 0usize;
    for (order, closed) in curves {
        let edge_count = order.len() - usize::from(!closed);
        if edge_count < params.min_edges {
            dropped += 1;
            continue;
        }
        let vertices: Vec<u32> = order.iter().map(|&v| add_vertex(&mut net, v)).collect();
        net.curves.push(FeatureCurve {
            vertices,
            closed,
            label: CurveLabel::Other,
        });
    }
    let mut report = Report::new();
    report
        .set("curves", net.curves.len())
        .set("curves_dropped_short", dropped)
        .set("sharp_edges", fe.sharp)
        .set("pruned_edges", pruned)
        .set(
            "boundary_edges",
            if params.boundaries { fe.boundary } else { 0 },
        )
        .set("corners", chains.is_corner.iter().filter(|&&c| c).count())
        .set("joins", joins);
    Ok(SharpEdgesOutput {
        network: net,
        report,
    })
}

/// The vertices of a chain in walking order, and whether it is a loop. An open chain starts
/// at the smaller of its two ends (vertices met by one of its edges); a loop (a chain without
/// a corner, or one that starts and ends at the same corner) at its smallest vertex, heading
/// to the smaller neighbour, without repeating the first vertex at the end.
fn chain_vertex_order(all_edges: &[[u32; 2]], edges: &[u32]) -> (Vec<u32>, bool) {
    use std::collections::BTreeMap;
    let mut adj: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for &e in edges {
        let [a, b] = all_edges[e as usize];
        adj.entry(a).or_default().push(b);
        adj.entry(b).or_default().push(a);
    }
    adj.values_mut().for_each(|n| n.sort_unstable());
    let end = adj.iter().find(|(_, n)| n.len() == 1).map(|(&v, _)| v);
    let closed = end.is_none();
    let Some(start) = end.or_else(|| adj.keys().next().copied()) else {
        return (Vec::new(), false);
    };
    let mut order = vec![start];
    let mut prev = u32::MAX;
    let mut cur = start;
    for _ in 0..edges.len() {
        let Some(&next) = adj[&cur].iter().find(|&&w| w != prev) else {
            break;
        };
        if next == start {
            break;
        }
        order.push(next);
        prev = cur;
        cur = next;
    }
    (order, closed)
}

/// Joins open chains end to end at shared corners. At each corner the pairs of chain ends
/// meeting there are taken straightest first (turn = angle between the incoming and the
/// outgoing direction of the first edges), each end at most once, while the turn is below
/// `max_turn_deg`; then the linked chains are concatenated into curves (a cycle of links
/// into a closed curve). Closed chains are kept as they are. The order of the result is
/// fixed by the chain order, so it does not depend on anything but the input.
fn join_at_corners(
    curves: Vec<(Vec<u32>, bool)>,
    positions: &[V3],
    max_turn_deg: f64,
) -> Vec<(Vec<u32>, bool)> {
    use std::collections::BTreeMap;
    // End k of chain c is 2c + k (k = 0 its first vertex, 1 its last).
    let mut at: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (c, (order, closed)) in curves.iter().enumerate() {
        if !closed && order.len() >= 2 {
            at.entry(order[0]).or_default().push(2 * c);
            at.entry(order[order.len() - 1])
                .or_default()
                .push(2 * c + 1);
        }
    }
    // Unit direction from an end's vertex into its chain.
    let inward = |end: usize| -> V3 {
        let order = &curves[end / 2].0;
        let (v, w) = if end.is_multiple_of(2) {
            (order[0], order[1])
        } else {
            (order[order.len() - 1], order[order.len() - 2])
        };
        vec3::normalize(vec3::sub(positions[w as usize], positions[v as usize]))
    };
    let cos_max = max_turn_deg.to_radians().cos();
    let mut link = vec![usize::MAX; 2 * curves.len()];
    for ends in at.values() {
        let mut pairs = Vec::new();
        for (i, &a) in ends.iter().enumerate() {
            for &b in &ends[i + 1..] {
                // Going in along a and out along b: straight when the inward directions
                // are opposite, so the turn's cosine is −dot.
                let cos_turn = -vec3::dot(inward(a), inward(b));
                if cos_turn > cos_max {
                    pairs.push((cos_turn, a, b));
                }
            }
        }
        pairs.sort_by(|x, y| y.0.total_cmp(&x.0).then((x.1, x.2).cmp(&(y.1, y.2))));
        for (_, a, b) in pairs {
            if link[a] == usize::MAX && link[b] == usize::MAX {
                link[a] = b;
                link[b] = a;
            }
        }
    }
    let mut used = vec![false; curves.len()];
    let mut out = Vec::new();
    // Walks from chain end `start` (which enters the chain) through the links.
    let walk = |start: usize, used: &mut Vec<bool>| -> (Vec<u32>, bool) {
        let mut order: Vec<u32> = Vec::new();
        let mut end = start;
        loop {
            let c = end / 2;
            used[c] = true;
            let mut part = curves[c].0.clone();
            if end % 2 == 1 {
                part.reverse();
            }
            // The shared corner is the last vertex so far and the first of `part`.
            let skip = usize::from(!order.is_empty());
            order.extend_from_slice(&part[skip..]);
            let exit = end ^ 1;
            let next = link[exit];
            if next == usize::MAX {
                return (order, false);
            }
            if next == start {
                order.pop(); // back at the first vertex: a closed curve
                return (order, true);
            }
            end = next;
        }
    };
    for c in 0..curves.len() {
        if used[c] {
            continue;
        }
        if curves[c].1 || curves[c].0.len() < 2 {
            used[c] = true;
            out.push(curves[c].clone());
            continue;
        }
        // Start at a free end of the path this chain lies on; if there is none, it is a cycle.
        let mut end = 2 * c;
        let mut free = None;
        for _ in 0..=2 * curves.len() {
            if link[end] == usize::MAX {
                free = Some(end);
                break;
            }
            end = link[end] ^ 1;
            if end == 2 * c {
                break;
            }
        }
        out.push(walk(free.unwrap_or(2 * c), &mut used));
    }
    out
}

/// Node wrapper of [`sharp_edges`].
pub struct SharpEdgesNode;

impl NodeKind for SharpEdgesNode {
    type Params = SharpEdgesParams;
    const KIND: &'static str = "remesh.sharp_edges";
    const VERSION: u32 = 3;
    const DOC: &'static str = "Sharp edges (dihedral angle above angle_deg) and boundaries of \
        a mesh as a feature curve network, split at corners (other than two feature edges, or \
        a turn above corner_angle_deg) into the chains remesh.isotropic keeps: the features \
        of CAD meshes, where curvature ridges degenerate at the creases. With join_angle_deg \
        above 0, chains meeting at a corner are joined into one curve, straightest pairs \
        first, while they turn by less than that angle. With prune_scale above 0 (a fraction of the \
        bounding-box diagonal), dangling branches shorter than it and branches closing cycles \
        shorter than twice it are removed first, weakest first. Vertex strength is the sharpest \
        dihedral angle at the vertex (radians). Outputs the network and a Report (curves, \
        curves_dropped_short, sharp_edges, pruned_edges, boundary_edges, corners, joins).";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<TriMesh>("mesh", "the surface")]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "one curve per sharp-edge chain"),
            Port::of::<Report>("report", "counts"),
        ]
    }
    fn run(params: &Self::Params, inputs: &Inputs, _ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let out = sharp_edges(mesh, params)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new()
            .with("network", out.network)
            .with("report", out.report))
    }
}

#[cfg(test)]
#[path = "sharp_edges_test.rs"]
mod tests;
