//! `spectral.eigenbasis`: the k smallest eigenpairs of the generalized problem `L φ = λ M φ`
//! (thesis §2.3; the basis of the functional maps of §2.6.3 and §5.2, Ovsjanikov et al. 2012).
//!
//! Method: block shift-invert Lanczos with full reorthogonalisation and thick restarts
//! (Krylov–Schur style; Grimes, Lewis, Simon 1994 for the shift-invert block Lanczos idea,
//! Stewart 2001 for Krylov–Schur restarts). The operator is `S = (L − σM)⁻¹ M`, self-adjoint
//! in the M-inner product, whose eigenvalues `θ = 1 / (λ − σ)` largest in magnitude belong to
//! the λ nearest σ. `L − σM` is factorised once ([`SpdSolver`]: sparse Cholesky, or `L D Lᵀ`
//! for a shift inside the spectrum); each Lanczos step solves for a whole block of `b`
//! right-hand sides. A block (rather than a single vector) is what finds every copy of a
//! repeated eigenvalue (the icosphere's multiplicities 1, 3, 5, …, a disconnected mesh's
//! zeros): `b` copies at once, further ones as rounding brings them in (the icosphere tests
//! find all 11 copies of l = 5 with blocks of 4). Each new block is orthogonalised against the
//! two newest blocks, then once against the whole basis, and again only when that pass removed
//! much of it (Daniel, Gragg, Kaufman, Stewart 1976).
//!
//! The shift: for k ≥ 16 it lies inside the wanted part of the spectrum, at `inner_shift`
//! (default 0.4) times Weyl's estimate `4πk / area` of λ_k (the counting function of a
//! surface grows as area · λ / 4π). The relative gap `(λ_{k+1} − λ_k) / (λ_k − σ)` that sets
//! the convergence at the upper end of the wanted pairs is then about 1/(1 − 0.4) ≈ 1.7 times
//! that with σ near 0, and the wanted pairs below σ sit apart at the negative end of θ, where
//! nothing unwanted competes (cgal_bunny00 at k = 20 / 60 / 120: 96 / 192 / 384 solves instead
//! of 112 / 232 / 464). `L − σM` is then
//! indefinite and is factorised as `L D Lᵀ` without pivoting ([`SpdSolver::new_indefinite`]);
//! its negative pivots count the eigenvalues below σ (Sylvester's law of inertia), ν. Ritz
//! pairs are ranked by their distance to σ; the k nearest contain the k smallest exactly
//! when ν of them lie below σ, which is checked once they have converged (else more pairs
//! are taken). Where more than 0.7 k eigenvalues lie below σ (Weyl's law undercounts the low
//! spectrum of thin shapes: cgal_camel at k = 20), σ is halved, twice at most (a numeric
//! refactorisation each). Where that does not help, the factorisation fails, or the wanted
//! pairs outgrow the basis, the solver starts over (same symbolic analysis) with the shift
//! below the spectrum, `σ = −shift · n / area` (`n / area` is the scale of the largest eigenvalues, so this is a
//! tiny fraction of the spectrum at any mesh size or unit; not tinier than needed, default
//! 1e-5: the zero eigenvalue's `θ = 1/|σ|` sets the rounding level of the projected
//! problem, and a huge `θ` would blur the small ones). That shift is also the one for k < 16.
//! The reported eigenvalues are the Rayleigh quotients `φᵀ L φ / φᵀ M φ` of the final
//! vectors (error quadratic in the vector error), sorted ascending.
//!
//! Convergence: a Ritz pair `(θ, y)` is accepted when `‖S y − θ y‖_M ≤ tol · |θ|` (read off the
//! Lanczos coupling block, no extra solve). The output reports the true backward errors
//! `‖L φ − λ M φ‖ / ((‖L‖₁ + |λ| ‖M‖₁) ‖φ‖)` and the M-orthonormality error
//! `max |Φᵀ M Φ − I|`.
//!
//! Small problems (`n` not larger than twice the Krylov space) are solved densely
//! (nalgebra's symmetric eigensolver on `M^{-1/2} L M^{-1/2}`).
//!
//! Vertices with zero mass (not referenced by any triangle) are left out of the problem:
//! their entries in every eigenvector are 0.
//!
//! Determinism: the start block comes from a seeded SplitMix64 stream; dense block products
//! are split in fixed row chunks whose partial sums are added in chunk order; sparse solves
//! give each column the same bits however columns are grouped. `Par::Seq` and `Par::Rayon`
//! give the same bits. Each eigenvector's sign is fixed: its entry of largest magnitude is
//! positive.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};

use crate::laplacian::LaplacianOperator;
use crate::sparse::{CsrMatrix, SparseError, SpdSolver};

/// Parameters of `spectral.eigenbasis`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EigenbasisParams {
    /// Number of eigenpairs (default 60, range 1..=2000).
    pub k: usize,
    /// Relative shift: σ = −shift · n / area (default 1e-5, range 1e-9..=1e-2). Below 1e-9 the
    /// zero eigenvalue's θ = 1/|σ| swamps the others in rounding (on a 642-vertex sphere,
    /// residuals of 1.1e-8 at 1e-10 and 6e-7 at 1e-12).
    pub shift: f64,
    /// Shift into the spectrum (module docs): σ = inner_shift · 4πk / area, this fraction
    /// of Weyl's estimate of λ_k, for k ≥ 16 (default 0.4, range 0..=0.9; 0 keeps the
    /// shift below the spectrum).
    pub inner_shift: f64,
    /// Ritz pairs are accepted when ‖S y − θ y‖_M ≤ tol · |θ| (default 1e-9, range
    /// 1e-14..=1e-4).
    pub tol: f64,
    /// Block size; 0 chooses it from k (default 0, range 0..=256).
    pub block: usize,
    /// Largest Krylov basis before a thick restart; 0 chooses max(2k + 2·block, k + 4·block)
    /// (default 0, range 0..=10000).
    pub subspace: usize,
    /// Most block Lanczos steps before giving up (default 1000, range 1..=100000).
    pub max_steps: usize,
    /// Seed of the random start block (default 0).
    pub seed: u64,
}

