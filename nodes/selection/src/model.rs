//! `selection.model`: Bayesian model selection of the transformations that explain a noisy
//! feature curve network (thesis §4.2.2, eq. 4.1, heuristic §4.2.2.1).
//!
//! The candidate transformations come from the symmetry family: each orbit of
//! `symmetry.orbits` is one candidate when orbits are given — a translation grid with all its
//! reoccurrences i g₀ + j g₁ that fit in the curves' bounding box, a closed rotation with all
//! its powers, other orbits with their cluster transformations (and their inverses);
//! otherwise each cluster of `symmetry.cluster` with enough support is one (with its inverse).
//!
//! The likelihood of curve c under a candidate T is the Feature BLAST affinity of its
//! inverse-transformed samples T⁻¹ p against the curve on which their nearest neighbour lies
//! (another curve: landing on c itself is no evidence). Along c, maximal runs of samples whose
//! nearest curve is the same curve c′ and whose distance to c′ stays below t_high are the grown
//! matches; a run of length l ≥ l0 with mean distance d ≤ t_low has the affinity
//! l·exp(−d / (0.5 t_high)), which every sample of the run carries. The average over the
//! samples of c is w(T, c). For a grid (an orbit) the averages of all its transformations are
//! summed, as the thesis does. Optionally (`align_iterations` > 0) T⁻¹ c is first aligned onto
//! c′ by a few rigid ICP steps, which tolerates a cluster transformation that is only accurate
//! to its bin size but also lets noise curves snap onto nearby curves; off by default.
//!
//! The null hypothesis T_null has w = l0·e⁻², the smallest affinity of a match of length l0.
//! L(c | H) = max over T ∈ H ∪ {T_null} of w(T, c) (eq. 4.1); with a uniform prior the Bayes
//! ratio of two models is the ratio of their likelihoods Π_c L(c | H); everything is computed
//! as sums of logarithms. Heuristic selection (§4.2.2.1): start from all candidates, and while
//! removing the candidate whose removal costs least (the least support) gives a Bayes ratio
//! K = L(C | Hⁱ) / L(C | Hⁱ⁺¹) ≤ `bayes_ratio`, remove it. T_null is never removed.
//!
//! Lengths in parameters are multiples of the mean edge length h (the unit of the clusters).

use std::collections::{BTreeMap, BTreeSet};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::vec3::{add, dist, norm, scale, V3};
use crestflow_geom::FeatureCurveNetwork;
use crestflow_nodes_symmetry::cluster::conjugate_by_mirror;
use crestflow_nodes_symmetry::transform::fit_rigid;
use crestflow_nodes_symmetry::{Generator, Orbits, RigidTransform, TransformClusters};
use serde::{Deserialize, Serialize};

use crate::curves::{
    nearest_curve, reduce_basis, sample_network, sample_tree, Iso, SampleTree, Sampled,
};

/// Parameters of `selection.model`. Lengths are multiples of the mean edge length h.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModelParams {
    /// Minimal match length l0 (thesis: 20–30 h); also fixes w(T_null) = l0·e⁻².
    /// In [1, 1000]. Default 25.
    pub l0: f64,
    /// A match must have a mean distance below t_low (thesis: 1 h). In (0, 100]. Default 1.
    pub t_low: f64,
    /// Samples stay in a match while closer than t_high to the partner curve (thesis:
    /// 2 t_low). In (0, 200], at least `t_low`. Default 2.
    pub t_high: f64,
    /// Resampling step of the curves. In [0.1, 10]. Default 1.
    pub sample_step: f64,
    /// Without orbits: clusters with less support (summed affinity, in h) are not candidates.
    /// In [0, 1e9]. Default 40.
    pub min_support: f64,
    /// Without orbits: at most this many candidates (the strongest clusters); with orbits: at
    /// most this many reoccurrences of a grid (the shortest). In [1, 10000]. Default 200.
    pub max_candidates: u32,
    /// A removal stops when the Bayes ratio K of the model before over the model after
    /// exceeds this (thesis: 10, "strong support" after Jeffreys). In (1, 1e12]. Default 10.
    pub bayes_ratio: f64,
    /// Iterations of the local rigid alignment of T⁻¹ c onto its partner curve before the
    /// affinity is measured (0: T⁻¹ as it is, as the thesis writes). In [0, 100]. Default 0.
    pub align_iterations: u32,
    /// Points within this distance of the partner curve drive the alignment, which may move
    /// the curve by at most this much on average. In (0, 1000]. Default 2.
    pub align_radius: f64,
}

