//! Sparse matrices and the discrete Laplace–Beltrami operator (thesis §2.3), shared by the
//! node families that solve linear systems on meshes (spectral, smoothing, functional maps).
//!
//! - [`CsrMatrix`]: a compressed-sparse-row `f64` matrix with sorted, duplicate-free columns.
//!   For a symmetric matrix its arrays are also the compressed-sparse-column arrays.
//! - [`cotan_laplacian`] / [`lumped_mass`] (or [`laplacian_and_mass`] with options): the
//!   cotangent stiffness matrix in the positive semi-definite convention
//!   `L_ij = −½ (cot α_ij + cot β_ij)`, `L_ii = −Σ_j L_ij` (Pinkall & Polthier 1993; Meyer,
//!   Desbrun, Schröder, Barr 2003), and the lumped mass matrix (mixed Voronoi areas of Meyer et
//!   al. 2003 by default, the same as libigl's `massmatrix` default; barycentric as an option).
//! - [`SpdSolver`]: a sparse Cholesky factorisation (faer's AMD ordering and supernodal
//!   analysis, a multifrontal numeric factorisation of our own) of a symmetric positive
//!   definite matrix, whose symbolic analysis is reused by
//!   [`SpdSolver::refactor`] when only the values change (e.g. `M + t L` for a new `t`); or,
//!   built by [`SpdSolver::new_indefinite`], an `L D Lᵀ` factorisation of a symmetric
//!   indefinite one without pivoting, with its inertia.
//!
//! Degenerate triangles: cotangents are computed intrinsically from edge lengths. With
//! `mollify > 0` (default 1e-6) every edge length gets the same small δ ≥ 0, the least one for
//! which each triangle satisfies the triangle inequality with slack `mollify · mean edge
//! length` (the intrinsic mollification of Sharp & Crane 2020, "A Laplacian for nonmanifold
//! triangle meshes"); δ is 0 on meshes without near-degenerate triangles, which then get the
//! plain cotangent Laplacian. Whatever remains (e.g. `mollify = 0` on a zero-area triangle) is
//! caught by the cotangent clamp: a triangle with a cotangent beyond `±COT_CLAMP` (an angle below
//! about 1e-8 rad) contributes nothing to `L` (dropping it keeps `L` positive semi-definite,
//! clamping single cotangents would not): no NaN or infinity reaches the matrix.
//!
//! Determinism: assembly sums contributions in face order; the triangular solves give each
//! right-hand side the same operations whatever columns it is solved with; products split
//! work in fixed-size pieces that do not depend on the thread count, so `Par::Seq` and
//! `Par::Rayon` give the same bits. The solves and the fronts run an AVX2 copy of their code
//! where the processor has AVX2 (`with_avx2_copy!`), with the bits of the plain copy.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LdltRef, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::{amd, SupernodalThreshold};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Side};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crestflow_flow::Par;
use crestflow_geom::{MeshDefect, TriMesh};

