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
}

impl Default for SharpEdgesParams {
    fn default() -> Self {
        SharpEdgesParams {
            angle_deg: 30.0,
            corner_angle_deg: 60.0,
            boundaries: true,
            min_edges: 1,
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
    let mut fe = mark_features(mesh, Some(params.angle_deg), None, &proj)?;
    let topo = mesh.topology();
    if !params.boundaries {
        for (e, &[_, f1]) in topo.edge_faces.iter().enumerate() {
            if f1 == NO_FACE {
                fe.is_feature[e] = false;
            }
        }
    }
    let chains = build_chains(mesh, &fe, params.corner_angle_deg);

    // Per vertex: the sharpest feature edge at it.
    let normals = mesh.face_normals();
    let mut strength = vec![0.0f64; n];
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if !fe.is_feature[e] {
            continue;
        }
        let [f0, f1] = topo.edge_faces[e];
        let angle = if f1 == NO_FACE {
            std::f64::consts::FRAC_PI_2
        } else {
            vec3::dot(normals[f0 as usize], normals[f1 as usize])
                .clamp(-1.0, 1.0)
                .acos()
        };
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
    let mut dropped = 0usize;
    for edges in &chain_edges {
        if edges.len() < params.min_edges {
            dropped += 1;
            continue;
        }
        let (order, closed) = chain_vertex_order(&topo.edges, edges);
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
        .set(
            "boundary_edges",
            if params.boundaries { fe.boundary } else { 0 },
        )
        .set("corners", chains.is_corner.iter().filter(|&&c| c).count());
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

/// Node wrapper of [`sharp_edges`].
pub struct SharpEdgesNode;

impl NodeKind for SharpEdgesNode {
    type Params = SharpEdgesParams;
    const KIND: &'static str = "remesh.sharp_edges";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Sharp edges (dihedral angle above angle_deg) and boundaries of \
        a mesh as a feature curve network, split at corners (other than two feature edges, or \
        a turn above corner_angle_deg) into the chains remesh.isotropic keeps: the features \
        of CAD meshes, where curvature ridges degenerate at the creases. Vertex strength is \
        the sharpest dihedral angle at the vertex (radians). Outputs the network and a Report \
        (curves, curves_dropped_short, sharp_edges, boundary_edges, corners).";

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