impl Default for EigenbasisParams {
    fn default() -> Self {
        EigenbasisParams {
            k: 60,
            shift: 1e-5,
            inner_shift: 0.4,
            tol: 1e-9,
            block: 0,
            subspace: 0,
            max_steps: 1000,
            seed: 0,
        }
    }
}

impl Validate for EigenbasisParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "k", self.k, 1, 2000);
        check_range(&mut issues, "shift", self.shift, 1e-9, 1e-2);
        check_range(&mut issues, "inner_shift", self.inner_shift, 0.0, 0.9);
        check_range(&mut issues, "tol", self.tol, 1e-14, 1e-4);
        check_range(&mut issues, "block", self.block, 0, 256);
        check_range(&mut issues, "subspace", self.subspace, 0, 10_000);
        if self.subspace > 0 && self.subspace < self.k + 2 * self.block.max(1) {
            issues.push(ParamIssue::new(
                "subspace",
                format!(
                    "{} is below k + 2·block = {}",
                    self.subspace,
                    self.k + 2 * self.block.max(1)
                ),
            ));
        }
        check_range(&mut issues, "max_steps", self.max_steps, 1, 100_000);
        issues
    }
}

/// The k smallest eigenpairs of `L φ = λ M φ`, M-orthonormal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EigenBasis {
    /// Number of vertices (rows of each eigenvector).
    pub n: usize,
    /// Eigenvalues, ascending.
    pub values: Vec<f64>,
    /// Eigenvectors, `n × k` column-major: vector `i` is `vectors[i·n .. (i+1)·n]`.
    pub vectors: Vec<f64>,
    /// The lumped mass diagonal the basis is orthonormal for (`Φᵀ M Φ = I`).
    pub mass: Vec<f64>,
    /// Largest backward error `‖L φ − λ M φ‖ / ((‖L‖₁ + |λ| ‖M‖₁) ‖φ‖)` over the pairs.
    pub max_residual: f64,
    /// `max |Φᵀ M Φ − I|`.
    pub max_orthonormality_error: f64,
    /// Sparse solves (right-hand sides) used.
    pub solves: usize,
    /// The shift σ of the operator `(L − σM)⁻¹ M` the pairs came from: inside the spectrum
    /// (positive) or just below it (module docs); 0 when the problem was solved densely.
    pub shift: f64,
}

impl EigenBasis {
    /// Number of eigenpairs.
    pub fn k(&self) -> usize {
        self.values.len()
    }
    /// Eigenvector `i`.
    pub fn vector(&self, i: usize) -> &[f64] {
        &self.vectors[i * self.n..(i + 1) * self.n]
    }
}

/// Errors of [`eigenbasis`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EigenbasisError {
    #[error("the operator has {n_mass} masses but the stiffness matrix is {rows}×{cols}")]
    SizeMismatch {
        n_mass: usize,
        rows: usize,
        cols: usize,
    },
    #[error("vertex {vertex} has mass {mass}: masses must be finite and not negative")]
    BadMass { vertex: usize, mass: f64 },
    #[error("k = {k} eigenpairs asked but the mesh has only {n} vertices with mass")]
    TooFewVertices { k: usize, n: usize },
    #[error(
        "only {converged} of {k} eigenpairs converged in {steps} block steps (worst relative \
         Ritz residual {worst:e}); raise max_steps or tol"
    )]
    NotConverged {
        converged: usize,
        k: usize,
        steps: usize,
        worst: f64,
    },
    #[error("the Krylov basis lost rank at block step {step}")]
    Breakdown { step: usize },
    #[error("the shifted matrix L − σM could not be factorised: {0}")]
    Factorization(#[from] SparseError),
    #[error("cancelled")]
    Cancelled,
}

/// SplitMix64: a seeded, portable stream for the start block.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    fn symmetric(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (2.0 / (1u64 << 53) as f64) - 1.0
    }
}

/// Rows per piece of a dense block product: fixed, so sums do not depend on thread count.
const ROW_CHUNK: usize = 2048;

fn mref(v: &[f64], rows: usize, cols: usize) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(v, rows, cols)
}

/// `Aᵀ D B` for column-major `A` (n × p), `B` (n × q) and an optional diagonal `D`: partial
/// products over fixed row chunks, summed in chunk order, so the bits do not depend on the
/// thread count. Returns p × q column-major (zeros when n = 0).
pub fn at_d_b(
    a: &[f64],
    p: usize,
    d: Option<&[f64]>,
    b: &[f64],
    q: usize,
    n: usize,
    par: Par,
) -> Vec<f64> {
    let chunks = n.div_ceil(ROW_CHUNK);
    // Computed as (D B)ᵀ A, q × p, per chunk: with the wide basis `A` as the right operand
    // faer streams it without repacking, several times faster than Aᵀ (D B) for the
    // n × 256 by n × 8 products of the Lanczos steps.
    let parts = par.map_collect(chunks, |c| {
        let r0 = c * ROW_CHUNK;
        let len = ROW_CHUNK.min(n - r0);
        let am = mref(a, n, p).subrows(r0, len);
        let mut out = Mat::<f64>::zeros(q, p);
        match d {
            None => {
                let bm = mref(b, n, q).subrows(r0, len);
                matmul(
                    out.as_mut(),
                    Accum::Replace,
                    bm.transpose(),
                    am,
                    1.0,
                    faer::Par::Seq,
                );
            }
            Some(d) => {
                let d = &d[r0..r0 + len];
                let mut db = Vec::with_capacity(len * q);
                for j in 0..q {
                    let bj = &b[j * n + r0..j * n + r0 + len];
                    db.extend(d.iter().zip(bj).map(|(di, bi)| di * bi));
                }
                matmul(
                    out.as_mut(),
                    Accum::Replace,
                    mref(&db, len, q).transpose(),
                    am,
                    1.0,
                    faer::Par::Seq,
                );
            }
        }
        out
    });
    let mut sum = vec![0.0; p * q];
    for part in parts {
        for j in 0..q {
            for i in 0..p {
                sum[j * p + i] += part[(j, i)];
            }
        }
    }
    sum
}