/// Defines a function twice from one body: as written (`$name`), and on x86-64 compiled for
/// AVX2 (`$avx2`; closures inside inherit the feature). The default target is SSE2 only, where
/// the interleaved right-hand sides and front updates run two lanes wide; AVX2 runs four. Rust
/// never fuses or reorders floating-point operations, so both copies give the same bits (a
/// test compares them). Callers choose with [`avx2`]; the form `fn name => base / avx2(...)`
/// (free functions) also defines `name(simd, ...)`, which runs the AVX2 copy when `simd`.
macro_rules! with_avx2_copy {
    ($(#[$attr:meta])* fn $name:ident => $base:ident / $avx2:ident ($($arg:ident : $ty:ty),* $(,)?) -> $ret:ty $body:block) => {
        $(#[$attr])*
        fn $name(simd: bool, $($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if simd {
                // SAFETY: callers set `simd` only where the processor has AVX2.
                return unsafe { $avx2($($arg),*) };
            }
            let _ = simd;
            $base($($arg),*)
        }

        with_avx2_copy! { $(#[$attr])* fn $base / $avx2 ($($arg: $ty),*) -> $ret $body }
    };
    ($(#[$attr:meta])* fn $name:ident / $avx2:ident $(<const $g:ident : $gt:ty>)? ($($args:tt)*) $(-> $ret:ty)? $body:block) => {
        $(#[$attr])*
        fn $name $(<const $g: $gt>)? ($($args)*) $(-> $ret)? $body

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        $(#[$attr])*
        fn $avx2 $(<const $g: $gt>)? ($($args)*) $(-> $ret)? $body
    };
}

/// Whether this processor runs the AVX2 copies of [`with_avx2_copy`] (the standard library
/// caches the answer).
fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[path = "multifrontal.rs"]
mod multifrontal;

/// Largest absolute cotangent a triangle may have to enter the Laplacian (an angle of about
/// 1e-8 rad); beyond it the triangle is left out of `L` (module docs).
pub const COT_CLAMP: f64 = 1e8;

/// Columns solved together by one task in [`SpdSolver::solve_many`] (the width of the
/// interleaved right-hand-side block of the triangular solves).
const SOLVE_CHUNK: usize = 8;

/// Errors of sparse matrix construction, products and factorisation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SparseError {
    #[error("entry ({row}, {col}) is outside a {nrows}×{ncols} matrix")]
    IndexOutOfRange {
        row: usize,
        col: usize,
        nrows: usize,
        ncols: usize,
    },
    #[error("entry ({row}, {col}) is not finite ({value})")]
    NonFinite { row: usize, col: usize, value: f64 },
    #[error("malformed CSR arrays: {0}")]
    Malformed(String),
    #[error("the matrix is {nrows}×{ncols}, expected a square matrix")]
    NotSquare { nrows: usize, ncols: usize },
    #[error("dimension mismatch: {what} has length {got}, expected {expected}")]
    DimensionMismatch {
        what: &'static str,
        got: usize,
        expected: usize,
    },
    #[error(
        "the matrix is not numerically positive definite (Cholesky pivot {pivot} of {n} is not \
         positive)"
    )]
    NotPositiveDefinite { pivot: usize, n: usize },
    #[error("sparse factorisation failed: {0}")]
    Factorization(String),
}

/// A sparse `f64` matrix in compressed-sparse-row form: the columns of row `i` are
/// `col_idx[row_ptr[i]..row_ptr[i + 1]]`, strictly increasing, with their `values`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CsrMatrix {
    nrows: usize,
    ncols: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
}

impl CsrMatrix {
    /// Builds a matrix from `(row, col, value)` triplets; duplicates are summed in the order
    /// given. Errors on an index outside the matrix or a non-finite value.
    pub fn from_triplets(
        nrows: usize,
        ncols: usize,
        triplets: &[(usize, usize, f64)],
    ) -> Result<CsrMatrix, SparseError> {
        for &(row, col, value) in triplets {
            if row >= nrows || col >= ncols {
                return Err(SparseError::IndexOutOfRange {
                    row,
                    col,
                    nrows,
                    ncols,
                });
            }
            if !value.is_finite() {
                return Err(SparseError::NonFinite { row, col, value });
            }
        }
        // Order by (row, column), keeping the given order among duplicates (the sums are
        // reproducible): a stable counting sort by column, then a stable counting sort of
        // that sequence by row.
        let mut by_col = vec![0usize; ncols + 1];
        for &(_, c, _) in triplets {
            by_col[c + 1] += 1;
        }
        for j in 0..ncols {
            by_col[j + 1] += by_col[j];
        }
        let mut column_order: Vec<u32> = vec![0; triplets.len()];
        for (t, &(_, c, _)) in triplets.iter().enumerate() {
            column_order[by_col[c]] = t as u32;
            by_col[c] += 1;
        }
        let mut fill = vec![0usize; nrows + 1];
        for &(r, _, _) in triplets {
            fill[r + 1] += 1;
        }
        for i in 0..nrows {
            fill[i + 1] += fill[i];
        }
        let mut order: Vec<u32> = vec![0; triplets.len()];
        for &t in &column_order {
            let r = triplets[t as usize].0;
            order[fill[r]] = t;
            fill[r] += 1;
        }
        let mut row_ptr = vec![0usize; nrows + 1];
        let mut col_idx = Vec::with_capacity(triplets.len());
        let mut values: Vec<f64> = Vec::with_capacity(triplets.len());
        let mut last: Option<(usize, usize)> = None;
        for &t in &order {
            let (r, c, v) = triplets[t as usize];
            if last == Some((r, c)) {
                if let Some(x) = values.last_mut() {
                    *x += v;
                }
            } else {
                col_idx.push(c);
                values.push(v);
                row_ptr[r + 1] += 1;
                last = Some((r, c));
            }
        }
        for i in 0..nrows {
            row_ptr[i + 1] += row_ptr[i];
        }
        Ok(CsrMatrix {
            nrows,
            ncols,
            row_ptr,
            col_idx,
            values,
        })
    }

    /// Builds a matrix from raw CSR arrays, checking every invariant.
    pub fn from_raw(
        nrows: usize,
        ncols: usize,
        row_ptr: Vec<usize>,
        col_idx: Vec<usize>,
        values: Vec<f64>,
    ) -> Result<CsrMatrix, SparseError> {
        let m = CsrMatrix {
            nrows,
            ncols,
            row_ptr,
            col_idx,
            values,
        };
        m.check()?;
        Ok(m)
    }

    /// The diagonal matrix with `diag` on its diagonal (zeros are stored too, so the pattern
    /// is the full diagonal).
    pub fn from_diagonal(diag: &[f64]) -> Result<CsrMatrix, SparseError> {
        let n = diag.len();
        if let Some((i, &v)) = diag.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(SparseError::NonFinite {
                row: i,
                col: i,
                value: v,
            });
        }
        Ok(CsrMatrix {
            nrows: n,
            ncols: n,
            row_ptr: (0..=n).collect(),
            col_idx: (0..n).collect(),
            values: diag.to_vec(),
        })
    }

    /// The `n × n` identity.
    pub fn identity(n: usize) -> CsrMatrix {
        CsrMatrix {
            nrows: n,
            ncols: n,
            row_ptr: (0..=n).collect(),
            col_idx: (0..n).collect(),
            values: vec![1.0; n],
        }
    }

    /// Checks the CSR invariants (used on values that come from outside, e.g. a cache).
    pub fn check(&self) -> Result<(), SparseError> {
        let bad = |m: String| Err(SparseError::Malformed(m));
        if self.row_ptr.len() != self.nrows + 1 {
            return bad(format!(
                "row_ptr has {} entries for {} rows",
                self.row_ptr.len(),
                self.nrows
            ));
        }
        if self.row_ptr[0] != 0 || self.row_ptr[self.nrows] != self.col_idx.len() {
            return bad("row_ptr does not span col_idx".into());
        }
        if self.col_idx.len() != self.values.len() {
            return bad(format!(
                "{} column indices but {} values",
                self.col_idx.len(),
                self.values.len()
            ));
        }
        for i in 0..self.nrows {
            let (a, b) = (self.row_ptr[i], self.row_ptr[i + 1]);
            if a > b || b > self.col_idx.len() {
                return bad(format!("row_ptr decreases at row {i}"));
            }
            let cols = &self.col_idx[a..b];
            for (k, &c) in cols.iter().enumerate() {
                if c >= self.ncols {
                    return Err(SparseError::IndexOutOfRange {
                        row: i,
                        col: c,
                        nrows: self.nrows,
                        ncols: self.ncols,
                    });
                }
                if k > 0 && cols[k - 1] >= c {
                    return bad(format!("columns of row {i} are not strictly increasing"));
                }
                let v = self.values[a + k];
                if !v.is_finite() {
                    return Err(SparseError::NonFinite {
                        row: i,
                        col: c,
                        value: v,
                    });
                }
            }
        }
        Ok(())
    }

    pub fn nrows(&self) -> usize {
        self.nrows
    }
    pub fn ncols(&self) -> usize {
        self.ncols
    }
    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }
    pub fn col_idx(&self) -> &[usize] {
        &self.col_idx
    }
    pub fn values(&self) -> &[f64] {
        &self.values
    }
    /// Mutable values (the pattern stays fixed).
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }
    /// The `(column, value)` pairs of row `i`.
    pub fn row(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.row_ptr[i]..self.row_ptr[i + 1];
        self.col_idx[r.clone()]
            .iter()
            .copied()
            .zip(self.values[r].iter().copied())
    }
    /// Entry `(i, j)` (0 when not stored or out of range).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        if i >= self.nrows {
            return 0.0;
        }
        let r = self.row_ptr[i]..self.row_ptr[i + 1];
        match self.col_idx[r.clone()].binary_search(&j) {
            Ok(k) => self.values[r.start + k],
            Err(_) => 0.0,
        }
    }
    /// The diagonal (zeros where not stored), length `min(nrows, ncols)`.
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.nrows.min(self.ncols))
            .map(|i| self.get(i, i))
            .collect()
    }
    /// The transpose (a counting sort: columns come out strictly increasing).
    pub fn transpose(&self) -> CsrMatrix {
        let mut row_ptr = vec![0usize; self.ncols + 1];
        for &c in &self.col_idx {
            row_ptr[c + 1] += 1;
        }
        for j in 0..self.ncols {
            row_ptr[j + 1] += row_ptr[j];
        }
        let mut fill = row_ptr.clone();
        let mut col_idx = vec![0usize; self.nnz()];
        let mut values = vec![0.0; self.nnz()];
        for i in 0..self.nrows {
            for (j, v) in self.row(i) {
                col_idx[fill[j]] = i;
                values[fill[j]] = v;
                fill[j] += 1;
            }
        }
        CsrMatrix {
            nrows: self.ncols,
            ncols: self.nrows,
            row_ptr,
            col_idx,
            values,
        }
    }
    /// Largest |A_ij − A_ji| over stored entries (0 for a symmetric matrix).
    pub fn asymmetry(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..self.nrows {
            for (j, v) in self.row(i) {
                worst = worst.max((v - self.get(j, i)).abs());
            }
        }
        worst
    }
    /// Maximum absolute column sum (the matrix 1-norm).
    pub fn norm1(&self) -> f64 {
        let mut col = vec![0.0; self.ncols];
        for (&c, &v) in self.col_idx.iter().zip(&self.values) {
            col[c] += v.abs();
        }
        col.into_iter().fold(0.0, f64::max)
    }

    /// `alpha · self + beta · other` (patterns merged). Errors when the shapes differ.
    pub fn add_scaled(
        &self,
        alpha: f64,
        other: &CsrMatrix,
        beta: f64,
    ) -> Result<CsrMatrix, SparseError> {
        if self.nrows != other.nrows || self.ncols != other.ncols {
            return Err(SparseError::DimensionMismatch {
                what: "the second matrix's rows",
                got: other.nrows,
                expected: self.nrows,
            });
        }
        let mut row_ptr = Vec::with_capacity(self.nrows + 1);
        row_ptr.push(0);
        let mut col_idx = Vec::with_capacity(self.nnz() + other.nnz());
        let mut values = Vec::with_capacity(self.nnz() + other.nnz());
        for i in 0..self.nrows {
            let (mut a, ae) = (self.row_ptr[i], self.row_ptr[i + 1]);
            let (mut b, be) = (other.row_ptr[i], other.row_ptr[i + 1]);
            while a < ae || b < be {
                let ca = if a < ae { self.col_idx[a] } else { usize::MAX };
                let cb = if b < be { other.col_idx[b] } else { usize::MAX };
                if ca < cb {
                    col_idx.push(ca);
                    values.push(alpha * self.values[a]);
                    a += 1;
                } else if cb < ca {
                    col_idx.push(cb);
                    values.push(beta * other.values[b]);
                    b += 1;
                } else {
                    col_idx.push(ca);
                    values.push(alpha * self.values[a] + beta * other.values[b]);
                    a += 1;
                    b += 1;
                }
            }
            row_ptr.push(col_idx.len());
        }
        let m = CsrMatrix {
            nrows: self.nrows,
            ncols: self.ncols,
            row_ptr,
            col_idx,
            values,
        };
        if let Some(k) = m.values.iter().position(|v| !v.is_finite()) {
            let row = m.row_ptr.partition_point(|&p| p <= k) - 1;
            return Err(SparseError::NonFinite {
                row,
                col: m.col_idx[k],
                value: m.values[k],
            });
        }
        Ok(m)
    }

    /// `self + diag(d)` (the diagonal pattern is added where missing).
    pub fn add_diagonal(&self, d: &[f64]) -> Result<CsrMatrix, SparseError> {
        if d.len() != self.nrows || self.nrows != self.ncols {
            return Err(SparseError::DimensionMismatch {
                what: "the diagonal",
                got: d.len(),
                expected: self.nrows,
            });
        }
        self.add_scaled(1.0, &CsrMatrix::from_diagonal(d)?, 1.0)
    }

    fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let mut s = 0.0;
        for k in self.row_ptr[i]..self.row_ptr[i + 1] {
            s += self.values[k] * x[self.col_idx[k]];
        }
        s
    }

    /// `y = A x`. Each entry of `y` is one row's dot product in column order, so the result
    /// is the same with any `par`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64], par: Par) -> Result<(), SparseError> {
        if x.len() != self.ncols {
            return Err(SparseError::DimensionMismatch {
                what: "x",
                got: x.len(),
                expected: self.ncols,
            });
        }
        if y.len() != self.nrows {
            return Err(SparseError::DimensionMismatch {
                what: "y",
                got: y.len(),
                expected: self.nrows,
            });
        }
        match par {
            Par::Seq => y
                .iter_mut()
                .enumerate()
                .for_each(|(i, yi)| *yi = self.row_dot(i, x)),
            Par::Rayon => y
                .par_iter_mut()
                .with_min_len(1024)
                .enumerate()
                .for_each(|(i, yi)| *yi = self.row_dot(i, x)),
        }
        Ok(())
    }

    /// `A X` for a dense `ncols × m` block `x` stored column-major; returns the `nrows × m`
    /// product, column-major.
    pub fn mul_dense(&self, x: &[f64], m: usize, par: Par) -> Result<Vec<f64>, SparseError> {
        if x.len() != self.ncols * m {
            return Err(SparseError::DimensionMismatch {
                what: "the dense block",
                got: x.len(),
                expected: self.ncols * m,
            });
        }
        let mut y = vec![0.0; self.nrows * m];
        if self.nrows == 0 || m == 0 {
            return Ok(y);
        }
        let (n, nc) = (self.nrows, self.ncols);
        let body = |(i, yi): (usize, &mut f64)| {
            let (row, col) = (i % n, i / n);
            *yi = self.row_dot(row, &x[col * nc..(col + 1) * nc]);
        };
        match par {
            Par::Seq => y.iter_mut().enumerate().for_each(body),
            Par::Rayon => y
                .par_iter_mut()
                .with_min_len(4096)
                .enumerate()
                .for_each(body),
        }
        Ok(y)
    }

    /// A faer view of the same arrays as a compressed-sparse-column matrix: it is the
    /// transpose, i.e. the matrix itself when it is symmetric.
    fn as_faer_transpose(&self) -> Result<SparseColMatRef<'_, usize, f64>, SparseError> {
        let sym = SymbolicSparseColMatRef::new_checked(
            self.ncols,
            self.nrows,
            &self.row_ptr,
            None,
            &self.col_idx,
        );
        Ok(SparseColMatRef::new(sym, &self.values))
    }
}

