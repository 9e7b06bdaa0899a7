//! `symmetry.blast`: partial feature curve matching by Feature BLAST and local transformation
//! space voting (thesis §3.2.2, Algorithm 3.1; background §2.6.2 after Mitra, Guibas & Pauly
//! 2006). For a pair of curves c0, c1 every pair of sample points (p0, p1) grows a match by
//! hysteresis: segments of length l0 starting at p0 and p1 are aligned (p0 moved onto p1, best
//! rotation by Kabsch); if their mean distance is below t_low the segments grow by Δl while the
//! distance stays below t_high. The affinity l·exp(−d / (0.5 t_high)) of each grown match votes
//! for its rigid transformation in a 7-D space (translation, unit quaternion with q ≡ −q) binned
//! at 2× the mean edge length and 1.5°. The maxima of the votes are the best transformations of
//! the curve pair; each one is refined by ICP of the matched part of c0 onto the polyline c1.
//!
//! Choices beyond the thesis, documented here:
//! - Only curves with strong evidence take part (§3.2.2): longer than l0, or with sharpness w_κ
//!   (§4.1) above 0.5 κ_avg, κ_avg the length-weighted mean strength along all curves.
//! - Curves are resampled at one mean edge length, so segment points correspond by index.
//! - Instead of all point pairs of all curve pairs, candidate point pairs come from an R-tree of
//!   rigid-invariant chord signatures of the short segment starting at each sample (both
//!   directions, since two copies of a curve may be traced in opposite directions): a pair is
//!   only tried when its signatures are close. Cost is then linear in the number of curve
//!   samples times the number of similar segments, never quadratic in surface points.
//! - Votes from (nearly) straight segments are dropped: a straight segment does not fix the
//!   spin about itself, so its rotation is arbitrary.
//! - Reflections: the network is also matched against its mirror image M (the plane x = centre
//!   of the bounding box of the curves). A match with `mirrored = true` maps M(c0) onto c1 by the
//!   rigid `transform`, i.e. c0 onto c1 by the improper isometry `transform ∘ M`.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::vec3::{add, dist, dot, norm, scale, sub, V3};
use crestflow_geom::{CurveLabel, FeatureCurveNetwork, SurfacePoint, TriMesh};
use serde::{Deserialize, Serialize};

use crate::transform::{fit_rigid, kabsch, mean_transform, quat_angle_deg, RigidTransform};

/// Parameters of `symmetry.blast`. Lengths are multiples of the mesh's mean edge length h.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BlastParams {
    /// Minimal match length l0 (thesis: 20–30 h). In [2, 1000]. Default 25.
    pub l0: f64,
    /// Lower hysteresis threshold on the mean distance: a match starts below it (thesis: 1 h).
    /// In (0, 100]. Default 1.
    pub t_low: f64,
    /// Upper hysteresis threshold: a match grows while below it (thesis: 2 t_low).
    /// In (0, 200], at least `t_low`. Default 2.
    pub t_high: f64,
    /// Matches stop growing at this length (bounds the cost on long closed curves, where
    /// every point pair of two circles would otherwise grow all the way round). In [2, 1e6],
    /// at least `l0`. Default 100.
    pub max_length: f64,
    /// Growth step Δl (thesis: 5 h). In [0.5, 1000]. Default 5.
    pub delta_l: f64,
    /// Curves with sharpness w_κ above this multiple of κ_avg count as strong even when shorter
    /// than l0 (thesis: 0.5). In [0, 100]. Default 0.5.
    pub strength_factor: f64,
    /// Resampling step of the curves. In [0.1, 10]. Default 1.
    pub sample_step: f64,
    /// Length of the segment whose chord signature preselects point pairs; also the shortest
    /// match tried. In [2, 1000], at most `l0`. Default 8.
    pub signature_length: f64,
    /// Point pairs are tried when their chord signatures differ by at most this (Euclidean, in
    /// h). In (0, 100]. Default 3.
    pub signature_radius: f64,
    /// At most this many partners per sample point (the closest signatures). In [1, 100000].
    /// Default 400.
    pub max_candidates: u32,
    /// Translation bin size of the voting space (thesis: 2 h). In (0, 100]. Default 2.
    pub bin_translation: f64,
    /// Rotation bin size in degrees (thesis: 1.5°). In (0, 45]. Default 1.5.
    pub bin_angle_deg: f64,
    /// Votes of segments whose spread about their best line is below this (RMS, in h) are
    /// dropped: their rotation is not determined. In [0, 100]. Default 0.5.
    pub min_bend: f64,
    /// Keep further vote maxima of a curve pair while they have at least this fraction of the
    /// best one's weight. In (0, 1]. Default 0.5.
    pub mode_fraction: f64,
    /// At most this many transformations per curve pair. In [1, 64]. Default 6.
    pub max_modes: u32,
    /// At most this many ICP iterations refining each transformation. In [0, 1000].
    /// Default 50.
    pub icp_iterations: u32,
    /// Also match against the mirrored network to find reflections. Default true.
    pub mirror: bool,
    /// Only match curves of the same label (ridge with ridge, ravine with ravine). Default true.
    pub same_label: bool,
    /// A grown match is dropped when the surface normals along it disagree, after the
    /// transformation, by more than this mean angle (degrees; needs the mesh). In [0, 180].
    /// Default 45.
    pub max_normal_angle_deg: f64,
}

