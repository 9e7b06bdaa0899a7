//! `symmetry.cluster`: global transformation space voting (thesis §3.2.3). The transformations
//! of all curve-pair matches (and their inverses, so that c0 → c1 and c1 → c0 meet) are grouped
//! by agglomerative hierarchical clustering: each transformation starts as its own cluster, the
//! two closest clusters are fused and represented by their affinity-weighted average
//! transformation (which avoids the m·k comparisons of a full average link, as the thesis
//! notes), and fusing stops when the next distance exceeds the maximal error: twice the mean
//! edge length in translation or 1.5° in rotation. Distances are max(|Δt| / max_translation,
//! Δθ / max_angle), so "1" is the stopping threshold.
//!
//! Candidate neighbours come from an R-tree over the 7-D points (t / max_translation,
//! q / (max_angle/2)), each inserted with both quaternion signs; merging uses a lazy priority
//! queue, so the cost is about n log n for n transformations rather than n³.
//! Reflections (matches against the mirrored network) are clustered separately from proper
//! motions.

use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::vec3::{dist, V3};
use serde::{Deserialize, Serialize};

use crate::blast::CurveMatches;
use crate::transform::{mean_transform, quat_angle_deg, RigidTransform};

/// Parameters of `symmetry.cluster`. Lengths are multiples of the mean edge length h.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterParams {
    /// Maximal translation error of a cluster (thesis: 2 h). In (0, 1000]. Default 2.
    pub max_translation: f64,
    /// Maximal rotation error in degrees (thesis: 1.5°). In (0, 90]. Default 1.5.
    pub max_angle_deg: f64,
    /// Matches with an affinity below this (in h) are ignored. In [0, 1e6]. Default 5.
    pub min_affinity: f64,
}

impl Default for ClusterParams {
    fn default() -> Self {
        ClusterParams {
            max_translation: 2.0,
            max_angle_deg: 1.5,
            min_affinity: 5.0,
        }
    }
}

impl Validate for ClusterParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(
            &mut v,
            "max_translation",
            self.max_translation,
            1e-9,
            1000.0,
        );
        check_range(&mut v, "max_angle_deg", self.max_angle_deg, 1e-9, 90.0);
        check_range(&mut v, "min_affinity", self.min_affinity, 0.0, 1e6);
        v
    }
}

/// One transformation of a cluster: a match, possibly inverted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClusterMember {
    /// Index into [`CurveMatches::matches`].
    pub match_index: u32,
    /// The member maps curve b onto curve a (the match's inverse).
    pub inverse: bool,
    /// The curve mapped and its image.
    pub from: u32,
    pub to: u32,
    pub affinity: f64,
    /// Mean distance of the refined match (mesh units).
    pub residual: f64,
}

/// A cluster of similar transformations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformCluster {
    /// Reflection cluster: the isometry is `transform ∘ M` (M the mirror of the matches).
    pub mirrored: bool,
    /// The representative (affinity-weighted mean) transformation.
    pub transform: RigidTransform,
    pub members: Vec<ClusterMember>,
    /// Sum of the members' affinities (mesh units of length).
    pub support: f64,
    /// Number of distinct (from, to) curve pairs.
    pub pairs: usize,
}

/// The output of `symmetry.cluster`, clusters by decreasing support.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformClusters {
    pub unit: f64,
    pub mirror_x: f64,
    pub clusters: Vec<TransformCluster>,
}

impl TransformClusters {
    /// The mirror M: p ↦ (2 mirror_x − p.x, p.y, p.z).
    pub fn mirror(&self, p: V3) -> V3 {
        [2.0 * self.mirror_x - p[0], p[1], p[2]]
    }
}

/// Why `symmetry.cluster` cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClusterError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("the matches have no valid length unit ({0})")]
    NoScale(f64),
    #[error("match {index} has a non-finite transformation")]
    NonFinite { index: usize },
}