/// Which lumped mass matrix to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum MassKind {
    /// Mixed Voronoi areas (Meyer et al. 2003): Voronoi regions in non-obtuse triangles, half
    /// the area to the obtuse corner and a quarter to the others otherwise (libigl's default).
    #[default]
    Voronoi,
    /// A third of each incident triangle's area.
    Barycentric,
}

/// How [`laplacian_and_mass`] discretises the operator.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaplacianOptions {
    pub mass: MassKind,
    /// Intrinsic mollification slack as a fraction of the mean edge length (module docs);
    /// 0 disables it. Default 1e-6.
    pub mollify: f64,
}

impl Default for LaplacianOptions {
    fn default() -> Self {
        LaplacianOptions {
            mass: MassKind::Voronoi,
            mollify: 1e-6,
        }
    }
}

/// Errors of the mesh operators.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OperatorError {
    #[error("the mesh has no triangles")]
    NoTriangles,
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("face {face} uses vertex {vertex} twice")]
    RepeatedVertex { face: usize, vertex: u32 },
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinitePosition { vertex: usize, position: [f64; 3] },
    #[error("mollify = {0} must be finite and in [0, 0.1]")]
    BadMollify(f64),
    #[error(
        "the mesh's bounding box is {side:e} across, outside the range where triangle areas \
         are representable in double precision (about 1e-75 to 1e75): scale the mesh to a \
         size near 1"
    )]
    Scale { side: f64 },
    #[error(transparent)]
    Sparse(#[from] SparseError),
}

/// The per-face quantities both matrices need: corner cotangents and the three vertex
/// masses, from (possibly mollified) edge lengths.
pub(crate) struct FaceTerms {
    /// cot of the angle at corner i (clamped).
    pub(crate) cot: [f64; 3],
    /// Mass given to corner i.
    pub(crate) mass: [f64; 3],
}

fn check_mesh(mesh: &TriMesh, opts: &LaplacianOptions) -> Result<(), OperatorError> {
    if !(opts.mollify.is_finite() && (0.0..=0.1).contains(&opts.mollify)) {
        return Err(OperatorError::BadMollify(opts.mollify));
    }
    if mesh.triangles.is_empty() {
        return Err(OperatorError::NoTriangles);
    }
    mesh.check_data().map_err(|d| match d {
        MeshDefect::NonFinitePosition { vertex, position } => {
            OperatorError::NonFinitePosition { vertex, position }
        }
        MeshDefect::IndexOutOfRange {
            face,
            index,
            n_vertices,
        } => OperatorError::IndexOutOfRange {
            face,
            index,
            n_vertices,
        },
    })?;
    // Heron's product is of degree 4 in the lengths: finite coordinates far from 1 overflow
    // to infinite or underflow to zero areas, which would leave a NaN or an empty operator.
    // The box's largest side, not its diagonal, whose own squares can underflow.
    let (lo, hi) = mesh.bbox();
    let side = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if side > 0.0 && !side.powi(4).is_normal() {
        return Err(OperatorError::Scale { side });
    }
    for (face, t) in mesh.triangles.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            let vertex = if t[0] == t[1] || t[0] == t[2] {
                t[0]
            } else {
                t[1]
            };
            return Err(OperatorError::RepeatedVertex { face, vertex });
        }
    }
    Ok(())
}

/// Edge lengths of triangle `t` at positions `x`: `l[i]` is the length of the side opposite
/// corner i.
pub(crate) fn triangle_lengths(x: &[[f64; 3]], t: [u32; 3]) -> [f64; 3] {
    let (a, b, c) = (x[t[0] as usize], x[t[1] as usize], x[t[2] as usize]);
    let d = |p: [f64; 3], q: [f64; 3]| {
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };
    [d(b, c), d(c, a), d(a, b)]
}

/// Edge lengths of face f of `mesh`.
fn face_lengths(mesh: &TriMesh, f: usize) -> [f64; 3] {
    triangle_lengths(&mesh.positions, mesh.triangles[f])
}

/// The mollification δ from the faces' edge lengths.
pub(crate) fn mollify_delta_of_lengths(lens: &[[f64; 3]], mollify: f64) -> f64 {
    if mollify == 0.0 {
        return 0.0;
    }
    let mut sum = 0.0;
    let mut count = 0usize;
    for l in lens {
        sum += l[0] + l[1] + l[2];
        count += 3;
    }
    let eps = mollify * sum / count.max(1) as f64;
    // Adding δ to all three lengths raises every slack by δ.
    let mut delta: f64 = 0.0;
    for l in lens {
        for i in 0..3 {
            // Slack of the triangle inequality for the side opposite corner i.
            let slack = l[(i + 1) % 3] + l[(i + 2) % 3] - l[i];
            delta = delta.max(eps - slack);
        }
    }
    delta
}

pub(crate) fn face_terms(l: [f64; 3], mass: MassKind) -> FaceTerms {
    // Heron's formula in its stable form (Kahan): sort a ≥ b ≥ c.
    let mut s = l;
    s.sort_by(|x, y| y.total_cmp(x));
    let [a, b, c] = s;
    let prod = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c));
    let area = 0.25 * prod.max(0.0).sqrt();
    let sq = [l[0] * l[0], l[1] * l[1], l[2] * l[2]];
    let mut cot = [0.0; 3];
    for i in 0..3 {
        // cot θ_i = (l_j² + l_k² − l_i²) / (4 A).
        let num = sq[(i + 1) % 3] + sq[(i + 2) % 3] - sq[i];
        cot[i] = if num == 0.0 { 0.0 } else { num / (4.0 * area) };
    }
    // Clamping the cotangents one by one would break the per-triangle positive
    // semi-definiteness (it rests on cot α cot β + cot β cot γ + cot γ cot α = 1), so a
    // triangle with a cotangent beyond the clamp (or a NaN from zero area) is left out of L.
    let dropped = cot.iter().any(|c| c.is_nan() || c.abs() > COT_CLAMP);
    if dropped {
        cot = [0.0; 3];
    }
    let masses = match mass {
        // A dropped triangle has (next to) no area: a third to each corner is as good as any.
        MassKind::Barycentric => [area / 3.0; 3],
        MassKind::Voronoi if dropped => [area / 3.0; 3],
        MassKind::Voronoi => {
            // Obtuse corner: the cosine's numerator is negative.
            let obtuse = (0..3).find(|&i| sq[(i + 1) % 3] + sq[(i + 2) % 3] - sq[i] < 0.0);
            match obtuse {
                Some(o) => {
                    let mut m = [0.25 * area; 3];
                    m[o] = 0.5 * area;
                    m
                }
                None => {
                    // Voronoi area of corner i: (|e_ij|² cot θ_k + |e_ik|² cot θ_j) / 8,
                    // where e_ij is opposite corner k.
                    let mut m = [0.0; 3];
                    for (i, mi) in m.iter_mut().enumerate() {
                        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                        *mi = (sq[k] * cot[k] + sq[j] * cot[j]) / 8.0;
                    }
                    m
                }
            }
        }
    };
    FaceTerms { cot, mass: masses }
}

