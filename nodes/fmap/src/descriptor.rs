//! `fmap.descriptor`: the descriptor-preservation functional map (Ovsjanikov et al. 2012;
//! thesis eq. 2.7 + 2.8), the baseline that curve constraints are compared against.
//!
//! `C = argmin ‖C G̃₁ − G̃₂‖² + α ‖C Λ₁ − Λ₂ C‖²`, with `G̃ = Φ'ᵀ M' G` the spectral
//! coefficients of m corresponding descriptor functions on each shape (unit-area bases). Both
//! terms separate over the rows of C: row i solves `(G̃₁ G̃₁ᵀ + α diag(D_{i·})) cᵢ = G̃₁ g̃₂ᵢ`
//! with `D_ij = (λ₂ᵢ − λ₁ⱼ)²` — k dense Cholesky solves.
//!
//! Descriptors, computed from the first `k_descriptor` eigenpairs of each shape:
//! - `Hks`: heat kernel signature `Σᵢ e^{−λᵢ t} φᵢ(x)²` (Sun, Ovsjanikov, Guibas 2009) at
//!   `count` times log-spaced in `[4 ln 10 / λ_max, 4 ln 10 / λ₁]`;
//! - `Wks`: wave kernel signature (Aubry, Schlickewei, Cremers 2011) at `count` log-energies
//!   evenly spaced in `[log λ₁ + 2σ, log λ_max − 2σ]`, `σ = 7 δ` (δ the energy step),
//!   normalised per energy.
//!
//! Times and energies come from the source spectrum and are used on both shapes (both
//! normalised to unit area). With `landmarks`, each landmark pair adds heat kernel maps
//! `Σᵢ e^{−λᵢ t} φᵢ(x) φᵢ(l)` at `landmark_times` of the descriptor times. Every descriptor
//! function is scaled to unit M'-norm on its shape.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate,
};
use crestflow_nodes_spectral::EigenBasis;

use crate::dense::{at_d_b, spd_solve, Basis};
use crate::types::{FmapError, FunctionalMap, LandmarkPairs};

/// Which point signature.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum DescriptorKind {
    Hks,
    #[default]
    Wks,
}

/// Parameters of `fmap.descriptor`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DescriptorMapParams {
    /// Basis size of the map (default 120; 0: the smaller basis; range 0..=2000).
    pub k: usize,
    /// Eigenpairs used to compute the descriptors (default 0: all in the bases).
    pub k_descriptor: usize,
    /// Signature (default `Wks`).
    pub descriptor: DescriptorKind,
    /// Descriptor functions per shape (default 100, range 1..=10000).
    pub count: usize,
    /// Keep every `subsample`-th descriptor (default 1, range 1..=1000).
    pub subsample: usize,
    /// Weight α of the Laplacian commutativity term (default 1e-3, range 0..=1e6).
    pub alpha: f64,
    /// Heat-kernel-map times per landmark (default 5, range 0..=1000; spread over the HKS
    /// time range).
    pub landmark_times: usize,
}

impl Default for DescriptorMapParams {
    fn default() -> Self {
        DescriptorMapParams {
            k: 120,
            k_descriptor: 0,
            descriptor: DescriptorKind::Wks,
            count: 100,
            subsample: 1,
            alpha: 1e-3,
            landmark_times: 5,
        }
    }
}

impl Validate for DescriptorMapParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "k", self.k, 0, 2000);
        check_range(&mut issues, "k_descriptor", self.k_descriptor, 0, 2000);
        check_range(&mut issues, "count", self.count, 1, 10_000);
        check_range(&mut issues, "subsample", self.subsample, 1, 1000);
        check_range(&mut issues, "alpha", self.alpha, 0.0, 1e6);
        check_range(&mut issues, "landmark_times", self.landmark_times, 0, 1000);
        issues
    }
}

/// First eigenvalue above the numerical zero (relative to λ_max).
fn first_positive(values: &[f64]) -> f64 {
    let max = values
        .last()
        .copied()
        .unwrap_or(1.0)
        .abs()
        .max(f64::MIN_POSITIVE);
    values
        .iter()
        .copied()
        .find(|&l| l > 1e-9 * max)
        .unwrap_or(max)
}

/// HKS times log-spaced in `[4 ln 10 / λ_max, 4 ln 10 / λ₁]`.
pub fn hks_times(values: &[f64], count: usize) -> Vec<f64> {
    let l1 = first_positive(values);
    let lmax = values.last().copied().unwrap_or(l1).max(l1);
    let (t0, t1) = ((4.0 * 10f64.ln() / lmax).ln(), (4.0 * 10f64.ln() / l1).ln());
    (0..count)
        .map(|i| {
            let f = if count > 1 {
                i as f64 / (count - 1) as f64
            } else {
                0.5
            };
            (t0 + f * (t1 - t0)).exp()
        })
        .collect()
}

