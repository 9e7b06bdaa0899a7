//! `curves.shortest_path`: corresponding curves between landmark pairs (thesis §5.2.2).
//!
//! The user gives only the endpoints of corresponding curves; each curve is the shortest path
//! along mesh edges between its two endpoint vertices (Dijkstra), with one of two edge weights:
//!
//! - `Geodesic`: the edge length (an approximation of a geodesic curve);
//! - `Anisotropic`: a curvature-aligned weight in the spirit of anisotropic geodesics
//!   (Campen, Heistermann, Kobbelt 2013; thesis §2.1.3). An edge of length ℓ with unit
//!   direction d costs `ℓ / (1 + β h |κ⊥|)`, where `κ⊥ = k_max + k_min − κ_n(d)` is the normal
//!   curvature across the edge (averaged over its two end vertices, `κ_n(d)` by Euler's
//!   formula) and h the mean edge length. Paths therefore prefer to run along ridges and
//!   valleys, where the curvature across the path is large.
//!
//! The same node runs on both shapes: `side: Source` takes the first vertex of every landmark
//! pair, `side: Target` the second. Curve `i` of both outputs joins the same two landmarks, so
//! curve `i` on the source corresponds to curve `i` on the target.
//!
//! Which landmarks are joined: the explicit `pairs` list of landmark indices, or by default
//! the closed chain `(0, 1), (1, 2), …, (L−1, 0)` of the L landmarks in file order. `curves`
//! keeps the first so many of them (0: all).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate,
};
use crestflow_geom::vec3::{dist, dot, normalize, sub};
use crestflow_geom::{CurvatureField, CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork};
use crestflow_geom::{SurfacePoint, TriMesh};

use crate::types::{FmapError, LandmarkPairs};

/// Which vertex of every landmark pair this node uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Side {
    /// The first vertex of each pair.
    #[default]
    Source,
    /// The second vertex of each pair.
    Target,
}

impl Side {
    fn name(self) -> &'static str {
        match self {
            Side::Source => "source",
            Side::Target => "target",
        }
    }
}

/// Edge weights of the shortest paths.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum EdgeWeight {
    /// Edge length.
    #[default]
    Geodesic,
    /// Curvature-aligned: needs a `curvature` input; `beta` ≥ 0 sets the strength.
    Anisotropic { beta: f64 },
}

/// Parameters of `curves.shortest_path`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShortestPathParams {
    /// Which vertex of each landmark pair to use (default `Source`).
    pub side: Side,
    /// Landmark index pairs `[a, b]` to join (default empty: the closed chain of all landmarks).
    pub pairs: Vec<[u32; 2]>,
    /// Keep the first `curves` curves (default 0: all; range 0..=10000).
    pub curves: usize,
    /// Edge weights (default `Geodesic`).
    pub weight: EdgeWeight,
}

impl Validate for ShortestPathParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "curves", self.curves, 0, 10_000);
        if let EdgeWeight::Anisotropic { beta } = self.weight {
            check_range(&mut issues, "weight.beta", beta, 0.0, 1e6);
        }
        issues
    }
}

/// The landmark index pairs joined by curves, after defaults and the `curves` cut.
pub fn curve_pairs(
    n_landmarks: usize,
    pairs: &[[u32; 2]],
    curves: usize,
) -> Result<Vec<[u32; 2]>, FmapError> {
    let all: Vec<[u32; 2]> = if pairs.is_empty() {
        if n_landmarks < 2 {
            return Err(FmapError::TooManyCurves {
                what: "the landmark chain",
                asked: 1,
                available: 0,
            });
        }
        if n_landmarks == 2 {
            vec![[0, 1]]
        } else {
            (0..n_landmarks)
                .map(|i| [i as u32, ((i + 1) % n_landmarks) as u32])
                .collect()
        }
    } else {
        for (p, pair) in pairs.iter().enumerate() {
            for &index in pair {
                if index as usize >= n_landmarks {
                    return Err(FmapError::PairOutOfRange {
                        pair: p,
                        index,
                        count: n_landmarks,
                    });
                }
            }
        }
        pairs.to_vec()
    };
    if curves == 0 {
        return Ok(all);
    }
    if curves > all.len() {
        return Err(FmapError::TooManyCurves {
            what: "curves.shortest_path",
            asked: curves,
            available: all.len(),
        });
    }
    Ok(all[..curves].to_vec())
}

#[derive(PartialEq)]
struct Item {
    d: f64,
    v: u32,
}
impl Eq for Item {}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        // Min-heap on distance, ties by vertex index: deterministic.
        o.d.total_cmp(&self.d).then_with(|| o.v.cmp(&self.v))
    }
}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// Shortest edge path from `from` to `to` by Dijkstra with `weight(a, b)`; vertices in order.
pub fn dijkstra_path(
    mesh: &TriMesh,
    from: u32,
    to: u32,
    weight: &dyn Fn(u32, u32) -> f64,
) -> Result<Vec<u32>, FmapError> {
    let n = mesh.n_vertices();
    let topo = mesh.topology();
    let mut d = vec![f64::INFINITY; n];
    let mut prev = vec![u32::MAX; n];
    let mut heap = BinaryHeap::new();
    d[from as usize] = 0.0;
    heap.push(Item { d: 0.0, v: from });
    while let Some(Item { d: du, v }) = heap.pop() {
        if du > d[v as usize] {
            continue;
        }
        if v == to {
            break;
        }
        for &w in topo.neighbors(v) {
            let nd = du + weight(v, w);
            if nd < d[w as usize] {
                d[w as usize] = nd;
                prev[w as usize] = v;
                heap.push(Item { d: nd, v: w });
            }
        }
    }
    if !d[to as usize].is_finite() {
        return Err(FmapError::Disconnected { from, to });
    }
    let mut path = vec![to];
    let mut v = to;
    while v != from {
        v = prev[v as usize];
        path.push(v);
    }
    path.reverse();
    Ok(path)
}

