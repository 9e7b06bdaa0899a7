//! `selection.complete`: feature curve co-completion (thesis §4.2.3).
//!
//! 1. Classification noise removal (§4.2.3.1): curves assigned to T_null, and curves assigned
//!    to a candidate none of whose matches lands on another curve of that candidate (no point
//!    of theirs has a reoccurrence), are dropped unless strong: longer than `strong_length` · l0,
//!    or with a sharpness w_κ above `strong_curvature` · κ_avg (κ_avg the length-weighted mean
//!    strength along all curves) and longer than l0.
//! 2. Connected components (§4.2.3.2): the graph whose nodes are the reoccurring curves and
//!    whose edges join a curve to the curves its inverse-transformed points matched under its
//!    assigned candidate (the partners of `selection.model`).
//! 3. Grid cells: each candidate's generator defines cells — a 1-D or 2-D translation grid
//!    (its basis first reduced to the shortest pair spanning the same lattice; coordinates
//!    along the generators with the shear accounted for, as the projection directions ḡ of the
//!    thesis do), a rotation (angle about the axis in steps of the generator angle) or a
//!    reflection (the two sides of the plane). The grid origin is the offset z minimising
//!    Σᵢ binentry(z + i·|g|) over the binned projections of all its curves' points, so that cell
//!    borders cut as few curves as possible. Each curve lies in the cell of its centroid.
//! 4. Consolidation: the curves of a component are moved into cell 0 by the inverse cell map and
//!    consolidated by longest shortest paths (see [`crate::consolidate`]); the consolidated
//!    curves of all components of a candidate form its template.
//! 5. Gaps: cells between observed ones without evidence. A single empty cell between two
//!    observed ones along a generator is a gap that may be filled (`fill_single_gaps`); two or
//!    more neighbouring empty cells split the grid (counted, never filled).
//! 6. Completion: the template is copied into every cell where an occurrence was observed (and
//!    filled gaps), without the parts that repeat an earlier copy (a template curve reaching
//!    beyond its cell overlaps the copies next to it); strong non-reoccurring curves are added unchanged with the label `Other`
//!    (the light blue of thesis Fig. 4.1–4.4 when rendered with `other_color`).
//!
//! Lengths in parameters are multiples of the mean edge length h of the model.

use std::collections::{BTreeMap, BTreeSet};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::vec3::{add, cross, dot, norm, normalize, scale, sub, V3};
use crestflow_geom::{CurveLabel, FcnVertex, FeatureCurve, FeatureCurveNetwork, SurfacePoint};
use crestflow_nodes_symmetry::{Generator, RigidTransform};
use serde::{Deserialize, Serialize};

use crate::consolidate::{consolidate, Poly};
use crate::curves::{reduce_basis, sample_network};
use crate::model::{check_network, ModelError, SelectedModel};

/// Parameters of `selection.complete`. Lengths are multiples of the mean edge length h.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CompleteParams {
    /// Non-reoccurring curves longer than this multiple of l0 are strong and kept (thesis: 3).
    /// In [0, 1000]. Default 3.
    pub strong_length: f64,
    /// Non-reoccurring curves with sharpness above this multiple of κ_avg and longer than l0
    /// are strong and kept (thesis: 1). In [0, 1000]. Default 1.
    pub strong_curvature: f64,
    /// Radius ε of the projection of end points onto other reoccurrences and of redundancy.
    /// In (0, 100]. Default 2.
    pub epsilon: f64,
    /// Consolidated curves shorter than this are dropped. In [0, 10000]. Default 5.
    pub min_length: f64,
    /// Bins of the grid origin search per generator step. In [4, 4096]. Default 36.
    pub bins: u32,
    /// Copy templates into single empty cells between two observed ones. Default false.
    pub fill_single_gaps: bool,
}

impl Default for CompleteParams {
    fn default() -> Self {
        CompleteParams {
            strong_length: 3.0,
            strong_curvature: 1.0,
            epsilon: 2.0,
            min_length: 5.0,
            bins: 36,
            fill_single_gaps: false,
        }
    }
}