/// Descriptor functions (n × m, column-major) of one shape.
pub fn signatures(b: &Basis, kind: DescriptorKind, count: usize, ref_values: &[f64]) -> Vec<f64> {
    let n = b.n;
    let k = b.k;
    let mut out = vec![0.0; n * count];
    match kind {
        DescriptorKind::Hks => {
            let times = hks_times(ref_values, count);
            for (c, &t) in times.iter().enumerate() {
                let w: Vec<f64> = b.values.iter().map(|l| (-l * t).exp()).collect();
                let col = &mut out[c * n..(c + 1) * n];
                for (i, wi) in w.iter().enumerate() {
                    let phi = b.col(i);
                    for v in 0..n {
                        col[v] += wi * phi[v] * phi[v];
                    }
                }
            }
        }
        DescriptorKind::Wks => {
            let l1 = first_positive(ref_values);
            let lmax = ref_values.last().copied().unwrap_or(l1).max(l1);
            let (e_lo, e_hi) = (l1.ln(), lmax.ln());
            let delta = (e_hi - e_lo) / (count as f64 + 28.0);
            let sigma = 7.0 * delta;
            let start = e_lo + 2.0 * sigma;
            let stop = e_hi - 2.0 * sigma;
            let logs: Vec<f64> = b
                .values
                .iter()
                .map(|&l| if l > 1e-9 * lmax { l.ln() } else { f64::NAN })
                .collect();
            for c in 0..count {
                let e = if count > 1 {
                    start + (stop - start) * c as f64 / (count - 1) as f64
                } else {
                    0.5 * (start + stop)
                };
                let w: Vec<f64> = logs
                    .iter()
                    .map(|&lg| {
                        if lg.is_nan() {
                            0.0
                        } else {
                            (-(e - lg) * (e - lg) / (2.0 * sigma * sigma)).exp()
                        }
                    })
                    .collect();
                let wsum: f64 = w.iter().sum::<f64>().max(f64::MIN_POSITIVE);
                let col = &mut out[c * n..(c + 1) * n];
                for (i, wi) in w.iter().enumerate().take(k) {
                    if *wi == 0.0 {
                        continue;
                    }
                    let phi = b.col(i);
                    for v in 0..n {
                        col[v] += wi / wsum * phi[v] * phi[v];
                    }
                }
            }
        }
    }
    out
}

/// Heat kernel maps from vertex `l` at `times` (n × times, column-major).
pub fn heat_kernel_maps(b: &Basis, l: usize, times: &[f64]) -> Vec<f64> {
    let n = b.n;
    let mut out = vec![0.0; n * times.len()];
    for (c, &t) in times.iter().enumerate() {
        let col = &mut out[c * n..(c + 1) * n];
        for i in 0..b.k {
            let w = (-b.values[i] * t).exp() * b.at(l, i);
            let phi = b.col(i);
            for v in 0..n {
                col[v] += w * phi[v];
            }
        }
    }
    out
}

/// Scales each column to unit M'-norm (zero columns stay zero).
fn normalize_columns(g: &mut [f64], n: usize, mass: &[f64]) {
    for col in g.chunks_mut(n) {
        let nrm = col
            .iter()
            .zip(mass)
            .map(|(x, m)| m * x * x)
            .sum::<f64>()
            .sqrt();
        if nrm > 0.0 {
            col.iter_mut().for_each(|x| *x /= nrm);
        }
    }
}

/// Solves eq. 2.7 + 2.8 given descriptor coefficients `g1` (k × m) and `g2` (k × m).
pub fn solve_descriptor_system(
    g1: &[f64],
    g2: &[f64],
    m: usize,
    l1: &[f64],
    l2: &[f64],
    alpha: f64,
    par: Par,
) -> Result<FunctionalMap, FmapError> {
    let k = l1.len();
    // G̃₁ G̃₁ᵀ and G̃₁ G̃₂ᵀ from the transposed (m × k) layouts.
    let g1t: Vec<f64> = (0..k * m).map(|idx| g1[(idx % m) * k + idx / m]).collect();
    let g2t: Vec<f64> = (0..k * m).map(|idx| g2[(idx % m) * k + idx / m]).collect();
    let gg = at_d_b(&g1t, k, None, &g1t, k, m, Par::Seq);
    let g12 = at_d_b(&g1t, k, None, &g2t, k, m, Par::Seq); // column i = G̃₁ g̃₂ᵢ
    let rows = par.map_collect(k, |i| {
        let mut a = gg.clone();
        for j in 0..k {
            let d = l2[i] - l1[j];
            a[j * k + j] += alpha * d * d;
        }
        spd_solve(&a, k, &g12[i * k..(i + 1) * k], i)
    });
    let mut c = vec![0.0; k * k];
    for (i, r) in rows.into_iter().enumerate() {
        for (j, x) in r?.into_iter().enumerate() {
            c[j * k + i] = x;
        }
    }
    // Energy.
    let mut e = 0.0;
    for s in 0..m {
        for i in 0..k {
            let mut v = -g2[s * k + i];
            for j in 0..k {
                v += c[j * k + i] * g1[s * k + j];
            }
            e += v * v;
        }
    }
    for j in 0..k {
        for i in 0..k {
            let d = l2[i] - l1[j];
            e += alpha * d * d * c[j * k + i] * c[j * k + i];
        }
    }
    Ok(FunctionalMap {
        k_source: k,
        k_target: k,
        matrix: c,
        energy: e,
        iterations: 0,
    })
}