/// Traces the curves between the chosen landmarks on `mesh` (see the module docs).
pub fn shortest_paths(
    mesh: &TriMesh,
    landmarks: &LandmarkPairs,
    curvature: Option<&CurvatureField>,
    params: &ShortestPathParams,
    par: Par,
) -> Result<FeatureCurveNetwork, FmapError> {
    let n = mesh.n_vertices();
    let slot = match params.side {
        Side::Source => 0,
        Side::Target => 1,
    };
    for (i, p) in landmarks.pairs.iter().enumerate() {
        if p[slot] as usize >= n {
            return Err(FmapError::LandmarkOutOfRange {
                origin: landmarks.origin.clone(),
                line: landmarks.lines.get(i).copied().unwrap_or(i + 1),
                side: params.side.name(),
                vertex: p[slot],
                n_vertices: n,
            });
        }
    }
    let pairs = curve_pairs(landmarks.pairs.len(), &params.pairs, params.curves)?;
    let beta = match params.weight {
        EdgeWeight::Geodesic => None,
        EdgeWeight::Anisotropic { beta } => {
            let k = curvature.ok_or(FmapError::Param {
                field: "weight",
                message: "Anisotropic weights need a `curvature` input".into(),
            })?;
            if k.len() != n {
                return Err(FmapError::Param {
                    field: "weight",
                    message: format!(
                        "the curvature field has {} vertices but the mesh has {n}",
                        k.len()
                    ),
                });
            }
            Some((beta, k))
        }
    };
    let h = mesh.mean_edge_length();
    let p = &mesh.positions;
    let weight = |a: u32, b: u32| -> f64 {
        let len = dist(p[a as usize], p[b as usize]);
        match beta {
            None => len,
            Some((beta, k)) => {
                let d = normalize(sub(p[b as usize], p[a as usize]));
                let across = |v: usize| {
                    let c1 = dot(d, k.t_max[v]);
                    let c2 = dot(d, k.t_min[v]);
                    let kn = k.k_max[v] * c1 * c1 + k.k_min[v] * c2 * c2;
                    let kp = k.k_max[v] + k.k_min[v] - kn;
                    if kp.is_finite() {
                        kp.abs()
                    } else {
                        0.0
                    }
                };
                let kp = 0.5 * (across(a as usize) + across(b as usize));
                len / (1.0 + beta * h * kp)
            }
        }
    };
    let ends: Vec<(u32, u32)> = pairs
        .iter()
        .map(|pr| {
            (
                landmarks.pairs[pr[0] as usize][slot],
                landmarks.pairs[pr[1] as usize][slot],
            )
        })
        .collect();
    let paths = par.map_collect(ends.len(), |c| {
        let (a, b) = ends[c];
        dijkstra_path(mesh, a, b, &weight)
    });
    let mut net = FeatureCurveNetwork::default();
    for path in paths {
        let path = path?;
        let base = net.vertices.len() as u32;
        for &v in &path {
            net.vertices.push(FcnVertex {
                position: p[v as usize],
                location: SurfacePoint::Vertex(v),
                strength: 0.0,
            });
        }
        net.curves.push(FeatureCurve {
            vertices: (0..path.len() as u32).map(|i| base + i).collect(),
            closed: false,
            label: CurveLabel::Other,
        });
    }
    Ok(net)
}

/// Node wrapper of [`shortest_paths`].
pub struct ShortestPathNode;

impl NodeKind for ShortestPathNode {
    type Params = ShortestPathParams;
    const KIND: &'static str = "curves.shortest_path";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Corresponding curves from landmark pairs (thesis §5.2.2): each \
        curve is the Dijkstra shortest path along mesh edges between two landmark vertices, \
        with edge-length (geodesic) or curvature-aligned (anisotropic, §2.1.3) weights. Run it \
        with side: Source and side: Target to get curve i on both shapes between the same \
        landmarks.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the mesh the curves run on"),
            Port::of::<LandmarkPairs>("landmarks", "corresponding vertex pairs"),
            Port::optional::<CurvatureField>("curvature", "for Anisotropic weights"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<FeatureCurveNetwork>(
            "network",
            "one open curve per landmark pair, on mesh vertices",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let lm = inputs.get::<LandmarkPairs>("landmarks")?;
        let k = inputs.opt::<CurvatureField>("curvature")?;
        let net = shortest_paths(mesh, lm, k, params, ctx.par).map_err(FmapError::into_node)?;
        Ok(Outputs::new().with("network", net))
    }
}

#[cfg(test)]
#[path = "shortest_path_test.rs"]
mod tests;