impl Validate for CompleteParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "strong_length", self.strong_length, 0.0, 1000.0);
        check_range(
            &mut v,
            "strong_curvature",
            self.strong_curvature,
            0.0,
            1000.0,
        );
        check_range(&mut v, "epsilon", self.epsilon, 1e-6, 100.0);
        check_range(&mut v, "min_length", self.min_length, 0.0, 10_000.0);
        check_range(&mut v, "bins", self.bins, 4, 4096);
        v
    }
}

/// A candidate's template: consolidated curves in its cell 0, and where it was observed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Template {
    /// Index of the candidate in the model.
    pub candidate: u32,
    /// The template curves, in cell 0.
    pub curves: FeatureCurveNetwork,
    /// Cells with an observed occurrence (grid indices; rotations and reflections use the
    /// first index), and single gaps filled.
    pub cells: Vec<[i64; 2]>,
    pub filled: Vec<[i64; 2]>,
    /// Empty cells between observed ones, and runs of two or more of them (grid splits).
    pub gap_cells: usize,
    pub splits: usize,
    /// Connected components grouped into this template.
    pub components: usize,
}

/// The output of `selection.complete`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Completion {
    /// The completed network: template copies and strong non-reoccurring curves.
    pub network: FeatureCurveNetwork,
    /// All template curves (cell 0 of each candidate).
    pub templates: FeatureCurveNetwork,
    /// The reoccurring input curves, one component after another.
    pub components: FeatureCurveNetwork,
    /// Per input curve: its component (`None` when it does not reoccur).
    pub component_of: Vec<Option<u32>>,
    pub per_template: Vec<Template>,
    pub curves_in: usize,
    pub noise_curves_removed: usize,
    pub strong_curves_kept: usize,
}

/// Why `selection.complete` cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompleteError {
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error(transparent)]
    Network(#[from] ModelError),
    #[error("the model covers {model} curves but the network has {network}")]
    CurveCount { model: usize, network: usize },
    #[error("curve {curve} is assigned to candidate {candidate} but the model has {n}")]
    Candidate {
        curve: usize,
        candidate: u32,
        n: usize,
    },
    #[error("curve {curve} has partner curve {partner} but the network has {n} curves")]
    Partner {
        curve: usize,
        partner: u32,
        n: usize,
    },
    #[error("the model has no valid length unit ({0})")]
    NoScale(f64),
}

/// How cells of a candidate map onto each other.
pub(crate) enum Cells {
    /// Translation grid: p ≈ a g0 + b g1; origin offsets in grid units.
    Grid { g: Vec<V3>, z: Vec<f64> },
    /// Rotation about (axis, center) in steps of `step` radians; `order` 0 when open.
    Rot {
        axis: V3,
        center: V3,
        u: V3,
        step: f64,
        order: i64,
        z: f64,
    },
    /// Reflection in n·x = d: cell 0 on the negative side.
    Refl { n: V3, d: f64 },
    /// No generator: one cell.
    Single,
}