impl Default for BlastParams {
    fn default() -> Self {
        BlastParams {
            l0: 25.0,
            t_low: 1.0,
            t_high: 2.0,
            max_length: 100.0,
            delta_l: 5.0,
            strength_factor: 0.5,
            sample_step: 1.0,
            signature_length: 8.0,
            signature_radius: 3.0,
            max_candidates: 400,
            bin_translation: 2.0,
            bin_angle_deg: 1.5,
            min_bend: 0.5,
            mode_fraction: 0.5,
            max_modes: 6,
            icp_iterations: 50,
            mirror: true,
            same_label: true,
            max_normal_angle_deg: 45.0,
        }
    }
}

impl Validate for BlastParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "l0", self.l0, 2.0, 1000.0);
        check_range(&mut v, "t_low", self.t_low, 1e-6, 100.0);
        check_range(&mut v, "t_high", self.t_high, 1e-6, 200.0);
        check_range(&mut v, "max_length", self.max_length, 2.0, 1e6);
        if self.max_length < self.l0 {
            v.push(ParamIssue::new(
                "max_length",
                format!("{} is below l0 = {}", self.max_length, self.l0),
            ));
        }
        check_range(&mut v, "delta_l", self.delta_l, 0.5, 1000.0);
        check_range(&mut v, "strength_factor", self.strength_factor, 0.0, 100.0);
        check_range(&mut v, "sample_step", self.sample_step, 0.1, 10.0);
        check_range(
            &mut v,
            "signature_length",
            self.signature_length,
            2.0,
            1000.0,
        );
        check_range(
            &mut v,
            "signature_radius",
            self.signature_radius,
            1e-6,
            100.0,
        );
        check_range(&mut v, "max_candidates", self.max_candidates, 1, 100_000);
        check_range(&mut v, "bin_translation", self.bin_translation, 1e-6, 100.0);
        check_range(&mut v, "bin_angle_deg", self.bin_angle_deg, 1e-6, 45.0);
        check_range(&mut v, "min_bend", self.min_bend, 0.0, 100.0);
        check_range(&mut v, "mode_fraction", self.mode_fraction, 1e-6, 1.0);
        check_range(&mut v, "max_modes", self.max_modes, 1, 64);
        check_range(&mut v, "icp_iterations", self.icp_iterations, 0, 1000);
        check_range(
            &mut v,
            "max_normal_angle_deg",
            self.max_normal_angle_deg,
            0.0,
            180.0,
        );
        if self.t_high < self.t_low {
            v.push(ParamIssue::new(
                "t_high",
                format!("{} is below t_low = {}", self.t_high, self.t_low),
            ));
        }
        if self.signature_length > self.l0 {
            v.push(ParamIssue::new(
                "signature_length",
                format!("{} is above l0 = {}", self.signature_length, self.l0),
            ));
        }
        v
    }
}

/// A matched part of two curves and its rigid transformation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveMatch {
    /// Curve indices in the network.
    pub curve_a: u32,
    pub curve_b: u32,
    /// `transform` maps the mirror image M(c_a) onto c_b (see [`CurveMatches::mirror_x`]).
    pub mirrored: bool,
    /// Maps (the mirrored, if `mirrored`) curve a onto curve b.
    pub transform: RigidTransform,
    /// Summed Feature BLAST affinities of the votes of this maximum.
    pub votes: f64,
    /// Length of curve a matched within t_high after refinement (mesh units).
    pub matched_length: f64,
    /// Mean distance of the matched points after refinement (mesh units).
    pub mean_distance: f64,
    /// l·exp(−d / (0.5 t_high)) of the refined match (mesh units of length).
    pub affinity: f64,
    /// Point correspondences: a point of curve a (not mirrored) and its partner on curve b.
    pub correspondences: Vec<[V3; 2]>,
}

/// The output of `symmetry.blast`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CurveMatches {
    /// The length unit h: the mesh's mean edge length.
    pub unit: f64,
    /// Mirror plane x = `mirror_x` used for reflections: M(p) = (2 mirror_x − p.x, p.y, p.z).
    pub mirror_x: f64,
    /// κ_avg: length-weighted mean strength along all curves.
    pub kappa_avg: f64,
    /// The curves with strong evidence that took part.
    pub strong_curves: Vec<u32>,
    /// Curve samples used and point pairs tried (for benchmarks).
    pub samples: usize,
    pub point_pairs: usize,
    pub matches: Vec<CurveMatch>,
}

impl CurveMatches {
    /// The mirror M as a function.
    pub fn mirror(&self, p: V3) -> V3 {
        crate::transform::mirror_in_x(self.mirror_x, p)
    }
}

