//! `smooth.laplacian`: Laplacian smoothing that keeps feature curves (thesis §5.1.3,
//! feature-preserving smoothing, Table 5.1; Desbrun, Meyer, Schröder & Barr 1999, "Implicit
//! fairing of irregular meshes"; Taubin 1995; cotangent weights of §2.3, Pinkall & Polthier
//! 1993).
//!
//! Every iteration moves the free vertices towards a weighted average of their one-ring.
//! Vertices under the curves of an optional feature curve network are fixed (the rule is in
//! [`crate::constraints`]), and so are boundary vertices (unless `fix_boundary` is false) and
//! vertices no face uses.
//!
//! Weights (`weights`):
//! - `Uniform`: every edge weighs 1 (the umbrella operator). It also evens out the triangles
//!   (tangential drift).
//! - `Cotan`: w_ij = ½ (cot α_ij + cot β_ij) from the cotangent Laplacian of
//!   `crestflow_nodes_spectral::sparse` (intrinsically mollified, so degenerate triangles give
//!   finite weights). It moves vertices along the mean curvature normal only.
//!
//! Steps (`step`):
//! - `Explicit`: x_i ← x_i + λ (Σ_j w_ij x_j / Σ_j w_ij − x_i), all vertices from the previous
//!   positions (Jacobi). The cotangent weights are used as they are, which keeps linear
//!   precision (a plane is a fixed point), unless negative weights (non-Delaunay edges)
//!   dominate a vertex's row (Σ w < ½ Σ |w|): that vertex then uses the weights clamped at 0
//!   (a convex combination), or uniform weights if none is positive. λ in (0, 1].
//! - `Implicit` (backward Euler, DMSB99): (M + τ L) x' = M x, with L the positive
//!   semi-definite stiffness matrix (cotangent, or the graph Laplacian D − A for uniform
//!   weights) and M the lumped mass (`mass`: barycentric or mixed Voronoi areas; the degree
//!   matrix D for uniform weights). For cotangent weights τ = `time_step` · h² with h the mean
//!   edge length of the input mesh, so `time_step` does not depend on the mesh's scale; the
//!   uniform operator has no length unit and τ = `time_step`. Fixed vertices are eliminated:
//!   only the free rows are solved, with the fixed neighbours moved to the right-hand side. The
//!   sparse Cholesky analysis (ordering, elimination tree) is done once; when the weights are
//!   recomputed on the moving mesh (`update_weights`) only the numeric factorisation is
//!   redone; the three coordinates are solved together.
//!
//! Deterministic: the same output, bit for bit, for `Par::Seq` and `Par::Rayon`.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{FeatureCurveNetwork, MeshDefect, TriMesh};
use crestflow_nodes_spectral::sparse::{
    CsrMatrix, MassKind, OperatorError, SparseError, SpdSolver,
};

use crate::constraints::{curve_fixed_vertices, ConstraintError};
use crestflow_nodes_spectral::assemble::CotanAssembler;

/// Edge weights of the Laplacian.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Weights {
    /// Every edge weighs 1.
    Uniform,
    /// Cotangent weights (thesis §2.3).
    #[default]
    Cotan,
}

/// Explicit (forward) or implicit (backward Euler) steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Step {
    #[default]
    Explicit,
    Implicit,
}

/// Lumped mass of the implicit cotangent step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Mass {
    /// A third of each incident triangle's area (libigl's `MASSMATRIX_TYPE_BARYCENTRIC`).
    #[default]
    Barycentric,
    /// Mixed Voronoi areas (Meyer et al. 2003).
    Voronoi,
}

/// Parameters of `smooth.laplacian`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LaplacianParams {
    /// `Uniform` or `Cotan` (default).
    pub weights: Weights,
    /// `Explicit` (default) or `Implicit`.
    pub step: Step,
    /// Explicit step size λ, in (0, 1] (default 0.5).
    pub lambda: f64,
    /// Implicit time step, in units of the squared mean edge length for cotangent weights
    /// (dimensionless for uniform weights); in (0, 1e6] (default 1).
    pub time_step: f64,
    /// Number of steps (default 100, as in thesis Table 5.1; range 0..=100000).
    pub iterations: u32,
    /// Keep boundary vertices in place (default true).
    pub fix_boundary: bool,
    /// Recompute the weights (and masses) from the current positions at every iteration
    /// (default true). False keeps those of the input: a linear filter, and the implicit
    /// step then factorises once.
    pub update_weights: bool,
    /// Mass matrix of the implicit cotangent step (default `Barycentric`).
    pub mass: Mass,
    /// A curve vertex fixes every corner of its mesh element whose weight (barycentric
    /// coordinate) is at least this, and always its heaviest corner; in [0, 1] (default
    /// 0.25: a point in the middle half of an edge fixes both ends).
    pub min_weight: f64,
}

