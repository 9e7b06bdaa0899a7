//! `geodesic.heat`: geodesic distance by the heat method.
//!
//! Crane, Weischedel and Wardetzky, "Geodesics in Heat: A New Approach to Computing Distance
//! Based on Heat Flow", ACM TOG 32(5), 2013. Thesis §3.1.2.1 and §3.1.2.5 name it as the fast
//! way to get the distance fields the curve GICS needs.
//!
//! 1. Heat flow for a short time `t = m · h²` (h the mean edge length): one backward Euler step
//!    `(M + t L) u = δ`, with `L` the positive semi-definite cotangent stiffness matrix and `M`
//!    the lumped mass (both from `crestflow-nodes-spectral`).
//! 2. The normalised direction of heat flow per face, `X = −∇u / |∇u|`.
//! 3. The Poisson problem `L φ = ∫ X · ∇ψ_i` (the weak divergence of `X`, written with the hat
//!    functions ψ_i; it equals the cotangent formula of the paper).
//! 4. Shift so that the sources sit at distance 0.
//!
//! `L` is singular (constants are in its kernel). We pin one vertex per connected component
//! (its row and column become the identity row), which is exact rather than a regularisation;
//! the shift of step 4 then fixes the constant. Components that hold no source get distance
//! `+∞`, as do vertices no triangle references.
//!
//! Sources are convex combinations of mesh vertices: a vertex, or a feature-curve vertex on a
//! mesh edge or inside a face. A curve emits heat along its whole length: every curve vertex
//! gets half the length of its two segments, spread on the mesh vertices by its barycentric
//! weights. On meshes with boundary the heat step is the mean of the Neumann solution and the
//! solution with zero boundary values, as the paper recommends (the Poisson step keeps the
//! natural Neumann condition).
//!
//! [`HeatSolver`] factorises both matrices once; [`HeatSolver::distances`] solves a batch of
//! sources as one block of right-hand sides. Results are the same bits at any thread count.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Validate,
};
use crestflow_geom::fcn::{FeatureCurveNetwork, SurfacePoint};
use crestflow_geom::mesh::TriMesh;
use crestflow_geom::vec3::{cross, dot, norm, sub, V3};
use crestflow_nodes_spectral::sparse::{
    laplacian_and_mass, CsrMatrix, LaplacianOptions, OperatorError, SparseError, SpdSolver,
};

/// Parameters of `geodesic.heat`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HeatParams {
    /// Source vertices (default empty). With a `curves` input, the curves are sources too.
    pub vertices: Vec<u32>,
    /// With a `curves` input: the indices of the curves that are sources (default empty:
    /// all of them).
    pub curve_ids: Vec<u32>,
    /// `m` in the time step `t = m · h²` (default 1, the paper's choice; range 1e-3..=1e3).
    pub time_factor: f64,
}

impl Default for HeatParams {
    fn default() -> Self {
        HeatParams {
            vertices: Vec::new(),
            curve_ids: Vec::new(),
            time_factor: 1.0,
        }
    }
}

impl Validate for HeatParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "time_factor", self.time_factor, 1e-3, 1e3);
        issues
    }
}

/// Per-vertex geodesic distance from a source set (`+∞` where unreachable).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DistanceField {
    pub values: Vec<f64>,
}

impl DistanceField {
    /// The largest finite distance (0 for an empty field).
    pub fn max_finite(&self) -> f64 {
        self.values
            .iter()
            .copied()
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max)
    }
}

/// One point of a source: mesh vertices with barycentric weights (summing to 1) and the heat
/// it emits.
#[derive(Clone, Debug, PartialEq)]
pub struct SourcePoint {
    pub corners: Vec<(u32, f64)>,
    pub heat: f64,
}

/// A set of points from which distance is measured.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct HeatSource {
    pub points: Vec<SourcePoint>,
}

