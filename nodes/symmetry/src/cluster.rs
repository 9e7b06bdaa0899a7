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
//!
//! Consolidation on the geometry (`consolidate`, beyond the thesis): under noise the curves
//! fragment, and a transformation voted by a short fragment is a few degrees off, which moves
//! its translation far outside the cluster radius. So the clusters, by decreasing support,
//! re-estimate their transformation from the pooled point correspondences of all their members
//! (robust point-to-point Kabsch, then point-to-line Gauss–Newton steps with a small weight
//! along the curves), and take every unassigned match (same kind, rotation within
//! `consolidate_angle_deg`) whose correspondences the pooled transformation maps within the
//! maximal error `max_error` (thesis: t_high = 2 h) on average, until the member set is
//! stable. The representative transformation is then the pooled fit.

use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::vec3::{add, dist, norm, scale, sub, V3};
use serde::{Deserialize, Serialize};

use crate::blast::CurveMatches;
use crate::transform::{fit_rigid, mean_transform, quat_angle_deg, RigidTransform};

/// Cell size (in units of the stopping radius) of the grid that merges near-identical
/// transformations before the agglomeration.
const PREMERGE_CELL: f64 = 0.2;

/// A point of the 7-D transformation space: a position in units of `p_unit` and a unit
/// quaternion (times `sign`, for the q ≡ −q identification) in units of `q_unit`.
fn scaled_key(p: V3, p_unit: f64, q: [f64; 4], q_unit: f64, sign: f64) -> [f64; 7] {
    [
        p[0] / p_unit,
        p[1] / p_unit,
        p[2] / p_unit,
        sign * q[0] / q_unit,
        sign * q[1] / q_unit,
        sign * q[2] / q_unit,
        sign * q[3] / q_unit,
    ]
}

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
    /// Consolidate the clusters on the geometry (see the module docs): re-estimate each
    /// cluster's transformation from the pooled point correspondences of all its members and
    /// gather every match whose correspondences that transformation explains. Default true.
    pub consolidate: bool,
    /// Maximal mean distance (in h) of a member's correspondences under its cluster's pooled
    /// transformation (thesis: the hysteresis threshold t_high = 2 h). In (0, 100]. Default 2.
    pub max_error: f64,
    /// Matches whose own rotation differs from a cluster's by more than this many degrees are
    /// not tested for membership (a cheap pre-filter; short fragments under noise are a few
    /// degrees off). In (0, 90]. Default 8.
    pub consolidate_angle_deg: f64,
}

impl Default for ClusterParams {
    fn default() -> Self {
        ClusterParams {
            max_translation: 2.0,
            max_angle_deg: 1.5,
            min_affinity: 5.0,
            consolidate: true,
            max_error: 2.0,
            consolidate_angle_deg: 8.0,
        }
    }
}