impl Cells {
    /// Grid coordinates (continuous) of a point.
    fn coords(&self, p: V3) -> [f64; 2] {
        match self {
            Cells::Grid { g, .. } => {
                if g.len() == 1 {
                    [dot(p, g[0]) / dot(g[0], g[0]), 0.0]
                } else {
                    let (aa, ab, bb) = (dot(g[0], g[0]), dot(g[0], g[1]), dot(g[1], g[1]));
                    let det = aa * bb - ab * ab;
                    let (pa, pb) = (dot(p, g[0]), dot(p, g[1]));
                    [(bb * pa - ab * pb) / det, (aa * pb - ab * pa) / det]
                }
            }
            Cells::Rot {
                axis,
                center,
                u,
                step,
                ..
            } => {
                let v = sub(p, *center);
                let w = cross(*axis, *u);
                let phi = dot(v, w)
                    .atan2(dot(v, *u))
                    .rem_euclid(std::f64::consts::TAU);
                [phi / step, 0.0]
            }
            Cells::Refl { .. } | Cells::Single => [0.0, 0.0],
        }
    }
    fn cell(&self, centroid: V3) -> [i64; 2] {
        match self {
            Cells::Grid { z, .. } => {
                let c = self.coords(centroid);
                let mut out = [0i64; 2];
                for k in 0..z.len() {
                    out[k] = (c[k] - z[k]).floor() as i64;
                }
                out
            }
            Cells::Rot { order, z, .. } => {
                let c = self.coords(centroid);
                let mut i = (c[0] - z).floor() as i64;
                if *order > 0 {
                    i = i.rem_euclid(*order);
                }
                [i, 0]
            }
            Cells::Refl { n, d } => [i64::from(dot(*n, centroid) > *d), 0],
            Cells::Single => [0, 0],
        }
    }
    /// Maps cell 0 onto `cell`.
    fn map(&self, cell: [i64; 2], p: V3) -> V3 {
        match self {
            Cells::Grid { g, .. } => {
                let mut q = add(p, scale(g[0], cell[0] as f64));
                if g.len() > 1 {
                    q = add(q, scale(g[1], cell[1] as f64));
                }
                q
            }
            Cells::Rot {
                axis, center, step, ..
            } => RigidTransform::rotation_about(*axis, step * cell[0] as f64, *center).apply(p),
            Cells::Refl { n, d } => {
                if cell[0] == 0 {
                    p
                } else {
                    sub(p, scale(*n, 2.0 * (dot(*n, p) - d)))
                }
            }
            Cells::Single => p,
        }
    }
    /// Maps `cell` onto cell 0.
    fn unmap(&self, cell: [i64; 2], p: V3) -> V3 {
        match self {
            Cells::Grid { .. } | Cells::Rot { .. } => self.map([-cell[0], -cell[1]], p),
            _ => self.map(cell, p),
        }
    }
    fn dims(&self) -> usize {
        match self {
            Cells::Grid { g, .. } => g.len(),
            Cells::Rot { .. } => 1,
            _ => 0,
        }
    }
}

/// The offset z in [0, 1) minimising the binned counts of the fractional parts of `values`.
pub(crate) fn best_offset(values: &[f64], bins: usize) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut hist = vec![0usize; bins];
    for v in values {
        let f = v.rem_euclid(1.0);
        hist[((f * bins as f64) as usize).min(bins - 1)] += 1;
    }
    let k = (0..bins).min_by_key(|&k| (hist[k], k)).unwrap_or(0);
    (k as f64 + 0.5) / bins as f64
}

/// The cells of a generator, with origins from the points `pts` of its curves.
/// Copies of the template in the given cells without their repeated parts: a template curve
/// reaching beyond its cell (a ring about a rotation axis, a rail along a translation) overlaps
/// its copies in the neighbouring cells, and only the first copy of each overlap is kept.
pub(crate) fn place_template(
    template: &[Poly],
    cells: &Cells,
    at: impl Iterator<Item = [i64; 2]>,
    eps: f64,
    min_len: f64,
) -> Vec<Poly> {
    let copies: Vec<Poly> = at
        .flat_map(|cell| {
            template.iter().map(move |pl| Poly {
                pts: pl.pts.iter().map(|p| cells.map(cell, *p)).collect(),
                ..pl.clone()
            })
        })
        .collect();
    drop_repeated_parts(&copies, eps, min_len)
}