fn all_face_terms(
    mesh: &TriMesh,
    opts: &LaplacianOptions,
    par: Par,
) -> Result<Vec<FaceTerms>, OperatorError> {
    check_mesh(mesh, opts)?;
    let lens = par.map_collect(mesh.n_faces(), |f| face_lengths(mesh, f));
    let delta = mollify_delta_of_lengths(&lens, opts.mollify);
    Ok(par.map_collect(mesh.n_faces(), |f| {
        let l = lens[f];
        face_terms([l[0] + delta, l[1] + delta, l[2] + delta], opts.mass)
    }))
}

/// Rows assembled per parallel task (a fixed split: the result does not depend on it).
const ROWS_PER_TASK: usize = 4096;

/// Assembles `L` and the lumped mass row by row, without a global sort. Each row visits the
/// faces at its vertex in face order ([`crestflow_geom::mesh::vertex_faces_csr`]) and, within a face, the
/// corners in order: its off-diagonal entries arrive in the order of the triplets of
/// [`CsrMatrix::from_triplets`] in face order, are sorted by column (stably, by insertion:
/// an interior row holds about 12) and summed per column in that order; the diagonal and the
/// mass are summed in that order too. The result is therefore bit for bit that of the
/// triplet sum and of [`assemble_mass`], on any thread count, in a fraction of the time (the
/// triplets' global counting sorts took half of the operator's time).
fn assemble_laplacian_and_mass(
    mesh: &TriMesh,
    terms: &[FaceTerms],
    par: Par,
) -> Result<(CsrMatrix, Vec<f64>), OperatorError> {
    let n = mesh.n_vertices();
    // Built here rather than through `mesh.topology()`, which would also build the edge
    // table (a mesh from the cache or from another node has none yet).
    let (start, faces_at) = crestflow_geom::mesh::vertex_faces_csr(n, &mesh.triangles);
    let tasks = n.div_ceil(ROWS_PER_TASK);
    type Part = (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>);
    let parts: Vec<Part> = par.map_collect(tasks, |task| {
        let rows = task * ROWS_PER_TASK..((task + 1) * ROWS_PER_TASK).min(n);
        let mut lens = Vec::with_capacity(rows.len());
        let mut mass = Vec::with_capacity(rows.len());
        let mut cols = Vec::new();
        let mut vals = Vec::new();
        let mut row: Vec<(u32, f64)> = Vec::new();
        for r in rows {
            row.clear();
            let (mut diag, mut m) = (0.0, 0.0);
            let faces = &faces_at[start[r] as usize..start[r + 1] as usize];
            for &f in faces {
                let t = mesh.triangles[f as usize];
                let ft = &terms[f as usize];
                for i in 0..3 {
                    // The side opposite corner i joins corners j and k.
                    let (j, k) = (t[(i + 1) % 3] as usize, t[(i + 2) % 3] as usize);
                    if j == r || k == r {
                        let w = 0.5 * ft.cot[i];
                        row.push(((j + k - r) as u32, -w));
                        diag += w;
                    } else {
                        // Corner i is r itself.
                        m += ft.mass[i];
                    }
                }
            }
            mass.push(m);
            for a in 1..row.len() {
                let mut b = a;
                while b > 0 && row[b - 1].0 > row[b].0 {
                    row.swap(b - 1, b);
                    b -= 1;
                }
            }
            let before = cols.len();
            // A vertex no face references keeps an empty row.
            let mut diag_done = faces.is_empty();
            for &(c, v) in &row {
                let c = c as usize;
                if !diag_done && c > r {
                    cols.push(r);
                    vals.push(diag);
                    diag_done = true;
                }
                if cols.len() > before && *cols.last().unwrap() == c {
                    *vals.last_mut().unwrap() += v;
                } else {
                    cols.push(c);
                    vals.push(v);
                }
            }
            if !diag_done {
                cols.push(r);
                vals.push(diag);
            }
            lens.push(cols.len() - before);
        }
        (lens, cols, vals, mass)
    });
    let nnz = parts.iter().map(|p| p.1.len()).sum();
    let mut row_ptr = Vec::with_capacity(n + 1);
    row_ptr.push(0);
    let mut col_idx = Vec::with_capacity(nnz);
    let mut values = Vec::with_capacity(nnz);
    let mut mass = Vec::with_capacity(n);
    for (lens, cols, vals, m) in parts {
        for len in lens {
            row_ptr.push(row_ptr.last().unwrap() + len);
        }
        col_idx.extend_from_slice(&cols);
        values.extend_from_slice(&vals);
        mass.extend_from_slice(&m);
    }
    // Face terms are finite by construction (dropped triangles contribute zeros); checked
    // all the same, so no NaN can reach a solver.
    for r in 0..n {
        for p in row_ptr[r]..row_ptr[r + 1] {
            if !values[p].is_finite() {
                return Err(SparseError::NonFinite {
                    row: r,
                    col: col_idx[p],
                    value: values[p],
                }
                .into());
            }
        }
    }
    Ok((
        CsrMatrix {
            nrows: n,
            ncols: n,
            row_ptr,
            col_idx,
            values,
        },
        mass,
    ))
}

fn assemble_mass(mesh: &TriMesh, terms: &[FaceTerms]) -> Vec<f64> {
    let mut m = vec![0.0; mesh.n_vertices()];
    for (t, ft) in mesh.triangles.iter().zip(terms) {
        for i in 0..3 {
            m[t[i] as usize] += ft.mass[i];
        }
    }
    m
}

/// The cotangent stiffness matrix `L` (positive semi-definite, rows sum to 0) and the lumped
/// mass diagonal `M` of `mesh`. Vertices no face references get an empty row and mass 0.
pub fn laplacian_and_mass(
    mesh: &TriMesh,
    opts: &LaplacianOptions,
    par: Par,
) -> Result<(CsrMatrix, Vec<f64>), OperatorError> {
    let terms = all_face_terms(mesh, opts, par)?;
    assemble_laplacian_and_mass(mesh, &terms, par)
}

/// The cotangent stiffness matrix `L` with default options (module docs).
pub fn cotan_laplacian(mesh: &TriMesh) -> Result<CsrMatrix, OperatorError> {
    let terms = all_face_terms(mesh, &LaplacianOptions::default(), Par::Seq)?;
    Ok(assemble_laplacian_and_mass(mesh, &terms, Par::Seq)?.0)
}

/// The lumped mass diagonal with default options (mixed Voronoi areas).
pub fn lumped_mass(mesh: &TriMesh) -> Result<Vec<f64>, OperatorError> {
    let terms = all_face_terms(mesh, &LaplacianOptions::default(), Par::Seq)?;
    Ok(assemble_mass(mesh, &terms))
}

/// A sparse Cholesky factorisation `A = P^T L L^T P` of a symmetric positive definite
/// matrix (faer; AMD fill-reducing ordering; only the lower triangle of `A` is read), or an
/// `L D Lᵀ` one of a symmetric indefinite matrix ([`SpdSolver::new_indefinite`]).
///
/// The symbolic analysis (faer's AMD ordering and supernodal structure) runs on the calling
/// thread. The numeric factorisation is multifrontal (`multifrontal.rs`): under `Par::Rayon`
/// the independent subtrees of the elimination tree are factorised in parallel, with the
/// same bits as under `Par::Seq`. [`SpdSolver::solve_many`] solves independent right-hand
/// sides in parallel.
/// The value is `Send + Sync`: share it between threads by reference.
#[derive(Debug, Clone)]
pub struct SpdSolver {
    n: usize,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// How the triangular solves split the elimination tree (from the symbolic analysis);
    /// its subtrees are also factorised in parallel.
    schedule: Arc<SolveSchedule>,
    /// Where the entries of `A` go in the multifrontal factorisation (supernodal only).
    scatter: Option<Arc<multifrontal::Scatter>>,
    factor: Vec<f64>,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    /// Built by [`SpdSolver::new_indefinite`]: `A = P^T L D L^T P` with `D` of either sign,
    /// stored as the Cholesky-like factor `L |D|^{1/2}`; the triangular solves are those of
    /// a Cholesky factor with the signs of `D` applied in between.
    indefinite: bool,
    /// Positions (in the permuted order) of the negative entries of `D`.
    negative: Vec<usize>,
}

impl SpdSolver {
    /// Analyses and factorises `a`, which must be square, symmetric and positive definite.
    pub fn new(a: &CsrMatrix, par: Par) -> Result<SpdSolver, SparseError> {
        let mut s = SpdSolver::new_symbolic(a, par)?;
        s.numeric(a, par)?;
        Ok(s)
    }

