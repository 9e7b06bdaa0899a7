//! `fmap.curve_constrained`: functional maps from corresponding curves (thesis §5.2.3–5.2.4).
//!
//! Energy (eq. 5.5), for the k₂ × k₁ map `C` between the unit-area bases of the source (M₁)
//! and the target (M₂):
//!
//! `E(C) = α ‖C Λ₁ − Λ₂ C‖² + Σ_ℓ ‖Φ_{c_ℓ}^{M₂} C − Φ_{c_ℓ}^{M₁}‖²`,
//!
//! where `Φ_c^{M}` (N_s × k) holds the basis functions restricted to curve c, sampled at
//! N_s points uniformly spaced in arc length (curve vertices on mesh vertices, edges or faces
//! are interpolated barycentrically; a sample between two curve vertices linearly).
//!
//! Normal equations. With the precomputed k × k terms of Algorithm 5.1,
//! `A = Σ_ℓ Φ_{c_ℓ}^{M₂ᵀ} Φ_{c_ℓ}^{M₂}` and `B = Σ_ℓ Φ_{c_ℓ}^{M₂ᵀ} Φ_{c_ℓ}^{M₁}`, and since the
//! Λ are diagonal, `∇E / 2 = A C + α D ⊙ C − B` with `D_ij = (λ₂ᵢ − λ₁ⱼ)²`. So the linear
//! operator of Algorithm 5.2 is `H(C) = A C + α D ⊙ C` (this is the thesis' `T₁C + CT₂ −
//! α(…)` with the commutativity terms collected entrywise; the thesis' listing has the cross
//! term with a factor α where the derivative gives 4α, and `Λ₁ C Λ₂` where `Λ₂ C Λ₁` is meant).
//!
//! Solvers:
//! - `Cg` (default): conjugate gradients on the Frobenius inner product (Algorithm 5.2), one
//!   k×k×k product per iteration, with an optional Jacobi preconditioner (`diag H = A_ii +
//!   α D_ij`; on by default, it cuts the iterations by an order of magnitude because `D`
//!   spans many decades). Stops when `‖R‖_F ≤ tol ‖B‖_F`.
//! - `Direct`: `H` acts on each column of C separately, `(A + α diag(D_{·j})) c_j = b_j`, so
//!   the exact minimiser is k dense Cholesky solves of size k (used to check CG).
//!
//! Adding a curve pair (Algorithm 5.1): [`CurveSystem::add_pair`] adds its two k × k
//! products to `A` and `B`; [`CurveSystem::solve_cg`] restarts CG from the previous map. The
//! node takes an optional `initial` map to warm-start the same way.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate,
};
use crestflow_geom::vec3::dist;
use crestflow_geom::{FeatureCurveNetwork, SurfacePoint, TriMesh};
use crestflow_nodes_spectral::EigenBasis;

use crate::dense::{at_d_b, mul, spd_solve, Basis};
use crate::types::{FmapError, FunctionalMap};

/// How the normal equations are solved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum CurveMapSolver {
    /// Conjugate gradients (Algorithm 5.2).
    #[default]
    Cg,
    /// k dense Cholesky solves (exact; O(k⁴)).
    Direct,
}

/// Parameters of `fmap.curve_constrained`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurveConstrainedParams {
    /// Basis size on both shapes (default 120, the thesis' choice; 0: all functions of the
    /// smaller basis; range 0..=2000).
    pub k: usize,
    /// Weight α of the Laplacian commutativity term (default 0.5, the thesis' choice; range
    /// 0..=1e6).
    pub alpha: f64,
    /// Samples N_s per curve (default 64, range 2..=100000).
    pub samples: usize,
    /// Solver (default `Cg`).
    pub solver: CurveMapSolver,
    /// Jacobi preconditioner for CG (default true).
    pub precondition: bool,
    /// CG stops when ‖residual‖_F ≤ tol ‖B‖_F (default 1e-8, range 1e-15..=1e-1).
    pub tol: f64,
    /// Most CG iterations (default 5000, range 1..=1000000).
    pub max_iterations: usize,
}