impl HeatSource {
    /// Mesh vertices, each emitting unit heat.
    pub fn vertices(vertices: &[u32]) -> HeatSource {
        HeatSource {
            points: vertices
                .iter()
                .map(|&v| SourcePoint {
                    corners: vec![(v, 1.0)],
                    heat: 1.0,
                })
                .collect(),
        }
    }

    /// The whole curve `c` of `network` on `mesh`: each curve vertex emits heat in
    /// proportion to the curve length it stands for (half of each adjacent segment), lengths
    /// measured on `mesh` (so a network traced on one pose can be used on another pose with
    /// the same connectivity).
    pub fn curve(
        network: &FeatureCurveNetwork,
        c: usize,
        mesh: &TriMesh,
    ) -> Result<HeatSource, HeatError> {
        let corners = curve_corners(network, c, mesh)?;
        let pos: Vec<V3> = corners
            .iter()
            .map(|cs| corners_position(mesh, cs))
            .collect();
        let weights = curve_vertex_weights(&pos, network.curves[c].closed);
        Ok(HeatSource {
            points: corners
                .into_iter()
                .zip(weights)
                .map(|(corners, heat)| SourcePoint { corners, heat })
                .collect(),
        })
    }
}

/// The points of curve `c` as mesh-vertex combinations, checked against `mesh`.
pub fn curve_corners(
    network: &FeatureCurveNetwork,
    c: usize,
    mesh: &TriMesh,
) -> Result<Vec<Vec<(u32, f64)>>, HeatError> {
    let curve = network.curves.get(c).ok_or(HeatError::NoSuchCurve {
        curve: c,
        n_curves: network.curves.len(),
    })?;
    let n = mesh.n_vertices();
    let mut out = Vec::with_capacity(curve.vertices.len());
    for &id in &curve.vertices {
        let v = network
            .vertices
            .get(id as usize)
            .ok_or(HeatError::BadCurveVertex {
                curve: c,
                vertex: id,
                n_vertices: network.vertices.len(),
            })?;
        let cs = surface_point_corners(v.location, &mesh.triangles).ok_or(
            HeatError::FreeCurveVertex {
                curve: c,
                vertex: id,
            },
        )?;
        if let Some(&(bad, _)) = cs.iter().find(|(m, _)| *m as usize >= n) {
            return Err(HeatError::CurveOffMesh {
                curve: c,
                vertex: id,
                mesh_vertex: bad,
                n_vertices: n,
            });
        }
        out.push(cs);
    }
    Ok(out)
}

/// The position of a mesh-vertex combination (indices must be in range).
pub fn corners_position(mesh: &TriMesh, corners: &[(u32, f64)]) -> V3 {
    let mut p = [0.0; 3];
    for &(v, w) in corners {
        let q = mesh.positions[v as usize];
        for k in 0..3 {
            p[k] += w * q[k];
        }
    }
    p
}

/// Half the length of the segments at each polyline vertex, normalised to sum 1 (uniform
/// when the polyline has zero length).
pub fn curve_vertex_weights(pos: &[V3], closed: bool) -> Vec<f64> {
    let n = pos.len();
    let mut w = vec![0.0; n];
    if n == 0 {
        return w;
    }
    let n_seg = if closed && n > 2 { n } else { n - 1 };
    for s in 0..n_seg {
        let (a, b) = (s, (s + 1) % n);
        let l = norm(sub(pos[b], pos[a]));
        w[a] += 0.5 * l;
        w[b] += 0.5 * l;
    }
    let total: f64 = w.iter().sum();
    if total > 0.0 && total.is_finite() {
        w.iter_mut().for_each(|x| *x /= total);
    } else {
        w.iter_mut().for_each(|x| *x = 1.0 / n as f64);
    }
    w
}