impl Default for LaplacianParams {
    fn default() -> Self {
        LaplacianParams {
            weights: Weights::Cotan,
            step: Step::Explicit,
            lambda: 0.5,
            time_step: 1.0,
            iterations: 100,
            fix_boundary: true,
            update_weights: true,
            mass: Mass::Barycentric,
            min_weight: 0.25,
        }
    }
}

impl Validate for LaplacianParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "lambda", self.lambda, f64::MIN_POSITIVE, 1.0);
        check_range(&mut v, "time_step", self.time_step, f64::MIN_POSITIVE, 1e6);
        check_range(&mut v, "iterations", self.iterations, 0, 100_000);
        check_range(&mut v, "min_weight", self.min_weight, 0.0, 1.0);
        v
    }
}

/// Why smoothing could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SmoothError {
    #[error("the mesh has no faces ({vertices} vertices)")]
    NoFaces { vertices: usize },
    #[error("face {face} references vertex {index} but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        n_vertices: usize,
    },
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFinite { vertex: usize, position: V3 },
    #[error("face {face} uses vertex {vertex} twice")]
    RepeatedVertex { face: usize, vertex: u32 },
    #[error("feature curves: {0}")]
    Curves(#[from] ConstraintError),
    #[error("Laplacian: {0}")]
    Operator(#[from] OperatorError),
    #[error("implicit step {iteration}: {source}")]
    Solve {
        iteration: u32,
        #[source]
        source: SparseError,
    },
    #[error(
        "vertex {vertex} left the finite numbers: the steps diverged (try a smaller lambda or \
         time_step, or fewer iterations)"
    )]
    Diverged { vertex: usize },
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("cancelled")]
    Cancelled,
}

impl SmoothError {
    /// The node error kind this maps to.
    pub fn kind(&self) -> ErrorKind {
        match self {
            SmoothError::Solve { .. } | SmoothError::Diverged { .. } => ErrorKind::NumericalFailure,
            SmoothError::Cancelled => ErrorKind::Cancelled,
            _ => ErrorKind::InvalidInput,
        }
    }
}

/// What smoothing did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SmoothStats {
    pub vertices: usize,
    /// Vertices fixed by the curves.
    pub fixed_by_curves: usize,
    /// Boundary vertices fixed (and not already fixed by curves).
    pub fixed_boundary: usize,
    /// Vertices no face uses.
    pub isolated: usize,
    /// Curve vertices not tied to the mesh, snapped to their nearest vertex.
    pub free_curve_points: usize,
    pub iterations: u32,
    /// Largest and mean distance a vertex moved, relative to the bounding-box diagonal.
    pub max_displacement_rel: f64,
    pub mean_displacement_rel: f64,
}

impl SmoothStats {
    pub fn to_report(&self) -> Report {
        let mut r = Report::new();
        r.set("vertices", self.vertices)
            .set("fixed_by_curves", self.fixed_by_curves)
            .set("fixed_boundary", self.fixed_boundary)
            .set("isolated", self.isolated)
            .set("free_curve_points", self.free_curve_points)
            .set("iterations", self.iterations as usize)
            .set("max_displacement_rel", self.max_displacement_rel)
            .set("mean_displacement_rel", self.mean_displacement_rel);
        r
    }
}

/// The smoothed mesh, which vertices were held, and stats.
#[derive(Clone, Debug, PartialEq)]
pub struct SmoothOutput {
    pub mesh: TriMesh,
    pub fixed: Vec<bool>,
    pub stats: SmoothStats,
}

fn check_mesh(mesh: &TriMesh) -> Result<(), SmoothError> {
    let n = mesh.n_vertices();
    if mesh.n_faces() == 0 {
        return Err(SmoothError::NoFaces { vertices: n });
    }
    mesh.check_data().map_err(|d| match d {
        MeshDefect::NonFinitePosition { vertex, position } => {
            SmoothError::NonFinite { vertex, position }
        }
        MeshDefect::IndexOutOfRange {
            face,
            index,
            n_vertices,
        } => SmoothError::IndexOutOfRange {
            face,
            index,
            n_vertices,
        },
    })?;
    for (face, t) in mesh.triangles.iter().enumerate() {
        if t[0] == t[1] || t[0] == t[2] || t[1] == t[2] {
            let vertex = if t[0] == t[1] || t[0] == t[2] {
                t[0]
            } else {
                t[1]
            };
            return Err(SmoothError::RepeatedVertex { face, vertex });
        }
    }
    Ok(())
}