/// Why `symmetry.blast` cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BlastError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("the mesh has no edge of positive finite length (mean edge length {0})")]
    NoScale(f64),
    #[error("curve {curve} references network vertex {index} but the network has {n} vertices")]
    VertexIndex { curve: usize, index: u32, n: usize },
    #[error("network vertex {vertex} has a non-finite position {position:?}")]
    NonFinite { vertex: usize, position: V3 },
}

/// A curve resampled at a fixed arc-length step.
struct Sampled {
    curve: u32,
    pts: Vec<V3>,
    /// Surface normals at the samples (when a mesh is given).
    normals: Option<Vec<V3>>,
    closed: bool,
    label: CurveLabel,
}

impl Sampled {
    /// Steps available from sample `i` in direction `dir` (±1) without leaving the curve or
    /// wrapping onto itself.
    fn avail(&self, i: usize, dir: i64) -> usize {
        let n = self.pts.len();
        if self.closed {
            n.saturating_sub(1)
        } else if dir > 0 {
            n - 1 - i
        } else {
            i
        }
    }
    fn at(&self, i: usize, k: usize, dir: i64) -> V3 {
        let n = self.pts.len() as i64;
        let idx = (i as i64 + dir * k as i64).rem_euclid(n);
        self.pts[idx as usize]
    }
}