/// Mesh vertices and weights of a surface point; `None` for a point not on the mesh (or in a
/// face that does not exist).
pub fn surface_point_corners(p: SurfacePoint, triangles: &[[u32; 3]]) -> Option<Vec<(u32, f64)>> {
    match p {
        SurfacePoint::Vertex(v) => Some(vec![(v, 1.0)]),
        SurfacePoint::Edge { a, b, t } => Some(vec![(a, 1.0 - t), (b, t)]),
        SurfacePoint::Face { f, bary } => {
            let t = triangles.get(f as usize)?;
            Some((0..3).map(|i| (t[i], bary[i])).collect())
        }
        SurfacePoint::Free => None,
    }
}

/// Errors of the heat method.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HeatError {
    #[error("the mesh has no triangles")]
    NoTriangles,
    #[error("time_factor = {0} must be finite and positive")]
    BadTimeFactor(f64),
    #[error("source {source_index} is empty (no points)")]
    EmptySource { source_index: usize },
    #[error(
        "source {source_index} references vertex {vertex} but the mesh has {n_vertices} vertices"
    )]
    SourceOutOfRange {
        source_index: usize,
        vertex: u32,
        n_vertices: usize,
    },
    #[error("source {source_index} has a point with a non-finite or negative weight")]
    BadSourceWeight { source_index: usize },
    #[error("source {source_index} only touches vertices that no triangle references")]
    UnreferencedSource { source_index: usize },
    #[error("curve {curve} does not exist (the network has {n_curves} curves)")]
    NoSuchCurve { curve: usize, n_curves: usize },
    #[error("curve {curve} references network vertex {vertex} but the network has {n_vertices}")]
    BadCurveVertex {
        curve: usize,
        vertex: u32,
        n_vertices: usize,
    },
    #[error("vertex {vertex} of curve {curve} is not tied to the mesh (a free point or a face index out of range)")]
    FreeCurveVertex { curve: usize, vertex: u32 },
    // A network names mesh vertices by index: it only carries over to meshes of one
    // connectivity (poses of one template), the usual cause of this error.
    #[error("vertex {vertex} of curve {curve} refers to mesh vertex {mesh_vertex} but the mesh has {n_vertices} vertices (was the network traced on another mesh? it carries over only to meshes with the same vertices and faces)")]
    CurveOffMesh {
        curve: usize,
        vertex: u32,
        mesh_vertex: u32,
        n_vertices: usize,
    },
    #[error("no sources: give `vertices` or connect `curves`")]
    NoSources,
    #[error(transparent)]
    Operator(#[from] OperatorError),
    #[error(transparent)]
    Sparse(#[from] SparseError),
}

impl HeatError {
    fn kind(&self) -> ErrorKind {
        match self {
            HeatError::Sparse(_) => ErrorKind::NumericalFailure,
            _ => ErrorKind::InvalidInput,
        }
    }
}

/// Faces whose divergence terms are computed before they are added to their vertices.
const DIVERGENCE_BLOCK: usize = 64;

/// Factorised operators of the heat method for one mesh, reusable across sources.
#[derive(Debug, Clone)]
pub struct HeatSolver {
    n: usize,
    time: f64,
    triangles: Vec<[u32; 3]>,
    /// Per face: the cotangent weights `½ cot θ_k` of the edges opposite its corners `k`
    /// (its stiffness matrix `A ∇ψ_i · ∇ψ_j`) and `1 / A` (zeros for a degenerate face).
    stiffness: Vec<[f64; 4]>,
    /// Connected component of each vertex (`u32::MAX` for unreferenced vertices).
    component: Vec<u32>,
    /// The pinned vertex of each component.
    pins: Vec<u32>,
    heat: SpdSolver,
    /// `M + tL` with zero (Dirichlet) boundary values, when the mesh has a boundary.
    heat_dirichlet: Option<SpdSolver>,
    boundary: Vec<u32>,
    poisson: SpdSolver,
}

impl HeatSolver {
    /// Builds and factorises `M + tL` and the pinned `L` of `mesh`.
    pub fn new(mesh: &TriMesh, time_factor: f64, par: Par) -> Result<HeatSolver, HeatError> {
        if !(time_factor.is_finite() && time_factor > 0.0) {
            return Err(HeatError::BadTimeFactor(time_factor));
        }
        if mesh.triangles.is_empty() {
            return Err(HeatError::NoTriangles);
        }
        let n = mesh.n_vertices();
        let (l, mass) = laplacian_and_mass(mesh, &LaplacianOptions::default(), par)?;
        let h = mesh.mean_edge_length();
        let time = time_factor * h * h;

        let (component, pins) = components(n, &mesh.triangles);
        // Unreferenced vertices have an empty row: give them a unit diagonal in both systems.
        let unref: Vec<f64> = component
            .iter()
            .map(|&c| if c == u32::MAX { 1.0 } else { 0.0 })
            .collect();
        let heat_diag: Vec<f64> = mass.iter().zip(&unref).map(|(m, u)| m + u).collect();
        let heat_matrix = l.add_scaled(time, &CsrMatrix::from_diagonal(&heat_diag)?, 1.0)?;
        let heat = SpdSolver::new(&heat_matrix, par)?;
        let boundary: Vec<u32> = (0..n as u32)
            .filter(|&v| mesh.topology().is_boundary_vertex[v as usize])
            .collect();
        let mut lp = l.add_diagonal(&unref)?;
        pin_rows(&mut lp, &pins);
        // The Dirichlet heat matrix and L + diag(unref) have the pattern of M + tL (L's rows
        // hold their diagonal, the unreferenced vertices get one): both reuse its ordering and
        // symbolic analysis, and their numeric factorisations run side by side (the factors
        // do not depend on the thread count).
        let dirichlet = || -> Result<Option<SpdSolver>, HeatError> {
            if boundary.is_empty() {
                return Ok(None);
            }
            let mut hd = heat_matrix.clone();
            pin_rows(&mut hd, &boundary);
            let mut solver = heat.clone();
            solver.refactor(&hd, par)?;
            Ok(Some(solver))
        };
        let poisson = || -> Result<SpdSolver, HeatError> {
            let mut solver = heat.clone();
            solver.refactor(&lp, par)?;
            Ok(solver)
        };
        let (heat_dirichlet, poisson) = match par {
            Par::Seq => (dirichlet(), poisson()),
            Par::Rayon => rayon::join(dirichlet, poisson),
        };
        let (heat_dirichlet, poisson) = (heat_dirichlet?, poisson?);

        let stiffness: Vec<[f64; 4]> = (0..mesh.n_faces())
            .map(|f| {
                let p = mesh.face_points(f);
                let a2 = norm(cross(sub(p[1], p[0]), sub(p[2], p[0])));
                if !(a2 > 0.0 && a2.is_finite()) {
                    // A degenerate face carries no gradient.
                    return [0.0; 4];
                }
                // ½ cot θ_k = ½ (e1 · e2) / |e1 × e2| at corner k.
                let half_cot = |k: usize| {
                    let (e1, e2) = (sub(p[(k + 1) % 3], p[k]), sub(p[(k + 2) % 3], p[k]));
                    0.5 * dot(e1, e2) / a2
                };
                [half_cot(0), half_cot(1), half_cot(2), 2.0 / a2]
            })
            .collect();
        Ok(HeatSolver {
            n,
            time,
            triangles: mesh.triangles.clone(),
            stiffness,
            component,
            pins,
            heat,
            heat_dirichlet,
            boundary,
            poisson,
        })
    }

    /// The time step `t`.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Number of mesh vertices.
    pub fn n(&self) -> usize {
        self.n
    }

    fn check_source(&self, s: usize, src: &HeatSource) -> Result<(), HeatError> {
        if src.points.is_empty() {
            return Err(HeatError::EmptySource { source_index: s });
        }
        let mut referenced = false;
        for p in &src.points {
            if !(p.heat.is_finite() && p.heat >= 0.0) {
                return Err(HeatError::BadSourceWeight { source_index: s });
            }
            for &(v, w) in &p.corners {
                if v as usize >= self.n {
                    return Err(HeatError::SourceOutOfRange {
                        source_index: s,
                        vertex: v,
                        n_vertices: self.n,
                    });
                }
                if !w.is_finite() {
                    return Err(HeatError::BadSourceWeight { source_index: s });
                }
                referenced |= self.component[v as usize] != u32::MAX;
            }
        }
        if !referenced {
            return Err(HeatError::UnreferencedSource { source_index: s });
        }
        Ok(())
    }

    /// Distance fields of several sources, solved as blocks of right-hand sides.
    pub fn distances(
        &self,
        sources: &[HeatSource],
        par: Par,
    ) -> Result<Vec<DistanceField>, HeatError> {
        for (s, src) in sources.iter().enumerate() {
            self.check_source(s, src)?;
        }
        let n = self.n;
        let m = sources.len();
        if m == 0 {
            return Ok(Vec::new());
        }
        // 1. heat flow
        let mut u = vec![0.0; n * m];
        for (s, src) in sources.iter().enumerate() {
            let col = &mut u[s * n..(s + 1) * n];
            for p in &src.points {
                for &(v, w) in &p.corners {
                    col[v as usize] += p.heat * w;
                }
            }
        }
        // If every point emits zero heat, fall back to unit heat per point.
        for (s, src) in sources.iter().enumerate() {
            let col = &mut u[s * n..(s + 1) * n];
            if col.iter().all(|&x| x == 0.0) {
                for p in &src.points {
                    for &(v, w) in &p.corners {
                        col[v as usize] += w;
                    }
                }
            }
        }
        if let Some(hd) = &self.heat_dirichlet {
            // Mean of the Neumann and Dirichlet solutions (Crane et al. 2013, §3.2.3):
            // isolines neither bend towards nor away from the boundary.
            let mut ud = u.clone();
            for s in 0..m {
                for &b in &self.boundary {
                    ud[s * n + b as usize] = 0.0;
                }
            }
            // The two solves are independent: run them side by side.
            let (ra, rb) = match par {
                Par::Seq => (
                    self.heat.solve_many(&mut u, m, par),
                    hd.solve_many(&mut ud, m, par),
                ),
                Par::Rayon => rayon::join(
                    || self.heat.solve_many(&mut u, m, par),
                    || hd.solve_many(&mut ud, m, par),
                ),
            };
            ra?;
            rb?;
            u.iter_mut().zip(&ud).for_each(|(a, b)| *a = 0.5 * (*a + b));
        } else {
            self.heat.solve_many(&mut u, m, par)?;
        }
        // 2.-3. normalised gradient and its divergence.
        let mut phi = vec![0.0; n * m];
        let mut scratch = vec![0.0; n];
        for (s, col) in phi.chunks_mut(n).enumerate() {
            self.divergence(&u[s * n..(s + 1) * n], col, &mut scratch, par);
        }
        self.poisson.solve_many(&mut phi, m, par)?;
        // 4. shift per component
        let out = par.map_collect(m, |s| self.shift(&phi[s * n..(s + 1) * n], &sources[s]));
        Ok(out)
    }

    /// Distance from one source.
    pub fn distance(&self, source: &HeatSource, par: Par) -> Result<DistanceField, HeatError> {
        let mut v = self.distances(std::slice::from_ref(source), par)?;
        v.pop().ok_or(HeatError::NoSources)
    }

    /// `b = ∫ X · ∇ψ_i` for `X = −∇u/|∇u|`, with pinned rows zeroed. Each face's terms are
    /// added to its vertices as they are computed, in one pass over the faces (no per-face
    /// array to write and read back). The faces are
    /// cut into two fixed halves, summed into `b` and `scratch` side by side and then added:
    /// the same bits at any thread count.
    fn divergence(&self, u: &[f64], b: &mut [f64], scratch: &mut [f64], par: Par) {
        // b_i = −(K u)_i / |∇u| with K the face's cotangent stiffness matrix and
        // |∇u|² = uᵀ K u / A.
        let accumulate = |faces: std::ops::Range<usize>, out: &mut [f64]| {
            out.iter_mut().for_each(|x| *x = 0.0);
            let tris = &self.triangles[faces.clone()];
            let stiff = &self.stiffness[faces];
            // Blocks of faces: the square roots and divisions of a block are independent
            // and overlap; adding each face's terms right away would chain them through
            // the vertices neighbouring faces share.
            let mut terms = [[0.0f64; 3]; DIVERGENCE_BLOCK];
            for (tb, kb) in tris
                .chunks(DIVERGENCE_BLOCK)
                .zip(stiff.chunks(DIVERGENCE_BLOCK))
            {
                for ((t, &[c0, c1, c2, inv_area]), out) in tb.iter().zip(kb).zip(&mut terms) {
                    let (u0, u1, u2) = (u[t[0] as usize], u[t[1] as usize], u[t[2] as usize]);
                    let (d01, d12, d20) = (u0 - u1, u1 - u2, u2 - u0);
                    let energy = c0 * d12 * d12 + c1 * d20 * d20 + c2 * d01 * d01;
                    let grad_sq = energy * inv_area;
                    *out = if grad_sq > 0.0 && grad_sq.is_finite() {
                        let s = -1.0 / grad_sq.sqrt();
                        [
                            s * (c2 * d01 - c1 * d20),
                            s * (c0 * d12 - c2 * d01),
                            s * (c1 * d20 - c0 * d12),
                        ]
                    } else {
                        [0.0; 3]
                    };
                }
                for (t, tv) in tb.iter().zip(&terms) {
                    for k in 0..3 {
                        out[t[k] as usize] += tv[k];
                    }
                }
            }
        };
        let nf = self.triangles.len();
        let half = nf / 2;
        match par {
            Par::Seq => {
                accumulate(0..half, b);
                accumulate(half..nf, scratch);
            }
            Par::Rayon => {
                rayon::join(|| accumulate(0..half, b), || accumulate(half..nf, scratch));
            }
        }
        b.iter_mut().zip(scratch.iter()).for_each(|(x, y)| *x += y);
        for &p in &self.pins {
            b[p as usize] = 0.0;
        }
    }

    fn shift(&self, phi: &[f64], src: &HeatSource) -> DistanceField {
        let n_comp = self.pins.len();
        let mut sum = vec![0.0; n_comp];
        let mut wsum = vec![0.0; n_comp];
        for p in &src.points {
            let Some(&(v0, _)) = p
                .corners
                .iter()
                .find(|(v, _)| self.component[*v as usize] != u32::MAX)
            else {
                continue;
            };
            let c = self.component[v0 as usize] as usize;
            let val: f64 = p.corners.iter().map(|&(v, w)| w * phi[v as usize]).sum();
            // Unit weight per point: the source set should sit at 0 as a whole.
            sum[c] += val;
            wsum[c] += 1.0;
        }
        let values = (0..self.n)
            .map(|v| {
                let c = self.component[v];
                if c == u32::MAX || wsum[c as usize] == 0.0 {
                    f64::INFINITY
                } else {
                    (phi[v] - sum[c as usize] / wsum[c as usize]).max(0.0)
                }
            })
            .collect();
        DistanceField { values }
    }
}

/// Connected components through triangles; returns the component of each vertex
/// (`u32::MAX` when unreferenced) and the smallest vertex of each component.
fn components(n: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, Vec<u32>) {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let g = parent[parent[x as usize] as usize];
            parent[x as usize] = g;
            x = g;
        }
        x
    }
    let mut used = vec![false; n];
    for t in triangles {
        for &v in t {
            used[v as usize] = true;
        }
        for k in 1..3 {
            let a = find(&mut parent, t[0]);
            let b = find(&mut parent, t[k]);
            if a != b {
                let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                parent[hi as usize] = lo;
            }
        }
    }
    let mut comp = vec![u32::MAX; n];
    let mut root_comp = vec![u32::MAX; n];
    let mut pins = Vec::new();
    for v in 0..n {
        if !used[v] {
            continue;
        }
        let r = find(&mut parent, v as u32) as usize;
        if root_comp[r] == u32::MAX {
            root_comp[r] = pins.len() as u32;
            pins.push(v as u32);
        }
        comp[v] = root_comp[r];
    }
    (comp, pins)
}

