//! `fmap.point_map`: a point-to-point map from a functional map (Ovsjanikov et al. 2012,
//! thesis §2.6.3.1), optionally refined by ZoomOut (Melzi et al. 2019).
//!
//! A point map `T` (target vertex ↦ source vertex) induces `C = Φ₂'ᵀ M₂' Π_T Φ₁'`; for an
//! orthonormal C, row y of `Φ₂'` equals row `T(y)` of `Φ₁' Cᵀ`. Each target vertex is sent to
//! the source vertex whose carried embedding (row of `Φ₁' Cᵀ`, k₂ dimensions) is nearest to
//! its own row of `Φ₂'` (Euclidean).
//!
//! Nearest neighbours are found by brute force in blocks (no kd-tree in high dimension):
//! `‖q − p‖² = ‖p‖² − 2 q·p + ‖q‖²`, the cross terms of a block of queries against a block of
//! source rows as one dense product (faer, screened in f32 then confirmed exactly in f64, see
//! [`nearest_neighbors`]), the blocks of queries in parallel. Every query's
//! result depends only on fixed block shapes, so it is the same at any thread count; ties go
//! to the smallest source index.
//!
//! ZoomOut: from the map's top-left `k_start × k_start` block, alternate a point map and the
//! functional map it induces, growing k by `step` up to `k_end`; the output point map is the
//! one of the final `k_end` map.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat};
use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate,
};
use crestflow_nodes_spectral::EigenBasis;

use crate::dense::{at_d_b, tall_mul, Basis};
use crate::types::{FmapError, FunctionalMap, PointMap};

/// Queries per block (the screening product of a block reuses each packed source block for
/// this many queries).
const QUERY_BLOCK: usize = 1024;
/// Source rows per block.
const REF_BLOCK: usize = 256;

/// ZoomOut settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZoomOutParams {
    /// Start size (default 0: the map's size).
    pub k_start: usize,
    /// Final size (default 0: the smaller basis).
    pub k_end: usize,
    /// Growth per iteration (default 5, range 1..=1000).
    pub step: usize,
}

impl Default for ZoomOutParams {
    fn default() -> Self {
        ZoomOutParams {
            k_start: 0,
            k_end: 0,
            step: 5,
        }
    }
}

/// Parameters of `fmap.point_map`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PointMapParams {
    /// ZoomOut refinement (default none).
    pub zoomout: Option<ZoomOutParams>,
}

impl Validate for PointMapParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        if let Some(z) = &self.zoomout {
            check_range(&mut issues, "zoomout.step", z.step, 1, 1000);
            check_range(&mut issues, "zoomout.k_start", z.k_start, 0, 2000);
            check_range(&mut issues, "zoomout.k_end", z.k_end, 0, 2000);
        }
        issues
    }
}