impl Default for ModelParams {
    fn default() -> Self {
        ModelParams {
            l0: 25.0,
            t_low: 1.0,
            t_high: 2.0,
            sample_step: 1.0,
            min_support: 40.0,
            max_candidates: 200,
            bayes_ratio: 10.0,
            align_iterations: 0,
            align_radius: 2.0,
        }
    }
}

impl Validate for ModelParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "l0", self.l0, 1.0, 1000.0);
        check_range(&mut v, "t_low", self.t_low, 1e-6, 100.0);
        check_range(&mut v, "t_high", self.t_high, 1e-6, 200.0);
        check_range(&mut v, "sample_step", self.sample_step, 0.1, 10.0);
        check_range(&mut v, "min_support", self.min_support, 0.0, 1e9);
        check_range(&mut v, "max_candidates", self.max_candidates, 1, 10_000);
        check_range(&mut v, "bayes_ratio", self.bayes_ratio, 1.0 + 1e-9, 1e12);
        check_range(&mut v, "align_iterations", self.align_iterations, 0, 100);
        check_range(&mut v, "align_radius", self.align_radius, 1e-6, 1000.0);
        if self.t_high < self.t_low {
            v.push(ParamIssue::new(
                "t_high",
                format!("{} is below t_low = {}", self.t_high, self.t_low),
            ));
        }
        v
    }
}

/// One candidate transformation (a whole orbit, or one cluster).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// The generator (grid steps, rotation, reflection); `None` for a cluster whose motion is
    /// a screw (neither a translation nor a rotation about a fixed axis).
    pub generator: Option<Generator>,
    /// The isometries whose affinities are summed (an orbit's clusters, or one cluster).
    pub transforms: Vec<Iso>,
    /// Indices into the clusters.
    pub clusters: Vec<u32>,
    /// Summed affinity support of the clusters (mesh units of length).
    pub support: f64,
}

/// A match of a curve's inverse-transformed samples onto another curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Partner {
    /// The curve hit.
    pub curve: u32,
    /// Index into the candidate's `transforms`.
    pub transform: u32,
    /// Matched length l (mesh units) and mean distance d.
    pub length: f64,
    pub distance: f64,
}

/// One step of the heuristic removal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RemovalStep {
    /// The candidate with least support at this step.
    pub candidate: u32,
    /// log₁₀ K of the model with it over the model without it.
    pub log10_k: f64,
    /// Whether it was removed (K ≤ the threshold); the last step is the one that stops.
    pub removed: bool,
}

/// The output of `selection.model`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SelectedModel {
    /// The length unit h.
    pub unit: f64,
    /// l0, t_low, t_high and the sampling step in mesh units.
    pub l0: f64,
    pub t_low: f64,
    pub t_high: f64,
    pub step: f64,
    /// All candidates, and the indices of those kept by the selection.
    pub candidates: Vec<Candidate>,
    pub kept: Vec<u32>,
    /// Per curve: the candidate that explains it best (argmax of eq. 4.1), `None` for T_null.
    pub assignment: Vec<Option<u32>>,
    /// Per curve: ln L(c | H) under the selected model.
    pub log_likelihood: Vec<f64>,
    /// Per curve: its matches under its assigned candidate.
    pub partners: Vec<Vec<Partner>>,
    /// ln w(T_null).
    pub log_null: f64,
    /// ln L(C | H) of the full and of the selected model.
    pub log_evidence_all: f64,
    pub log_evidence: f64,
    pub steps: Vec<RemovalStep>,
}