/// Replaces the rows and columns of `pins` by identity rows (pattern kept).
fn pin_rows(a: &mut CsrMatrix, pins: &[u32]) {
    let n = a.nrows();
    let mut pinned = vec![false; n];
    for &p in pins {
        pinned[p as usize] = true;
    }
    let row_ptr = a.row_ptr().to_vec();
    let col_idx = a.col_idx().to_vec();
    let values = a.values_mut();
    for i in 0..n {
        for k in row_ptr[i]..row_ptr[i + 1] {
            let j = col_idx[k];
            if pinned[i] || pinned[j] {
                values[k] = if i == j { 1.0 } else { 0.0 };
            }
        }
    }
}

/// Distance from the union of `params.vertices` and (when given) the curves of `curves`
/// listed in `params.curve_ids` (all when empty).
pub fn heat_distance(
    mesh: &TriMesh,
    curves: Option<&FeatureCurveNetwork>,
    params: &HeatParams,
    par: Par,
) -> Result<DistanceField, HeatError> {
    let mut source = HeatSource::vertices(&params.vertices);
    if let Some(net) = curves {
        let ids: Vec<usize> = if params.curve_ids.is_empty() {
            (0..net.curves.len()).collect()
        } else {
            params.curve_ids.iter().map(|&c| c as usize).collect()
        };
        for c in ids {
            source
                .points
                .extend(HeatSource::curve(net, c, mesh)?.points);
        }
    }
    if source.points.is_empty() {
        return Err(HeatError::NoSources);
    }
    let solver = HeatSolver::new(mesh, params.time_factor, par)?;
    solver.distance(&source, par)
}