/// The uniform graph Laplacian D − A over the unique edges (sorted pattern, diagonal
/// included for every vertex with an edge).
fn uniform_laplacian(mesh: &TriMesh) -> Result<CsrMatrix, SparseError> {
    let topo = mesh.topology();
    let n = mesh.n_vertices();
    let mut trip = Vec::with_capacity(topo.edges.len() * 4);
    for e in &topo.edges {
        let (a, b) = (e[0] as usize, e[1] as usize);
        trip.push((a, b, -1.0));
        trip.push((b, a, -1.0));
        trip.push((a, a, 1.0));
        trip.push((b, b, 1.0));
    }
    CsrMatrix::from_triplets(n, n, &trip)
}

/// Stiffness matrix and mass diagonal of the input, and for cotangent weights the assembler
/// that recomputes them on moved positions.
#[allow(clippy::type_complexity)]
fn operator(
    mesh: &TriMesh,
    params: &LaplacianParams,
    par: Par,
) -> Result<(Option<CotanAssembler>, CsrMatrix, Vec<f64>), SmoothError> {
    match params.weights {
        Weights::Cotan => {
            let kind = match params.mass {
                Mass::Barycentric => MassKind::Barycentric,
                Mass::Voronoi => MassKind::Voronoi,
            };
            let (asm, l, m) = CotanAssembler::new(mesh, kind, par)?;
            Ok((Some(asm), l, m))
        }
        Weights::Uniform => {
            let l = uniform_laplacian(mesh).map_err(OperatorError::from)?;
            let d = l.diagonal();
            Ok((None, l, d))
        }
    }
}

/// One explicit step from `x` (module docs).
fn explicit_step(l: &CsrMatrix, x: &[V3], fixed: &[bool], lambda: f64, par: Par) -> Vec<V3> {
    par.map_collect(x.len(), |i| {
        if fixed[i] {
            return x[i];
        }
        // Raw weights keep the cotangent operator's linear precision (a plane stays in place);
        // when negative weights dominate a row (badly shaped one-ring) the clamped convex
        // weights, and failing those uniform weights, keep the step stable.
        let mut raw = [0.0; 3];
        let mut raw_sum = 0.0;
        let mut abs_sum = 0.0;
        let mut pos = [0.0; 3];
        let mut pos_sum = 0.0;
        let mut uni = [0.0; 3];
        let mut count = 0usize;
        for (j, v) in l.row(i) {
            if j == i {
                continue;
            }
            let w = -v;
            raw = vec3::add(raw, vec3::scale(x[j], w));
            raw_sum += w;
            abs_sum += w.abs();
            if w > 0.0 {
                pos = vec3::add(pos, vec3::scale(x[j], w));
                pos_sum += w;
            }
            uni = vec3::add(uni, x[j]);
            count += 1;
        }
        let avg = if raw_sum > 0.5 * abs_sum && raw_sum.is_finite() {
            vec3::scale(raw, 1.0 / raw_sum)
        } else if pos_sum > 0.0 && pos_sum.is_finite() {
            vec3::scale(pos, 1.0 / pos_sum)
        } else if count > 0 {
            vec3::scale(uni, 1.0 / count as f64)
        } else {
            return x[i];
        };
        vec3::add(x[i], vec3::scale(vec3::sub(avg, x[i]), lambda))
    })
}

/// The free-vertex block of M + τL with a fixed pattern, and where each entry of L goes.
struct Reduced {
    /// Reduced index of each vertex, `u32::MAX` for fixed ones.
    index: Vec<u32>,
    /// Vertex of each reduced index.
    vertex: Vec<u32>,
    matrix: CsrMatrix,
    /// For every stored entry k of L: its position in `matrix`, or `usize::MAX` when its row
    /// or column is fixed.
    slot: Vec<usize>,
    /// Position of each reduced row's diagonal entry in `matrix`.
    diag: Vec<usize>,
}

