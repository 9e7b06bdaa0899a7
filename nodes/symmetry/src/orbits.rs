//! `symmetry.orbits`: orbit detection (thesis §3.2.4, after Pauly, Mitra, Wallner, Pottmann &
//! Guibas 2008). Reoccurrences on a regular grid appear in transformation space as the powers
//! T, T², …, Tᵏ of one generating transformation; this node merges them into one generator:
//!
//! - translations (rotation below `angle_tol`): the shortest translation g₁ explains every
//!   translation t ≈ k g₁ (k ∈ ℤ); of the rest, the shortest one not parallel to g₁ gives g₂ of a
//!   2-D grid t ≈ i g₁ + j g₂. The generators are refined by weighted least squares over all
//!   members with their integer coordinates (the grid fit of PMW*08, without its RANSAC: the
//!   clusters are few and clean after §3.2.3).
//! - rotations: grouped by their screw axis (direction and position); the smallest angle θ₁ of
//!   a group gives the order n = round(360° / θ₁) when 360°/n matches it, and the generator
//!   angle is fitted by least squares over the members m·θ.
//! - reflections (clusters of matches against the mirrored network): each plane is an orbit of
//!   two instances.
//!
//! Only clusters with support (summed affinity, in mean edge lengths h) of at least
//! `min_support` take part: this is the documented threshold below which a generator counts as
//! noise.

use std::collections::BTreeSet;

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::vec3::{add, cross, dist, dot, norm, scale, sub, V3};
use crestflow_geom::FeatureCurveNetwork;
use serde::{Deserialize, Serialize};

use crate::cluster::TransformClusters;
use crate::transform::RigidTransform;

/// Parameters of `symmetry.orbits`. Lengths are multiples of the mean edge length h.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OrbitParams {
    /// Clusters with less support (summed affinity, in h) are ignored. In [0, 1e9]. Default 40.
    pub min_support: f64,
    /// Orbits whose support is below this fraction of the strongest orbit's are dropped:
    /// partial self-similarities of smooth curves (a curve sliding along a copy of itself)
    /// give weak clusters that are not repetitions. In [0, 1]. Default 0.25.
    pub min_relative_support: f64,
    /// Translation tolerance of grid membership and axis positions (in h). In (0, 1000].
    /// Default 2.
    pub translation_tol: f64,
    /// Angle tolerance in degrees: below it a motion is a translation; grid angles and axis
    /// directions agree within it. In (0, 45]. Default 1.5.
    pub angle_tol: f64,
}

impl Default for OrbitParams {
    fn default() -> Self {
        OrbitParams {
            min_support: 40.0,
            min_relative_support: 0.25,
            translation_tol: 2.0,
            angle_tol: 1.5,
        }
    }
}

impl Validate for OrbitParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "min_support", self.min_support, 0.0, 1e9);
        check_range(
            &mut v,
            "min_relative_support",
            self.min_relative_support,
            0.0,
            1.0,
        );
        check_range(
            &mut v,
            "translation_tol",
            self.translation_tol,
            1e-9,
            1000.0,
        );
        check_range(&mut v, "angle_tol", self.angle_tol, 1e-9, 45.0);
        v
    }
}

/// The generating transformation of an orbit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Generator {
    /// A 1-D (one step) or 2-D (two steps) translation grid.
    Translation { steps: Vec<V3> },
    /// Rotation by `angle_deg` about the line through `center` along `axis`; `order` n when
    /// n·angle = 360° (0 when the rotations do not close a full turn).
    Rotation {
        axis: V3,
        center: V3,
        angle_deg: f64,
        order: u32,
    },
    /// Reflection in the plane {x : normal·x = offset}.
    Reflection { normal: V3, offset: f64 },
}

impl Generator {
    pub fn kind(&self) -> &'static str {
        match self {
            Generator::Translation { .. } => "translation",
            Generator::Rotation { .. } => "rotation",
            Generator::Reflection { .. } => "reflection",
        }
    }
}

/// One orbit: a generator, how many instances it relates, and what supports it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Orbit {
    pub generator: Generator,
    /// Instances of the repeated geometry (grid size, rotation order, 2 for a reflection).
    pub instances: usize,
    /// Indices into [`TransformClusters::clusters`].
    pub clusters: Vec<u32>,
    /// Curves (network indices) related by the orbit.
    pub curves: Vec<u32>,
    /// Summed support of its clusters (mesh units of length).
    pub support: f64,
}

/// The output of `symmetry.orbits`, by decreasing support.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Orbits {
    pub orbits: Vec<Orbit>,
}