/// Arc-length samples of a polyline at `step` (a closed one at the nearest step that divides
/// its length), as (segment, parameter) pairs over the polyline's vertices (a closed polyline's
/// last segment runs back to vertex 0).
fn resample(points: &[V3], closed: bool, step: f64) -> Vec<(usize, f64)> {
    let n = points.len();
    let nseg = if closed && n > 2 {
        n
    } else {
        n.saturating_sub(1)
    };
    let mut cum = vec![0.0];
    for k in 0..nseg {
        let last = cum[cum.len() - 1];
        cum.push(last + dist(points[k], points[(k + 1) % n]));
    }
    let total = cum[cum.len() - 1];
    if nseg == 0 || total <= 0.0 {
        return if n > 0 { vec![(0, 0.0)] } else { Vec::new() };
    }
    let (count, h) = if closed {
        let c = (total / step).round().max(3.0) as usize;
        (c, total / c as f64)
    } else {
        ((total / step).floor() as usize + 1, step)
    };
    let mut out = Vec::with_capacity(count);
    let mut seg = 0;
    for k in 0..count {
        let s = k as f64 * h;
        while seg + 1 < nseg && cum[seg + 1] < s {
            seg += 1;
        }
        let len = cum[seg + 1] - cum[seg];
        let t = if len > 0.0 {
            ((s - cum[seg]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push((seg, t));
    }
    out
}

/// Values at the samples of [`resample`] by linear interpolation of per-vertex values.
fn interpolate(values: &[V3], samples: &[(usize, f64)]) -> Vec<V3> {
    let n = values.len();
    samples
        .iter()
        .map(|&(seg, t)| {
            let a = values[seg];
            let b = values[(seg + 1) % n];
            add(a, scale(sub(b, a), t))
        })
        .collect()
}

/// The surface normal at a network vertex from the mesh's vertex normals.
fn normal_at(loc: &SurfacePoint, mesh: &TriMesh, vn: &[V3]) -> Option<V3> {
    let get = |v: u32| vn.get(v as usize).copied();
    let n = match *loc {
        SurfacePoint::Vertex(v) => get(v)?,
        SurfacePoint::Edge { a, b, t } => add(scale(get(a)?, 1.0 - t), scale(get(b)?, t)),
        SurfacePoint::Face { f, bary } => {
            let tri = mesh.triangles.get(f as usize)?;
            let mut acc = [0.0; 3];
            for k in 0..3 {
                acc = add(acc, scale(get(tri[k])?, bary[k]));
            }
            acc
        }
        SurfacePoint::Free => return None,
    };
    Some(n)
}

/// The chord signature of the segment of `m` steps starting at sample `i` in direction `dir`.
fn signature(s: &Sampled, i: usize, dir: i64, m: usize) -> [f64; 6] {
    let p = |k: usize| s.at(i, k, dir);
    let (q1, q2, q3) = (m / 4, m / 2, (3 * m) / 4);
    [
        dist(p(0), p(q1)),
        dist(p(0), p(q2)),
        dist(p(0), p(q3)),
        dist(p(0), p(m)),
        dist(p(q1), p(q3)),
        dist(p(q2), p(m)),
    ]
}

/// A candidate point pair of a curve pair: sample on a (forward), sample on b, b's direction.
type PointPair = (u32, u32, i8);

/// One grown point match: its transformation and affinity.
struct Vote {
    t: RigidTransform,
    w: f64,
    i: usize,
    m: usize,
}

/// All lengths of the parameters in mesh units.
struct Scaled {
    step: f64,
    m0: usize,
    dm: usize,
    msig: usize,
    mmax: usize,
    t_low: f64,
    t_high: f64,
    bin_t: f64,
    bin_q: f64,
    bin_angle: f64,
    min_bend2: f64,
}

/// Finds partial matches between the strong curves of `network`; the unit is `mesh`'s mean edge
/// length.
pub fn blast(
    network: &FeatureCurveNetwork,
    mesh: &TriMesh,
    params: &BlastParams,
    par: Par,
) -> Result<CurveMatches, BlastError> {
    blast_impl(network, mesh.mean_edge_length(), Some(mesh), params, par)
}

/// [`blast`] with an explicit length unit h, for networks without a mesh (no surface normals:
/// matches are checked on the curves' shapes only).
pub fn blast_with_unit(
    network: &FeatureCurveNetwork,
    unit: f64,
    params: &BlastParams,
    par: Par,
) -> Result<CurveMatches, BlastError> {
    blast_impl(network, unit, None, params, par)
}

fn blast_impl(
    network: &FeatureCurveNetwork,
    unit: f64,
    mesh: Option<&TriMesh>,
    params: &BlastParams,
    par: Par,
) -> Result<CurveMatches, BlastError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(BlastError::Params(text.join("; ")));
    }
    if !(unit.is_finite() && unit > 0.0) {
        return Err(BlastError::NoScale(unit));
    }
    let nv = network.vertices.len();
    for (c, curve) in network.curves.iter().enumerate() {
        if let Some(&bad) = curve.vertices.iter().find(|&&v| v as usize >= nv) {
            return Err(BlastError::VertexIndex {
                curve: c,
                index: bad,
                n: nv,
            });
        }
    }
    if let Some((v, fv)) = network
        .vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !v.position.iter().all(|x| x.is_finite()))
    {
        return Err(BlastError::NonFinite {
            vertex: v,
            position: fv.position,
        });
    }
    let h = unit;
    let step = params.sample_step * h;
    let sc = Scaled {
        step,
        m0: ((params.l0 * h) / step).round().max(2.0) as usize,
        dm: ((params.delta_l * h) / step).round().max(1.0) as usize,
        msig: ((params.signature_length * h) / step).round().max(2.0) as usize,
        mmax: ((params.max_length * h) / step).round().max(2.0) as usize,
        t_low: params.t_low * h,
        t_high: params.t_high * h,
        bin_t: params.bin_translation * h,
        // |q1 − q2| ≈ δ/2 for rotations δ apart.
        bin_q: 0.5 * params.bin_angle_deg.to_radians(),
        bin_angle: params.bin_angle_deg,
        min_bend2: (params.min_bend * h).powi(2),
    };

    // Strong curves (§3.2.2): longer than l0 or sharper than strength_factor · κ_avg.
    let lengths: Vec<f64> = (0..network.curves.len())
        .map(|c| network.curve_length(c))
        .collect();
    let strengths: Vec<f64> = (0..network.curves.len())
        .map(|c| network.curve_strength(c))
        .collect();
    let total_len: f64 = lengths.iter().sum();
    let kappa_avg = if total_len > 0.0 {
        lengths
            .iter()
            .zip(&strengths)
            .map(|(l, s)| l * s)
            .sum::<f64>()
            / total_len
    } else {
        0.0
    };
    let min_len = sc.msig as f64 * step;
    let vertex_normals = mesh.map(|m| (m, m.vertex_normals()));
    let mut strong = Vec::new();
    let mut sampled = Vec::new();
    for c in 0..network.curves.len() {
        let evidence =
            lengths[c] >= params.l0 * h || strengths[c] > params.strength_factor * kappa_avg;
        if !evidence || lengths[c] < min_len {
            continue;
        }
        let raw = network.curve_points(c);
        let at = resample(&raw, network.curves[c].closed, step);
        if at.len() <= sc.msig {
            continue;
        }
        let normals = vertex_normals.as_ref().and_then(|(m, vn)| {
            let per_vertex: Option<Vec<V3>> = network.curves[c]
                .vertices
                .iter()
                .map(|&v| normal_at(&network.vertices[v as usize].location, m, vn))
                .collect();
            per_vertex.map(|nv| {
                interpolate(&nv, &at)
                    .into_iter()
                    .map(|n| {
                        let l = norm(n);
                        if l > 0.0 {
                            scale(n, 1.0 / l)
                        } else {
                            n
                        }
                    })
                    .collect()
            })
        });
        strong.push(c as u32);
        sampled.push(Sampled {
            curve: c as u32,
            pts: interpolate(&raw, &at),
            normals,
            closed: network.curves[c].closed,
            label: network.curves[c].label,
        });
    }
    // Mirror plane through the centre of the curves' bounding box.
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for s in &sampled {
        for p in &s.pts {
            lo = lo.min(p[0]);
            hi = hi.max(p[0]);
        }
    }
    let mirror_x = if lo.is_finite() { 0.5 * (lo + hi) } else { 0.0 };
    let mirrored: Vec<Vec<V3>> = sampled
        .iter()
        .map(|s| {
            s.pts
                .iter()
                .map(|p| crate::transform::mirror_in_x(mirror_x, *p))
                .collect()
        })
        .collect();
    let mirrored_normals: Vec<Option<Vec<V3>>> = sampled
        .iter()
        .map(|s| {
            s.normals
                .as_ref()
                .map(|ns| ns.iter().map(|n| [-n[0], n[1], n[2]]).collect())
        })
        .collect();
    // Nearest-sample lookup on each curve for the ICP refinement.
    let sample_trees: Vec<rstar::RTree<rstar::primitives::GeomWithData<V3, u32>>> = sampled
        .iter()
        .map(|s| {
            rstar::RTree::bulk_load(
                s.pts
                    .iter()
                    .enumerate()
                    .map(|(k, p)| rstar::primitives::GeomWithData::new(*p, k as u32))
                    .collect(),
            )
        })
        .collect();

    // Signatures of every (curve, sample, direction) with room for a signature segment.
    let mut entries: Vec<(u32, u32, i8)> = Vec::new();
    let mut sigs: Vec<[f64; 6]> = Vec::new();
    for (si, s) in sampled.iter().enumerate() {
        for i in 0..s.pts.len() {
            for dir in [1i64, -1] {
                if s.avail(i, dir) >= sc.msig {
                    entries.push((si as u32, i as u32, dir as i8));
                    sigs.push(signature(s, i, dir, sc.msig));
                }
            }
        }
    }
    let tree = rstar::RTree::bulk_load(
        sigs.iter()
            .enumerate()
            .map(|(k, s)| rstar::primitives::GeomWithData::new(*s, k as u32))
            .collect(),
    );
    let radius = params.signature_radius * h;
    let cap = params.max_candidates as usize;
    // Candidate point pairs from forward entries of curve a to entries of curves b ≥ a.
    let queries: Vec<usize> = (0..entries.len()).filter(|&k| entries[k].2 > 0).collect();
    let found: Vec<Vec<(u32, u32, u32, i8)>> = par.map_collect(queries.len(), |qi| {
        let k = queries[qi];
        let (a, i, _) = entries[k];
        let mut near: Vec<(f64, u32)> = tree
            .locate_within_distance(sigs[k], radius * radius)
            .filter_map(|g| {
                let e = entries[g.data as usize];
                (e.0 >= a).then(|| {
                    let d: f64 = (0..6).map(|x| (g.geom()[x] - sigs[k][x]).powi(2)).sum();
                    (d, g.data)
                })
            })
            .collect();
        near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        near.truncate(cap);
        near.iter()
            .map(|&(_, g)| {
                let e = entries[g as usize];
                (e.0, i, e.1, e.2)
            })
            .collect()
    });
    let mut by_pair: BTreeMap<(u32, u32), Vec<PointPair>> = BTreeMap::new();
    let mut point_pairs = 0;
    for (qi, list) in found.into_iter().enumerate() {
        let a = entries[queries[qi]].0;
        for (b, i, j, dir) in list {
            by_pair.entry((a, b)).or_default().push((i, j, dir));
            point_pairs += 1;
        }
    }
    let mut jobs: Vec<((u32, u32), bool)> = Vec::new();
    for &(a, b) in by_pair.keys() {
        if params.same_label && sampled[a as usize].label != sampled[b as usize].label {
            continue;
        }
        if a != b {
            jobs.push(((a, b), false));
        }
        if params.mirror {
            jobs.push(((a, b), true));
        }
    }
    let results: Vec<Vec<CurveMatch>> = par.map_collect(jobs.len(), |k| {
        let ((a, b), mir) = jobs[k];
        let cands = &by_pair[&(a, b)];
        let sa = &sampled[a as usize];
        let sb = &sampled[b as usize];
        let side = Side {
            pts: if mir { &mirrored[a as usize] } else { &sa.pts },
            normals: if mir {
                mirrored_normals[a as usize].as_deref()
            } else {
                sa.normals.as_deref()
            },
        };
        match_pair(
            sa,
            &side,
            sb,
            &sample_trees[b as usize],
            cands,
            mir,
            &sc,
            params,
        )
    });
    let matches = results.into_iter().flatten().collect();
    Ok(CurveMatches {
        unit: h,
        mirror_x,
        kappa_avg,
        strong_curves: strong,
        samples: sampled.iter().map(|s| s.pts.len()).sum(),
        point_pairs,
        matches,
    })
}