impl Reduced {
    fn new(l: &CsrMatrix, fixed: &[bool]) -> Result<Reduced, SparseError> {
        let n = l.nrows();
        let mut index = vec![u32::MAX; n];
        let mut vertex = Vec::new();
        for i in 0..n {
            if !fixed[i] {
                index[i] = vertex.len() as u32;
                vertex.push(i as u32);
            }
        }
        let mut row_ptr = vec![0usize];
        let mut col_idx = Vec::new();
        let mut slot = vec![usize::MAX; l.nnz()];
        let mut diag = vec![usize::MAX; vertex.len()];
        let (rp, ci) = (l.row_ptr(), l.col_idx());
        for &v in &vertex {
            let i = v as usize;
            for k in rp[i]..rp[i + 1] {
                let j = ci[k];
                if index[j] != u32::MAX {
                    if j == i {
                        diag[index[i] as usize] = col_idx.len();
                    }
                    slot[k] = col_idx.len();
                    col_idx.push(index[j] as usize);
                }
            }
            row_ptr.push(col_idx.len());
        }
        let nnz = col_idx.len();
        let matrix =
            CsrMatrix::from_raw(vertex.len(), vertex.len(), row_ptr, col_idx, vec![0.0; nnz])?;
        // Every free vertex has faces, hence a diagonal entry in L.
        if let Some(r) = diag.iter().position(|&k| k == usize::MAX) {
            return Err(SparseError::Malformed(format!(
                "row {} of the Laplacian has no diagonal entry",
                vertex[r]
            )));
        }
        Ok(Reduced {
            index,
            vertex,
            matrix,
            slot,
            diag,
        })
    }

    /// Writes M_ff + τ L_ff into `matrix` (same pattern every time).
    fn fill(&mut self, l: &CsrMatrix, mass: &[f64], tau: f64) {
        let vals = self.matrix.values_mut();
        vals.iter_mut().for_each(|v| *v = 0.0);
        for (k, &lv) in l.values().iter().enumerate() {
            if self.slot[k] != usize::MAX {
                vals[self.slot[k]] += tau * lv;
            }
        }
        for (&v, &k) in self.vertex.iter().zip(&self.diag) {
            vals[k] += mass[v as usize];
        }
    }

    /// Right-hand sides M_f x_f − τ L_fc x_c, column-major (n_free × 3).
    fn rhs(&self, l: &CsrMatrix, mass: &[f64], tau: f64, x: &[V3]) -> Vec<f64> {
        let nf = self.vertex.len();
        let mut b = vec![0.0; nf * 3];
        let (rp, ci, lv) = (l.row_ptr(), l.col_idx(), l.values());
        for (r, &v) in self.vertex.iter().enumerate() {
            let i = v as usize;
            let mut acc = vec3::scale(x[i], mass[i]);
            for k in rp[i]..rp[i + 1] {
                let j = ci[k];
                if self.index[j] == u32::MAX {
                    acc = vec3::sub(acc, vec3::scale(x[j], tau * lv[k]));
                }
            }
            for c in 0..3 {
                b[c * nf + r] = acc[c];
            }
        }
        b
    }
}