/// Why `selection.model` cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("the clusters have no valid length unit ({0})")]
    NoScale(f64),
    #[error("curve {curve} references network vertex {index} but the network has {n} vertices")]
    VertexIndex { curve: usize, index: u32, n: usize },
    #[error("network vertex {vertex} has a non-finite position {position:?}")]
    NonFinite { vertex: usize, position: V3 },
    #[error("cluster {index} has a non-finite transformation")]
    NonFiniteTransform { index: usize },
    #[error("orbit {orbit} refers to cluster {cluster} but there are {n} clusters")]
    ClusterIndex {
        orbit: usize,
        cluster: u32,
        n: usize,
    },
}

/// Checks the network's indices and coordinates.
pub(crate) fn check_network(net: &FeatureCurveNetwork) -> Result<(), ModelError> {
    for (k, v) in net.vertices.iter().enumerate() {
        if !v.position.iter().all(|x| x.is_finite()) {
            return Err(ModelError::NonFinite {
                vertex: k,
                position: v.position,
            });
        }
    }
    let n = net.vertices.len();
    for (c, curve) in net.curves.iter().enumerate() {
        if let Some(&bad) = curve.vertices.iter().find(|&&v| v as usize >= n) {
            return Err(ModelError::VertexIndex {
                curve: c,
                index: bad,
                n,
            });
        }
    }
    Ok(())
}

/// The generator of a single cluster's motion.
fn cluster_generator(iso: &Iso, tol: f64, atol: f64) -> Option<Generator> {
    if iso.mirror_x.is_some() {
        return None;
    }
    let t = &iso.transform;
    if t.angle_deg() < atol {
        return Some(Generator::Translation {
            steps: vec![t.translation],
        });
    }
    let (center, slide) = t.screw();
    if slide.abs() > tol {
        return None;
    }
    let angle = t.angle_deg();
    let n = (360.0 / angle).round();
    let order = if n >= 2.0 && (360.0 / n - angle).abs() <= atol {
        n as u32
    } else {
        0
    };
    Some(Generator::Rotation {
        axis: t.axis(),
        center,
        angle_deg: angle,
        order,
    })
}