/// For every row of `queries` (nq × d, column-major), the index of the nearest row of `refs`
/// (nr × d, column-major); ties go to the smallest index.
///
/// Two passes: a screening pass in single precision (half the cost of the dense products)
/// keeps, per query, every source row whose f32 distance is within twice a rigorous rounding
/// bound of the best f32 distance; the survivors are then compared exactly in f64. The
/// screening product computes `‖p‖² − 2 q·p` directly: the source rows are augmented by their
/// squared norm and scaled by −2 (exact in binary), the queries by a column of ones, so one
/// dense product of inner size d + 1 gives the screened values and the scan is a plain
/// minimum. The bound (sums of d + 1 terms: `(d + 9) u (2 |q| P + P²)` with u = 2⁻²³ and P
/// the largest source norm, doubled for safety) covers the conversions to f32 (inputs and
/// norms) and the sum in any order, so the answer is the exact f64 nearest neighbour.
pub fn nearest_neighbors(
    queries: &[f64],
    nq: usize,
    refs: &[f64],
    nr: usize,
    d: usize,
    par: Par,
) -> Vec<u32> {
    if nr == 0 {
        return vec![0; nq];
    }
    let da = d + 1;
    // Queries augmented by a column of ones.
    let mut q32: Vec<f32> = Vec::with_capacity(nq * da);
    q32.extend(queries[..nq * d].iter().map(|&x| x as f32));
    q32.resize(nq * da, 1.0);
    // Source rows scaled by −2 and augmented by their squared norm.
    let mut r32: Vec<f32> = Vec::with_capacity(nr * da);
    r32.extend(refs[..nr * d].iter().map(|&x| -2.0 * (x as f32)));
    // Source rows, row-major (for the norms and the exact comparisons).
    let rrows = to_rows(refs, nr, d, 0, nr);
    r32.extend(rrows.chunks_exact(d.max(1)).take(nr).map(|row| {
        row.iter()
            .map(|&v| {
                let v = v as f32 as f64;
                v * v
            })
            .sum::<f64>() as f32
    }));
    r32.resize(nr * da, 0.0);
    let qm = faer::MatRef::from_column_major_slice(&q32, nq, da);
    let rm = faer::MatRef::from_column_major_slice(&r32, nr, da);
    let pmax = rrows
        .chunks_exact(d.max(1))
        .map(|row| row.iter().map(|v| v.powi(2)).sum::<f64>())
        .fold(0.0, f64::max)
        .sqrt();
    let u = f32::EPSILON as f64;
    let gamma = 2.0 * (da as f64 + 8.0) * u;
    let blocks = nq.div_ceil(QUERY_BLOCK);
    let parts = par.map_collect(blocks, |b| {
        let q0 = b * QUERY_BLOCK;
        let ql = QUERY_BLOCK.min(nq - q0);
        let qb = qm.subrows(q0, ql);
        // The block's queries, row-major.
        let qrows = to_rows(queries, nq, d, q0, ql);
        let margin: Vec<f64> = (0..ql)
            .map(|q| {
                let qn = qrows[q * d..(q + 1) * d]
                    .iter()
                    .map(|v| v.powi(2))
                    .sum::<f64>()
                    .sqrt();
                2.0 * gamma * (pmax * pmax + 2.0 * qn * pmax) + f64::MIN_POSITIVE
            })
            .collect();
        let mut best = vec![f64::INFINITY; ql];
        let mut cands: Vec<Vec<(f64, u32)>> = vec![Vec::new(); ql];
        let mut prod = Mat::<f32>::zeros(REF_BLOCK.min(nr), ql);
        let mut mins = vec![0.0f32; ql];
        let mut r0 = 0;
        while r0 < nr {
            let rl = REF_BLOCK.min(nr - r0);
            matmul(
                prod.as_mut().subrows_mut(0, rl),
                Accum::Replace,
                rm.subrows(r0, rl),
                qb.transpose(),
                1.0f32,
                faer::Par::Seq,
            );
            let pr = prod.as_ref().subrows(0, rl);
            column_minima(pr, &mut mins);
            for q in 0..ql {
                let m = margin[q];
                // f32 screen threshold; the exact test below uses f64.
                if mins[q] > widen((best[q] + m) as f32) {
                    continue;
                }
                scan_block(column(pr, q), r0, m, &mut best[q], &mut cands[q]);
            }
            r0 += rl;
        }
        (0..ql)
            .map(|q| {
                let qrow = &qrows[q * d..(q + 1) * d];
                let mut win = (f64::INFINITY, u32::MAX);
                for &(dd, x) in &cands[q] {
                    if dd > best[q] + margin[q] {
                        continue;
                    }
                    let x0 = x as usize * d;
                    let exact: f64 = qrow
                        .iter()
                        .zip(&rrows[x0..x0 + d])
                        .map(|(a, b)| {
                            let t = a - b;
                            t * t
                        })
                        .sum();
                    if exact < win.0 || (exact == win.0 && x < win.1) {
                        win = (exact, x);
                    }
                }
                win.1
            })
            .collect::<Vec<u32>>()
    });
    parts.into_iter().flatten().collect()
}