/// `Y = beta · Y + s · A X` with `s = 1` when `beta == 0` (Y overwritten) and `s = −1`
/// otherwise, written straight into `Y` (n × q column-major) over fixed row chunks, with no
/// temporaries. Each output row depends only on its own chunk: the bits do not depend on
/// the thread count.
#[allow(clippy::too_many_arguments)]
fn a_x_into(
    y: &mut [f64],
    beta: f64,
    a: &[f64],
    p: usize,
    x: &[f64],
    q: usize,
    n: usize,
    par: Par,
) {
    let chunks = n.div_ceil(ROW_CHUNK);
    let yp = SendPtr(y.as_mut_ptr());
    let body = |c: usize| {
        let r0 = c * ROW_CHUNK;
        let len = ROW_CHUNK.min(n - r0);
        let am = mref(a, n, p).subrows(r0, len);
        // SAFETY: chunks are disjoint row ranges of the n × q column-major `y`, which
        // outlives this call; each task writes only its own rows.
        let ym =
            unsafe { faer::MatMut::from_raw_parts_mut(yp.get().add(r0), len, q, 1, n as isize) };
        let (accum, alpha) = if beta == 0.0 {
            (Accum::Replace, 1.0)
        } else {
            (Accum::Add, -1.0)
        };
        matmul(ym, accum, am, mref(x, p, q), alpha, faer::Par::Seq);
    };
    if beta == 0.0 {
        par.for_each(chunks, body);
    } else {
        // An update right after a product over the same rows: last chunks first, while
        // they are still in cache from that product's end.
        par.for_each(chunks, |c| body(chunks - 1 - c));
    }
}

/// A raw pointer that may cross threads (disjoint writes only, see [`a_x_into`]).
#[derive(Clone, Copy)]
struct SendPtr(*mut f64);
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}
impl SendPtr {
    fn get(self) -> *mut f64 {
        self.0
    }
}

/// `W −= V C` in place (V: n × p, C: p × q, W: n × q).
fn sub_a_x(w: &mut [f64], v: &[f64], p: usize, c: &[f64], q: usize, n: usize, par: Par) {
    a_x_into(w, 1.0, v, p, c, q, n, par);
}

/// Symmetric eigen-decomposition of a small dense matrix (column-major, symmetrised), with
/// eigenvalues sorted descending (ties by index) and the vectors in the same order.
fn sym_eig_desc(h: &[f64], m: usize) -> (Vec<f64>, Vec<f64>) {
    let a = Mat::<f64>::from_fn(m, m, |i, j| 0.5 * (h[j * m + i] + h[i * m + j]));
    let mut s = faer::diag::Diag::<f64>::zeros(m);
    let mut u = Mat::<f64>::zeros(m, m);
    let fpar = faer::Par::Seq;
    let mut mem = MemBuffer::new(faer::linalg::evd::self_adjoint_evd_scratch::<f64>(
        m,
        faer::linalg::evd::ComputeEigenvectors::Yes,
        fpar,
        Default::default(),
    ));
    let ok = faer::linalg::evd::self_adjoint_evd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        fpar,
        MemStack::new(&mut mem),
        Default::default(),
    );
    if ok.is_err() {
        // faer's tridiagonal QR did not converge (not seen in practice): fall back to
        // nalgebra's symmetric eigensolver on the same matrix.
        let e = nalgebra::DMatrix::<f64>::from_fn(m, m, |i, j| a[(i, j)]).symmetric_eigen();
        for i in 0..m {
            s[i] = e.eigenvalues[i];
            for r in 0..m {
                u[(r, i)] = e.eigenvectors[(r, i)];
            }
        }
    }
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&i, &j| s[j].total_cmp(&s[i]).then(i.cmp(&j)));
    let vals = order.iter().map(|&i| s[i]).collect();
    let mut vecs = vec![0.0; m * m];
    for (c, &i) in order.iter().enumerate() {
        for r in 0..m {
            vecs[c * m + r] = u[(r, i)];
        }
    }
    (vals, vecs)
}

/// M-orthonormalises the columns of `w` (n × q): [`svqb_once`], and where its Gram matrix is
/// too ill-conditioned for that (it squares the condition number: with a small shift the
/// constant vector can dominate every column of a block by 1e9 and more), modified
/// Gram–Schmidt first, column by column, then SVQB on the result. Returns the q × q factor
/// `R` with `W_old = W_new R`, or `None` when the block is rank deficient (a column keeps
/// less than 1e-13 of its norm; `w` is then left part-way, and the caller gives the run up).
fn svqb(w: &mut [f64], q: usize, mass: &[f64], n: usize, par: Par) -> Option<Vec<f64>> {
    if let Some(r) = svqb_once(w, q, mass, n, par) {
        return Some(r);
    }
    let mut r1 = vec![0.0; q * q];
    for j in 0..q {
        let (done, rest) = w.split_at_mut((j + 1) * n);
        let col = &mut done[j * n..];
        let norm = at_d_b(col, 1, Some(mass), col, 1, n, par)[0].sqrt();
        // The column's norm before the projections: what it had in the earlier directions.
        let before = r1[j * q..j * q + j].iter().map(|x| x * x).sum::<f64>() + norm * norm;
        if !(norm.is_finite() && norm > 1e-13 * before.sqrt()) {
            return None;
        }
        col.iter_mut().for_each(|x| *x /= norm);
        r1[j * q + j] = norm;
        let later = q - j - 1;
        if later > 0 {
            let c = orthogonalize(&mut rest[..later * n], later, col, 1, mass, n, par);
            for (i, &cij) in c.iter().enumerate() {
                r1[(j + 1 + i) * q + j] = cij;
            }
        }
    }
    let r2 = svqb_once(w, q, mass, n, par)?;
    Some(small_product(&r2, &r1, q))
}