impl ClusterParams {
    /// Scale (in h) of the robust weights of the pooled fits: half the maximal error, i.e.
    /// the thesis's t_low for t_high = 2 t_low.
    fn t_low_scale(&self) -> f64 {
        0.5 * self.max_error
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
        check_range(&mut v, "max_error", self.max_error, 1e-9, 100.0);
        check_range(
            &mut v,
            "consolidate_angle_deg",
            self.consolidate_angle_deg,
            1e-9,
            90.0,
        );
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
        crate::transform::mirror_in_x(self.mirror_x, p)
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
    /// Correspondences in the item's direction: `t` maps src\[j\] (mirrored first for a
    /// reflection) onto dst\[j\].
    src: Vec<V3>,
    dst: Vec<V3>,
    /// Centroids of `src` and `dst`.
    c_src: V3,
    c_dst: V3,
}

fn centroid(p: &[V3]) -> V3 {
    if p.is_empty() {
        return [0.0; 3];
    }
    scale(
        p.iter().fold([0.0; 3], |s, x| add(s, *x)),
        1.0 / p.len() as f64,
    )
}

impl Item {
    fn new(
        mirrored: bool,
        t: RigidTransform,
        member: ClusterMember,
        src: Vec<V3>,
        dst: Vec<V3>,
    ) -> Item {
        let (c_src, c_dst) = (centroid(&src), centroid(&dst));
        Item {
            mirrored,
            t,
            member,
            src,
            dst,
            c_src,
            c_dst,
        }
    }
    /// Mean distance of the correspondences under `x` (infinite without correspondences).
    fn residual(&self, x: &RigidTransform) -> f64 {
        if self.src.is_empty() {
            return f64::INFINITY;
        }
        self.src
            .iter()
            .zip(&self.dst)
            .map(|(s, d)| dist(x.apply(*s), *d))
            .sum::<f64>()
            / self.src.len() as f64
    }
}

/// Weight of the residual along the curve in the pooled point-to-line fits.
const SLIDE_WEIGHT: f64 = 0.1;

/// Unit tangents of a polyline of correspondence targets (central differences; zero where
/// the neighbours coincide).
fn tangents(d: &[V3]) -> Vec<V3> {
    let n = d.len();
    (0..n)
        .map(|j| {
            let a = d[j.saturating_sub(1)];
            let b = d[(j + 1).min(n.saturating_sub(1))];
            let e = sub(b, a);
            let l = norm(e);
            if l > 0.0 {
                scale(e, 1.0 / l)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// The rigid transformation that best maps the pooled correspondences of `members`, starting
/// at `x0`: robust point-to-point fits (iteratively reweighted least squares, Cauchy weights of
/// scale `c`), then Gauss–Newton steps of the point-to-line distance to the tangents of the
/// targets. The correspondences come from point-to-line ICP of each curve pair, so where
/// they slide along the curves is not determined; point-to-line residuals do not count it.
fn pooled_fit(items: &[Item], members: &[usize], x0: RigidTransform, c: f64) -> RigidTransform {
    let mut a = Vec::new();
    let mut b = Vec::new();
    let mut tan = Vec::new();
    for &k in members {
        a.extend_from_slice(&items[k].src);
        b.extend_from_slice(&items[k].dst);
        tan.extend(tangents(&items[k].dst));
    }
    if a.len() < 3 {
        return x0;
    }
    let mut x = x0;
    let mut w = vec![0.0; a.len()];
    for _ in 0..5 {
        for (j, wj) in w.iter_mut().enumerate() {
            let r = dist(x.apply(a[j]), b[j]) / c;
            *wj = 1.0 / (1.0 + r * r);
        }
        x = fit_rigid(&a, &b, Some(&w));
    }
    // Projectors of the residuals: across the tangent fully, along it with a small weight,
    // so that the slide along a circle or a straight piece stays determined by the matched
    // positions.
    let projs: Vec<nalgebra::Matrix3<f64>> = tan
        .iter()
        .map(|t| {
            let mut proj = nalgebra::Matrix3::<f64>::identity();
            for r in 0..3 {
                for q in 0..3 {
                    proj[(r, q)] -= (1.0 - SLIDE_WEIGHT) * t[r] * t[q];
                }
            }
            proj
        })
        .collect();
    let mut res = vec![nalgebra::Vector3::<f64>::zeros(); a.len()];
    let mut mags = vec![0.0; a.len()];
    for _ in 0..10 {
        for j in 0..a.len() {
            let p = x.apply(a[j]);
            res[j] =
                projs[j] * nalgebra::Vector3::new(p[0] - b[j][0], p[1] - b[j][1], p[2] - b[j][2]);
            mags[j] = res[j].norm();
        }
        // Robust scale: three times the median residual, at most c (exact members of a
        // noise-free cluster then outweigh partial matches at its rim).
        let mut sorted = mags.clone();
        sorted.sort_by(f64::total_cmp);
        let scale_c = (3.0 * sorted[sorted.len() / 2]).clamp(1e-3 * c, c);
        let mut jtj = nalgebra::Matrix6::<f64>::zeros();
        let mut jtr = nalgebra::Vector6::<f64>::zeros();
        for j in 0..a.len() {
            let p = x.apply(a[j]);
            let rn = mags[j] / scale_c;
            let wj = 1.0 / (1.0 + rn * rn);
            // d(ω × p)/dω = −[p]×
            let px = nalgebra::Matrix3::new(0.0, p[2], -p[1], -p[2], 0.0, p[0], p[1], -p[0], 0.0);
            let mut jac = nalgebra::Matrix3x6::<f64>::zeros();
            jac.fixed_view_mut::<3, 3>(0, 0).copy_from(&(projs[j] * px));
            jac.fixed_view_mut::<3, 3>(0, 3).copy_from(&projs[j]);
            jtj += wj * jac.transpose() * jac;
            jtr += wj * jac.transpose() * res[j];
        }
        let damp = 1e-9 * jtj.trace().max(1e-300);
        for k in 0..6 {
            jtj[(k, k)] += damp;
        }
        let Some(ch) = jtj.cholesky() else {
            break;
        };
        let dx = ch.solve(&(-jtr));
        if !dx.iter().all(|v| v.is_finite()) {
            break;
        }
        let omega = [dx[0], dx[1], dx[2]];
        let angle = norm(omega);
        let rot = if angle > 0.0 {
            RigidTransform::rotation_about(omega, angle, [0.0; 3])
        } else {
            RigidTransform::identity()
        };
        let step = RigidTransform {
            rotation: rot.rotation,
            translation: [dx[3], dx[4], dx[5]],
        };
        x = step.compose(&x);
        if dx.norm() < 1e-13 * (1.0 + c) {
            break;
        }
    }
    x
}

/// Consolidation on the geometry: clusters by decreasing support re-estimate their
/// transformation from the pooled correspondences of their members and take every unassigned
/// match (same kind, rotation within `angle` degrees) whose correspondences the pooled
/// transformation maps within `e` on average, until the member set is stable.
fn consolidate(
    items: &[Item],
    groups: Vec<(Vec<usize>, RigidTransform, f64)>,
    e: f64,
    c: f64,
    angle: f64,
    par: Par,
) -> Vec<(Vec<usize>, RigidTransform)> {
    // Candidates come from an R-tree over (T_k(o), q_k) for a fixed point o: a match whose
    // rotation is within `angle` of x and whose centroid x maps within e has T_k(o) within
    // e + M + 2 sin(angle/2) D of x(o) (D the largest distance of a centroid from o, M the
    // largest distance between a match's mapped and target centroids), so the query returns
    // every candidate the tests below accept (the same result as testing all matches), and
    // on a mesh with many copies of one feature not the thousands of equal rotations.
    let n = items.len();
    let o = centroid(&items.iter().map(|it| it.c_src).collect::<Vec<_>>());
    let reach = items
        .iter()
        .map(|it| dist(it.c_src, o))
        .fold(0.0f64, f64::max);
    let slack = items
        .iter()
        .map(|it| dist(it.t.apply(it.c_src), it.c_dst))
        .fold(0.0f64, f64::max);
    let bound = (e + slack + 2.0 * (0.5 * angle.to_radians()).sin() * reach).max(f64::MIN_POSITIVE);
    // Unit quaternions of rotations δ apart are 2 sin(δ/4) apart.
    let qr = 2.0 * (0.25 * angle.to_radians()).sin();
    let key =
        |x: &RigidTransform, sign: f64| scaled_key(x.apply(o), bound, x.quaternion(), qr, sign);
    let mut qpts = Vec::with_capacity(2 * n);
    for (k, it) in items.iter().enumerate() {
        qpts.push(rstar::primitives::GeomWithData::new(
            key(&it.t, 1.0),
            k as u32,
        ));
        qpts.push(rstar::primitives::GeomWithData::new(
            key(&it.t, -1.0),
            k as u32,
        ));
    }
    let qtree = rstar::RTree::bulk_load(qpts);
    let mut order: Vec<usize> = (0..groups.len()).collect();
    order.sort_by(|&a, &b| {
        groups[b]
            .2
            .total_cmp(&groups[a].2)
            .then(groups[a].0[0].cmp(&groups[b].0[0]))
    });
    let mut assigned = vec![false; n];
    let mut out = Vec::new();
    for g in order {
        let seed: Vec<usize> = groups[g]
            .0
            .iter()
            .copied()
            .filter(|&k| !assigned[k])
            .collect();
        let Some(&first) = seed.first() else {
            continue;
        };
        let mirrored = items[first].mirrored;
        let mut x = pooled_fit(items, &seed, groups[g].1, c);
        let mut members = seed;
        for _ in 0..8 {
            let mut cand: Vec<usize> = qtree
                .locate_within_distance(key(&x, 1.0), 2.0)
                .map(|p| p.data as usize)
                .filter(|&k| {
                    !assigned[k] && items[k].mirrored == mirrored && {
                        // The rotation test of the quaternion R-tree this replaces.
                        let (a, b) = (items[k].t.quaternion(), x.quaternion());
                        let d2 = |s: f64| (0..4).map(|i| (a[i] - s * b[i]).powi(2)).sum::<f64>();
                        d2(1.0).min(d2(-1.0)) <= qr * qr
                    }
                })
                .collect();
            cand.sort_unstable();
            cand.dedup();
            cand.retain(|&k| dist(x.apply(items[k].c_src), items[k].c_dst) <= e);
            let fits = par.map_collect(cand.len(), |q| items[cand[q]].residual(&x) <= e);
            let mut q = 0;
            cand.retain(|_| {
                q += 1;
                fits[q - 1]
            });
            if cand.is_empty() || cand == members {
                break;
            }
            members = cand;
            x = pooled_fit(items, &members, x, c);
        }
        for &k in &members {
            assigned[k] = true;
        }
        out.push((members, x));
    }
    out
}

/// Clusters the transformations of `matches` (see the module docs).
pub fn cluster(
    matches: &CurveMatches,
    params: &ClusterParams,
    par: Par,
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
        let src: Vec<V3> = m
            .correspondences
            .iter()
            .map(|[p, _]| if m.mirrored { matches.mirror(*p) } else { *p })
            .collect();
        let dst: Vec<V3> = m.correspondences.iter().map(|[_, q]| *q).collect();
        items.push(Item::new(m.mirrored, m.transform, fwd.clone(), src, dst));
        if m.mirrored && m.curve_a == m.curve_b {
            // A curve mirrored onto itself: the inverse is the same reflection.
            continue;
        }
        // The inverse maps q (mirrored first for a reflection) onto p.
        let src: Vec<V3> = m
            .correspondences
            .iter()
            .map(|[_, q]| if m.mirrored { matches.mirror(*q) } else { *q })
            .collect();
        let dst: Vec<V3> = m.correspondences.iter().map(|[p, _]| *p).collect();
        items.push(Item::new(
            m.mirrored,
            inv_t,
            ClusterMember {
                inverse: true,
                from: m.curve_b,
                to: m.curve_a,
                ..fwd
            },
            src,
            dst,
        ));
    }
    let qs = 0.5 * theta.to_radians();
    let feat =
        |t: &RigidTransform, sign: f64| scaled_key(t.translation, tau, t.quaternion(), qs, sign);
    let distance = |a: &RigidTransform, b: &RigidTransform| -> f64 {
        (dist(a.translation, b.translation) / tau)
            .max(quat_angle_deg(a.quaternion(), b.quaternion()) / theta)
    };
    // Transformations closer than a fifth of the stopping radius start as one cluster: a
    // grid of that cell size in the 7-D space (quaternions in the hemisphere of their first
    // non-zero component). Many copies of one feature (a grid of holes) vote the same
    // transformation thousands of times, and their all-pairs neighbour lists would be
    // quadratic in the number of matches.
    let mut cells: std::collections::BTreeMap<(bool, [i64; 7]), Vec<usize>> =
        std::collections::BTreeMap::new();
    for (k, it) in items.iter().enumerate() {
        let q = it.t.quaternion();
        let lead = q.iter().copied().find(|x| x.abs() > 1e-12).unwrap_or(1.0);
        let f = feat(&it.t, lead.signum());
        let key = f.map(|x| (x / PREMERGE_CELL).floor() as i64);
        cells.entry((it.mirrored, key)).or_default().push(k);
    }
    let seeds: Vec<Vec<usize>> = cells.into_values().collect();
    let n = seeds.len();
    let mut rep: Vec<RigidTransform> = seeds
        .iter()
        .map(|s| {
            if s.len() == 1 {
                items[s[0]].t
            } else {
                let list: Vec<(RigidTransform, f64)> = s
                    .iter()
                    .map(|&i| (items[i].t, items[i].member.affinity))
                    .collect();
                mean_transform(&list)
            }
        })
        .collect();
    let seed_mirrored: Vec<bool> = seeds.iter().map(|s| items[s[0]].mirrored).collect();
    let mut weight: Vec<f64> = seeds
        .iter()
        .map(|s| s.iter().map(|&i| items[i].member.affinity).sum())
        .collect();
    let mut points = Vec::with_capacity(2 * n);
    for (k, t) in rep.iter().enumerate() {
        points.push(rstar::primitives::GeomWithData::new(feat(t, 1.0), k as u32));
        points.push(rstar::primitives::GeomWithData::new(
            feat(t, -1.0),
            k as u32,
        ));
    }
    let tree = rstar::RTree::bulk_load(points);
    let mut nbrs: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
    let mut heap = BinaryHeap::new();
    for k in 0..n {
        for g in tree.locate_within_distance(feat(&rep[k], 1.0), 2.0) {
            let o = g.data as usize;
            if o <= k || seed_mirrored[o] != seed_mirrored[k] {
                continue;
            }
            let d = distance(&rep[k], &rep[o]);
            if d <= 1.0 && nbrs[k].insert(o) {
                nbrs[o].insert(k);
                heap.push(Reverse((Key(d), k, o, 0u32, 0u32)));
            }
        }
    }
    // Lazy agglomeration: stale heap entries (a cluster changed since) are re-evaluated.
    let mut alive = vec![true; n];
    let mut version = vec![0u32; n];
    let mut members: Vec<Vec<usize>> = seeds;
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
    // Stage-1 clusters with their representative: the mean weighted by affinity / residual²
    // (precision weights: a member that aligns its curves exactly is more reliable than one
    // whose curves only resemble each other), then re-averaged over the members within a
    // quarter of the cluster radius of it, so that partial (sliding) matches at the rim do not
    // bias it.
    let floor = (1e-3 * h).powi(2);
    let mut groups: Vec<(Vec<usize>, RigidTransform, f64)> = Vec::new();
    for k in 0..n {
        if !alive[k] {
            continue;
        }
        let mut ms: Vec<usize> = members[k].clone();
        ms.sort_unstable();
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
        groups.push((ms, repr, weight[k]));
    }
    let groups: Vec<(Vec<usize>, RigidTransform)> = if params.consolidate {
        consolidate(
            &items,
            groups,
            params.max_error * h,
            params.t_low_scale() * h,
            params.consolidate_angle_deg,
            par,
        )
    } else {
        groups.into_iter().map(|(m, t, _)| (m, t)).collect()
    };
    let mut clusters: Vec<TransformCluster> = Vec::new();
    for (ms, repr) in groups {
        let pairs: BTreeSet<(u32, u32)> = ms
            .iter()
            .map(|&i| (items[i].member.from, items[i].member.to))
            .collect();
        clusters.push(TransformCluster {
            mirrored: items[ms[0]].mirrored,
            transform: repr,
            members: ms.iter().map(|&i| items[i].member.clone()).collect(),
            support: ms.iter().map(|&i| items[i].member.affinity).sum(),
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
    const VERSION: u32 = 2;
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