/// Why `symmetry.orbits` cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OrbitError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("the clusters have no valid length unit ({0})")]
    NoScale(f64),
}

/// A unit vector's sign made canonical: its largest component is positive.
fn canonical_sign(n: V3) -> f64 {
    let mut k = 0;
    for i in 1..3 {
        if n[i].abs() > n[k].abs() {
            k = i;
        }
    }
    if n[k] < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Detects orbits among the clusters with enough support.
pub fn orbits(
    clusters: &TransformClusters,
    params: &OrbitParams,
    _par: Par,
) -> Result<Orbits, OrbitError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(OrbitError::Params(text.join("; ")));
    }
    let h = clusters.unit;
    if !(h.is_finite() && h > 0.0) {
        return Err(OrbitError::NoScale(h));
    }
    let tol = params.translation_tol * h;
    let atol = params.angle_tol;
    let strong: Vec<usize> = (0..clusters.clusters.len())
        .filter(|&k| clusters.clusters[k].support >= params.min_support * h)
        .collect();
    let mut out = Vec::new();

    // --- translations and rotations (proper motions)
    let mut trans: Vec<(usize, V3, f64)> = Vec::new();
    let mut rots: Vec<(usize, RigidTransform, f64)> = Vec::new();
    let mut refl: Vec<(usize, V3, f64, f64)> = Vec::new();
    for &k in &strong {
        let c = &clusters.clusters[k];
        if c.mirrored {
            if let Some((n, d)) = as_reflection(&c.transform, clusters.mirror_x, atol, tol) {
                refl.push((k, n, d, c.support));
            }
        } else if c.transform.angle_deg() < atol {
            trans.push((k, c.transform.translation, c.support));
        } else {
            rots.push((k, c.transform, c.support));
        }
    }
    translation_orbits(&trans, tol, atol, &mut out);
    rotation_orbits(&rots, tol, atol, &mut out);
    reflection_orbits(&refl, tol, atol, &mut out);

    for o in &mut out {
        let mut curves = BTreeSet::new();
        let mut support = 0.0;
        for &k in &o.clusters {
            let c = &clusters.clusters[k as usize];
            support += c.support;
            for m in &c.members {
                curves.insert(m.from);
                curves.insert(m.to);
            }
        }
        o.curves = curves.into_iter().collect();
        o.support = support;
    }
    let best = out.iter().map(|o| o.support).fold(0.0, f64::max);
    out.retain(|o| o.support >= params.min_relative_support * best);
    out.sort_by(|a, b| {
        b.support
            .total_cmp(&a.support)
            .then(a.clusters.cmp(&b.clusters))
    });
    Ok(Orbits { orbits: out })
}

/// The plane of a mirrored cluster's isometry S = T∘M when S is a reflection (not a glide or a
/// rotatory reflection).
fn as_reflection(t: &RigidTransform, mx: f64, atol: f64, tol: f64) -> Option<(V3, f64)> {
    // S(x) = R (D x + m) + t = (R D) x + (R m + t), D = diag(−1, 1, 1), m = (2 mx, 0, 0).
    let mut a = t.rotation;
    for row in a.iter_mut() {
        row[0] = -row[0];
    }
    let ts = add(t.rotate([2.0 * mx, 0.0, 0.0]), t.translation);
    // (I − A)/2 ≈ n nᵀ for a reflection A = I − 2 n nᵀ.
    let mut b = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            b[i][j] = (if i == j { 1.0 } else { 0.0 } - a[i][j]) * 0.5;
        }
    }
    let k = (0..3)
        .max_by(|&x, &y| b[x][x].total_cmp(&b[y][y]))
        .unwrap_or(0);
    let col = [b[0][k], b[1][k], b[2][k]];
    let len = norm(col);
    if len < 1e-9 {
        return None;
    }
    let mut n = scale(col, 1.0 / len);
    n = scale(n, canonical_sign(n));
    // A · H should be the identity for H = I − 2 n nᵀ.
    let mut p = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            p[i][j] = (0..3)
                .map(|l| {
                    let hlj = if l == j { 1.0 } else { 0.0 } - 2.0 * n[l] * n[j];
                    a[i][l] * hlj
                })
                .sum();
        }
    }
    let prop = RigidTransform {
        rotation: p,
        translation: [0.0; 3],
    };
    if prop.angle_deg() > atol {
        return None;
    }
    let along = dot(ts, n);
    let glide = norm(sub(ts, scale(n, along)));
    if glide > tol {
        return None;
    }
    Some((n, 0.5 * along))
}