/// Rows `start..start + len` of the column-major n × d matrix `a`, row-major (in tiles of
/// rows, so the writes stay in cache).
fn to_rows(a: &[f64], n: usize, d: usize, start: usize, len: usize) -> Vec<f64> {
    const TILE: usize = 32;
    let mut out = vec![0.0f64; len * d];
    let mut t0 = 0;
    while t0 < len {
        let tl = TILE.min(len - t0);
        for j in 0..d {
            let src = &a[j * n + start + t0..j * n + start + t0 + tl];
            for (i, &v) in src.iter().enumerate() {
                out[(t0 + i) * d + j] = v;
            }
        }
        t0 += tl;
    }
    out
}

/// Lanes of the branch-free minimum (a multiple of every SIMD width).
const LANES: usize = 16;
/// Values per chunk of the candidate scan.
const CHUNK: usize = 64;

/// Column `q` of a column-major block as a slice.
fn column(m: faer::MatRef<'_, f32>, q: usize) -> &[f32] {
    match m.col(q).try_as_col_major() {
        Some(c) => c.as_slice(),
        None => unreachable!("a fresh Mat is column-major"),
    }
}

/// The minimum of every column of `m` into `out` (NaN ignored; +∞ for an empty column), with
/// the widest vector instructions the processor has (the minimum is exact, so the result does
/// not depend on them).
fn column_minima(m: faer::MatRef<'_, f32>, out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor supports AVX-512F (checked just above).
            unsafe { column_minima_avx512(m, out) };
            return;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2 (checked just above).
            unsafe { column_minima_avx2(m, out) };
            return;
        }
    }
    column_minima_body(m, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn column_minima_avx512(m: faer::MatRef<'_, f32>, out: &mut [f32]) {
    column_minima_body(m, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn column_minima_avx2(m: faer::MatRef<'_, f32>, out: &mut [f32]) {
    column_minima_body(m, out)
}

#[inline(always)]
fn column_minima_body(m: faer::MatRef<'_, f32>, out: &mut [f32]) {
    for (q, o) in out.iter_mut().enumerate().take(m.ncols()) {
        *o = min_f32(column(m, q));
    }
}

/// The smallest value of `v` (NaN ignored; +∞ when empty), branch-free over `LANES`
/// independent lanes so it vectorises.
#[inline(always)]
fn min_f32(v: &[f32]) -> f32 {
    let mut acc = [f32::INFINITY; LANES];
    let chunks = v.chunks_exact(LANES);
    let rest = chunks.remainder();
    for ch in chunks {
        for (a, &x) in acc.iter_mut().zip(ch) {
            *a = if x < *a { x } else { *a };
        }
    }
    acc.iter()
        .chain(rest)
        .fold(f32::INFINITY, |m, &x| if x < m { x } else { m })
}

/// Collects into `list` every row of one screened column (`‖p‖² − 2 q·p` in f32, rows from
/// `r0`) within `margin` of the best value so far, which it lowers; chunks whose minimum is
/// above the threshold are skipped.
fn scan_block(col: &[f32], r0: usize, margin: f64, best: &mut f64, list: &mut Vec<(f64, u32)>) {
    let mut bv = *best;
    let mut thr = widen((bv + margin) as f32);
    for (c, ch) in col.chunks(CHUNK).enumerate() {
        if min_f32(ch) > thr {
            continue;
        }
        for (i, &v) in ch.iter().enumerate() {
            if v > thr {
                continue;
            }
            let dd = v as f64;
            if dd <= bv + margin {
                if dd < bv {
                    bv = dd;
                    thr = widen((bv + margin) as f32);
                }
                list.push((dd, (r0 + c * CHUNK + i) as u32));
            }
        }
    }
    if list.len() > 64 {
        list.retain(|&(dd, _)| dd <= bv + margin);
    }
    *best = bv;
}

/// `t` moved up by a few f32 ulps (covers the rounding of an f64 bound to f32).
fn widen(t: f32) -> f32 {
    t + t.abs() * 4.0 * f32::EPSILON
}

/// Point map of the k₂ × k₁ map `c` between bases `b1` (source, ≥ k₁ functions) and `b2`
/// (target, ≥ k₂ functions): every row of `Φ₂'` (k₂ dimensions) is matched to the nearest
/// row of `Φ₁' Cᵀ`, the source embedding carried to the target basis (Ovsjanikov et al.
/// 2012; thesis §2.6.3.1).
pub fn map_to_points(
    b1: &Basis,
    b2: &Basis,
    c: &[f64],
    k1: usize,
    k2: usize,
    par: Par,
) -> Vec<u32> {
    // Cᵀ (k₁ × k₂) from C (k₂ × k₁), both column-major.
    let mut ct = vec![0.0; k1 * k2];
    for j in 0..k1 {
        for i in 0..k2 {
            ct[i * k1 + j] = c[j * k2 + i];
        }
    }
    let refs = tall_mul(&b1.vectors[..b1.n * k1], b1.n, k1, &ct, k2, par);
    nearest_neighbors(&b2.vectors[..b2.n * k2], b2.n, &refs, b1.n, k2, par)
}

/// The k × k functional map induced by a point map: `Φ₂'ᵀ M₂' Π Φ₁'` (first k functions).
pub fn points_to_map(b1: &Basis, b2: &Basis, t: &[u32], k: usize, par: Par) -> Vec<f64> {
    let n2 = b2.n;
    let mut pulled = vec![0.0; n2 * k];
    for j in 0..k {
        let src = b1.col(j);
        for (y, &x) in t.iter().enumerate() {
            pulled[j * n2 + y] = src[x as usize];
        }
    }
    at_d_b(
        &b2.vectors[..n2 * k],
        k,
        Some(&b2.mass),
        &pulled,
        k,
        n2,
        par,
    )
}

/// ZoomOut from the `k_start × k_start` block of `map` up to `k_end`; returns the final point
/// map and functional map.
pub fn zoomout(
    b1: &Basis,
    b2: &Basis,
    map: &FunctionalMap,
    z: &ZoomOutParams,
    par: Par,
) -> Result<(Vec<u32>, FunctionalMap), FmapError> {
    let k_avail = b1.k.min(b2.k);
    let k_start = if z.k_start == 0 {
        map.k_source.min(map.k_target)
    } else {
        z.k_start
    };
    let k_end = if z.k_end == 0 { k_avail } else { z.k_end };
    if k_start > map.k_source.min(map.k_target) {
        return Err(FmapError::Param {
            field: "zoomout.k_start",
            message: format!(
                "{k_start} is larger than the {}×{} map",
                map.k_target, map.k_source
            ),
        });
    }
    if k_end > k_avail || k_end < k_start {
        return Err(FmapError::Param {
            field: "zoomout.k_end",
            message: format!("{k_end} must lie in [k_start = {k_start}, basis size {k_avail}]"),
        });
    }
    let mut k = k_start;
    let mut c = vec![0.0; k * k];
    for j in 0..k {
        for i in 0..k {
            c[j * k + i] = map.get(i, j);
        }
    }
    let mut iterations = 0;
    loop {
        let t = map_to_points(b1, b2, &c, k, k, par);
        if k >= k_end {
            return Ok((
                t,
                FunctionalMap {
                    k_source: k,
                    k_target: k,
                    matrix: c,
                    energy: 0.0,
                    iterations,
                },
            ));
        }
        k = (k + z.step.max(1)).min(k_end);
        c = points_to_map(b1, b2, &t, k, par);
        iterations += 1;
    }
}

/// The point map of `map` (with ZoomOut when asked). Returns it with the final functional map.
pub fn point_map(
    source: &EigenBasis,
    target: &EigenBasis,
    map: &FunctionalMap,
    params: &PointMapParams,
    par: Par,
) -> Result<(PointMap, FunctionalMap), FmapError> {
    if map.matrix.len() != map.k_source * map.k_target {
        return Err(FmapError::MapSizeMismatch {
            rows: map.k_target,
            cols: map.k_source,
            k_target: target.k(),
            k_source: source.k(),
        });
    }
    if map.k_source > source.k() || map.k_target > target.k() {
        return Err(FmapError::MapSizeMismatch {
            rows: map.k_target,
            cols: map.k_source,
            k_target: target.k(),
            k_source: source.k(),
        });
    }
    let b1 = Basis::new(source, 0, "source")?;
    let b2 = Basis::new(target, 0, "target")?;
    let (t, fm) = match &params.zoomout {
        None => (
            map_to_points(&b1, &b2, &map.matrix, map.k_source, map.k_target, par),
            map.clone(),
        ),
        Some(z) => zoomout(&b1, &b2, map, z, par)?,
    };
    Ok((
        PointMap {
            target_to_source: t,
            n_source: b1.n,
        },
        fm,
    ))
}

/// Parameters of `fmap.save_point_map`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SavePointMapParams {
    /// Output text file, relative to the pipeline file (required): line y holds the source
    /// vertex of target vertex y (the format of `pyfm_lion2cat.txt`).
    pub path: std::path::PathBuf,
}

impl Validate for SavePointMapParams {
    fn validate(&self) -> Vec<ParamIssue> {
        if self.path.as_os_str().is_empty() {
            vec![ParamIssue::new("path", "the output path is empty")]
        } else {
            Vec::new()
        }
    }
}

/// Writes a point map as text, one source vertex per line.
pub fn write_point_map(pm: &PointMap, path: &std::path::Path) -> Result<(), FmapError> {
    let io = |e: std::io::Error| FmapError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
    }
    let mut text = String::with_capacity(pm.target_to_source.len() * 6);
    for x in &pm.target_to_source {
        text.push_str(&x.to_string());
        text.push('\n');
    }
    std::fs::write(path, text).map_err(io)
}

/// The `fmap.save_point_map` node.
pub struct SavePointMapNode;

impl NodeKind for SavePointMapNode {
    type Params = SavePointMapParams;
    const KIND: &'static str = "fmap.save_point_map";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Writes a point map as text: line y is the source vertex matched \
        to target vertex y (0-based), the format of the ground-truth files.";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<PointMap>(
            "points",
            "target vertex → source vertex",
        )]
    }
    fn outputs() -> Vec<Port> {
        Vec::new()
    }
    fn output_files(params: &Self::Params) -> Vec<std::path::PathBuf> {
        vec![params.path.clone()]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        write_point_map(inputs.get("points")?, &ctx.resolve(&params.path))
            .map_err(FmapError::into_node)?;
        Ok(Outputs::new())
    }
}

/// Node wrapper of [`point_map`].
pub struct PointMapNode;

impl NodeKind for PointMapNode {
    type Params = PointMapParams;
    const KIND: &'static str = "fmap.point_map";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Point-to-point map from a functional map: every target vertex \
        goes to the source vertex nearest in the spectral embedding (Ovsjanikov et al. 2012; \
        blocked brute-force search, parallel and deterministic), optionally refined by ZoomOut \
        (Melzi et al. 2019).";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<EigenBasis>("source_basis", "eigenbasis of the source mesh"),
            Port::of::<EigenBasis>("target_basis", "eigenbasis of the target mesh"),
            Port::of::<FunctionalMap>("map", "the functional map"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<PointMap>("points", "target vertex → source vertex"),
            Port::of::<FunctionalMap>("map", "the final functional map (after ZoomOut)"),
        ]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        ctx.check_cancelled()?;
        let (p, m) = point_map(
            inputs.get("source_basis")?,
            inputs.get("target_basis")?,
            inputs.get("map")?,
            params,
            ctx.par,
        )
        .map_err(FmapError::into_node)?;
        Ok(Outputs::new().with("points", p).with("map", m))
    }
}

#[cfg(test)]
#[path = "point_map_test.rs"]
mod tests;