    /// The symbolic analysis of `a` (ordering, elimination tree, solve schedule), no values.
    fn new_symbolic(a: &CsrMatrix, par: Par) -> Result<SpdSolver, SparseError> {
        a.check()?;
        if a.nrows != a.ncols {
            return Err(SparseError::NotSquare {
                nrows: a.nrows,
                ncols: a.ncols,
            });
        }
        let view = a.as_faer_transpose()?;
        // faer's AMD ordering, computed here rather than inside faer's analysis so that where
        // A's entries land in the fronts (which needs the ordering only) is worked out while
        // faer computes the supernodes; the analysis is the one faer makes with its AMD.
        let n = a.nrows;
        let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
        let mut mem = MemBuffer::new(amd::order_maybe_unsorted_scratch::<usize>(
            n,
            a.col_idx.len(),
        ));
        let flops = amd::order_maybe_unsorted(
            &mut fwd,
            &mut inv,
            view.symbolic(),
            amd::Control::default(),
            MemStack::new(&mut mem),
        )
        .map_err(|e| SparseError::Factorization(format!("{e:?}")))?;
        drop(mem);
        // faer picks its simplicial layout when AMD counts no elimination work at all (a
        // diagonal matrix); handing it the ordering would not tell it that, so such a matrix
        // goes through faer's own ordering as before.
        let ordering = if flops.n_div + flops.n_mult_subs_ldl > 0.0 {
            SymmetricOrdering::Custom(PermRef::new_checked(&fwd, &inv, n))
        } else {
            SymmetricOrdering::Amd
        };
        let analyse = || {
            factorize_symbolic_cholesky(
                view.symbolic(),
                Side::Lower,
                ordering,
                // Supernodal always: the triangular solves below walk its dense column panels.
                CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    ..Default::default()
                },
            )
            .map_err(|e| SparseError::Factorization(format!("{e:?}")))
        };
        let scatter = || Arc::new(multifrontal::Scatter::new(a, &inv));
        let (symbolic, scatter) = match par {
            Par::Seq => (analyse(), scatter()),
            Par::Rayon => rayon::join(analyse, scatter),
        };
        let symbolic = symbolic?;
        // (faer keeps the simplicial layout for degenerate sizes only: no fronts there.)
        let scatter =
            matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)).then_some(scatter);
        let schedule = Arc::new(SolveSchedule::new(&symbolic));
        Ok(SpdSolver {
            n: a.nrows,
            symbolic: Arc::new(symbolic),
            schedule,
            scatter,
            factor: Vec::new(),
            row_ptr: a.row_ptr.clone(),
            col_idx: a.col_idx.clone(),
            indefinite: false,
            negative: Vec::new(),
        })
    }

    /// Analyses and factorises `a`, which must be square and symmetric and may be
    /// indefinite, as `P^T L D L^T P` without pivoting (a shifted operator `L − σM` with
    /// σ inside the spectrum). By Sylvester's law of inertia, [`SpdSolver::negative_pivots`]
    /// is then the number of negative eigenvalues of `a`. Fails on a zero or non-finite
    /// pivot. Without pivoting a pivot tiny against its column would spoil the solves: meant
    /// for shifted operators whose shift keeps away from an eigenvalue (the eigenbasis
    /// reports the backward errors of what it finds).
    pub fn new_indefinite(a: &CsrMatrix, par: Par) -> Result<SpdSolver, SparseError> {
        let mut s = SpdSolver::new_symbolic(a, par)?;
        s.indefinite = true;
        s.numeric(a, par)?;
        Ok(s)
    }

    /// Number of negative entries of `D` (0 for a positive definite factorisation).
    pub fn negative_pivots(&self) -> usize {
        self.negative.len()
    }

    /// Factorises new values. When `a` has the pattern of the matrix this solver was built
    /// from, the symbolic analysis (ordering, elimination tree) is reused; otherwise it is
    /// redone.
    pub fn refactor(&mut self, a: &CsrMatrix, par: Par) -> Result<(), SparseError> {
        if a.row_ptr == self.row_ptr && a.col_idx == self.col_idx && a.nrows == self.n {
            a.check()?;
            self.numeric(a, par)
        } else {
            *self = if self.indefinite {
                SpdSolver::new_indefinite(a, par)?
            } else {
                SpdSolver::new(a, par)?
            };
            Ok(())
        }
    }

    /// Factorises new values: `L Lᵀ`, or for an indefinite solver `L D Lᵀ` without pivoting,
    /// stored as `L |D|^{1/2}` so that the Cholesky solves below apply, with the signs of `D`
    /// kept apart. Multifrontal on a supernodal analysis (the tiny simplicial ones go to
    /// faer).
    fn numeric(&mut self, a: &CsrMatrix, par: Par) -> Result<(), SparseError> {
        if let (SymbolicCholeskyRaw::Supernodal(sym), Some(scatter)) =
            (self.symbolic.raw(), self.scatter.as_deref())
        {
            let n = self.n;
            match multifrontal::factorize(
                sym,
                &self.schedule,
                scatter,
                &a.values,
                self.indefinite,
                par,
                avx2(),
            ) {
                Ok((values, negative)) => {
                    self.factor = values;
                    self.negative = negative;
                    return Ok(());
                }
                Err(multifrontal::Failure::Pivot { column, value }) => {
                    return Err(if self.indefinite {
                        SparseError::Factorization(format!("pivot {value} at {column} of {n}"))
                    } else {
                        SparseError::NotPositiveDefinite { pivot: column, n }
                    });
                }
                // A structure the fronts cannot hold: faer's factorisation below.
                Err(multifrontal::Failure::Structure) => {}
            }
        }
        self.numeric_faer(a)
    }

    /// faer's own numeric factorisation (left-looking, one thread), then for `L D Lᵀ` each
    /// column of `L` scaled by `|d|^{1/2}` and its diagonal set to that.
    fn numeric_faer(&mut self, a: &CsrMatrix) -> Result<(), SparseError> {
        let view = a.as_faer_transpose()?;
        let fpar = faer::Par::Seq;
        let mut values = vec![0.0; self.symbolic.len_val()];
        let scratch = if self.indefinite {
            self.symbolic
                .factorize_numeric_ldlt_scratch::<f64>(fpar, Default::default())
        } else {
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(fpar, Default::default())
        };
        let mut mem = MemBuffer::try_new(scratch)
            .map_err(|e| SparseError::Factorization(format!("{e:?}")))?;
        let stack = MemStack::new(&mut mem);
        let n = self.n;
        if self.indefinite {
            self.symbolic
                .factorize_numeric_ldlt::<f64>(
                    &mut values,
                    view,
                    Side::Lower,
                    Default::default(),
                    fpar,
                    stack,
                    Default::default(),
                )
                .map_err(|e| match e {
                    faer::linalg::cholesky::ldlt::factor::LdltError::ZeroPivot { index } => {
                        SparseError::Factorization(format!("zero pivot at {index} of {n}"))
                    }
                })?;
            self.negative = self.scale_ldlt(&mut values)?;
        } else {
            self.symbolic
                .factorize_numeric_llt::<f64>(
                    &mut values,
                    view,
                    Side::Lower,
                    Default::default(),
                    fpar,
                    stack,
                    Default::default(),
                )
                .map_err(|e| match e {
                    faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                        SparseError::NotPositiveDefinite { pivot: index, n }
                    }
                })?;
        }
        self.factor = values;
        Ok(())
    }

    /// Turns faer's supernodal `L D Lᵀ` values into `L |D|^{1/2}` in place and returns the
    /// positions of the negative entries of `D` (the simplicial layout, for tiny matrices,
    /// stays as faer's solve reads it).
    fn scale_ldlt(&self, values: &mut [f64]) -> Result<Vec<usize>, SparseError> {
        let pivot_error = |d: f64, at: usize| {
            SparseError::Factorization(format!("pivot {d} at {at} of {}", self.n))
        };
        let sym = match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sym) => sym,
            SymbolicCholeskyRaw::Simplicial(sym) => {
                // faer's own layout (tiny matrices only): D first in each column, kept as
                // it is for faer's LDLᵀ solve.
                let mut negative = Vec::new();
                for (j, &p) in sym.col_ptr()[..self.n].iter().enumerate() {
                    let d = values[p];
                    if !(d.is_finite() && d != 0.0) {
                        return Err(pivot_error(d, j));
                    }
                    if d < 0.0 {
                        negative.push(j);
                    }
                }
                return Ok(negative);
            }
        };
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let (rptr, vptr) = (sym.col_ptr_for_row_idx(), sym.col_ptr_for_val());
        let mut negative = Vec::new();
        for s in 0..begin.len() {
            let nc = end[s] - begin[s];
            let ld = nc + (rptr[s + 1] - rptr[s]);
            let vals = &mut values[vptr[s]..vptr[s + 1]];
            for jj in 0..nc {
                let col = &mut vals[jj * ld..(jj + 1) * ld];
                let d = col[jj];
                if !(d.is_finite() && d != 0.0) {
                    return Err(pivot_error(d, begin[s] + jj));
                }
                if d < 0.0 {
                    negative.push(begin[s] + jj);
                }
                let r = d.abs().sqrt();
                col[jj] = r;
                col[jj + 1..].iter_mut().for_each(|l| *l *= r);
            }
        }
        Ok(negative)
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored values of the Cholesky factor (a measure of fill-in).
    pub fn factor_nnz(&self) -> usize {
        self.factor.len()
    }

    /// Solves `A x = b` for a column-major `n × m` block, `m` at most [`SOLVE_CHUNK`];
    /// independent subtrees of the elimination tree run in parallel under `Par::Rayon`.
    fn solve_block(&self, b: &mut [f64], m: usize, par: Par) {
        match m {
            1 => self.solve_block_w::<1>(b, 1, par),
            2 => self.solve_block_w::<2>(b, 2, par),
            3 | 4 => self.solve_block_w::<4>(b, m, par),
            _ => self.solve_block_w::<SOLVE_CHUNK>(b, m, par),
        }
    }

    /// The triangular solves with the supernodal factor for up to `W` right-hand sides,
    /// interleaved row by row (`x[i·W + j]`) so that the inner loops run over the
    /// right-hand sides. Every column sees the same operations in the same order whatever
    /// `W`, the other columns and the thread count are: the subtrees of the
    /// [`SolveSchedule`] are fixed by the matrix, and their contributions to the rows above
    /// them are added in subtree order.
    fn solve_block_w<const W: usize>(&self, b: &mut [f64], m: usize, par: Par) {
        #[cfg(target_arch = "x86_64")]
        if avx2() {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { self.solve_block_w_avx2::<W>(b, m, par) };
        }
        self.solve_block_w_base::<W>(b, m, par)
    }

    with_avx2_copy! {
    /// The body of [`SpdSolver::solve_block_w`].
    fn solve_block_w_base / solve_block_w_avx2<const W: usize>(&self, b: &mut [f64], m: usize, par: Par) {
        let n = self.n;
        let SymbolicCholeskyRaw::Supernodal(sym) = self.symbolic.raw() else {
            // faer chose the simplicial layout (it does so only for degenerate sizes): its own
            // solve, one column at a time.
            let fpar = faer::Par::Seq;
            let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(1, fpar));
            for col in b.chunks_mut(n).take(m) {
                let rhs = MatMut::from_column_major_slice_mut(col, n, 1);
                let stack = MemStack::new(&mut mem);
                if self.indefinite {
                    LdltRef::<usize, f64>::new(&self.symbolic, &self.factor)
                        .solve_in_place_with_conj(Conj::No, rhs, fpar, stack);
                } else {
                    LltRef::<usize, f64>::new(&self.symbolic, &self.factor)
                        .solve_in_place_with_conj(Conj::No, rhs, fpar, stack);
                }
            }
            return;
        };
        let (fwd, inv) = match self.symbolic.perm() {
            Some(p) => {
                let (f, i) = p.arrays();
                (Some(f), Some(i))
            }
            None => (None, None),
        };
        // Into the factor's order, interleaved (on the pool in row pieces: a tenth of a
        // four-column solve on one thread).
        let mut x = vec![[0.0f64; W]; n];
        let gather = |(piece, xs): (usize, &mut [[f64; W]])| {
            let r0 = piece * PERMUTE_PIECE;
            for (k, xi) in xs.iter_mut().enumerate() {
                let src = fwd.map_or(r0 + k, |f| f[r0 + k]);
                for (j, v) in xi.iter_mut().enumerate().take(m) {
                    *v = b[j * n + src];
                }
            }
        };
        match par {
            Par::Seq => x.chunks_mut(PERMUTE_PIECE).enumerate().for_each(gather),
            Par::Rayon => x.par_chunks_mut(PERMUTE_PIECE).enumerate().for_each(gather),
        }
        let f = FactorView {
            begin: sym.supernode_begin(),
            end: sym.supernode_end(),
            rptr: sym.col_ptr_for_row_idx(),
            vptr: sym.col_ptr_for_val(),
            rows: sym.row_idx(),
            values: &self.factor,
        };
        let sched = &*self.schedule;
        let max_pat = sched.max_pattern;
        let seq = matches!(par, Par::Seq) || sched.subtrees.len() < 2;
        // A sparse right-hand side (a heat source) only reaches the ancestors of its nonzero
        // rows in the forward solve; the other supernodes would compute on zeros and leave
        // every bit as it is, so they are skipped.
        let active = sched.reached(&f, &x);
        let is_active = |s: usize| active.as_ref().is_none_or(|a| a[s]);

        // Forward, L y = b: the subtrees (their rows above them go to private sums), then
        // the sums in subtree order, then the separator supernodes on top.
        {
            let mut parts = sched.split_mut(&mut x);
            let mut sums: Vec<Vec<[f64; W]>> = sched
                .subtrees
                .iter()
                .map(|t| vec![[0.0; W]; t.above.len()])
                .collect();
            let run = |t: &Subtree, xs: &mut [[f64; W]], sum: &mut [[f64; W]]| {
                let mut tmp = vec![[0.0f64; W]; if W < 4 { max_pat } else { 0 }];
                for s in (t.first..=t.last).filter(|&s| is_active(s)) {
                    let pat = f.pattern(s);
                    let (xd, below) = xs[f.begin[s] - t.col0..].split_at_mut(f.end[s] - f.begin[s]);
                    f.forward_diagonal(s, xd);
                    let inside = sched.inside[s] as usize;
                    let dest = &sched.above_slot;
                    let e0 = f.rptr[s];
                    f.forward_products(s, xd, &mut tmp, |i, tv| {
                        if i < inside {
                            let xi = &mut below[pat[i] - f.end[s]];
                            for w in 0..W {
                                xi[w] -= tv[w];
                            }
                        } else {
                            let acc = &mut sum[dest[e0 + i] as usize];
                            for w in 0..W {
                                acc[w] += tv[w];
                            }
                        }
                    });
                }
            };
            let jobs = sched
                .subtrees
                .iter()
                .zip(parts.iter_mut().zip(sums.iter_mut()));
            if seq {
                jobs.for_each(|(t, (xs, sum))| run(t, xs, sum));
            } else {
                jobs.collect::<Vec<_>>()
                    .into_par_iter()
                    .for_each(|(t, (xs, sum))| run(t, xs, sum));
            }
            drop(parts);
            for (t, sum) in sched.subtrees.iter().zip(&sums) {
                for (&r, acc) in t.above.iter().zip(sum) {
                    let xi = &mut x[r];
                    for w in 0..W {
                        xi[w] -= acc[w];
                    }
                }
            }
            let mut tmp = vec![[0.0f64; W]; if W < 4 { max_pat } else { 0 }];
            for &s in sched.top.iter().filter(|&&s| is_active(s)) {
                let pat = f.pattern(s);
                let (xd, below) = x[f.begin[s]..].split_at_mut(f.end[s] - f.begin[s]);
                f.forward_diagonal(s, xd);
                f.forward_products(s, xd, &mut tmp, |i, tv| {
                    let xi = &mut below[pat[i] - f.end[s]];
                    for w in 0..W {
                        xi[w] -= tv[w];
                    }
                });
            }
        }
        // An indefinite factor: y ← sign(D) y between the two triangular solves.
        for &i in &self.negative {
            for v in x[i].iter_mut() {
                *v = -*v;
            }
        }
        // Backward, Lᵀ x = y: the separators, then the subtrees (reading the separator
        // values from a copy).
        {
            let mut tmp = vec![[0.0f64; W]; max_pat];
            for &s in sched.top.iter().rev() {
                let pat = f.pattern(s);
                let tmp = &mut tmp[..pat.len()];
                for (tv, &r) in tmp.iter_mut().zip(pat) {
                    *tv = x[r];
                }
                f.backward_supernode(s, &mut x[f.begin[s]..], tmp);
            }
            let top_x: Vec<[f64; W]> = sched.top_cols.iter().map(|&c| x[c]).collect();
            let mut parts = sched.split_mut(&mut x);
            let run = |(t, xs): (&Subtree, &mut &mut [[f64; W]])| {
                let mut tmp = vec![[0.0f64; W]; max_pat];
                for s in (t.first..=t.last).rev() {
                    let pat = f.pattern(s);
                    let tmp = &mut tmp[..pat.len()];
                    let inside = sched.inside[s] as usize;
                    let (tin, tout) = tmp.split_at_mut(inside);
                    for (tv, &r) in tin.iter_mut().zip(pat) {
                        *tv = xs[r - t.col0];
                    }
                    for (tv, &r) in tout.iter_mut().zip(&pat[inside..]) {
                        *tv = top_x[sched.top_index[r] as usize];
                    }
                    f.backward_supernode(s, &mut xs[f.begin[s] - t.col0..], tmp);
                }
            };
            let jobs = sched.subtrees.iter().zip(parts.iter_mut());
            if seq {
                jobs.for_each(run);
            } else {
                jobs.collect::<Vec<_>>().into_par_iter().for_each(run);
            }
        }
        let scatter = |(j, col): (usize, &mut [f64])| match inv {
            Some(iv) => col.iter_mut().zip(iv).for_each(|(c, &ii)| *c = x[ii][j]),
            None => col.iter_mut().zip(&x).for_each(|(c, xi)| *c = xi[j]),
        };
        match par {
            Par::Seq => b.chunks_mut(n).take(m).enumerate().for_each(scatter),
            Par::Rayon => b.par_chunks_mut(n).take(m).enumerate().for_each(scatter),
        }
    }
    }

    /// Overwrites `b` with `A⁻¹ b`.
    pub fn solve_in_place(&self, b: &mut [f64]) -> Result<(), SparseError> {
        if b.len() != self.n {
            return Err(SparseError::DimensionMismatch {
                what: "the right-hand side",
                got: b.len(),
                expected: self.n,
            });
        }
        if self.n > 0 {
            self.solve_block(b, 1, Par::Seq);
        }
        Ok(())
    }

    /// Overwrites the column-major `n × m` block `b` with `A⁻¹ b`. Columns are solved in
    /// groups of up to eight, in parallel under `Par::Rayon`; each column gets the same bits
    /// whatever the grouping, so the result does not depend on the thread count.
    pub fn solve_many(&self, b: &mut [f64], m: usize, par: Par) -> Result<(), SparseError> {
        if b.len() != self.n * m {
            return Err(SparseError::DimensionMismatch {
                what: "the right-hand side block",
                got: b.len(),
                expected: self.n * m,
            });
        }
        if self.n == 0 || m == 0 {
            return Ok(());
        }
        // Groups of at most SOLVE_CHUNK columns; narrower when that leaves threads idle, but
        // not below four (a group of four shares the threads over the elimination tree; the
        // bunny's eigenbasis at k = 20, block 4, spent 0.13–0.14 s in solves against
        // 0.15–0.19 s with two groups of two, each of which reads the whole factor). A
        // column's bits do not depend on its group (solve_block_w).
        let width = match par {
            Par::Seq => SOLVE_CHUNK,
            Par::Rayon => {
                let threads = rayon::current_num_threads().max(1);
                m.div_ceil(threads).max(m.min(4)).clamp(1, SOLVE_CHUNK)
            }
        };
        let chunk = self.n * width;
        match par {
            Par::Seq => b
                .chunks_mut(chunk)
                .for_each(|c| self.solve_block(c, c.len() / self.n, Par::Seq)),
            // One group: the subtrees of the elimination tree share the threads instead.
            Par::Rayon if m <= width => self.solve_block(b, m, Par::Rayon),
            Par::Rayon => b
                .par_chunks_mut(chunk)
                .for_each(|c| self.solve_block(c, c.len() / self.n, Par::Seq)),
        }
        Ok(())
    }
}