/// One SVQB pass (Stathopoulos & Wu 2002): `G = Wᵀ M W = U D Uᵀ`, `W ← W U D^{-1/2}`;
/// `None` (and `w` untouched) when `G` has an eigenvalue below 1e-26 of its largest.
fn svqb_once(w: &mut [f64], q: usize, mass: &[f64], n: usize, par: Par) -> Option<Vec<f64>> {
    let g = at_d_b(w, q, Some(mass), w, q, n, par);
    let (d, u) = sym_eig_desc(&g, q);
    let dmax = d.first().copied().unwrap_or(0.0);
    // NaN-safe: a NaN fails `is_finite` or the comparison.
    let tiny = |x: f64| x.is_nan() || x <= 1e-26 * dmax;
    if !dmax.is_finite() || dmax <= 0.0 || d.iter().any(|&x| tiny(x)) {
        return None;
    }
    // T = U D^{-1/2}: W ← W T; R = D^{1/2} Uᵀ.
    let mut t = u.clone();
    let mut r = vec![0.0; q * q];
    for j in 0..q {
        let s = d[j].sqrt();
        for i in 0..q {
            t[j * q + i] /= s;
            // R[j, i] = sqrt(d_j) U[i, j]
            r[i * q + j] = s * u[j * q + i];
        }
    }
    mul_right_in_place(w, q, &t, n, par);
    Some(r)
}

/// `W ← W T` for a column-major n × q `W` and a q × q `T`, one row chunk at a time (no
/// n × q temporary: a fresh one per call costs page faults on every Lanczos step).
fn mul_right_in_place(w: &mut [f64], q: usize, t: &[f64], n: usize, par: Par) {
    let chunks = n.div_ceil(ROW_CHUNK);
    let wp = SendPtr(w.as_mut_ptr());
    let body = |c: usize| {
        let r0 = c * ROW_CHUNK;
        let len = ROW_CHUNK.min(n - r0);
        // SAFETY: chunks are disjoint row ranges of the n × q column-major `w`, which
        // outlives this call; each task reads and writes only its own rows.
        let mut wm =
            unsafe { faer::MatMut::from_raw_parts_mut(wp.get().add(r0), len, q, 1, n as isize) };
        let mut tmp = Mat::<f64>::zeros(len, q);
        matmul(
            tmp.as_mut(),
            Accum::Replace,
            wm.as_ref(),
            mref(t, q, q),
            1.0,
            faer::Par::Seq,
        );
        wm.copy_from(&tmp);
    };
    par.for_each(chunks, body);
}

/// `C = Vᵀ M W` and `W −= V C` (one classical Gram–Schmidt pass); returns C (p × q). The
/// caller runs it twice with a normalisation in between ("twice is enough").
fn orthogonalize(
    w: &mut [f64],
    q: usize,
    v: &[f64],
    p: usize,
    mass: &[f64],
    n: usize,
    par: Par,
) -> Vec<f64> {
    let c = at_d_b(v, p, Some(mass), w, q, n, par);
    sub_a_x(w, v, p, &c, q, n, par);
    c
}

/// The k smallest eigenpairs of `op` (module docs).
pub fn eigenbasis(
    op: &LaplacianOperator,
    params: &EigenbasisParams,
    par: Par,
) -> Result<EigenBasis, EigenbasisError> {
    eigenbasis_with_cancel(op, params, par, &|| false)
}