/// Smooths `mesh`, keeping the vertices under `curves` fixed (module docs). `keep_going` is
/// called before every iteration with the fraction done; returning false cancels.
pub fn laplacian_smooth_with(
    mesh: &TriMesh,
    curves: Option<&FeatureCurveNetwork>,
    params: &LaplacianParams,
    par: Par,
    keep_going: &mut dyn FnMut(f32) -> bool,
) -> Result<SmoothOutput, SmoothError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(SmoothError::Params(text.join("; ")));
    }
    check_mesh(mesh)?;
    let n = mesh.n_vertices();
    let mut stats = SmoothStats {
        vertices: n,
        iterations: params.iterations,
        ..Default::default()
    };

    let mut fixed = vec![false; n];
    if let Some(net) = curves {
        let (mask, free) = curve_fixed_vertices(mesh, net, params.min_weight)?;
        fixed = mask;
        stats.free_curve_points = free;
        stats.fixed_by_curves = fixed.iter().filter(|&&f| f).count();
    }
    let topo = mesh.topology();
    for (v, fx) in fixed.iter_mut().enumerate() {
        if topo.vertex_faces(v as u32).is_empty() {
            *fx = true;
            stats.isolated += 1;
        } else if params.fix_boundary && topo.is_boundary_vertex[v] && !*fx {
            *fx = true;
            stats.fixed_boundary += 1;
        }
    }

    let mut x = mesh.positions.clone();
    let h = mesh.mean_edge_length();
    let tau = match params.weights {
        Weights::Cotan => params.time_step * h * h,
        Weights::Uniform => params.time_step,
    };
    let (assembler, mut l, mut mass) = operator(mesh, params, par)?;
    let mut solver: Option<(Reduced, SpdSolver)> = None;
    for it in 0..params.iterations {
        if !keep_going(it as f32 / params.iterations.max(1) as f32) {
            return Err(SmoothError::Cancelled);
        }
        // The uniform operator does not depend on the positions.
        let update = params.update_weights && params.weights == Weights::Cotan;
        if it > 0 && update {
            if let Some(asm) = &assembler {
                asm.assemble(&mesh.triangles, &x, &mut l, &mut mass, par);
            }
        }
        match params.step {
            Step::Explicit => x = explicit_step(&l, &x, &fixed, params.lambda, par),
            Step::Implicit => {
                let solve_err = |source| SmoothError::Solve {
                    iteration: it,
                    source,
                };
                let refresh = it == 0 || update;
                match &mut solver {
                    None => {
                        let mut red = Reduced::new(&l, &fixed).map_err(solve_err)?;
                        if red.vertex.is_empty() {
                            break;
                        }
                        red.fill(&l, &mass, tau);
                        let s = SpdSolver::new(&red.matrix, par).map_err(solve_err)?;
                        solver = Some((red, s));
                    }
                    Some((red, s)) if refresh => {
                        red.fill(&l, &mass, tau);
                        s.refactor(&red.matrix, par).map_err(solve_err)?;
                    }
                    Some(_) => {}
                }
                if let Some((red, s)) = &solver {
                    let mut b = red.rhs(&l, &mass, tau, &x);
                    s.solve_many(&mut b, 3, par).map_err(solve_err)?;
                    let nf = red.vertex.len();
                    for (r, &v) in red.vertex.iter().enumerate() {
                        x[v as usize] = [b[r], b[nf + r], b[2 * nf + r]];
                    }
                }
            }
        }
    }
    keep_going(1.0);
    if let Some(vertex) = x.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(SmoothError::Diverged { vertex });
    }

    let diag = mesh.bbox_diagonal();
    let mut max_d = 0.0f64;
    let mut sum_d = 0.0;
    for (p, q) in mesh.positions.iter().zip(&x) {
        let d = vec3::dist(*p, *q);
        max_d = max_d.max(d);
        sum_d += d;
    }
    if diag > 0.0 {
        stats.max_displacement_rel = max_d / diag;
        stats.mean_displacement_rel = sum_d / n as f64 / diag;
    }
    Ok(SmoothOutput {
        mesh: mesh.with_positions(x),
        fixed,
        stats,
    })
}

/// [`laplacian_smooth_with`] without progress reporting.
pub fn laplacian_smooth(
    mesh: &TriMesh,
    curves: Option<&FeatureCurveNetwork>,
    params: &LaplacianParams,
    par: Par,
) -> Result<SmoothOutput, SmoothError> {
    laplacian_smooth_with(mesh, curves, params, par, &mut |_| true)
}

/// The `smooth.laplacian` node.
pub struct LaplacianNode;

impl NodeKind for LaplacianNode {
    type Params = LaplacianParams;
    const KIND: &'static str = "smooth.laplacian";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Laplacian smoothing that keeps feature curves: uniform or \
        cotangent weights, explicit steps or implicit backward-Euler steps (M + tL) x' = M x \
        with one symbolic Cholesky analysis reused; mesh vertices under the curves of an \
        optional feature curve network (and boundary vertices) stay fixed. Thesis §5.1.3 \
        (Table 5.1), §2.3; Desbrun, Meyer, Schröder & Barr 1999, Taubin 1995.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the mesh to smooth"),
            Port::optional::<FeatureCurveNetwork>(
                "curves",
                "feature curves whose mesh vertices stay fixed",
            ),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the smoothed mesh (same connectivity)"),
            Port::of::<Report>("report", "fixed vertex counts and displacements"),
        ]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let curves = inputs.opt::<FeatureCurveNetwork>("curves")?;
        let out = laplacian_smooth_with(mesh, curves, params, ctx.par, &mut |f| {
            ctx.progress(f);
            !ctx.cancel.is_cancelled()
        })
        .map_err(|e| NodeError::from_source(e.kind(), e))?;
        Ok(Outputs::new()
            .with("mesh", out.mesh)
            .with("report", out.stats.to_report()))
    }
}