/// M ∘ X ∘ M for the mirror M(x) = D x + m, D = diag(−1, 1, 1), m = (2 mx, 0, 0): a proper
/// rigid transformation.
pub fn conjugate_by_mirror(x: &RigidTransform, mx: f64) -> RigidTransform {
    let d = [-1.0, 1.0, 1.0];
    let mut r = x.rotation;
    for (i, row) in r.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v *= d[i] * d[j];
        }
    }
    let m = [2.0 * mx, 0.0, 0.0];
    // D R m + D t + m
    let rm = x.rotate(m);
    let t = [
        -(rm[0] + x.translation[0]) + m[0],
        rm[1] + x.translation[1],
        rm[2] + x.translation[2],
    ];
    RigidTransform {
        rotation: r,
        translation: t,
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
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

struct Item {
    mirrored: bool,
    t: RigidTransform,
    member: ClusterMember,
}

/// Clusters the transformations of `matches` (see the module docs).
pub fn cluster(
    matches: &CurveMatches,
    params: &ClusterParams,
    _par: Par,
) -> Result<TransformClusters, ClusterError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(ClusterError::Params(text.join("; ")));
    }
    let h = matches.unit;
    if !(h.is_finite() && h > 0.0) {
        return Err(ClusterError::NoScale(h));
    }
    let tau = params.max_translation * h;
    let theta = params.max_angle_deg;
    let mut items = Vec::new();
    for (k, m) in matches.matches.iter().enumerate() {
        let finite = m.transform.translation.iter().all(|x| x.is_finite())
            && m.transform.rotation.iter().flatten().all(|x| x.is_finite());
        if !finite || !m.affinity.is_finite() {
            return Err(ClusterError::NonFinite { index: k });
        }
        if m.affinity < params.min_affinity * h {
            continue;
        }
        let fwd = ClusterMember {
            match_index: k as u32,
            inverse: false,
            from: m.curve_a,
            to: m.curve_b,
            affinity: m.affinity,
            residual: m.mean_distance,
        };
        let inv = m.transform.inverse();
        // For a reflection S = T∘M, S⁻¹ = M∘T⁻¹ = (M∘T⁻¹∘M)∘M.
        let inv_t = if m.mirrored {
            conjugate_by_mirror(&inv, matches.mirror_x)
        } else {
            inv
        };
        items.push(Item {
            mirrored: m.mirrored,
            t: m.transform,
            member: fwd.clone(),
        });
        if m.mirrored && m.curve_a == m.curve_b {
            // A curve mirrored onto itself: the inverse is the same reflection.
            continue;
        }
        items.push(Item {
            mirrored: m.mirrored,
            t: inv_t,
            member: ClusterMember {
                inverse: true,
                from: m.curve_b,
                to: m.curve_a,
                ..fwd
            },
        });
    }
    let qs = 0.5 * theta.to_radians();
    let feat = |t: &RigidTransform, sign: f64| -> [f64; 7] {
        let q = t.quaternion();
        let tr = t.translation;
        [
            tr[0] / tau,
            tr[1] / tau,
            tr[2] / tau,
            sign * q[0] / qs,
            sign * q[1] / qs,
            sign * q[2] / qs,
            sign * q[3] / qs,
        ]
    };
    let distance = |a: &RigidTransform, b: &RigidTransform| -> f64 {
        (dist(a.translation, b.translation) / tau)
            .max(quat_angle_deg(a.quaternion(), b.quaternion()) / theta)
    };
    let mut points = Vec::with_capacity(2 * items.len());
    for (k, it) in items.iter().enumerate() {
        points.push(rstar::primitives::GeomWithData::new(
            feat(&it.t, 1.0),
            k as u32,
        ));
        points.push(rstar::primitives::GeomWithData::new(
            feat(&it.t, -1.0),
            k as u32,
        ));
    }
    let tree = rstar::RTree::bulk_load(points);
    let n = items.len();
    let mut nbrs: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
    let mut heap = BinaryHeap::new();
    for (k, it) in items.iter().enumerate() {
        for g in tree.locate_within_distance(feat(&it.t, 1.0), 2.0) {
            let o = g.data as usize;
            if o <= k || items[o].mirrored != it.mirrored {
                continue;
            }
            let d = distance(&it.t, &items[o].t);
            if d <= 1.0 && nbrs[k].insert(o) {
                nbrs[o].insert(k);
                heap.push(Reverse((Key(d), k, o, 0u32, 0u32)));
            }
        }
    }
    // Lazy agglomeration: stale heap entries (a cluster changed since) are re-evaluated.
    let mut alive = vec![true; n];
    let mut version = vec![0u32; n];
    let mut rep: Vec<RigidTransform> = items.iter().map(|i| i.t).collect();
    let mut weight: Vec<f64> = items.iter().map(|i| i.member.affinity).collect();
    let mut members: Vec<Vec<usize>> = (0..n).map(|k| vec![k]).collect();
    while let Some(Reverse((Key(d), a, b, va, vb))) = heap.pop() {
        if !alive[a] || !alive[b] {
            continue;
        }
        if va != version[a] || vb != version[b] {
            let d2 = distance(&rep[a], &rep[b]);
            if d2 <= 1.0 {
                heap.push(Reverse((Key(d2), a, b, version[a], version[b])));
            }
            continue;
        }
        if d > 1.0 {
            continue;
        }
        // Fuse b into a.
        rep[a] = mean_transform(&[(rep[a], weight[a]), (rep[b], weight[b])]);
        weight[a] += weight[b];
        let mb = std::mem::take(&mut members[b]);
        members[a].extend(mb);
        alive[b] = false;
        version[a] += 1;
        let nb = std::mem::take(&mut nbrs[b]);
        for c in nb {
            nbrs[c].remove(&b);
            if c != a {
                nbrs[c].insert(a);
                nbrs[a].insert(c);
            }
        }
        nbrs[a].remove(&b);
        let list: Vec<usize> = nbrs[a].iter().copied().collect();
        for c in list {
            if !alive[c] {
                continue;
            }
            let d2 = distance(&rep[a], &rep[c]);
            if d2 <= 1.0 {
                let (x, y) = if a < c { (a, c) } else { (c, a) };
                heap.push(Reverse((Key(d2), x, y, version[x], version[y])));
            }
        }
    }
    let mut clusters: Vec<TransformCluster> = Vec::new();
    for k in 0..n {
        if !alive[k] {
            continue;
        }
        let mut ms: Vec<usize> = members[k].clone();
        ms.sort_unstable();
        let pairs: BTreeSet<(u32, u32)> = ms
            .iter()
            .map(|&i| (items[i].member.from, items[i].member.to))
            .collect();
        // The representative: the mean weighted by affinity / residual² (precision weights:
        // a member that aligns its curves exactly is more reliable than one whose curves only
        // resemble each other), then re-averaged over the members within a quarter of the
        // cluster radius of it, so that partial (sliding) matches at the rim do not bias it.
        let floor = (1e-3 * h).powi(2);
        let list: Vec<(RigidTransform, f64)> = ms
            .iter()
            .map(|&i| {
                let m = &items[i].member;
                (items[i].t, m.affinity / (m.residual * m.residual + floor))
            })
            .collect();
        let mut repr = mean_transform(&list);
        for _ in 0..3 {
            let core: Vec<(RigidTransform, f64)> = list
                .iter()
                .filter(|(t, _)| distance(t, &repr) <= 0.25)
                .copied()
                .collect();
            if core.is_empty() {
                break;
            }
            repr = mean_transform(&core);
        }
        clusters.push(TransformCluster {
            mirrored: items[k].mirrored,
            transform: repr,
            members: ms.iter().map(|&i| items[i].member.clone()).collect(),
            support: weight[k],
            pairs: pairs.len(),
        });
    }
    clusters.sort_by(|x, y| {
        y.support
            .total_cmp(&x.support)
            .then(x.members[0].match_index.cmp(&y.members[0].match_index))
            .then(x.members[0].inverse.cmp(&y.members[0].inverse))
    });
    Ok(TransformClusters {
        unit: h,
        mirror_x: matches.mirror_x,
        clusters,
    })
}

/// The `symmetry.cluster` node.
pub struct ClusterNode;

impl NodeKind for ClusterNode {
    type Params = ClusterParams;
    const KIND: &'static str = "symmetry.cluster";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Global transformation space voting (thesis §3.2.3): agglomerative \
        clustering of the curve-pair transformations (and their inverses), fusing the closest \
        clusters into their weighted average until the next distance exceeds the maximal error \
        (2 mean edge lengths, 1.5°). Reflections are clustered apart from proper motions.";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<CurveMatches>(
            "matches",
            "curve-pair transformations from symmetry.blast",
        )]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<TransformClusters>(
            "clusters",
            "clusters of transformations with members and support",
        )]
    }
    fn run(params: &ClusterParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let matches = inputs.get::<CurveMatches>("matches")?;
        ctx.check_cancelled()?;
        let out = cluster(matches, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("clusters", out))
    }
}