/// The supernodal factor's arrays, borrowed for one solve.
struct FactorView<'a> {
    begin: &'a [usize],
    end: &'a [usize],
    rptr: &'a [usize],
    vptr: &'a [usize],
    rows: &'a [usize],
    values: &'a [f64],
}

impl FactorView<'_> {
    /// Rows of supernode `s` below its own columns, ascending.
    fn pattern(&self, s: usize) -> &[usize] {
        &self.rows[self.rptr[s]..self.rptr[s + 1]]
    }

    /// Forward step of supernode `s` on its diagonal block: solves it in place (`x` holds
    /// the supernode's own rows).
    #[inline(always)]
    fn forward_diagonal<const W: usize>(&self, s: usize, x: &mut [[f64; W]]) {
        let nc = x.len();
        let ld = nc + (self.rptr[s + 1] - self.rptr[s]);
        let vals = &self.values[self.vptr[s]..self.vptr[s + 1]];
        for jj in 0..nc {
            let col = &vals[jj * ld..(jj + 1) * ld];
            let d = col[jj];
            let mut xj = x[jj];
            for v in xj.iter_mut() {
                *v /= d;
            }
            x[jj] = xj;
            for (xi, &l) in x[jj + 1..nc].iter_mut().zip(&col[jj + 1..nc]) {
                for w in 0..W {
                    xi[w] -= l * xj[w];
                }
            }
        }
    }

    /// Hands `sink(i, p)` what pattern row `i` of supernode `s` must subtract in the forward
    /// solve, `p = Σ_j L[i, j] x_j` summed in column order (`xd` holds the supernode's solved
    /// rows), for every pattern row in order. With four or more right-hand sides eight rows
    /// at a time, the sums in registers (the whole solve of eight columns on the bunny's
    /// factor took 7.8–8.0 ms instead of 9.3 ms updating every row once per column, when it
    /// still went one row at a time); with one or two
    /// column by column into `tmp` (at least the pattern's length), where the rows of one
    /// column vectorise instead.
    #[inline(always)]
    fn forward_products<const W: usize>(
        &self,
        s: usize,
        xd: &[[f64; W]],
        tmp: &mut [[f64; W]],
        mut sink: impl FnMut(usize, &[f64; W]),
    ) {
        let nc = xd.len();
        let np = self.rptr[s + 1] - self.rptr[s];
        let ld = nc + np;
        let vals = &self.values[self.vptr[s]..self.vptr[s + 1]];
        if W >= 4 {
            // Rows in groups of R: R · W / 4 independent accumulator chains instead of one
            // (each sum is a chain of dependent additions, so a single row waits on the adder's
            // latency), and the R factor values of a column are adjacent. Each row's sum
            // still runs over the columns in order: the same bits.
            const R: usize = 8;
            let mut i = 0;
            while i + R <= np {
                let mut acc = [[0.0f64; W]; R];
                for (jj, xj) in xd.iter().enumerate() {
                    let l = &vals[jj * ld + nc + i..jj * ld + nc + i + R];
                    for r in 0..R {
                        for w in 0..W {
                            acc[r][w] += l[r] * xj[w];
                        }
                    }
                }
                for (r, a) in acc.iter().enumerate() {
                    sink(i + r, a);
                }
                i += R;
            }
            for i in i..np {
                let mut acc = [0.0f64; W];
                for (jj, xj) in xd.iter().enumerate() {
                    let l = vals[jj * ld + nc + i];
                    for w in 0..W {
                        acc[w] += l * xj[w];
                    }
                }
                sink(i, &acc);
            }
        } else {
            let tmp = &mut tmp[..np];
            tmp.iter_mut().for_each(|t| *t = [0.0; W]);
            for (jj, xj) in xd.iter().enumerate() {
                let col = &vals[jj * ld + nc..(jj + 1) * ld];
                for (t, &l) in tmp.iter_mut().zip(col) {
                    for w in 0..W {
                        t[w] += l * xj[w];
                    }
                }
            }
            for (i, t) in tmp.iter().enumerate() {
                sink(i, t);
            }
        }
    }

    /// Backward step of supernode `s` (`x` starts at its first column; `tmp` holds the
    /// solution at its pattern rows).
    #[inline(always)]
    fn backward_supernode<const W: usize>(&self, s: usize, x: &mut [[f64; W]], tmp: &[[f64; W]]) {
        let nc = self.end[s] - self.begin[s];
        let ld = nc + tmp.len();
        let vals = &self.values[self.vptr[s]..self.vptr[s + 1]];
        for jj in (0..nc).rev() {
            let col = &vals[jj * ld..(jj + 1) * ld];
            let mut acc = dot_w::<W>(&col[nc..], tmp);
            let top = dot_w::<W>(&col[jj + 1..nc], &x[jj + 1..nc]);
            let d = col[jj];
            let xj = &mut x[jj];
            for w in 0..W {
                acc[w] += top[w];
                xj[w] = (xj[w] - acc[w]) / d;
            }
        }
    }
}