/// Curve a as matched: its sample positions and normals, mirrored or not.
struct Side<'a> {
    pts: &'a [V3],
    normals: Option<&'a [V3]>,
}

/// Mean distance of the segments of `m` steps from (a, i, forward) and (b, j, dir) after
/// moving a's start onto b's start and rotating by the best rotation about it, and that
/// transformation.
fn segment_distance(
    a: &Side,
    b: &Sampled,
    i: usize,
    j: usize,
    dir: i64,
    m: usize,
) -> (f64, RigidTransform) {
    let na = a.pts.len();
    let p0 = a.pts[i];
    let p1 = b.pts[j];
    let mut va = Vec::with_capacity(m + 1);
    let mut vb = Vec::with_capacity(m + 1);
    for k in 0..=m {
        va.push(sub(a.pts[(i + k) % na], p0));
        vb.push(sub(b.at(j, k, dir), p1));
    }
    let (r, _) = kabsch(&va, &vb, None);
    let rt = RigidTransform {
        rotation: r,
        translation: [0.0; 3],
    };
    let d = va
        .iter()
        .zip(&vb)
        .map(|(x, y)| dist(rt.apply(*x), *y))
        .sum::<f64>()
        / va.len() as f64;
    // x ↦ R (x − p0) + p1
    let t = sub(p1, rt.apply(p0));
    (
        d,
        RigidTransform {
            rotation: r,
            translation: t,
        },
    )
}