/// The descriptor-preservation map between two eigenbases.
pub fn descriptor_map(
    source: &EigenBasis,
    target: &EigenBasis,
    landmarks: Option<&LandmarkPairs>,
    params: &DescriptorMapParams,
    par: Par,
) -> Result<FunctionalMap, FmapError> {
    let kd_avail = source.k().min(target.k());
    let kd = if params.k_descriptor == 0 {
        kd_avail
    } else {
        params.k_descriptor
    };
    let k = if params.k == 0 { kd_avail } else { params.k };
    let d1 = Basis::new(source, kd, "source")?;
    let d2 = Basis::new(target, kd, "target")?;
    let b1 = d1.truncated(k.min(kd));
    let b2 = d2.truncated(k.min(kd));
    if k > kd {
        // The map basis may be larger than the descriptor basis.
        return Err(FmapError::BasisTooSmall {
            side: "descriptor",
            have: kd,
            asked: k,
        });
    }
    if let Some(lm) = landmarks {
        for (i, p) in lm.pairs.iter().enumerate() {
            for (slot, (side, n)) in [("source", d1.n), ("target", d2.n)].iter().enumerate() {
                if p[slot] as usize >= *n {
                    return Err(FmapError::LandmarkOutOfRange {
                        origin: lm.origin.clone(),
                        line: lm.lines.get(i).copied().unwrap_or(i + 1),
                        side,
                        vertex: p[slot],
                        n_vertices: *n,
                    });
                }
            }
        }
    }
    let build = |b: &Basis, slot: usize| -> Vec<f64> {
        let mut g = signatures(b, params.descriptor, params.count, &d1.values);
        let n = b.n;
        if params.subsample > 1 {
            let keep: Vec<usize> = (0..params.count).step_by(params.subsample).collect();
            let mut s = Vec::with_capacity(keep.len() * n);
            for c in keep {
                s.extend_from_slice(&g[c * n..(c + 1) * n]);
            }
            g = s;
        }
        if let Some(lm) = landmarks {
            if params.landmark_times > 0 {
                let all = hks_times(&d1.values, params.landmark_times.max(2) + 2);
                let times = &all[1..=params.landmark_times];
                for p in &lm.pairs {
                    g.extend(heat_kernel_maps(b, p[slot] as usize, times));
                }
            }
        }
        normalize_columns(&mut g, n, &b.mass);
        g
    };
    let g1 = build(&d1, 0);
    let g2 = build(&d2, 1);
    let m = g1.len() / d1.n;
    let c1 = b1.project(&g1, m, par);
    let c2 = b2.project(&g2, m, par);
    solve_descriptor_system(&c1, &c2, m, &b1.values, &b2.values, params.alpha, par)
}

/// Node wrapper of [`descriptor_map`].
pub struct DescriptorMapNode;

impl NodeKind for DescriptorMapNode {
    type Params = DescriptorMapParams;
    const KIND: &'static str = "fmap.descriptor";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Descriptor-preservation functional map (Ovsjanikov et al. \
        2012; thesis eq. 2.7 + 2.8): HKS or WKS descriptors (plus heat kernel maps of optional \
        landmarks) preserved in the least-squares sense with Laplacian commutativity, solved \
        row by row exactly. The baseline for fmap.curve_constrained.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<EigenBasis>("source_basis", "eigenbasis of the source mesh"),
            Port::of::<EigenBasis>("target_basis", "eigenbasis of the target mesh"),
            Port::optional::<LandmarkPairs>("landmarks", "landmark pairs as extra descriptors"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<FunctionalMap>("map", "the k×k functional map")]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        ctx.check_cancelled()?;
        let m = descriptor_map(
            inputs.get("source_basis")?,
            inputs.get("target_basis")?,
            inputs.opt("landmarks")?,
            params,
            ctx.par,
        )
        .map_err(FmapError::into_node)?;
        Ok(Outputs::new().with("map", m))
    }
}

#[cfg(test)]
#[path = "descriptor_test.rs"]
mod tests;