impl Default for CurveConstrainedParams {
    fn default() -> Self {
        CurveConstrainedParams {
            k: 120,
            alpha: 0.5,
            samples: 64,
            solver: CurveMapSolver::Cg,
            precondition: true,
            tol: 1e-8,
            max_iterations: 5000,
        }
    }
}

impl Validate for CurveConstrainedParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "k", self.k, 0, 2000);
        check_range(&mut issues, "alpha", self.alpha, 0.0, 1e6);
        check_range(&mut issues, "samples", self.samples, 2, 100_000);
        check_range(&mut issues, "tol", self.tol, 1e-15, 1e-1);
        check_range(
            &mut issues,
            "max_iterations",
            self.max_iterations,
            1,
            1_000_000,
        );
        issues
    }
}

/// Mesh vertices and weights of a point of a curve.
fn corners(
    p: SurfacePoint,
    mesh: &TriMesh,
    side: &'static str,
    curve: usize,
) -> Result<Vec<(u32, f64)>, FmapError> {
    let n = mesh.n_vertices();
    let out = match p {
        SurfacePoint::Vertex(v) => vec![(v, 1.0)],
        SurfacePoint::Edge { a, b, t } => vec![(a, 1.0 - t), (b, t)],
        SurfacePoint::Face { f, bary } => {
            let tri = mesh
                .triangles
                .get(f as usize)
                .ok_or(FmapError::CurveNotOnMesh { side, curve })?;
            vec![(tri[0], bary[0]), (tri[1], bary[1]), (tri[2], bary[2])]
        }
        SurfacePoint::Free => return Err(FmapError::CurveNotOnMesh { side, curve }),
    };
    for &(v, w) in &out {
        if v as usize >= n {
            return Err(FmapError::CurveVertexOutOfRange {
                side,
                curve,
                vertex: v,
                n_vertices: n,
            });
        }
        if !w.is_finite() {
            return Err(FmapError::CurveNotOnMesh { side, curve });
        }
    }
    Ok(out)
}