/// Rows per task of the permutations around the triangular solves.
const PERMUTE_PIECE: usize = 4096;

/// Factor values below which the triangular solves stay in one piece (splitting costs more
/// than it saves on small factors).
const SPLIT_MIN_VALUES: usize = 200_000;

/// Subtrees are split until none holds more than this fraction of the factor's values.
const SPLIT_PIECES: usize = 16;

/// Parent of a root supernode.
const NO_PARENT: usize = usize::MAX;

/// One subtree of the supernodal elimination tree, solved as an independent task.
#[derive(Debug, Clone)]
struct Subtree {
    /// Its supernodes `first..=last` (contiguous: the tree is in postorder).
    first: usize,
    last: usize,
    /// Its columns `col0..col1`.
    col0: usize,
    col1: usize,
    /// The rows above it (separator columns) that its supernodes update, ascending.
    above: Vec<usize>,
}

/// How the triangular solves split the supernodal elimination tree: disjoint subtrees that
/// are solved independently, and the separator supernodes above them ("top"), solved
/// after (forward) or before (backward) them. The split depends on the factor's structure
/// only, never on the thread count, so the bits of a solve do not either.
#[derive(Debug, Clone, Default)]
struct SolveSchedule {
    subtrees: Vec<Subtree>,
    /// Supernodes outside every subtree, ascending.
    top: Vec<usize>,
    /// Columns of the top supernodes, ascending, and each column's index among them
    /// (`u32::MAX` for subtree columns).
    top_cols: Vec<usize>,
    top_index: Vec<u32>,
    /// For each pattern entry (parallel to the factor's row indices) of a subtree supernode
    /// that lies above its subtree: the entry's position in the subtree's `above` list.
    above_slot: Vec<u32>,
    /// Per supernode: how many of its pattern rows lie inside its subtree (all of them for
    /// the top supernodes).
    inside: Vec<u32>,
    /// Parent of each supernode in the elimination tree ([`NO_PARENT`] for a root); empty
    /// when the supernodes are not in postorder (then no forward step is skipped).
    parent: Vec<usize>,
    /// Largest pattern length of a supernode.
    max_pattern: usize,
}