fn translation_orbits(items: &[(usize, V3, f64)], tol: f64, atol: f64, out: &mut Vec<Orbit>) {
    let mut left: Vec<usize> = (0..items.len()).collect();
    // Shortest first; ties by cluster index for determinism.
    left.sort_by(|&a, &b| {
        norm(items[a].1)
            .total_cmp(&norm(items[b].1))
            .then(items[a].0.cmp(&items[b].0))
    });
    left.retain(|&i| norm(items[i].1) > tol);
    while let Some(&first) = left.first() {
        let mut g1 = items[first].1;
        // Members t ≈ k g1, then refine g1 = Σ w k t / Σ w k².
        let mut members: Vec<(usize, i64, i64)> = Vec::new();
        for _ in 0..2 {
            members.clear();
            let gg = dot(g1, g1);
            for &i in &left {
                let t = items[i].1;
                let k = (dot(t, g1) / gg).round() as i64;
                if k != 0 && dist(t, scale(g1, k as f64)) <= tol {
                    members.push((i, k, 0));
                }
            }
            let (mut num, mut den) = ([0.0; 3], 0.0);
            for &(i, k, _) in &members {
                num = add(num, scale(items[i].1, items[i].2 * k as f64));
                den += items[i].2 * (k * k) as f64;
            }
            if den > 0.0 {
                g1 = scale(num, 1.0 / den);
            }
        }
        let in_1d: BTreeSet<usize> = members.iter().map(|m| m.0).collect();
        // A second, non-parallel generator among the rest.
        let rest: Vec<usize> = left
            .iter()
            .copied()
            .filter(|i| !in_1d.contains(i))
            .collect();
        let mut steps = vec![g1];
        for &cand in &rest {
            let g2 = items[cand].1;
            let sin = norm(cross(g1, g2)) / (norm(g1) * norm(g2));
            if sin < atol.to_radians().sin() * 10.0 {
                continue;
            }
            // Lattice coordinates by least squares in the plane of g1, g2.
            let mut grid: Vec<(usize, i64, i64)> = Vec::new();
            let (mut a, mut b) = (g1, g2);
            for _ in 0..2 {
                grid.clear();
                let (aa, ab, bb) = (dot(a, a), dot(a, b), dot(b, b));
                let det = aa * bb - ab * ab;
                for &i in &left {
                    let t = items[i].1;
                    let (ta, tb) = (dot(t, a), dot(t, b));
                    let x = ((bb * ta - ab * tb) / det).round() as i64;
                    let y = ((aa * tb - ab * ta) / det).round() as i64;
                    let fit = add(scale(a, x as f64), scale(b, y as f64));
                    if (x, y) != (0, 0) && dist(t, fit) <= tol {
                        grid.push((i, x, y));
                    }
                }
                // Normal equations of Σ w |t − x a − y b|².
                let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
                let (mut rx, mut ry) = ([0.0; 3], [0.0; 3]);
                for &(i, x, y) in &grid {
                    let w = items[i].2;
                    let (x, y) = (x as f64, y as f64);
                    sxx += w * x * x;
                    sxy += w * x * y;
                    syy += w * y * y;
                    rx = add(rx, scale(items[i].1, w * x));
                    ry = add(ry, scale(items[i].1, w * y));
                }
                let det2 = sxx * syy - sxy * sxy;
                if det2.abs() > 1e-12 {
                    a = scale(sub(scale(rx, syy), scale(ry, sxy)), 1.0 / det2);
                    b = scale(sub(scale(ry, sxx), scale(rx, sxy)), 1.0 / det2);
                }
            }
            if grid.iter().any(|g| g.2 != 0) {
                steps = vec![a, b];
                members = grid;
            }
            break;
        }
        let mut max_i = 0;
        let mut max_j = 0;
        for &(_, i, j) in &members {
            max_i = max_i.max(i.unsigned_abs());
            max_j = max_j.max(j.unsigned_abs());
        }
        let instances = (max_i as usize + 1) * (max_j as usize + 1);
        let used: BTreeSet<usize> = members.iter().map(|m| m.0).collect();
        if used.is_empty() {
            left.remove(0);
            continue;
        }
        let mut cl: Vec<u32> = used.iter().map(|&i| items[i].0 as u32).collect();
        cl.sort_unstable();
        out.push(Orbit {
            generator: Generator::Translation { steps },
            instances,
            clusters: cl,
            curves: Vec::new(),
            support: 0.0,
        });
        left.retain(|i| !used.contains(i));
    }
}