/// Spread of a's segment of `m` steps from sample `i` about its best line (second singular
/// value of its covariance, per point).
fn segment_spread(a: &Side, i: usize, m: usize) -> f64 {
    let na = a.pts.len();
    let va: Vec<V3> = (0..=m).map(|k| a.pts[(i + k) % na]).collect();
    let c: V3 = scale(
        va.iter().fold([0.0; 3], |s, v| add(s, *v)),
        1.0 / va.len() as f64,
    );
    let centred: Vec<V3> = va.iter().map(|v| sub(*v, c)).collect();
    let (_, sv) = kabsch(&centred, &centred, None);
    sv[1] / va.len() as f64
}

/// Mean cosine between the rotated normals of a's segment and b's normals (1 without normals).
fn normal_agreement(
    a: &Side,
    b: &Sampled,
    t: &RigidTransform,
    i: usize,
    j: usize,
    dir: i64,
    m: usize,
) -> f64 {
    let (Some(na), Some(nb)) = (a.normals, b.normals.as_ref()) else {
        return 1.0;
    };
    let n = nb.len() as i64;
    let mut sum = 0.0;
    for k in 0..=m {
        let x = t.rotate(na[(i + k) % na.len()]);
        let jb = (j as i64 + dir * k as i64).rem_euclid(n) as usize;
        sum += dot(x, nb[jb]);
    }
    sum / (m + 1) as f64
}

/// Feature BLAST (Algorithm 3.1) for every candidate point pair of one curve pair, voting,
/// maxima and refinement.
#[allow(clippy::too_many_arguments)]
fn match_pair(
    sa: &Sampled,
    a: &Side,
    b: &Sampled,
    b_tree: &rstar::RTree<rstar::primitives::GeomWithData<V3, u32>>,
    cands: &[PointPair],
    mirrored: bool,
    sc: &Scaled,
    params: &BlastParams,
) -> Vec<CurveMatch> {
    let mut votes: Vec<Vote> = Vec::new();
    let min_cos = params.max_normal_angle_deg.to_radians().cos();
    let mut spread_memo: Vec<(usize, f64)> = vec![(usize::MAX, 0.0); a.pts.len()];
    for &(i, j, dir) in cands {
        let (i, j, dir) = (i as usize, j as usize, dir as i64);
        let avail = sa.avail(i, 1).min(b.avail(j, dir)).min(sc.mmax);
        let mut m = sc.m0.min(avail);
        if m < sc.msig {
            continue;
        }
        // The spread depends on a's segment only: computed once per (sample, length).
        let spread = if spread_memo[i].0 == m {
            spread_memo[i].1
        } else {
            let s = segment_spread(a, i, m);
            spread_memo[i] = (m, s);
            s
        };
        if spread < sc.min_bend2 {
            continue;
        }
        let (mut d, mut t) = segment_distance(a, b, i, j, dir, m);
        if d >= sc.t_low {
            continue;
        }
        // Grow by Δl while the distance stays below t_high; keep the last length that did.
        while m < avail {
            let m2 = (m + sc.dm).min(avail);
            let (d2, t2) = segment_distance(a, b, i, j, dir, m2);
            if d2 >= sc.t_high {
                break;
            }
            m = m2;
            d = d2;
            t = t2;
        }
        // The surfaces must agree too: a curve in a plane matches its own reflection in that
        // plane, but the surface around it does not.
        if normal_agreement(a, b, &t, i, j, dir, m) < min_cos {
            continue;
        }
        let l = m as f64 * sc.step;
        votes.push(Vote {
            t,
            w: l * (-d / (0.5 * sc.t_high)).exp(),
            i,
            m,
        });
    }
    if votes.is_empty() {
        return Vec::new();
    }
    // 7-D voting: translation and canonical quaternion (w ≥ 0) binned.
    let mut bins: HashMap<[i64; 7], (f64, Vec<usize>)> = HashMap::new();
    for (k, v) in votes.iter().enumerate() {
        let q = v.t.quaternion();
        let tr = v.t.translation;
        let key = [
            (tr[0] / sc.bin_t).floor() as i64,
            (tr[1] / sc.bin_t).floor() as i64,
            (tr[2] / sc.bin_t).floor() as i64,
            (q[0] / sc.bin_q).floor() as i64,
            (q[1] / sc.bin_q).floor() as i64,
            (q[2] / sc.bin_q).floor() as i64,
            (q[3] / sc.bin_q).floor() as i64,
        ];
        let e = bins.entry(key).or_insert((0.0, Vec::new()));
        e.0 += v.w;
        e.1.push(k);
    }
    let mut order: Vec<([i64; 7], f64)> = bins.iter().map(|(k, v)| (*k, v.0)).collect();
    order.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
    let mut modes: Vec<(RigidTransform, f64, Vec<usize>)> = Vec::new();
    let best = order[0].1;
    for (key, w) in order {
        if w < params.mode_fraction * best || modes.len() >= params.max_modes as usize {
            break;
        }
        let members: Vec<(RigidTransform, f64)> = bins[&key]
            .1
            .iter()
            .map(|&k| (votes[k].t, votes[k].w))
            .collect();
        let centre = mean_transform(&members);
        let near = |t: &RigidTransform, f: f64| {
            dist(t.translation, centre.translation) <= f * sc.bin_t
                && quat_angle_deg(t.quaternion(), centre.quaternion()) <= f * sc.bin_angle
        };
        if modes.iter().any(|(t, _, _)| near(t, 2.0)) {
            continue;
        }
        // Votes near the bin's centre, including those that fell into neighbouring bins.
        let inliers: Vec<usize> = (0..votes.len())
            .filter(|&k| near(&votes[k].t, 1.0))
            .collect();
        let wsum = inliers.iter().map(|&k| votes[k].w).sum();
        let refined = mean_transform(
            &inliers
                .iter()
                .map(|&k| (votes[k].t, votes[k].w))
                .collect::<Vec<_>>(),
        );
        modes.push((refined, wsum, inliers));
    }
    let mut out = Vec::new();
    for (t0, wsum, inliers) in modes {
        let fit = Fit {
            sa,
            a,
            b,
            b_tree,
            sc,
        };
        if let Some(m) = fit.refine(&votes, &inliers, t0, wsum, mirrored, params) {
            out.push(m);
        }
    }
    out
}