/// [`eigenbasis`] polling `cancelled` between block steps.
pub fn eigenbasis_with_cancel(
    op: &LaplacianOperator,
    params: &EigenbasisParams,
    par: Par,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Result<EigenBasis, EigenbasisError> {
    // Every Lanczos step runs several short parallel loops: started from a pool thread, that
    // thread works on them too instead of waiting for the pool to wake up.
    par.install(|| eigenbasis_on(op, params, par, cancelled))
}

fn eigenbasis_on(
    op: &LaplacianOperator,
    params: &EigenbasisParams,
    par: Par,
    cancelled: &(dyn Fn() -> bool + Sync),
) -> Result<EigenBasis, EigenbasisError> {
    let n_all = op.mass.len();
    let l_all = &op.stiffness;
    if l_all.nrows() != n_all || l_all.ncols() != n_all {
        return Err(EigenbasisError::SizeMismatch {
            n_mass: n_all,
            rows: l_all.nrows(),
            cols: l_all.ncols(),
        });
    }
    l_all.check()?;
    if let Some((vertex, &mass)) = op
        .mass
        .iter()
        .enumerate()
        .find(|(_, m)| !(m.is_finite() && **m >= 0.0))
    {
        return Err(EigenbasisError::BadMass { vertex, mass });
    }
    // Active vertices: those with mass.
    let active: Vec<usize> = (0..n_all).filter(|&i| op.mass[i] > 0.0).collect();
    let n = active.len();
    let k = params.k;
    if k == 0 || k > n {
        return Err(EigenbasisError::TooFewVertices { k, n });
    }
    let (l, mass) = if n == n_all {
        (l_all.clone(), op.mass.clone())
    } else {
        let mut new_index = vec![usize::MAX; n_all];
        for (j, &i) in active.iter().enumerate() {
            new_index[i] = j;
        }
        let mut trip = Vec::with_capacity(l_all.nnz());
        for (j, &i) in active.iter().enumerate() {
            for (c, v) in l_all.row(i) {
                if new_index[c] != usize::MAX {
                    trip.push((j, new_index[c], v));
                }
            }
        }
        (
            CsrMatrix::from_triplets(n, n, &trip)?,
            active.iter().map(|&i| op.mass[i]).collect(),
        )
    };
    let area: f64 = mass.iter().sum();
    let sigma = -params.shift * n as f64 / area;

    let block = if params.block > 0 {
        params.block
    } else {
        // Measured on 37k–115k-vertex meshes: small blocks need fewer solves and sweep the
        // basis less; past k ≈ 150 larger blocks win (fewer, wider block steps).
        (k / 16).next_power_of_two().clamp(4, 32)
    };
    let m_max = if params.subspace > 0 {
        params.subspace.max(k + 2 * block)
    } else {
        (2 * k + 2 * block).max(k + 4 * block)
    };

    let mut solves = 0usize;
    let (vectors, shift) = if n <= 2 * (m_max + block) {
        (dense_eig(&l, &mass, k).1, 0.0)
    } else {
        let shifted = |s: f64| l.add_diagonal(&mass.iter().map(|m| -s * m).collect::<Vec<_>>());
        let mut run = |solver: &SpdSolver, sigma: f64| {
            lanczos(
                solver,
                &mass,
                sigma,
                k,
                block,
                m_max,
                params,
                par,
                cancelled,
                &mut solves,
            )
        };
        // Shifted into the spectrum (k ≥ 16 only: below that the gain is small), with the
        // shift below the spectrum when that attempt gives up.
        let mut found = None;
        let mut solver = None;
        let mut inner = params.inner_shift * 4.0 * std::f64::consts::PI * k as f64 / area;
        if k >= 16 && inner > 0.0 && inner.is_finite() {
            if let Ok(mut s) = SpdSolver::new_indefinite(&shifted(inner)?, par) {
                // Weyl's law undercounts the low eigenvalues of thin shapes (a camel's legs
                // and neck): with more than 0.7 k below σ, σ is halved (a numeric
                // refactorisation: the pattern is the same), twice at most.
                let mut factored = true;
                for _ in 0..2 {
                    if 10 * s.negative_pivots() <= 7 * k {
                        break;
                    }
                    inner *= 0.5;
                    factored = s.refactor(&shifted(inner)?, par).is_ok();
                    if !factored {
                        break;
                    }
                }
                if factored && 10 * s.negative_pivots() <= 7 * k {
                    found = match run(&s, inner) {
                        Ok(v) => v.map(|v| (v, inner)),
                        // A block that loses rank there is retried below the spectrum too.
                        Err(EigenbasisError::Breakdown { .. }) => None,
                        Err(e) => return Err(e),
                    };
                }
                // Below the spectrum the same symbolic analysis serves (L D Lᵀ of a positive
                // definite matrix: every pivot positive).
                solver = Some(s);
            }
        }
        match found {
            Some(f) => f,
            None => {
                let a = shifted(sigma)?;
                let s = match solver {
                    Some(mut s) => {
                        s.refactor(&a, par)?;
                        s
                    }
                    None => SpdSolver::new(&a, par)?,
                };
                (
                    run(&s, sigma)?.ok_or(EigenbasisError::Breakdown { step: 0 })?,
                    sigma,
                )
            }
        }
    };

    // Rayleigh quotients, ascending order (ties keep the solver's order).
    let lv = l.mul_dense(&vectors, k, par)?;
    let rq: Vec<f64> = par.map_collect(k, |i| {
        let x = &vectors[i * n..(i + 1) * n];
        let (mut num, mut den) = (0.0, 0.0);
        for j in 0..n {
            num += x[j] * lv[i * n + j];
            den += x[j] * mass[j] * x[j];
        }
        num / den
    });
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|&a, &b| rq[a].total_cmp(&rq[b]).then(a.cmp(&b)));
    let values: Vec<f64> = order.iter().map(|&i| rq[i]).collect();

    // Signs: the largest entry of each vector is positive.
    let sign: Vec<f64> = par.map_collect(k, |i| {
        let col = &vectors[i * n..(i + 1) * n];
        let mut best = 0usize;
        for (j, x) in col.iter().enumerate() {
            if x.abs() > col[best].abs() {
                best = j;
            }
        }
        if col[best] < 0.0 {
            -1.0
        } else {
            1.0
        }
    });
    let (full, max_residual, max_orthonormality_error) = if n == n_all {
        // The quality figures depend neither on the order nor on the signs (negation is
        // exact): they come from the solver's vectors and `lv` as they are, then the
        // vectors are sorted and signed in place (no n × k copy).
        let (res, orth) = quality_with_product(l_all, &op.mass, &rq, &vectors, &lv, par);
        let mut vectors = vectors;
        permute_columns(&mut vectors, n, &order);
        let signs: Vec<f64> = order.iter().map(|&src| sign[src]).collect();
        let body = |(col, &s): (&mut [f64], &f64)| {
            if s < 0.0 {
                col.iter_mut().for_each(|x| *x = -*x);
            }
        };
        match par {
            Par::Seq => vectors.chunks_mut(n).zip(&signs).for_each(body),
            Par::Rayon => vectors.par_chunks_mut(n).zip(&signs).for_each(body),
        }
        (vectors, res, orth)
    } else {
        // Scatter back to all vertices.
        let mut full = vec![0.0; n_all * k];
        for (i, &src) in order.iter().enumerate() {
            let col = &vectors[src * n..(src + 1) * n];
            let dest = &mut full[i * n_all..(i + 1) * n_all];
            for (j, &a) in active.iter().enumerate() {
                dest[a] = sign[src] * col[j];
            }
        }
        let (res, orth) = quality(l_all, &op.mass, &values, &full, par)?;
        (full, res, orth)
    };
    Ok(EigenBasis {
        n: n_all,
        values,
        vectors: full,
        mass: op.mass.clone(),
        max_residual,
        max_orthonormality_error,
        solves,
        shift,
    })
}