/// Every reoccurrence of a grid within the bounding box `bbox` of the curves: the
/// translations i g₀ + j g₁ ≠ 0 that fit in the box, or the rotations by k·360°/n of a closed
/// rotation orbit (at most `cap` of them, smallest first). Empty for other generators, whose
/// cluster transformations are used as they are.
fn lattice_transforms(gen: &Generator, bbox: (V3, V3), cap: u32) -> Vec<Iso> {
    match gen {
        Generator::Translation { steps } if !steps.is_empty() && steps.len() <= 2 => {
            let steps = reduce_basis(steps);
            let (lo, hi) = bbox;
            let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
            // How many steps fit along each generator (its extent over the box).
            let span = |g: V3| -> i64 {
                let n = norm(g);
                if n <= 0.0 {
                    return 0;
                }
                let reach = (ext[0] * g[0].abs() + ext[1] * g[1].abs() + ext[2] * g[2].abs()) / n;
                ((reach / n).floor() as i64).clamp(0, 64)
            };
            let s0 = span(steps[0]);
            let s1 = if steps.len() > 1 { span(steps[1]) } else { 0 };
            let mut out: Vec<(f64, i64, i64, V3)> = Vec::new();
            for i in -s0..=s0 {
                for j in -s1..=s1 {
                    if i == 0 && j == 0 {
                        continue;
                    }
                    let mut t = scale(steps[0], i as f64);
                    if let Some(g1) = steps.get(1) {
                        t = add(t, scale(*g1, j as f64));
                    }
                    out.push((norm(t), i, j, t));
                }
            }
            out.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
            out.truncate(cap as usize);
            out.into_iter()
                .map(|(_, _, _, t)| Iso::rigid(RigidTransform::translation(t)))
                .collect()
        }
        Generator::Rotation {
            axis,
            center,
            order,
            ..
        } if *order >= 2 && norm(*axis) > 0.0 => (1..*order)
            .take(cap as usize)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / *order as f64;
                Iso::rigid(RigidTransform::rotation_about(*axis, a, *center))
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// The inverse of an isometry: T⁻¹, or for a reflection S = T∘M, S⁻¹ = M∘T⁻¹ = (M T⁻¹ M)∘M.
fn inverse(i: &Iso) -> Iso {
    let inv = i.transform.inverse();
    match i.mirror_x {
        None => Iso::rigid(inv),
        Some(mx) => Iso {
            transform: conjugate_by_mirror(&inv, mx),
            mirror_x: Some(mx),
        },
    }
}

/// `set` closed under inversion: a curve whose image lies on another curve under T has that
/// curve's image on it under T⁻¹, so both belong to the same hypothesis. Inverses that
/// coincide (within `tol` at the unit points, as for reflections) with a member are not added.
fn with_inverses(set: Vec<Iso>, tol: f64) -> Vec<Iso> {
    let probes = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let same = |a: &Iso, b: &Iso| {
        a.mirror_x.is_some() == b.mirror_x.is_some()
            && probes
                .iter()
                .all(|p| crestflow_geom::vec3::dist(a.apply(*p), b.apply(*p)) <= tol)
    };
    let mut out = set.clone();
    for t in &set {
        let i = inverse(t);
        if !out.iter().any(|o| same(o, &i)) {
            out.push(i);
        }
    }
    out
}

/// The candidates from orbits (when given) or from the strongest clusters.
fn candidates(
    clusters: &TransformClusters,
    orbits: Option<&Orbits>,
    bbox: (V3, V3),
    params: &ModelParams,
) -> Result<Vec<Candidate>, ModelError> {
    let h = clusters.unit;
    let iso = |k: usize| {
        let c = &clusters.clusters[k];
        Iso {
            transform: c.transform,
            mirror_x: c.mirrored.then_some(clusters.mirror_x),
        }
    };
    for k in 0..clusters.clusters.len() {
        if !iso(k).is_finite() {
            return Err(ModelError::NonFiniteTransform { index: k });
        }
    }
    let mut out = Vec::new();
    match orbits {
        Some(o) => {
            for (oi, orb) in o.orbits.iter().enumerate() {
                for &c in &orb.clusters {
                    if c as usize >= clusters.clusters.len() {
                        return Err(ModelError::ClusterIndex {
                            orbit: oi,
                            cluster: c,
                            n: clusters.clusters.len(),
                        });
                    }
                }
                let lattice = lattice_transforms(&orb.generator, bbox, params.max_candidates);
                let transforms = if lattice.is_empty() {
                    with_inverses(
                        orb.clusters.iter().map(|&c| iso(c as usize)).collect(),
                        0.5 * h,
                    )
                } else {
                    lattice
                };
                out.push(Candidate {
                    generator: Some(orb.generator.clone()),
                    transforms,
                    clusters: orb.clusters.clone(),
                    support: orb.support,
                });
            }
        }
        None => {
            let mut order: Vec<usize> = (0..clusters.clusters.len())
                .filter(|&k| clusters.clusters[k].support >= params.min_support * h)
                .collect();
            order.sort_by(|&a, &b| {
                clusters.clusters[b]
                    .support
                    .total_cmp(&clusters.clusters[a].support)
                    .then(a.cmp(&b))
            });
            order.truncate(params.max_candidates as usize);
            for k in order {
                let i = iso(k);
                out.push(Candidate {
                    generator: cluster_generator(&i, 2.0 * h, 1.5),
                    transforms: with_inverses(vec![i], 0.5 * h),
                    clusters: vec![k as u32],
                    support: clusters.clusters[k].support,
                });
            }
        }
    }
    Ok(out)
}

/// Lengths in mesh units.
struct Scaled {
    l0: f64,
    t_low: f64,
    t_high: f64,
    step: f64,
    /// Local alignment: iterations and the radius of the pairs.
    align_iterations: u32,
    t_align: f64,
}

/// Feature BLAST of curve `c` under `iso`: the average affinity over its samples and the
/// matches (runs) found.
fn affinity(
    c: usize,
    curves: &[Sampled],
    tree: &SampleTree,
    iso: &Iso,
    sc: &Scaled,
    ti: u32,
) -> (f64, Vec<Partner>) {
    let s = &curves[c];
    let n = s.pts.len();
    if n < 2 {
        return (0.0, Vec::new());
    }
    // T⁻¹ p, then aligned locally onto the partner curve as Feature BLAST aligns the segments
    // it compares (the cluster's mean transformation is only accurate to its bin size).
    let mut q: Vec<V3> = s.pts.iter().map(|p| iso.apply_inverse(*p)).collect();
    for _ in 0..sc.align_iterations {
        let near: Vec<Option<(u32, f64, V3)>> =
            q.iter().map(|&p| nearest_curve(tree, curves, p)).collect();
        let mut count: BTreeMap<u32, usize> = BTreeMap::new();
        for (cc, d, _) in near.iter().flatten() {
            if *cc as usize != c && *d < sc.t_align {
                *count.entry(*cc).or_default() += 1;
            }
        }
        let Some((&major, _)) = count.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))) else {
            break;
        };
        let (mut src, mut dst) = (Vec::new(), Vec::new());
        for (k, h) in near.iter().enumerate() {
            if let Some((cc, d, x)) = h {
                if *cc == major && *d < sc.t_align {
                    src.push(q[k]);
                    dst.push(*x);
                }
            }
        }
        if src.len() < 3 {
            break;
        }
        let t = fit_rigid(&src, &dst, None);
        let moved: Vec<V3> = q.iter().map(|p| t.apply(*p)).collect();
        let shift = moved.iter().zip(&q).map(|(a, b)| dist(*a, *b)).sum::<f64>() / n as f64;
        if !shift.is_finite() || shift > sc.t_align {
            break;
        }
        q = moved;
    }
    // (partner curve, distance) per sample, None when beyond t_high.
    let hits: Vec<Option<(u32, f64)>> = q
        .iter()
        .map(|&p| {
            // A curve is generated from *other* curves: landing on itself (a circle turned
            // about its own axis) is no evidence of reoccurrence.
            nearest_curve(tree, curves, p)
                .filter(|&(cc, d, _)| d < sc.t_high && cc as usize != c)
                .map(|(cc, d, _)| (cc, d))
        })
        .collect();
    // Runs of equal partners; a closed curve starts at a break so that no run wraps.
    let start = if s.closed {
        (0..n)
            .find(|&i| {
                let prev = (i + n - 1) % n;
                hits[i].map(|x| x.0) != hits[prev].map(|x| x.0) || hits[i].is_none()
            })
            .unwrap_or(0)
    } else {
        0
    };
    let mut runs: Vec<(u32, usize, f64)> = Vec::new(); // (curve, count, summed distance)
    for k in 0..n {
        let i = (start + k) % n;
        if let Some((cc, d)) = hits[i] {
            match runs.last_mut() {
                Some(last) if last.0 == cc && k > 0 && hits[(i + n - 1) % n].is_some() => {
                    last.1 += 1;
                    last.2 += d;
                }
                _ => runs.push((cc, 1, d)),
            }
        }
    }
    let mut sum = 0.0;
    let mut partners = Vec::new();
    for (cc, count, dsum) in runs {
        let l = count as f64 * sc.step;
        let d = dsum / count as f64;
        if l + 1e-9 * sc.step < sc.l0 || d > sc.t_low {
            continue;
        }
        let w = l * (-d / (0.5 * sc.t_high)).exp();
        sum += w * count as f64;
        partners.push(Partner {
            curve: cc,
            transform: ti,
            length: l,
            distance: d,
        });
    }
    (sum / n as f64, partners)
}