/// What ICP refinement of one curve pair needs.
struct Fit<'a> {
    sa: &'a Sampled,
    a: &'a Side<'a>,
    b: &'a Sampled,
    b_tree: &'a rstar::RTree<rstar::primitives::GeomWithData<V3, u32>>,
    sc: &'a Scaled,
}

impl Fit<'_> {
    /// The closest point to `p` on polyline b (on a segment next to b's nearest sample), its
    /// distance and the unit tangent there.
    fn closest(&self, p: V3) -> Option<(V3, f64, V3)> {
        let near = self.b_tree.nearest_neighbor(p)?;
        let pts = &self.b.pts;
        let n = pts.len();
        let u = near.data as usize;
        let mut best = (pts[u], f64::INFINITY, [0.0; 3]);
        let mut segs = Vec::with_capacity(2);
        if u + 1 < n || self.b.closed {
            segs.push((u, (u + 1) % n));
        }
        if u > 0 || self.b.closed {
            segs.push(((u + n - 1) % n, u));
        }
        for (x, y) in segs {
            let (x, y) = (pts[x], pts[y]);
            let e = sub(y, x);
            let ee = dot(e, e);
            let tt = if ee > 0.0 {
                (dot(sub(p, x), e) / ee).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let q = add(x, scale(e, tt));
            let d = dist(q, p);
            if d < best.1 && ee > 0.0 {
                best = (q, d, scale(e, 1.0 / ee.sqrt()));
            }
        }
        if best.1.is_infinite() {
            return Some((pts[u], dist(pts[u], p), [0.0; 3]));
        }
        Some(best)
    }

    /// Refines a transformation by ICP of the samples of a covered by the inlier votes onto
    /// the polyline b (point-to-point ICP converges slowly along the curves, hence the many
    /// iterations; it stops once the transformation no longer moves).
    fn refine(
        &self,
        votes: &[Vote],
        inliers: &[usize],
        t0: RigidTransform,
        wsum: f64,
        mirrored: bool,
        params: &BlastParams,
    ) -> Option<CurveMatch> {
        let na = self.a.pts.len();
        let mut covered = BTreeSet::new();
        for &k in inliers {
            let v = &votes[k];
            for s in 0..=v.m {
                covered.insert((v.i + s) % na);
            }
        }
        let src: Vec<usize> = covered.into_iter().collect();
        let mut t = t0;
        let mut pairs: Vec<(usize, V3, f64, V3)> = Vec::new();
        // A few point-to-point steps to get close, then Gauss–Newton point-to-line steps, which
        // also converge along the curve where point-to-point ICP crawls.
        let p2p = 5.min(params.icp_iterations);
        for it in 0..=params.icp_iterations {
            pairs.clear();
            for &u in &src {
                let p = t.apply(self.a.pts[u]);
                if let Some((q, d, tan)) = self.closest(p) {
                    // Points beyond an end of b are not matched (they would pull the
                    // transformation along the curve).
                    let at_end =
                        !self.b.closed && (q == self.b.pts[0] || Some(&q) == self.b.pts.last());
                    if d <= self.sc.t_high && !at_end {
                        pairs.push((u, q, d, tan));
                    }
                }
            }
            if pairs.len() < 3 || it == params.icp_iterations {
                break;
            }
            let t2 = if it < p2p {
                let xa: Vec<V3> = pairs.iter().map(|&(u, ..)| self.a.pts[u]).collect();
                let xb: Vec<V3> = pairs.iter().map(|&(_, q, ..)| q).collect();
                fit_rigid(&xa, &xb, None)
            } else {
                match point_to_line_step(&t, self.a.pts, &pairs) {
                    Some(x) => x,
                    None => break,
                }
            };
            let moved = dist(t2.translation, t.translation)
                + norm(sub(t2.rotate([1.0, 0.0, 0.0]), t.rotate([1.0, 0.0, 0.0]))) * self.sc.step;
            t = t2;
            if it >= p2p && moved < 1e-10 * self.sc.step {
                break;
            }
        }
        if pairs.len() < 3 {
            return None;
        }
        let mean_d = pairs.iter().map(|p| p.2).sum::<f64>() / pairs.len() as f64;
        if !mean_d.is_finite() {
            return None;
        }
        let matched = pairs.len() as f64 * self.sc.step;
        Some(CurveMatch {
            curve_a: self.sa.curve,
            curve_b: self.b.curve,
            mirrored,
            transform: t,
            votes: wsum,
            matched_length: matched,
            mean_distance: mean_d,
            affinity: matched * (-mean_d / (0.5 * self.sc.t_high)).exp(),
            correspondences: pairs
                .iter()
                .map(|&(u, q, ..)| [self.sa.pts[u], q])
                .collect(),
        })
    }
}