fn rotation_orbits(
    items: &[(usize, RigidTransform, f64)],
    tol: f64,
    atol: f64,
    out: &mut Vec<Orbit>,
) {
    // Screw axis of each rotation; pure rotations only (slide below tol).
    struct Rot {
        idx: usize,
        axis: V3,
        center: V3,
        angle: f64,
        w: f64,
    }
    let mut rs: Vec<Rot> = Vec::new();
    for &(idx, t, w) in items {
        let (center, slide) = t.screw();
        if slide.abs() > tol {
            continue;
        }
        let axis = t.axis();
        let angle = t.angle_deg();
        rs.push(Rot {
            idx,
            axis,
            center,
            angle,
            w,
        });
    }
    // Strongest first.
    let mut order: Vec<usize> = (0..rs.len()).collect();
    order.sort_by(|&a, &b| rs[b].w.total_cmp(&rs[a].w).then(rs[a].idx.cmp(&rs[b].idx)));
    let mut used = vec![false; rs.len()];
    for &seed in &order {
        if used[seed] {
            continue;
        }
        let n0 = scale(rs[seed].axis, canonical_sign(rs[seed].axis));
        let c0 = rs[seed].center;
        // (index, angle in [0, 360) about n0)
        let mut group: Vec<(usize, f64)> = Vec::new();
        for &k in &order {
            if used[k] {
                continue;
            }
            let r = &rs[k];
            let cosang = dot(r.axis, n0);
            let (n, ang) = if cosang < 0.0 {
                (scale(r.axis, -1.0), 360.0 - r.angle)
            } else {
                (r.axis, r.angle)
            };
            if dot(n, n0).clamp(-1.0, 1.0).acos().to_degrees() > 2.0 * atol {
                continue;
            }
            let off = norm(cross(sub(r.center, c0), n0));
            if off > tol {
                continue;
            }
            group.push((k, ang));
        }
        if group.is_empty() {
            continue;
        }
        let g_min = group
            .iter()
            .map(|&(_, a)| a.min(360.0 - a))
            .fold(f64::INFINITY, f64::min);
        if g_min.is_nan() || g_min < atol {
            for &(k, _) in &group {
                used[k] = true;
            }
            continue;
        }
        let order_n = (360.0 / g_min).round().max(1.0) as u32;
        let full = (360.0 / order_n as f64 - g_min).abs() <= atol;
        let base = if full { 360.0 / order_n as f64 } else { g_min };
        let mut members: Vec<(usize, i64, f64)> = Vec::new();
        for &(k, a) in &group {
            let m = (a / base).round() as i64;
            if m != 0 && (a - m as f64 * base).abs() <= atol * (m.unsigned_abs() as f64).max(1.0) {
                members.push((k, m, a));
            }
        }
        if members.is_empty() {
            used[seed] = true;
            continue;
        }
        // Generator angle by least squares over m·θ (angles of the members in [0, 360)).
        let (mut num, mut den) = (0.0, 0.0);
        for &(k, m, a) in &members {
            num += rs[k].w * m as f64 * a;
            den += rs[k].w * (m * m) as f64;
        }
        let angle = if den > 0.0 { num / den } else { base };
        let wsum: f64 = members.iter().map(|&(k, _, _)| rs[k].w).sum();
        let center = members.iter().fold([0.0; 3], |s, &(k, _, _)| {
            // Centres projected onto the plane ⟂ n0 through c0, then averaged.
            let c = rs[k].center;
            let c = sub(c, scale(n0, dot(sub(c, c0), n0)));
            add(s, scale(c, rs[k].w / wsum))
        });
        let max_m = members
            .iter()
            .map(|&(_, m, _)| m.unsigned_abs())
            .max()
            .unwrap_or(0);
        let instances = if full {
            order_n as usize
        } else {
            max_m as usize + 1
        };
        for &(k, _, _) in &members {
            used[k] = true;
        }
        used[seed] = true;
        let mut cl: Vec<u32> = members.iter().map(|&(k, _, _)| rs[k].idx as u32).collect();
        cl.sort_unstable();
        out.push(Orbit {
            generator: Generator::Rotation {
                axis: n0,
                center,
                angle_deg: angle,
                order: if full { order_n } else { 0 },
            },
            instances,
            clusters: cl,
            curves: Vec::new(),
            support: 0.0,
        });
    }
}