/// The polylines in order, each without the points within `eps` of an earlier polyline's
/// kept points; what remains of a polyline is split into runs, and runs shorter than
/// `min_len` are dropped.
pub(crate) fn drop_repeated_parts(polys: &[Poly], eps: f64, min_len: f64) -> Vec<Poly> {
    use std::collections::HashMap;
    let key = |p: V3| -> [i64; 3] {
        [
            (p[0] / eps).floor() as i64,
            (p[1] / eps).floor() as i64,
            (p[2] / eps).floor() as i64,
        ]
    };
    // Only looked up, never iterated: the output does not depend on the hash order.
    let mut kept_points: HashMap<[i64; 3], Vec<V3>> = HashMap::new();
    let near_kept = |grid: &HashMap<[i64; 3], Vec<V3>>, p: V3| {
        let k = key(p);
        (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                (-1..=1).any(|dz| {
                    grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz])
                        .is_some_and(|v| v.iter().any(|q| norm(sub(*q, p)) <= eps))
                })
            })
        })
    };
    let mut out = Vec::new();
    for pl in polys {
        let repeated: Vec<bool> = pl.pts.iter().map(|&p| near_kept(&kept_points, p)).collect();
        let mut runs: Vec<Poly> = Vec::new();
        if !repeated.iter().any(|&r| r) {
            runs.push(pl.clone());
        } else {
            let mut i = 0;
            while i < pl.pts.len() {
                if repeated[i] {
                    i += 1;
                    continue;
                }
                let j = (i..pl.pts.len())
                    .find(|&j| repeated[j])
                    .unwrap_or(pl.pts.len());
                runs.push(Poly {
                    pts: pl.pts[i..j].to_vec(),
                    strength: pl.strength[i..j].to_vec(),
                    closed: false,
                    label: pl.label,
                });
                i = j;
            }
        }
        for run in runs {
            if run.pts.len() < 2 || crate::curves::polyline_length(&run.pts, run.closed) < min_len {
                continue;
            }
            for &p in &run.pts {
                kept_points.entry(key(p)).or_default().push(p);
            }
            out.push(run);
        }
    }
    out
}