/// Reorders the columns of a column-major `n × k` block in place: column `i` becomes the old
/// column `order[i]` (`order` a permutation). Columns already in place are not touched.
fn permute_columns(x: &mut [f64], n: usize, order: &[usize]) {
    let mut done = vec![false; order.len()];
    let mut tmp = Vec::new();
    for start in 0..order.len() {
        if done[start] || order[start] == start {
            continue;
        }
        tmp.clear();
        tmp.extend_from_slice(&x[start * n..(start + 1) * n]);
        let mut j = start;
        loop {
            done[j] = true;
            let src = order[j];
            if src == start {
                x[j * n..(j + 1) * n].copy_from_slice(&tmp);
                break;
            }
            x.copy_within(src * n..(src + 1) * n, j * n);
            j = src;
        }
    }
}

/// Backward errors and M-orthonormality of a basis (module docs).
pub fn quality(
    l: &CsrMatrix,
    mass: &[f64],
    values: &[f64],
    vectors: &[f64],
    par: Par,
) -> Result<(f64, f64), SparseError> {
    let lx = l.mul_dense(vectors, values.len(), par)?;
    Ok(quality_with_product(l, mass, values, vectors, &lx, par))
}

/// [`quality`] with the product `L Φ` given.
fn quality_with_product(
    l: &CsrMatrix,
    mass: &[f64],
    values: &[f64],
    vectors: &[f64],
    lx: &[f64],
    par: Par,
) -> (f64, f64) {
    let n = mass.len();
    let k = values.len();
    let norm_l = l.norm1();
    let norm_m = mass.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let res = par.map_collect(k, |i| {
        let x = &vectors[i * n..(i + 1) * n];
        let lxi = &lx[i * n..(i + 1) * n];
        let mut r2 = 0.0;
        let mut x2 = 0.0;
        for j in 0..n {
            let r = lxi[j] - values[i] * mass[j] * x[j];
            r2 += r * r;
            x2 += x[j] * x[j];
        }
        r2.sqrt() / ((norm_l + values[i].abs() * norm_m) * x2.sqrt() + 1e-300)
    });
    let g = at_d_b(vectors, k, Some(mass), vectors, k, n, par);
    let mut orth: f64 = 0.0;
    for j in 0..k {
        for i in 0..k {
            let e = if i == j { 1.0 } else { 0.0 };
            orth = orth.max((g[j * k + i] - e).abs());
        }
    }
    (res.into_iter().fold(0.0, f64::max), orth)
}

/// Dense path for small problems: eigen-decomposition of `M^{-1/2} L M^{-1/2}`.
fn dense_eig(l: &CsrMatrix, mass: &[f64], k: usize) -> (Vec<f64>, Vec<f64>) {
    let n = mass.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
    for i in 0..n {
        for (j, v) in l.row(i) {
            a[(i, j)] = v / (mass[i] * mass[j]).sqrt();
        }
    }
    let at = a.transpose();
    a = (a + at) * 0.5;
    let e = a.symmetric_eigen();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| {
        e.eigenvalues[i]
            .total_cmp(&e.eigenvalues[j])
            .then(i.cmp(&j))
    });
    let mut vals = Vec::with_capacity(k);
    let mut vecs = vec![0.0; n * k];
    for (c, &i) in order.iter().take(k).enumerate() {
        vals.push(e.eigenvalues[i]);
        for r in 0..n {
            vecs[c * n + r] = e.eigenvectors[(r, i)] / mass[r].sqrt();
        }
    }
    (vals, vecs)
}