fn reflection_orbits(items: &[(usize, V3, f64, f64)], tol: f64, atol: f64, out: &mut Vec<Orbit>) {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| {
        items[b]
            .3
            .total_cmp(&items[a].3)
            .then(items[a].0.cmp(&items[b].0))
    });
    let mut used = vec![false; items.len()];
    for &seed in &order {
        if used[seed] {
            continue;
        }
        let (_, n0, d0, _) = items[seed];
        let mut n = [0.0; 3];
        let mut d = 0.0;
        let mut w = 0.0;
        let mut cl = Vec::new();
        for &k in &order {
            let (idx, nk, dk, wk) = items[k];
            if used[k] {
                continue;
            }
            let s = if dot(nk, n0) < 0.0 { -1.0 } else { 1.0 };
            let ang = (s * dot(nk, n0)).clamp(-1.0, 1.0).acos().to_degrees();
            if ang <= 2.0 * atol && (s * dk - d0).abs() <= tol {
                used[k] = true;
                n = add(n, scale(nk, s * wk));
                d += s * dk * wk;
                w += wk;
                cl.push(idx as u32);
            }
        }
        let len = norm(n);
        if len <= 0.0 || w <= 0.0 {
            continue;
        }
        cl.sort_unstable();
        out.push(Orbit {
            generator: Generator::Reflection {
                normal: scale(n, 1.0 / len),
                offset: d / w,
            },
            instances: 2,
            clusters: cl,
            curves: Vec::new(),
            support: 0.0,
        });
    }
}

/// The orbits as a [`Report`]: `orbits`, and per orbit `orbit_<i>.kind`, `.instances`,
/// `.support`, `.curves`, and `.angle_deg`/`.order` (rotations), `.step` (and `.step2` for a
/// 2-D grid; translations), `.offset` (reflections).
pub fn to_report(o: &Orbits) -> Report {
    let mut r = Report::new();
    r.set("orbits", o.orbits.len());
    for (i, orb) in o.orbits.iter().enumerate() {
        let p = format!("orbit_{i}");
        r.set(format!("{p}.kind"), orb.generator.kind());
        r.set(format!("{p}.instances"), orb.instances);
        r.set(format!("{p}.support"), orb.support);
        r.set(format!("{p}.curves"), orb.curves.len());
        match &orb.generator {
            Generator::Translation { steps } => {
                r.set(format!("{p}.step"), norm(steps[0]));
                if let Some(s2) = steps.get(1) {
                    r.set(format!("{p}.step2"), norm(*s2));
                }
                r.set(format!("{p}.dims"), steps.len());
            }
            Generator::Rotation {
                angle_deg, order, ..
            } => {
                r.set(format!("{p}.angle_deg"), *angle_deg);
                r.set(format!("{p}.order"), *order as usize);
            }
            Generator::Reflection { offset, .. } => {
                r.set(format!("{p}.offset"), *offset);
            }
        }
    }
    r
}

/// The curves of `network` that belong to at least one orbit (for pictures).
pub fn orbit_curves(network: &FeatureCurveNetwork, o: &Orbits) -> FeatureCurveNetwork {
    let keep: BTreeSet<u32> = o
        .orbits
        .iter()
        .flat_map(|x| x.curves.iter().copied())
        .collect();
    FeatureCurveNetwork {
        vertices: network.vertices.clone(),
        curves: network
            .curves
            .iter()
            .enumerate()
            .filter(|(c, _)| keep.contains(&(*c as u32)))
            .map(|(_, c)| c.clone())
            .collect(),
    }
}

/// The `symmetry.orbits` node.
pub struct OrbitsNode;

impl NodeKind for OrbitsNode {
    type Params = OrbitParams;
    const KIND: &'static str = "symmetry.orbits";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Orbit detection (thesis §3.2.4, after Pauly et al. 2008): merges \
        the transformation clusters T, T², … into generators — 1-D and 2-D translation grids, \
        rotations about a common axis by 360°/n, reflections — with their instances and member \
        curves. Emits a Report (`orbits`, `orbit_<i>.kind`, `.instances`, `.angle_deg` or \
        `.step`) and, when the network is connected, the curves that lie in an orbit.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TransformClusters>("clusters", "clusters from symmetry.cluster"),
            Port::optional::<FeatureCurveNetwork>(
                "network",
                "the matched network, to output the curves in orbits",
            ),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<Orbits>("orbits", "generators with instances and member curves"),
            Port::of::<Report>("report", "orbit count, kinds, instances, angles, steps"),
            Port::of::<FeatureCurveNetwork>(
                "curves",
                "the curves that lie in an orbit (empty without a network)",
            ),
        ]
    }
    fn run(params: &OrbitParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let clusters = inputs.get::<TransformClusters>("clusters")?;
        ctx.check_cancelled()?;
        let out = orbits(clusters, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        let curves = match inputs.opt::<FeatureCurveNetwork>("network")? {
            Some(n) => orbit_curves(n, &out),
            None => FeatureCurveNetwork::default(),
        };
        Ok(Outputs::new()
            .with("report", to_report(&out))
            .with("curves", curves)
            .with("orbits", out))
    }
}