/// ln L(C | H) for the candidate set `h` (indices), per-curve logs of w given.
fn log_evidence(logw: &[Vec<f64>], log_null: f64, h: &[usize], n_curves: usize) -> f64 {
    (0..n_curves)
        .map(|c| h.iter().map(|&j| logw[j][c]).fold(log_null, f64::max))
        .sum()
}

/// Selects the model (see the module docs).
pub fn select_model(
    network: &FeatureCurveNetwork,
    clusters: &TransformClusters,
    orbits: Option<&Orbits>,
    params: &ModelParams,
    par: Par,
) -> Result<SelectedModel, ModelError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(ModelError::Params(text.join("; ")));
    }
    let h = clusters.unit;
    if !(h.is_finite() && h > 0.0) {
        return Err(ModelError::NoScale(h));
    }
    check_network(network)?;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for c in &network.curves {
        for &v in &c.vertices {
            let p = network.vertices[v as usize].position;
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    if !lo[0].is_finite() {
        lo = [0.0; 3];
        hi = [0.0; 3];
    }
    let cands = candidates(clusters, orbits, (lo, hi), params)?;
    let sc = Scaled {
        l0: params.l0 * h,
        t_low: params.t_low * h,
        t_high: params.t_high * h,
        step: params.sample_step * h,
        align_iterations: params.align_iterations,
        t_align: params.align_radius * h,
    };
    let sampled = sample_network(network, sc.step);
    let tree = sample_tree(&sampled);
    let m = network.curves.len();
    let log_null = (sc.l0 * (-2.0f64).exp()).ln();
    // w[j][c] and the partners of each (candidate, curve).
    let per: Vec<(Vec<f64>, Vec<Vec<Partner>>)> = par.map_collect(cands.len(), |j| {
        let mut logw = Vec::with_capacity(m);
        let mut parts = Vec::with_capacity(m);
        for c in 0..m {
            let mut w = 0.0;
            let mut pc = Vec::new();
            for (ti, iso) in cands[j].transforms.iter().enumerate() {
                let (a, p) = affinity(c, &sampled, &tree, iso, &sc, ti as u32);
                w += a;
                pc.extend(p);
            }
            logw.push(if w > 0.0 { w.ln() } else { f64::NEG_INFINITY });
            parts.push(pc);
        }
        (logw, parts)
    });
    let logw: Vec<Vec<f64>> = per.iter().map(|p| p.0.clone()).collect();
    let mut model: Vec<usize> = (0..cands.len()).collect();
    let log_all = log_evidence(&logw, log_null, &model, m);
    let mut current = log_all;
    let ln_threshold = params.bayes_ratio.ln();
    let mut steps = Vec::new();
    while !model.is_empty() {
        // The candidate whose removal leaves the largest evidence (least support for the
        // data); among removals that cost the same, the candidate with the least cluster
        // support goes first, then the later one.
        let mut best: Option<(usize, f64)> = None;
        for (pos, &j) in model.iter().enumerate() {
            let rest: Vec<usize> = model
                .iter()
                .enumerate()
                .filter(|&(q, _)| q != pos)
                .map(|(_, &j)| j)
                .collect();
            let e = log_evidence(&logw, log_null, &rest, m);
            let better = match best {
                None => true,
                Some((bp, b)) => {
                    let tol = 1e-9 * (1.0 + b.abs());
                    if e > b + tol {
                        true
                    } else if e >= b - tol {
                        let (sj, sb) = (cands[j].support, cands[model[bp]].support);
                        sj < sb || (sj == sb && j > model[bp])
                    } else {
                        false
                    }
                }
            };
            if better {
                best = Some((pos, e));
            }
        }
        let Some((pos, e)) = best else { break };
        let ln_k = current - e;
        let removed = ln_k <= ln_threshold;
        steps.push(RemovalStep {
            candidate: model[pos] as u32,
            log10_k: ln_k / std::f64::consts::LN_10,
            removed,
        });
        if !removed {
            break;
        }
        model.remove(pos);
        current = e;
    }
    let kept: BTreeSet<usize> = model.iter().copied().collect();
    let mut assignment = Vec::with_capacity(m);
    let mut log_likelihood = Vec::with_capacity(m);
    let mut partners = Vec::with_capacity(m);
    #[allow(clippy::needless_range_loop)] // c indexes the inner vectors of logw and per
    for c in 0..m {
        let mut best: Option<(usize, f64)> = None;
        for &j in &kept {
            let v = logw[j][c];
            if v > log_null && best.is_none_or(|(_, b)| v > b) {
                best = Some((j, v));
            }
        }
        match best {
            Some((j, v)) => {
                assignment.push(Some(j as u32));
                log_likelihood.push(v);
                partners.push(per[j].1[c].clone());
            }
            None => {
                assignment.push(None);
                log_likelihood.push(log_null);
                partners.push(Vec::new());
            }
        }
    }
    Ok(SelectedModel {
        unit: h,
        l0: sc.l0,
        t_low: sc.t_low,
        t_high: sc.t_high,
        step: sc.step,
        candidates: cands,
        kept: kept.iter().map(|&j| j as u32).collect(),
        assignment,
        log_likelihood,
        partners,
        log_null,
        log_evidence_all: log_all,
        log_evidence: current,
        steps,
    })
}

/// The selection as a [`Report`]: `candidates`, `kept`, `curves`, `curves_null`,
/// `curves_assigned`, `log_evidence`, `log_evidence_all`, per kept candidate
/// `kept_<i>.kind`/`.curves`/`.support`, per removal step `step_<i>.candidate`/`.log10_k`/
/// `.removed`, and per curve `curve_<c>.assignment` (−1 for T_null) and `.log_likelihood`.
pub fn model_report(s: &SelectedModel) -> Report {
    let mut r = Report::new();
    r.set("candidates", s.candidates.len());
    r.set("kept", s.kept.len());
    r.set("curves", s.assignment.len());
    let null = s.assignment.iter().filter(|a| a.is_none()).count();
    r.set("curves_null", null);
    r.set("curves_assigned", s.assignment.len() - null);
    r.set("log_evidence", s.log_evidence);
    r.set("log_evidence_all", s.log_evidence_all);
    r.set("log_null", s.log_null);
    for (i, &j) in s.kept.iter().enumerate() {
        let c = &s.candidates[j as usize];
        let p = format!("kept_{i}");
        let kind = c.generator.as_ref().map_or("screw", |g| g.kind());
        r.set(format!("{p}.kind"), kind);
        r.set(format!("{p}.candidate"), j as usize);
        r.set(format!("{p}.support"), c.support);
        let n = s.assignment.iter().filter(|a| **a == Some(j)).count();
        r.set(format!("{p}.curves"), n);
        if let Some(Generator::Translation { steps }) = &c.generator {
            r.set(format!("{p}.step"), norm(steps[0]));
        }
        if let Some(Generator::Rotation { angle_deg, .. }) = &c.generator {
            r.set(format!("{p}.angle_deg"), *angle_deg);
        }
    }
    for (i, st) in s.steps.iter().enumerate() {
        let p = format!("step_{i}");
        r.set(format!("{p}.candidate"), st.candidate as usize);
        r.set(format!("{p}.log10_k"), st.log10_k);
        r.set(
            format!("{p}.removed"),
            if st.removed { "yes" } else { "no" },
        );
    }
    for (c, a) in s.assignment.iter().enumerate() {
        let p = format!("curve_{c}");
        r.set(format!("{p}.assignment"), a.map_or(-1.0, |j| j as f64));
        r.set(format!("{p}.log_likelihood"), s.log_likelihood[c]);
    }
    r
}

/// The `selection.model` node.
pub struct ModelNode;

impl NodeKind for ModelNode {
    type Params = ModelParams;
    const KIND: &'static str = "selection.model";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Bayesian model selection of reoccurrence transformations \
        (thesis §4.2.2, eq. 4.1, heuristic §4.2.2.1): the likelihood of each curve under a \
        candidate (an orbit or a cluster) is the Feature BLAST affinity of its inverse-\
        transformed points against the curve of their nearest neighbour; T_null has l0·e⁻²; \
        uniform prior, log space; the least supported candidate is removed while the Bayes \
        ratio K ≤ 10. Outputs the kept candidates, each curve's assignment and \
        log-likelihood, the Bayes ratios, and a Report.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "the noisy feature curves"),
            Port::of::<TransformClusters>("clusters", "clusters from symmetry.cluster"),
            Port::optional::<Orbits>(
                "orbits",
                "orbits from symmetry.orbits: each orbit is one candidate (else each cluster)",
            ),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<SelectedModel>("model", "kept candidates, assignments, likelihoods"),
            Port::of::<Report>("report", "counts, evidences, Bayes ratios, assignments"),
        ]
    }
    fn run(params: &ModelParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let network = inputs.get::<FeatureCurveNetwork>("network")?;
        let clusters = inputs.get::<TransformClusters>("clusters")?;
        let orbits = inputs.opt::<Orbits>("orbits")?;
        ctx.check_cancelled()?;
        let out = select_model(network, clusters, orbits, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new()
            .with("report", model_report(&out))
            .with("model", out))
    }
}