/// One Gauss–Newton step of point-to-line ICP: minimises Σ |P_k (p_k + ω × p_k + δ − q_k)|²
/// with P_k the projection across the tangent of b at q_k, then applies the small motion
/// (ω, δ) to `t`. A tiny damping keeps the slide along straight curves from blowing up.
fn point_to_line_step(
    t: &RigidTransform,
    a_pts: &[V3],
    pairs: &[(usize, V3, f64, V3)],
) -> Option<RigidTransform> {
    let mut jtj = nalgebra::Matrix6::<f64>::zeros();
    let mut jtr = nalgebra::Vector6::<f64>::zeros();
    for &(u, q, _, tan) in pairs {
        let p = t.apply(a_pts[u]);
        // P = I − τ τᵀ
        let mut proj = nalgebra::Matrix3::<f64>::identity();
        for r in 0..3 {
            for c in 0..3 {
                proj[(r, c)] -= tan[r] * tan[c];
            }
        }
        // d(ω × p)/dω = −[p]×
        let px = nalgebra::Matrix3::new(0.0, p[2], -p[1], -p[2], 0.0, p[0], p[1], -p[0], 0.0);
        let mut j = nalgebra::Matrix3x6::<f64>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&(proj * px));
        j.fixed_view_mut::<3, 3>(0, 3).copy_from(&proj);
        let r = proj * nalgebra::Vector3::new(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
        jtj += j.transpose() * j;
        jtr += j.transpose() * r;
    }
    let damp = 1e-9 * jtj.trace().max(1e-300);
    for k in 0..6 {
        jtj[(k, k)] += damp;
    }
    let x = jtj.cholesky()?.solve(&(-jtr));
    if !x.iter().all(|v| v.is_finite()) {
        return None;
    }
    let w = [x[0], x[1], x[2]];
    let angle = norm(w);
    let rot = if angle > 0.0 {
        RigidTransform::rotation_about(w, angle, [0.0; 3])
    } else {
        RigidTransform::identity()
    };
    let step = RigidTransform {
        rotation: rot.rotation,
        translation: [x[3], x[4], x[5]],
    };
    Some(step.compose(t))
}

/// The `symmetry.blast` node.
pub struct BlastNode;

impl NodeKind for BlastNode {
    type Params = BlastParams;
    const KIND: &'static str = "symmetry.blast";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Feature BLAST partial curve matching with local transformation \
        space voting (thesis §3.2.2, Algorithm 3.1; after Mitra, Guibas & Pauly 2006): point \
        pairs on strong curves grow matches by hysteresis thresholding, their affinities \
        l·exp(−d/(0.5 t_high)) vote in a binned 7-D space of rigid transformations, and the \
        maxima (refined by ICP) are the transformations between curve pairs. Reflections are \
        found by matching against the mirrored network.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "feature curves to match"),
            Port::of::<TriMesh>("mesh", "the surface; its mean edge length is the unit"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<CurveMatches>(
            "matches",
            "per curve pair: best transformations, affinities, point correspondences",
        )]
    }
    fn run(params: &BlastParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let network = inputs.get::<FeatureCurveNetwork>("network")?;
        let mesh = inputs.get::<TriMesh>("mesh")?;
        ctx.check_cancelled()?;
        let out = blast(network, mesh, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new().with("matches", out))
    }
}