/// Block shift-invert Lanczos with full reorthogonalisation and thick restarts on the
/// factorisation `solver` of `L − σM`; `solves` counts the right-hand sides solved.
///
/// When σ lies in the spectrum, the factorisation's negative pivots count the eigenvalues
/// below it (ν, Sylvester's law of inertia). The Ritz pairs are ranked by distance to σ
/// (|θ| descending, as below the spectrum); once the `nw` nearest (first k) have converged,
/// they hold the k smallest eigenvalues exactly when ν of them lie below σ, else `nw` grows.
/// Returns `None` (the caller shifts below the spectrum instead) when `nw` would outgrow the
/// basis.
#[allow(clippy::too_many_arguments)]
fn lanczos(
    solver: &SpdSolver,
    mass: &[f64],
    sigma: f64,
    k: usize,
    b: usize,
    m_max: usize,
    params: &EigenbasisParams,
    par: Par,
    cancelled: &(dyn Fn() -> bool + Sync),
    solves: &mut usize,
) -> Result<Option<Vec<f64>>, EigenbasisError> {
    let n = mass.len();
    // Eigenvalues below σ (none when σ is below the spectrum).
    let below = solver.negative_pivots();
    // Ritz pairs that must converge: the k nearest σ, more if they miss some below it.
    let mut nw = k;
    let cap = m_max + b;
    // Basis V (n × cap), H (cap × cap) column-major.
    let mut v = vec![0.0; n * cap];
    let mut h = vec![0.0; cap * cap];
    let mut rng = SplitMix64(params.seed ^ 0x005E_ED0F_C0DE);
    {
        let start = &mut v[..n * b];
        for x in start.iter_mut() {
            *x = rng.symmetric();
        }
        if svqb(start, b, mass, n, par).is_none() {
            return Err(EigenbasisError::Breakdown { step: 0 });
        }
    }
    // Columns 0..m form the basis; columns m..m+b hold the pending block, and its expansion
    // is computed in place in the b columns after it (m + b ≤ m_max holds at every step:
    // a step that leaves it larger restarts).
    let mut m = 0usize;
    let mut just_restarted = true;
    let mut steps = 0usize;
    // Ritz vectors of the restarts and of the result, one buffer for all (a fresh n × k
    // block per restart costs page faults).
    let mut ritz: Vec<f64> = Vec::new();
    loop {
        if cancelled() {
            return Err(EigenbasisError::Cancelled);
        }
        // Expand the pending block: W = S V_J = (L − σM)⁻¹ M V_J.
        let j0 = m;
        let times_mass = |(wc, vc): (&mut [f64], &[f64])| {
            for ((wi, &vi), &mi) in wc.iter_mut().zip(vc).zip(mass) {
                *wi = mi * vi;
            }
        };
        let p = m + b;
        let (basis, rest) = v.split_at_mut(n * p);
        let w = &mut rest[..n * b];
        let pending = &basis[j0 * n..];
        match par {
            Par::Seq => w
                .chunks_exact_mut(n)
                .zip(pending.chunks_exact(n))
                .for_each(times_mass),
            Par::Rayon => w
                .par_chunks_exact_mut(n)
                .zip(pending.par_chunks_exact(n))
                .for_each(times_mass),
        }
        solver.solve_many(w, b, par)?;
        *solves += b;
        steps += 1;
        // Block Gram–Schmidt with W_orig = V C + Q R kept exact through every pass. In exact
        // arithmetic S V_J only touches the two newest blocks (the Lanczos recurrence), so
        // the first pass runs against them alone and one pass against the whole basis
        // removes what rounding left elsewhere; a pass that still shrinks the block by more
        // than 1/√2 is repeated (Daniel, Gragg, Kaufman, Stewart 1976). Right after a thick
        // restart the pending block couples to every kept Ritz vector: then both passes run
        // against the whole basis.
        let lo = if just_restarted {
            0
        } else {
            p.saturating_sub(2 * b)
        };
        let c_local = orthogonalize(w, b, &basis[n * lo..], p - lo, mass, n, par);
        let mut c_acc = vec![0.0; p * b];
        for jj in 0..b {
            c_acc[jj * p + lo..(jj + 1) * p]
                .copy_from_slice(&c_local[jj * (p - lo)..(jj + 1) * (p - lo)]);
        }
        let mut r_acc =
            svqb(w, b, mass, n, par).ok_or(EigenbasisError::Breakdown { step: steps })?;
        for pass in 0.. {
            let c = orthogonalize(w, b, basis, p, mass, n, par);
            let r = svqb(w, b, mass, n, par).ok_or(EigenbasisError::Breakdown { step: steps })?;
            // C += c R_acc; R_acc = r R_acc (all column-major).
            for jj in 0..b {
                for t in 0..b {
                    let f = r_acc[jj * b + t];
                    if f != 0.0 {
                        for i in 0..p {
                            c_acc[jj * p + i] += c[t * p + i] * f;
                        }
                    }
                }
            }
            r_acc = small_product(&r, &r_acc, b);
            // The block was M-orthonormal before this pass: R's smallest singular value is
            // how much of it survived.
            if pass >= 1 || min_singular_value(&r, b) >= std::f64::consts::FRAC_1_SQRT_2 {
                break;
            }
        }
        just_restarted = false;
        for jj in 0..b {
            h[(j0 + jj) * cap..(j0 + jj) * cap + p].copy_from_slice(&c_acc[jj * p..(jj + 1) * p]);
            h[(j0 + jj) * cap + p..(j0 + jj) * cap + p + b]
                .copy_from_slice(&r_acc[jj * b..(jj + 1) * b]);
        }
        m = p;

        // Rayleigh–Ritz costs a dense m × m eigensolve: run it on every other step, and
        // always before a restart (which needs it). A step more at the end costs less.
        if m < nw || (m + b <= m_max && steps % 2 == 1) {
            continue;
        }
        // Rayleigh–Ritz on the basis.
        let mut hm = vec![0.0; m * m];
        for jj in 0..m {
            hm[jj * m..(jj + 1) * m].copy_from_slice(&h[jj * cap..jj * cap + m]);
        }
        let (theta, y) = sym_eig_desc(&hm, m);
        // Nearest σ first: |θ| descending (θ < 0 only with σ inside the spectrum).
        let (theta, y) = if theta.iter().any(|&t| t < 0.0) {
            by_magnitude(&theta, &y, m)
        } else {
            (theta, y)
        };
        // Residual of Ritz pair i: ‖H[m..m+b, 0..m] y_i‖.
        let resid = |i: usize| -> f64 {
            let mut s2 = 0.0;
            for r in 0..b {
                let mut s = 0.0;
                for jj in 0..m {
                    s += h[jj * cap + m + r] * y[i * m + jj];
                }
                s2 += s * s;
            }
            s2.sqrt()
        };
        let rel: Vec<f64> = (0..nw)
            .map(|i| resid(i) / theta[i].abs().max(1e-300))
            .collect();
        let converged = rel.iter().take_while(|&&r| r <= params.tol).count();
        if converged == nw {
            let found_below = theta[..nw].iter().filter(|&&t| t < 0.0).count();
            if found_below < below {
                // Some eigenvalues below σ lie farther from it than the nearest nw: widen
                // (and restart below if the basis is full).
                nw += below - found_below + b;
                if nw + 2 * b > m_max {
                    return Ok(None);
                }
            } else {
                // The k smallest of the nw (all of them when nw = k): λ = σ + 1/θ. The
                // caller takes the Rayleigh quotients of the vectors as eigenvalues.
                let vals: Vec<f64> = theta[..nw].iter().map(|t| sigma + 1.0 / t).collect();
                let mut pick: Vec<usize> = (0..nw).collect();
                pick.sort_by(|&a, &c| vals[a].total_cmp(&vals[c]).then(a.cmp(&c)));
                pick.truncate(k);
                pick.sort_unstable();
                let ys: Vec<f64> = pick
                    .iter()
                    .flat_map(|&i| y[i * m..(i + 1) * m].iter().copied())
                    .collect();
                ritz.resize(n * k, 0.0);
                a_x_into(&mut ritz, 0.0, &v[..n * m], m, &ys, k, n, par);
                return Ok(Some(ritz));
            }
        }
        if steps >= params.max_steps {
            return Err(EigenbasisError::NotConverged {
                converged,
                k,
                steps,
                worst: rel.iter().fold(0.0, |a: f64, &b| a.max(b)),
            });
        }
        if m + b > m_max {
            // Thick restart: keep the `keep` best Ritz vectors and the pending block.
            let keep = (nw + b).min(m - b);
            ritz.resize(n * keep, 0.0);
            a_x_into(&mut ritz, 0.0, &v[..n * m], m, &y[..m * keep], keep, n, par);
            // Coupling of the pending block to the kept Ritz vectors: H[m.., 0..m] Y.
            let mut z = vec![0.0; b * keep];
            for i in 0..keep {
                for r in 0..b {
                    let mut s = 0.0;
                    for jj in 0..m {
                        s += h[jj * cap + m + r] * y[i * m + jj];
                    }
                    z[i * b + r] = s;
                }
            }
            // The pending block moves down first: keep + b ≤ m, so it never overlaps the
            // Ritz vectors' destination before it is read.
            v.copy_within(n * m..n * (m + b), n * keep);
            v[..n * keep].copy_from_slice(&ritz);
            h.iter_mut().for_each(|x| *x = 0.0);
            for i in 0..keep {
                h[i * cap + i] = theta[i];
                for r in 0..b {
                    h[i * cap + keep + r] = z[i * b + r];
                    h[(keep + r) * cap + i] = z[i * b + r];
                }
            }
            m = keep;
            just_restarted = true;
        }
    }
}