/// Node wrapper of [`heat_distance`].
pub struct HeatNode;

impl NodeKind for HeatNode {
    type Params = HeatParams;
    const KIND: &'static str = "geodesic.heat";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Geodesic distance from source vertices and/or whole feature \
        curves by the heat method (Crane, Weischedel, Wardetzky, \"Geodesics in Heat\", ACM TOG \
        2013): heat flow (M + tL)u = δ with t = m·h², normalised gradient X = -∇u/|∇u|, Poisson \
        solve Lφ = ∇·X, shifted so the sources are at 0. Used for the curve GICS of thesis \
        §3.1.2 (§3.1.2.1, §3.1.2.5).";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<TriMesh>("mesh", "the surface"),
            Port::optional::<FeatureCurveNetwork>(
                "curves",
                "feature curves whose whole length is a source (vertices on mesh vertices or edges)",
            ),
        ]
    }

    fn outputs() -> Vec<Port> {
        vec![Port::of::<DistanceField>(
            "distance",
            "per-vertex geodesic distance from the sources (+inf where unreachable)",
        )]
    }

    fn run(params: &HeatParams, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let curves = inputs.opt::<FeatureCurveNetwork>("curves")?;
        let field = heat_distance(mesh, curves, params, ctx.par)
            .map_err(|e| NodeError::from_source(e.kind(), e))?;
        Ok(Outputs::new().with("distance", field))
    }
}