/// `Φ_c` (samples × k, column-major): the basis restricted to curve `c` of `net`, sampled at
/// `samples` points uniformly spaced in arc length (closed curves include the closing edge).
pub fn restrict(
    basis: &Basis,
    mesh: &TriMesh,
    net: &FeatureCurveNetwork,
    c: usize,
    samples: usize,
    side: &'static str,
) -> Result<Vec<f64>, FmapError> {
    let curve = &net.curves[c];
    let nv = net.vertices.len();
    let mut ids: Vec<usize> = Vec::with_capacity(curve.vertices.len() + 1);
    for &i in &curve.vertices {
        if i as usize >= nv {
            return Err(FmapError::DegenerateCurve { side, curve: c });
        }
        ids.push(i as usize);
    }
    if curve.closed && ids.len() > 2 {
        ids.push(ids[0]);
    }
    if ids.is_empty() {
        return Err(FmapError::DegenerateCurve { side, curve: c });
    }
    let pts: Vec<Vec<(u32, f64)>> = ids
        .iter()
        .map(|&i| corners(net.vertices[i].location, mesh, side, c))
        .collect::<Result<_, _>>()?;
    let mut cum = vec![0.0];
    for w in ids.windows(2) {
        let l = dist(net.vertices[w[0]].position, net.vertices[w[1]].position);
        cum.push(cum.last().unwrap() + l);
    }
    let total = *cum.last().unwrap();
    if !(total.is_finite() && total > 0.0) {
        return Err(FmapError::DegenerateCurve { side, curve: c });
    }
    let k = basis.k;
    let value = |cs: &[(u32, f64)], j: usize| -> f64 {
        cs.iter().map(|&(v, w)| w * basis.at(v as usize, j)).sum()
    };
    let mut out = vec![0.0; samples * k];
    let mut seg = 0;
    for s in 0..samples {
        let t = total * s as f64 / (samples - 1) as f64;
        while seg + 2 < cum.len() && cum[seg + 1] < t {
            seg += 1;
        }
        let len = cum[seg + 1] - cum[seg];
        let u = if len > 0.0 {
            ((t - cum[seg]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        for j in 0..k {
            out[j * samples + s] = (1.0 - u) * value(&pts[seg], j) + u * value(&pts[seg + 1], j);
        }
    }
    Ok(out)
}

/// Outcome of one solve.
#[derive(Clone, Debug)]
pub struct SolveStats {
    pub iterations: usize,
    pub relative_residual: f64,
}

/// The incremental solver of Algorithms 5.1 and 5.2: holds `A`, `B`, `D` and the constant of
/// the energy; curve pairs are added one by one.
#[derive(Clone, Debug)]
pub struct CurveSystem {
    pub k: usize,
    pub alpha: f64,
    /// `A = Σ Φc₂ᵀ Φc₂`, k × k column-major.
    pub a: Vec<f64>,
    /// `B = Σ Φc₂ᵀ Φc₁`, k × k column-major.
    pub b: Vec<f64>,
    /// `D_ij = (λ₂ᵢ − λ₁ⱼ)²`.
    pub d: Vec<f64>,
    /// `Σ ‖Φc₁‖²`.
    pub c0: f64,
    pub pairs: usize,
}

impl CurveSystem {
    /// An empty system for eigenvalues `l1` (source) and `l2` (target), both of length k.
    pub fn new(l1: &[f64], l2: &[f64], alpha: f64) -> CurveSystem {
        let k = l1.len();
        let mut d = vec![0.0; k * k];
        for j in 0..k {
            for i in 0..k {
                let x = l2[i] - l1[j];
                d[j * k + i] = x * x;
            }
        }
        CurveSystem {
            k,
            alpha,
            a: vec![0.0; k * k],
            b: vec![0.0; k * k],
            d,
            c0: 0.0,
            pairs: 0,
        }
    }

    /// Adds one pair of restricted bases (`phi1`, `phi2`: `samples × k`).
    pub fn add_pair(&mut self, phi1: &[f64], phi2: &[f64], samples: usize) {
        let k = self.k;
        let a = at_d_b(phi2, k, None, phi2, k, samples, Par::Seq);
        let b = at_d_b(phi2, k, None, phi1, k, samples, Par::Seq);
        self.a.iter_mut().zip(&a).for_each(|(x, y)| *x += y);
        self.b.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
        self.c0 += phi1.iter().map(|x| x * x).sum::<f64>();
        self.pairs += 1;
    }

    /// `H(C) = A C + α D ⊙ C`.
    pub fn apply(&self, c: &[f64]) -> Vec<f64> {
        let k = self.k;
        let mut h = mul(&self.a, k, k, c, k);
        for (i, hv) in h.iter_mut().enumerate() {
            *hv += self.alpha * self.d[i] * c[i];
        }
        h
    }

    /// The energy (eq. 5.5) of `c`.
    pub fn energy(&self, c: &[f64]) -> f64 {
        let k = self.k;
        let ac = mul(&self.a, k, k, c, k);
        let mut e = self.c0;
        for i in 0..k * k {
            e += c[i] * ac[i] - 2.0 * c[i] * self.b[i] + self.alpha * self.d[i] * c[i] * c[i];
        }
        e
    }

    /// Preconditioned conjugate gradients from `c` (in place), Algorithm 5.2.
    pub fn solve_cg(
        &self,
        c: &mut [f64],
        precondition: bool,
        tol: f64,
        max_iterations: usize,
    ) -> SolveStats {
        let k2 = self.k * self.k;
        let k = self.k;
        let pinv: Vec<f64> = (0..k2)
            .map(|idx| {
                if !precondition {
                    return 1.0;
                }
                let i = idx % k;
                let diag = self.a[i * k + i] + self.alpha * self.d[idx];
                if diag > 0.0 {
                    1.0 / diag
                } else {
                    1.0
                }
            })
            .collect();
        let bnorm = self.b.iter().map(|x| x * x).sum::<f64>().sqrt();
        let hc = self.apply(c);
        let mut r: Vec<f64> = (0..k2).map(|i| self.b[i] - hc[i]).collect();
        let target = if bnorm > 0.0 { tol * bnorm } else { tol };
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let mut rn = norm(&r);
        if rn <= target {
            return SolveStats {
                iterations: 0,
                relative_residual: rn / bnorm.max(f64::MIN_POSITIVE),
            };
        }
        let mut z: Vec<f64> = (0..k2).map(|i| pinv[i] * r[i]).collect();
        let mut p = z.clone();
        let mut gamma: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
        let mut it = 0;
        while it < max_iterations {
            it += 1;
            let hp = self.apply(&p);
            let php: f64 = p.iter().zip(&hp).map(|(a, b)| a * b).sum();
            if php.is_nan() || php <= 0.0 {
                break;
            }
            let step = gamma / php;
            for i in 0..k2 {
                c[i] += step * p[i];
                r[i] -= step * hp[i];
            }
            rn = norm(&r);
            if rn <= target {
                break;
            }
            for i in 0..k2 {
                z[i] = pinv[i] * r[i];
            }
            let g1: f64 = r.iter().zip(&z).map(|(a, b)| a * b).sum();
            let beta = g1 / gamma;
            gamma = g1;
            for i in 0..k2 {
                p[i] = z[i] + beta * p[i];
            }
        }
        SolveStats {
            iterations: it,
            relative_residual: rn / bnorm.max(f64::MIN_POSITIVE),
        }
    }

    /// The exact minimiser: one k × k Cholesky solve per column.
    pub fn solve_direct(&self, par: Par) -> Result<Vec<f64>, FmapError> {
        let k = self.k;
        let cols = par.map_collect(k, |j| {
            let mut m = self.a.clone();
            for i in 0..k {
                m[i * k + i] += self.alpha * self.d[j * k + i];
            }
            spd_solve(&m, k, &self.b[j * k..(j + 1) * k], j)
        });
        let mut out = Vec::with_capacity(k * k);
        for c in cols {
            out.extend(c?);
        }
        Ok(out)
    }
}

fn check_basis(eb: &EigenBasis, mesh: &TriMesh, side: &'static str) -> Result<(), FmapError> {
    if eb.n != mesh.n_vertices() {
        return Err(FmapError::BasisMeshMismatch {
            side,
            basis: eb.n,
            mesh: mesh.n_vertices(),
        });
    }
    Ok(())
}

/// The two unit-area bases truncated to the common `k` (0: the smaller basis size).
pub fn bases(
    source: &EigenBasis,
    target: &EigenBasis,
    k: usize,
) -> Result<(Basis, Basis), FmapError> {
    let k = if k == 0 {
        source.k().min(target.k())
    } else {
        k
    };
    Ok((
        Basis::new(source, k, "source")?,
        Basis::new(target, k, "target")?,
    ))
}

/// Builds the system of eq. 5.5 for all curve pairs of the two networks.
#[allow(clippy::too_many_arguments)]
pub fn build_system(
    b1: &Basis,
    b2: &Basis,
    mesh1: &TriMesh,
    mesh2: &TriMesh,
    net1: &FeatureCurveNetwork,
    net2: &FeatureCurveNetwork,
    params: &CurveConstrainedParams,
    par: Par,
) -> Result<CurveSystem, FmapError> {
    if net1.curves.len() != net2.curves.len() {
        return Err(FmapError::CurveCountMismatch {
            source_count: net1.curves.len(),
            target: net2.curves.len(),
        });
    }
    let mut sys = CurveSystem::new(&b1.values, &b2.values, params.alpha);
    let s = params.samples;
    let restricted = par.map_collect(net1.curves.len(), |c| {
        Ok::<_, FmapError>((
            restrict(b1, mesh1, net1, c, s, "source")?,
            restrict(b2, mesh2, net2, c, s, "target")?,
        ))
    });
    for r in restricted {
        let (p1, p2) = r?;
        sys.add_pair(&p1, &p2, s);
    }
    Ok(sys)
}

/// Solves eq. 5.5 for the curve pairs of `net1` (on the source) and `net2` (on the target),
/// starting CG from `initial` when given.
#[allow(clippy::too_many_arguments)]
pub fn curve_constrained(
    source_basis: &EigenBasis,
    target_basis: &EigenBasis,
    source_mesh: &TriMesh,
    target_mesh: &TriMesh,
    source_curves: &FeatureCurveNetwork,
    target_curves: &FeatureCurveNetwork,
    initial: Option<&FunctionalMap>,
    params: &CurveConstrainedParams,
    par: Par,
) -> Result<FunctionalMap, FmapError> {
    check_basis(source_basis, source_mesh, "source")?;
    check_basis(target_basis, target_mesh, "target")?;
    let (b1, b2) = bases(source_basis, target_basis, params.k)?;
    let sys = build_system(
        &b1,
        &b2,
        source_mesh,
        target_mesh,
        source_curves,
        target_curves,
        params,
        par,
    )?;
    solve_system(&sys, initial, params, par)
}

/// Solves a built system with the chosen solver.
pub fn solve_system(
    sys: &CurveSystem,
    initial: Option<&FunctionalMap>,
    params: &CurveConstrainedParams,
    par: Par,
) -> Result<FunctionalMap, FmapError> {
    let k = sys.k;
    let (c, iterations) = match params.solver {
        CurveMapSolver::Direct => (sys.solve_direct(par)?, 0),
        CurveMapSolver::Cg => {
            let mut c = match initial {
                Some(m) => warm_start(m, k)?,
                None => vec![0.0; k * k],
            };
            let st = sys.solve_cg(
                &mut c,
                params.precondition,
                params.tol,
                params.max_iterations,
            );
            (c, st.iterations)
        }
    };
    Ok(FunctionalMap {
        k_source: k,
        k_target: k,
        energy: sys.energy(&c),
        matrix: c,
        iterations,
    })
}

/// A k × k start from a previous map (its top-left block; zero-padded if smaller).
pub fn warm_start(m: &FunctionalMap, k: usize) -> Result<Vec<f64>, FmapError> {
    if m.matrix.len() != m.k_source * m.k_target {
        return Err(FmapError::MapSizeMismatch {
            rows: m.k_target,
            cols: m.k_source,
            k_target: k,
            k_source: k,
        });
    }
    let mut c = vec![0.0; k * k];
    for j in 0..k.min(m.k_source) {
        for i in 0..k.min(m.k_target) {
            c[j * k + i] = m.get(i, j);
        }
    }
    Ok(c)
}

/// Node wrapper of [`curve_constrained`].
pub struct CurveConstrainedNode;

impl NodeKind for CurveConstrainedNode {
    type Params = CurveConstrainedParams;
    const KIND: &'static str = "fmap.curve_constrained";
    const VERSION: u32 = 2;
    const DOC: &'static str = "Curve-constrained functional map (thesis §5.2, eq. 5.5): \
        Laplacian commutativity (α = 0.5) plus one restricted-basis term per corresponding \
        curve pair, solved by conjugate gradients on precomputed k×k terms (Algorithms 5.1, \
        5.2; Jacobi-preconditioned by default) or by k dense Cholesky solves. An optional \
        `initial` map warm-starts CG, as when one curve pair is added to a solved set.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<EigenBasis>("source_basis", "eigenbasis of the source mesh"),
            Port::of::<EigenBasis>("target_basis", "eigenbasis of the target mesh"),
            Port::of::<TriMesh>("source_mesh", "the source mesh"),
            Port::of::<TriMesh>("target_mesh", "the target mesh"),
            Port::of::<FeatureCurveNetwork>("source_curves", "curves on the source"),
            Port::of::<FeatureCurveNetwork>(
                "target_curves",
                "curves on the target; curve i corresponds to source curve i",
            ),
            Port::optional::<FunctionalMap>("initial", "start of the CG iteration"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<FunctionalMap>("map", "the k×k functional map")]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        ctx.check_cancelled()?;
        let m = curve_constrained(
            inputs.get("source_basis")?,
            inputs.get("target_basis")?,
            inputs.get("source_mesh")?,
            inputs.get("target_mesh")?,
            inputs.get("source_curves")?,
            inputs.get("target_curves")?,
            inputs.opt("initial")?,
            params,
            ctx.par,
        )
        .map_err(FmapError::into_node)?;
        Ok(Outputs::new().with("map", m))
    }
}

#[cfg(test)]
#[path = "curve_constrained_test.rs"]
pub(crate) mod tests;
