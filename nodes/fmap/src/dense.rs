//! Small dense helpers shared by the nodes of this family: the unit-area basis, deterministic
//! dense products and k×k SPD solves (faer).

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::{Accum, Mat, MatRef};

use crestflow_flow::Par;
use crestflow_nodes_spectral::EigenBasis;

use crate::types::FmapError;

/// Rows per piece of a tall product: fixed, so sums do not depend on the thread count.
pub const ROW_CHUNK: usize = 2048;

/// The first `k` functions of an eigenbasis on the mesh scaled to unit area:
/// `φ' = √A φ`, `λ' = A λ`, `M' = M / A` (so `Φ'ᵀ M' Φ' = I` still holds).
#[derive(Clone, Debug)]
pub struct Basis {
    pub n: usize,
    pub k: usize,
    /// `n × k`, column-major.
    pub vectors: Vec<f64>,
    pub values: Vec<f64>,
    pub mass: Vec<f64>,
    /// Area of the mesh before scaling.
    pub area: f64,
}

impl Basis {
    /// Takes the first `k` pairs of `eb` (`k = 0`: all of them).
    pub fn new(eb: &EigenBasis, k: usize, side: &'static str) -> Result<Basis, FmapError> {
        let k = if k == 0 { eb.k() } else { k };
        if k > eb.k() {
            return Err(FmapError::BasisTooSmall {
                side,
                have: eb.k(),
                asked: k,
            });
        }
        let area: f64 = eb.mass.iter().sum();
        if !(area.is_finite() && area > 0.0) {
            return Err(FmapError::ZeroArea { side });
        }
        let s = area.sqrt();
        let n = eb.n;
        let vectors: Vec<f64> = eb.vectors[..n * k].iter().map(|v| v * s).collect();
        Ok(Basis {
            n,
            k,
            vectors,
            values: eb.values[..k].iter().map(|l| l * area).collect(),
            mass: eb.mass.iter().map(|m| m / area).collect(),
            area,
        })
    }

    /// Column `i`.
    pub fn col(&self, i: usize) -> &[f64] {
        &self.vectors[i * self.n..(i + 1) * self.n]
    }

    /// Value of function `i` at mesh vertex `v`.
    pub fn at(&self, v: usize, i: usize) -> f64 {
        self.vectors[i * self.n + v]
    }

    /// The first `k` columns as a new basis.
    pub fn truncated(&self, k: usize) -> Basis {
        Basis {
            n: self.n,
            k,
            vectors: self.vectors[..self.n * k].to_vec(),
            values: self.values[..k].to_vec(),
            mass: self.mass.clone(),
            area: self.area,
        }
    }

    /// Spectral coefficients `Φ'ᵀ M' g` of the columns of `g` (n × m, column-major); k × m.
    pub fn project(&self, g: &[f64], m: usize, par: Par) -> Vec<f64> {
        at_d_b(&self.vectors, self.k, Some(&self.mass), g, m, self.n, par)
    }
}

/// Column-major view.
pub fn mref(v: &[f64], rows: usize, cols: usize) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(v, rows, cols)
}

/// Copies a faer matrix into a column-major vector.
pub fn to_vec(m: &Mat<f64>) -> Vec<f64> {
    let mut out = Vec::with_capacity(m.nrows() * m.ncols());
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            out.push(m[(i, j)]);
        }
    }
    out
}

/// `A B` for small column-major matrices (`A` r × s, `B` s × c), sequential.
pub fn mul(a: &[f64], r: usize, s: usize, b: &[f64], c: usize) -> Vec<f64> {
    let mut out = Mat::<f64>::zeros(r, c);
    matmul(
        out.as_mut(),
        Accum::Replace,
        mref(a, r, s),
        mref(b, s, c),
        1.0,
        faer::Par::Seq,
    );
    to_vec(&out)
}

/// `Aᵀ D B` in fixed row chunks (deterministic at any thread count); shared with the eigensolver.
pub use crestflow_nodes_spectral::eigenbasis::at_d_b;

/// `A X` for tall column-major `A` (n × p) and small `X` (p × q), in fixed row chunks.
pub fn tall_mul(a: &[f64], n: usize, p: usize, x: &[f64], q: usize, par: Par) -> Vec<f64> {
    let chunks = n.div_ceil(ROW_CHUNK).max(1);
    let parts = par.map_collect(chunks, |c| {
        let r0 = c * ROW_CHUNK;
        let len = ROW_CHUNK.min(n - r0.min(n));
        let mut out = Mat::<f64>::zeros(len, q);
        matmul(
            out.as_mut(),
            Accum::Replace,
            mref(a, n, p).subrows(r0, len),
            mref(x, p, q),
            1.0,
            faer::Par::Seq,
        );
        (r0, out)
    });
    let mut res = vec![0.0; n * q];
    for (r0, part) in parts {
        for j in 0..q {
            for i in 0..part.nrows() {
                res[j * n + r0 + i] = part[(i, j)];
            }
        }
    }
    res
}

/// Solves the SPD system `A x = b` (`A` k × k column-major) by Cholesky; `column` names the
/// system in the error.
pub fn spd_solve(a: &[f64], k: usize, b: &[f64], column: usize) -> Result<Vec<f64>, FmapError> {
    let am = mref(a, k, k).to_owned();
    let llt = am
        .llt(faer::Side::Lower)
        .map_err(|_| FmapError::NotPositiveDefinite { column })?;
    let rhs = mref(b, k, 1).to_owned();
    let x = llt.solve(&rhs);
    Ok((0..k).map(|i| x[(i, 0)]).collect())
}