pub(crate) fn make_cells(gen: Option<&Generator>, pts: &[V3], bins: usize) -> Cells {
    match gen {
        Some(Generator::Translation { steps }) if !steps.is_empty() => {
            let g: Vec<V3> = reduce_basis(&steps.iter().take(2).copied().collect::<Vec<_>>());
            if g.iter().any(|s| norm(*s) <= 0.0) {
                return Cells::Single;
            }
            let mut cells = Cells::Grid {
                g: g.clone(),
                z: vec![0.0; g.len()],
            };
            let z: Vec<f64> = (0..g.len())
                .map(|k| {
                    let vals: Vec<f64> = pts.iter().map(|p| cells.coords(*p)[k]).collect();
                    best_offset(&vals, bins)
                })
                .collect();
            if let Cells::Grid { z: zz, .. } = &mut cells {
                *zz = z;
            }
            cells
        }
        Some(Generator::Rotation {
            axis,
            center,
            angle_deg,
            order,
        }) if *angle_deg > 1e-6 && norm(*axis) > 0.0 => {
            let axis = normalize(*axis);
            let pick = if axis[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let u = normalize(cross(axis, pick));
            let step = if *order > 0 {
                std::f64::consts::TAU / *order as f64
            } else {
                angle_deg.to_radians()
            };
            let mut cells = Cells::Rot {
                axis,
                center: *center,
                u,
                step,
                order: *order as i64,
                z: 0.0,
            };
            let vals: Vec<f64> = pts.iter().map(|p| cells.coords(*p)[0]).collect();
            let z0 = best_offset(&vals, bins);
            if let Cells::Rot { z, .. } = &mut cells {
                *z = z0;
            }
            cells
        }
        Some(Generator::Reflection { normal, offset }) if norm(*normal) > 0.0 => Cells::Refl {
            n: normalize(*normal),
            d: *offset / norm(*normal),
        },
        _ => Cells::Single,
    }
}

/// Union–find root with path halving.
fn root(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Appends a polyline to a network as a curve of free points.
fn push_curve(net: &mut FeatureCurveNetwork, pl: &Poly) {
    if pl.pts.len() < 2 {
        return;
    }
    let base = net.vertices.len() as u32;
    for (p, s) in pl.pts.iter().zip(&pl.strength) {
        net.vertices.push(FcnVertex {
            position: *p,
            location: SurfacePoint::Free,
            strength: *s,
        });
    }
    net.curves.push(FeatureCurve {
        vertices: (base..base + pl.pts.len() as u32).collect(),
        closed: pl.closed,
        label: pl.label,
    });
}

/// Appends curve `c` of `src` (its vertices copied) with `label`.
fn copy_curve(
    net: &mut FeatureCurveNetwork,
    src: &FeatureCurveNetwork,
    c: usize,
    label: CurveLabel,
) {
    let base = net.vertices.len() as u32;
    let curve = &src.curves[c];
    for &v in &curve.vertices {
        net.vertices.push(src.vertices[v as usize].clone());
    }
    net.curves.push(FeatureCurve {
        vertices: (base..base + curve.vertices.len() as u32).collect(),
        closed: curve.closed,
        label,
    });
}

/// Empty cells inside the observed range and runs of ≥ 2 of them along a generator; the
/// single gaps (both neighbours along some generator observed).
pub(crate) fn gaps(
    cells: &BTreeSet<[i64; 2]>,
    dims: usize,
    order: i64,
) -> (usize, usize, Vec<[i64; 2]>) {
    if dims == 0 || cells.is_empty() {
        return (0, 0, Vec::new());
    }
    let lo0 = cells.iter().map(|c| c[0]).min().unwrap_or(0);
    let hi0 = cells.iter().map(|c| c[0]).max().unwrap_or(0);
    let lo1 = cells.iter().map(|c| c[1]).min().unwrap_or(0);
    let hi1 = cells.iter().map(|c| c[1]).max().unwrap_or(0);
    let (lo0, hi0) = if order > 0 {
        (0, order - 1)
    } else {
        (lo0, hi0)
    };
    let wrap = |i: i64| if order > 0 { i.rem_euclid(order) } else { i };
    let has = |c: [i64; 2]| cells.contains(&[wrap(c[0]), c[1]]);
    let mut empty = 0;
    let mut singles = Vec::new();
    let mut splits = 0;
    for i in lo0..=hi0 {
        for j in lo1..=hi1 {
            let c = [i, j];
            if has(c) {
                continue;
            }
            empty += 1;
            let along0 = has([i - 1, j]) && has([i + 1, j]);
            let along1 = dims > 1 && has([i, j - 1]) && has([i, j + 1]);
            if along0 || along1 {
                singles.push(c);
            }
            // A run of ≥ 2 empty cells starts here along generator 0 (or 1).
            if has([i - 1, j]) && !has([i + 1, j]) && i < hi0 {
                splits += 1;
            }
            if dims > 1 && has([i, j - 1]) && !has([i, j + 1]) && j < hi1 {
                splits += 1;
            }
        }
    }
    (empty, splits, singles)
}

/// Co-completes `network` with the selected `model` (see the module docs).
pub fn complete(
    network: &FeatureCurveNetwork,
    model: &SelectedModel,
    params: &CompleteParams,
    _par: Par,
) -> Result<Completion, CompleteError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(CompleteError::Params(text.join("; ")));
    }
    check_network(network)?;
    let m = network.curves.len();
    if model.assignment.len() != m || model.partners.len() != m {
        return Err(CompleteError::CurveCount {
            model: model.assignment.len(),
            network: m,
        });
    }
    let h = model.unit;
    if !(h.is_finite() && h > 0.0) {
        return Err(CompleteError::NoScale(h));
    }
    let nc = model.candidates.len();
    for (c, a) in model.assignment.iter().enumerate() {
        if let Some(j) = *a {
            if j as usize >= nc {
                return Err(CompleteError::Candidate {
                    curve: c,
                    candidate: j,
                    n: nc,
                });
            }
        }
        for p in &model.partners[c] {
            if p.curve as usize >= m {
                return Err(CompleteError::Partner {
                    curve: c,
                    partner: p.curve,
                    n: m,
                });
            }
        }
    }
    let eps = params.epsilon * h;
    let min_len = params.min_length * h;
    let l0 = model.l0;
    // κ_avg: length-weighted mean strength along all curves.
    let (mut num, mut den) = (0.0, 0.0);
    let lengths: Vec<f64> = (0..m).map(|c| network.curve_length(c)).collect();
    for (c, &l) in lengths.iter().enumerate() {
        num += network.curve_strength(c) * l;
        den += l;
    }
    let kappa_avg = if den > 0.0 { num / den } else { 0.0 };

    // 1. Reoccurrence: a curve reoccurs when one of its matches lands on another curve
    // assigned to the same candidate (its points then have reoccurrences, §4.2.2). The edges
    // of the curve graph of §4.2.3.2 are exactly these pairs.
    let mut parent: Vec<usize> = (0..m).collect();
    let mut reoccurs = vec![false; m];
    for c in 0..m {
        let Some(j) = model.assignment[c] else {
            continue;
        };
        for p in &model.partners[c] {
            let q = p.curve as usize;
            if q != c && model.assignment[q] == Some(j) {
                reoccurs[c] = true;
                reoccurs[q] = true;
                let (a, b) = (root(&mut parent, c), root(&mut parent, q));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    // 2. Noise removal (§4.2.3.1) among the curves that do not reoccur.
    let mut strong = Vec::new();
    let mut removed = 0;
    for c in 0..m {
        if reoccurs[c] {
            continue;
        }
        let l = lengths[c];
        let is_strong = l > params.strong_length * l0
            || (network.curve_strength(c) > params.strong_curvature * kappa_avg && l > l0);
        if is_strong {
            strong.push(c);
        } else {
            removed += 1;
        }
    }
    let mut comp_index: BTreeMap<usize, u32> = BTreeMap::new();
    let mut component_of = vec![None; m];
    for c in 0..m {
        if reoccurs[c] {
            let r = root(&mut parent, c);
            let next = comp_index.len() as u32;
            let k = *comp_index.entry(r).or_insert(next);
            component_of[c] = Some(k);
        }
    }
    let n_comp = comp_index.len();
    let mut components = FeatureCurveNetwork::default();
    for k in 0..n_comp as u32 {
        for (c, comp) in component_of.iter().enumerate() {
            if *comp == Some(k) {
                copy_curve(&mut components, network, c, network.curves[c].label);
            }
        }
    }

    // 3–6. Per candidate: cells, consolidation, gaps, copies.
    let sampled = sample_network(network, model.step);
    let mut out = FeatureCurveNetwork::default();
    let mut templates = FeatureCurveNetwork::default();
    let mut per_template = Vec::new();
    for j in 0..nc as u32 {
        let curves: Vec<usize> = (0..m)
            .filter(|&c| reoccurs[c] && model.assignment[c] == Some(j))
            .collect();
        if curves.is_empty() {
            continue;
        }
        let all_pts: Vec<V3> = curves
            .iter()
            .flat_map(|&c| sampled[c].pts.iter().copied())
            .collect();
        let cells = make_cells(
            model.candidates[j as usize].generator.as_ref(),
            &all_pts,
            params.bins as usize,
        );
        let mut observed = BTreeSet::new();
        let mut by_comp: BTreeMap<u32, Vec<Poly>> = BTreeMap::new();
        for &c in &curves {
            let s = &sampled[c];
            if s.pts.is_empty() {
                continue;
            }
            let centroid = scale(
                s.pts.iter().fold([0.0; 3], |a, p| add(a, *p)),
                1.0 / s.pts.len() as f64,
            );
            let cell = cells.cell(centroid);
            observed.insert(cell);
            let comp = component_of[c].unwrap_or(0);
            by_comp.entry(comp).or_default().push(Poly {
                pts: s.pts.iter().map(|p| cells.unmap(cell, *p)).collect(),
                strength: s.strength.clone(),
                closed: s.closed,
                label: network.curves[c].label,
            });
        }
        let mut merged = Vec::new();
        for polys in by_comp.values() {
            merged.extend(consolidate(polys, eps, min_len));
        }
        // Components of the same candidate seeded at the same origin form one template;
        // consolidating their union also removes duplicates between components.
        let template = consolidate(&merged, eps, min_len);
        if template.is_empty() {
            continue;
        }
        let order = match &cells {
            Cells::Rot { order, .. } => *order,
            _ => 0,
        };
        let (gap_cells, splits, singles) = gaps(&observed, cells.dims(), order);
        let filled = if params.fill_single_gaps {
            singles
        } else {
            Vec::new()
        };
        let mut tnet = FeatureCurveNetwork::default();
        for pl in &template {
            push_curve(&mut tnet, pl);
            push_curve(&mut templates, pl);
        }
        let placed = place_template(
            &template,
            &cells,
            observed.iter().chain(filled.iter()).copied(),
            eps,
            min_len,
        );
        for pl in &placed {
            push_curve(&mut out, pl);
        }
        per_template.push(Template {
            candidate: j,
            curves: tnet,
            cells: observed.iter().copied().collect(),
            filled,
            gap_cells,
            splits,
            components: by_comp.len(),
        });
    }
    for &c in &strong {
        copy_curve(&mut out, network, c, CurveLabel::Other);
    }
    Ok(Completion {
        network: out,
        templates,
        components,
        component_of,
        per_template,
        curves_in: m,
        noise_curves_removed: removed,
        strong_curves_kept: strong.len(),
    })
}

/// The completion as a [`Report`]: `curves_in`, `curves_out`, `templates`, `template_curves`,
/// `noise_curves_removed`, `strong_curves_kept`, `components`, `occurrences`, `gap_cells`,
/// `grid_splits`, `gaps_filled`, `length_in`, `length_out`, and per template
/// `template_<i>.curves`/`.cells`/`.components`.
pub fn completion_report(c: &Completion, network_in: &FeatureCurveNetwork) -> Report {
    let mut r = Report::new();
    r.set("curves_in", c.curves_in);
    r.set("curves_out", c.network.curves.len());
    r.set("templates", c.per_template.len());
    r.set("template_curves", c.templates.curves.len());
    r.set("noise_curves_removed", c.noise_curves_removed);
    r.set("strong_curves_kept", c.strong_curves_kept);
    let n_comp = c
        .component_of
        .iter()
        .flatten()
        .collect::<BTreeSet<_>>()
        .len();
    r.set("components", n_comp);
    r.set(
        "occurrences",
        c.per_template.iter().map(|t| t.cells.len()).sum::<usize>(),
    );
    r.set(
        "gap_cells",
        c.per_template.iter().map(|t| t.gap_cells).sum::<usize>(),
    );
    r.set(
        "grid_splits",
        c.per_template.iter().map(|t| t.splits).sum::<usize>(),
    );
    r.set(
        "gaps_filled",
        c.per_template.iter().map(|t| t.filled.len()).sum::<usize>(),
    );
    r.set("length_in", network_in.total_length());
    r.set("length_out", c.network.total_length());
    for (i, t) in c.per_template.iter().enumerate() {
        let p = format!("template_{i}");
        r.set(format!("{p}.candidate"), t.candidate as usize);
        r.set(format!("{p}.curves"), t.curves.curves.len());
        r.set(format!("{p}.cells"), t.cells.len());
        r.set(format!("{p}.components"), t.components);
    }
    r
}

/// The `selection.complete` node.
pub struct CompleteNode;

impl NodeKind for CompleteNode {
    type Params = CompleteParams;
    const KIND: &'static str = "selection.complete";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Feature curve co-completion (thesis §4.2.3): removes weak \
        non-reoccurring curves (keeps strong ones, §4.2.3.1), finds connected components of the \
        curve graph, moves reoccurrences into one grid cell (origins by projection onto the \
        generators, shear included), consolidates them by longest shortest paths, detects gaps, \
        and copies each template to every observed occurrence. Outputs the completed network, \
        the templates, the components and a Report.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "the noisy feature curves"),
            Port::of::<SelectedModel>("model", "the model from selection.model"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>(
                "network",
                "completed network: template copies and strong non-reoccurring curves (Other)",
            ),
            Port::of::<FeatureCurveNetwork>("templates", "template curves in their cell 0"),
            Port::of::<FeatureCurveNetwork>("components", "reoccurring input curves"),
            Port::of::<Report>("report", "curves in/out, templates, noise removed, gaps"),
        ]
    }
    fn run(params: &CompleteParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let network = inputs.get::<FeatureCurveNetwork>("network")?;
        let model = inputs.get::<SelectedModel>("model")?;
        ctx.check_cancelled()?;
        let out = complete(network, model, params, ctx.par)
            .map_err(|e| NodeError::from_source(ErrorKind::InvalidInput, e))?;
        Ok(Outputs::new()
            .with("report", completion_report(&out, network))
            .with("network", out.network)
            .with("templates", out.templates)
            .with("components", out.components))
    }
}