impl SolveSchedule {
    fn new(symbolic: &SymbolicCholesky<usize>) -> SolveSchedule {
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return SolveSchedule::default();
        };
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let (rptr, vptr, rows) = (
            sym.col_ptr_for_row_idx(),
            sym.col_ptr_for_val(),
            sym.row_idx(),
        );
        let ns = sym.n_supernodes();
        let n = symbolic.nrows();
        let max_pattern = (0..ns).map(|s| rptr[s + 1] - rptr[s]).max().unwrap_or(0);
        // The supernodal tree: the parent is the supernode of the first pattern row.
        let mut col_sn = vec![0usize; n];
        for s in 0..ns {
            col_sn[begin[s]..end[s]].iter_mut().for_each(|c| *c = s);
        }
        let parent: Vec<usize> = (0..ns)
            .map(|s| {
                rows.get(rptr[s])
                    .filter(|_| rptr[s + 1] > rptr[s])
                    .map_or(NO_PARENT, |&r| col_sn[r])
            })
            .collect();
        let postordered = (0..ns).all(|s| parent[s] == NO_PARENT || parent[s] > s);
        let everything = |max_pattern| SolveSchedule {
            subtrees: vec![Subtree {
                first: 0,
                last: ns.saturating_sub(1),
                col0: 0,
                col1: n,
                above: Vec::new(),
            }],
            top: Vec::new(),
            top_cols: Vec::new(),
            top_index: vec![u32::MAX; n],
            above_slot: Vec::new(),
            inside: (0..ns).map(|s| (rptr[s + 1] - rptr[s]) as u32).collect(),
            parent: if postordered {
                parent.clone()
            } else {
                Vec::new()
            },
            max_pattern,
        };
        if ns == 0 {
            return SolveSchedule {
                subtrees: Vec::new(),
                ..everything(0)
            };
        }
        let total: usize = vptr[ns] - vptr[0];
        if total < SPLIT_MIN_VALUES || !postordered {
            return everything(max_pattern);
        }
        const NONE: usize = NO_PARENT;
        // Subtree sizes and values; a postorder has each subtree at `s + 1 − size .. = s`.
        let mut size = vec![1usize; ns];
        let mut work: Vec<usize> = (0..ns).map(|s| vptr[s + 1] - vptr[s]).collect();
        let mut first = (0..ns).collect::<Vec<_>>();
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); ns];
        for s in 0..ns {
            let p = parent[s];
            if p == NONE {
                continue;
            }
            if p <= s {
                return everything(max_pattern);
            }
            size[p] += size[s];
            work[p] += work[s];
            first[p] = first[p].min(first[s]);
            children[p].push(s);
        }
        if (0..ns).any(|s| first[s] + size[s] != s + 1) {
            return everything(max_pattern);
        }
        // Split the heaviest subtree into its children until every piece is light enough.
        let limit = total / SPLIT_PIECES;
        let mut heap: std::collections::BinaryHeap<(usize, usize)> = (0..ns)
            .filter(|&s| parent[s] == NONE)
            .map(|s| (work[s], s))
            .collect();
        let mut is_top = vec![false; ns];
        while let Some(&(w, s)) = heap.peek() {
            if w <= limit || children[s].is_empty() {
                break;
            }
            heap.pop();
            is_top[s] = true;
            heap.extend(children[s].iter().map(|&c| (work[c], c)));
        }
        let mut roots: Vec<usize> = heap.into_iter().map(|(_, s)| s).collect();
        roots.sort_unstable();
        let top: Vec<usize> = (0..ns).filter(|&s| is_top[s]).collect();
        let mut top_cols = Vec::new();
        let mut top_index = vec![u32::MAX; n];
        for &s in &top {
            top_cols.extend(begin[s]..end[s]);
        }
        for (k, &c) in top_cols.iter().enumerate() {
            top_index[c] = k as u32;
        }
        let mut above_slot = vec![u32::MAX; rows.len()];
        let mut inside: Vec<u32> = (0..ns).map(|s| (rptr[s + 1] - rptr[s]) as u32).collect();
        let subtrees: Vec<Subtree> = roots
            .iter()
            .map(|&r| {
                let (f, l) = (first[r], r);
                let (col0, col1) = (begin[f], end[l]);
                let mut above: Vec<usize> = (f..=l)
                    .flat_map(|s| rows[rptr[s]..rptr[s + 1]].iter().copied())
                    .filter(|&row| row >= col1)
                    .collect();
                above.sort_unstable();
                above.dedup();
                for s in f..=l {
                    let pat = &rows[rptr[s]..rptr[s + 1]];
                    inside[s] = pat.partition_point(|&r| r < col1) as u32;
                    for e in rptr[s] + inside[s] as usize..rptr[s + 1] {
                        above_slot[e] = above.partition_point(|&a| a < rows[e]) as u32;
                    }
                }
                Subtree {
                    first: f,
                    last: l,
                    col0,
                    col1,
                    above,
                }
            })
            .collect();
        SolveSchedule {
            subtrees,
            top,
            top_cols,
            top_index,
            above_slot,
            inside,
            parent,
            max_pattern,
        }
    }

    /// The supernodes a forward solve of `x` reaches (those with a nonzero right-hand side
    /// and their ancestors), or `None` when that is (nearly) all of them.
    fn reached<const W: usize>(&self, f: &FactorView<'_>, x: &[[f64; W]]) -> Option<Vec<bool>> {
        let ns = self.parent.len();
        if ns == 0 {
            return None;
        }
        let mut active: Vec<bool> = (0..ns)
            .map(|s| {
                x[f.begin[s]..f.end[s]]
                    .iter()
                    .any(|v| v.iter().any(|&e| e != 0.0))
            })
            .collect();
        for s in 0..ns {
            if active[s] && self.parent[s] != NO_PARENT {
                active[self.parent[s]] = true;
            }
        }
        let reached: usize = (0..ns)
            .filter(|&s| active[s])
            .map(|s| f.vptr[s + 1] - f.vptr[s])
            .sum();
        (reached * 10 < (f.vptr[ns] - f.vptr[0]) * 9).then_some(active)
    }

    /// Disjoint mutable views of `x` on the subtrees' column ranges (ascending).
    fn split_mut<'x, T>(&self, x: &'x mut [T]) -> Vec<&'x mut [T]> {
        let mut out = Vec::with_capacity(self.subtrees.len());
        let mut rest = x;
        let mut offset = 0;
        for t in &self.subtrees {
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(t.col0 - offset);
            let (mine, tail) = tail.split_at_mut(t.col1 - t.col0);
            out.push(mine);
            rest = tail;
            offset = t.col1;
        }
        out
    }
}

/// `Σ_t l[t] · x[t]` per right-hand side, summed in four interleaved partial sums (a fixed
/// order, so the bits do not depend on `W`).
#[inline(always)]
fn dot_w<const W: usize>(l: &[f64], x: &[[f64; W]]) -> [f64; W] {
    let mut acc = [[0.0f64; W]; 4];
    let mut lc = l.chunks_exact(4);
    let mut xc = x.chunks_exact(4);
    for (lq, xq) in (&mut lc).zip(&mut xc) {
        for q in 0..4 {
            for w in 0..W {
                acc[q][w] += lq[q] * xq[q][w];
            }
        }
    }
    for (q, (&li, xi)) in lc.remainder().iter().zip(xc.remainder()).enumerate() {
        for w in 0..W {
            acc[q][w] += li * xi[w];
        }
    }
    let mut out = [0.0; W];
    for w in 0..W {
        out[w] = (acc[0][w] + acc[1][w]) + (acc[2][w] + acc[3][w]);
    }
    out
}

#[cfg(test)]
#[path = "sparse_test.rs"]
mod tests;