/// Ritz values and vectors (columns of the m × m `y`) reordered by |θ| descending, ties by
/// position.
fn by_magnitude(theta: &[f64], y: &[f64], m: usize) -> (Vec<f64>, Vec<f64>) {
    let mut order: Vec<usize> = (0..theta.len()).collect();
    order.sort_by(|&i, &j| theta[j].abs().total_cmp(&theta[i].abs()).then(i.cmp(&j)));
    let vals = order.iter().map(|&i| theta[i]).collect();
    let vecs = order
        .iter()
        .flat_map(|&i| y[i * m..(i + 1) * m].iter().copied())
        .collect();
    (vals, vecs)
}

/// `A B` for column-major q × q matrices.
fn small_product(a: &[f64], b: &[f64], q: usize) -> Vec<f64> {
    let mut out = vec![0.0; q * q];
    for j in 0..q {
        for t in 0..q {
            let f = b[j * q + t];
            for i in 0..q {
                out[j * q + i] += a[t * q + i] * f;
            }
        }
    }
    out
}

/// Smallest singular value of a column-major q × q matrix (square root of the smallest
/// eigenvalue of RᵀR).
fn min_singular_value(r: &[f64], q: usize) -> f64 {
    let mut rtr = vec![0.0; q * q];
    for j in 0..q {
        for i in 0..q {
            rtr[j * q + i] = (0..q).map(|t| r[i * q + t] * r[j * q + t]).sum();
        }
    }
    let (d, _) = sym_eig_desc(&rtr, q);
    d.last().copied().unwrap_or(0.0).max(0.0).sqrt()
}

/// Node wrapper of [`eigenbasis`].
pub struct EigenbasisNode;

impl NodeKind for EigenbasisNode {
    type Params = EigenbasisParams;
    const KIND: &'static str = "spectral.eigenbasis";
    const VERSION: u32 = 5;
    const DOC: &'static str = "The k smallest eigenpairs of the Laplace-Beltrami operator, \
        L phi = lambda M phi, M-orthonormal (thesis §2.3, §2.6.3; the basis of functional \
        maps, Ovsjanikov et al. 2012). Block shift-invert Lanczos with full \
        reorthogonalisation and thick restarts on a sparse factorisation of L - sigma M, sigma \
        inside the wanted spectrum for k >= 16 (inner_shift of Weyl's estimate of lambda_k; \
        its inertia checks that the k smallest were found); finds repeated eigenvalues. A \
        separate node so that downstream changes never recompute it. Output: an EigenBasis.";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<LaplacianOperator>(
            "operator",
            "stiffness L and mass M (spectral.laplacian)",
        )]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<EigenBasis>(
            "basis",
            "eigenvalues ascending and M-orthonormal eigenvectors (n × k column-major)",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let op = inputs.get::<LaplacianOperator>("operator")?;
        ctx.check_cancelled()?;
        let cancel = ctx.cancel.clone();
        let basis = eigenbasis_with_cancel(op, params, ctx.par, &move || cancel.is_cancelled())
            .map_err(|e| match e {
                EigenbasisError::Cancelled => NodeError::cancelled(),
                EigenbasisError::SizeMismatch { .. }
                | EigenbasisError::BadMass { .. }
                | EigenbasisError::TooFewVertices { .. } => {
                    NodeError::from_source(ErrorKind::InvalidInput, e)
                }
                _ => NodeError::from_source(ErrorKind::NumericalFailure, e),
            })?;
        if basis.max_residual > 1e-8 {
            ctx.warn(&format!(
                "largest relative residual {:e} exceeds 1e-8",
                basis.max_residual
            ));
        }
        Ok(Outputs::new().with("basis", basis))
    }
}

#[cfg(test)]
mod tests {
    use super::permute_columns;

    #[test]
    fn columns_follow_the_order_through_cycles_and_fixed_points() {
        let n = 3;
        // Column c holds c, c + 0.1, c + 0.2.
        let mut x: Vec<f64> = (0..6)
            .flat_map(|c| (0..n).map(move |r| c as f64 + 0.1 * r as f64))
            .collect();
        let order = [2, 0, 1, 3, 5, 4];
        permute_columns(&mut x, n, &order);
        for (i, &src) in order.iter().enumerate() {
            for r in 0..n {
                assert_eq!(x[i * n + r], src as f64 + 0.1 * r as f64, "column {i}");
            }
        }
    }
}
