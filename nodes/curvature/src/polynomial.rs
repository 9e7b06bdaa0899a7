//! `curvature.polynomial`: principal curvatures, directions and extremality coefficients from a
//! local bivariate polynomial fitted at every vertex (thesis §2.4, "Curvature from Local
//! Bivariate Polynomial Fitting"; Yoshizawa, Belyaev, Seidel 2005, "Fast and robust detection
//! of crest lines on meshes" \[YBS05\], with the adjacent-normal cubic approximation of
//! Goldfeather and Interrante 2004 \[GI04\]).
//!
//! At vertex p with unit normal n and a tangent frame (e1, e2), every vertex q of the n-ring
//! gives local coordinates (x, y, z) and is fitted by the YBS05 cubic
//!
//! z(x, y) = ½(w0 x² + 2 w1 xy + w2 y²) + ⅙(w3 x³ + 3 w4 x²y + 3 w5 xy² + w6 y³)
//!
//! plus two changes measured on analytic shapes (see the tests):
//! - slope terms a1 x + a2 y absorb the error of the vertex normal. The curvatures are then the
//!   eigenvalues of the Weingarten map I⁻¹ II of the fitted graph at the origin, and the
//!   extremality coefficients (thesis §2.1.2, e = ∇k · t) the third directional derivative
//!   C(t, t, t) corrected to first order for the slope s = ∇z · t (e = −C(t,t,t) + 3 k² s
//!   in this file's sign convention, where k = −z_tt);
//! - with `degree: 4` (the default) quartic terms (1/24)(q0 x⁴ + 4 q1 x³y + 6 q2 x²y² +
//!   4 q3 xy³ + q4 y⁴) keep the quartic part of the surface from leaking into the quadratic and
//!   cubic coefficients: on a 2-ring this bias is about 1 % of k on a 10k-vertex torus.
//!
//! With `use_normals` each neighbour also contributes its normal (a, b, c) in the frame as two
//! linear equations on the slopes, z_x = −a/c and z_y = −b/c (GI04), which pins the cubic terms
//! (the curvature derivatives) down. Averaged face normals are only first-order accurate on
//! irregular meshes and would bias those equations, so a first pass fits a positions-only cubic
//! at every vertex and the second pass uses the normals of those fits. Both passes work in the
//! frame of the averaged normal (the fitted slopes absorb its error), so the second pass reuses
//! the first pass' height sums and only adds the neighbours' normals.
//!
//! Coordinates are divided by the neighbourhood's RMS distance before the least-squares solve
//! (normal equations assembled from moments Σ xᵃyᵇ, Cholesky) so the system's conditioning does
//! not depend on the mesh scale. Too few neighbours or a singular system: the ring grows (up to
//! two more rings), then lower degrees are tried down to a quadric (extremality 0), then the
//! vertex gets zeros; each case is counted in [`FitStats`].
//!
//! Vertices are independent: both passes run with [`Par::map_collect`], so the output is the
//! same bit for bit at any thread count.

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, NodeError, NodeKind, Outputs, Par, ParamIssue, Port, Validate,
};
use crestflow_flow::{ErrorKind, Inputs};
use crestflow_geom::vec3::{self, V3};
use crestflow_geom::{CurvatureField, TriMesh};

use crate::local::{
    area_weighted_normals, check_mesh, pencil_eigen2, tangent_basis, with_scratch, MeshInputError,
};
use crate::orient::orient_directions;

/// Parameters of `curvature.polynomial`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PolynomialParams {
    /// Neighbourhood of the fit: the n-ring of each vertex (default 2, range 1..=6).
    pub rings: u32,
    /// Total degree of the local polynomial: 3 is the YBS05 cubic; 4 adds quartic terms so
    /// that they do not bias the curvature and its derivatives (default 4, range 3..=4).
    pub degree: u32,
    /// Use the neighbours' normals as extra equations (GI04 adjacent-normal cubic
    /// approximation; default true). The normals come from a first, positions-only cubic fit
    /// at every vertex (about a third of the cost). Without them the fit uses positions only,
    /// needs more neighbours (the ring grows) and its extremality coefficients are noisier.
    pub use_normals: bool,
    /// Orient principal directions consistently across the mesh (thesis §2.5.1.1 step 2;
    /// default true).
    pub orient: bool,
}

impl Default for PolynomialParams {
    fn default() -> Self {
        PolynomialParams {
            rings: 2,
            degree: 4,
            use_normals: true,
            orient: true,
        }
    }
}

impl Validate for PolynomialParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut issues = Vec::new();
        check_range(&mut issues, "rings", self.rings, 1, 6);
        check_range(&mut issues, "degree", self.degree, 3, 4);
        issues
    }
}

/// How many vertices needed a fallback.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FitStats {
    /// Fitted after growing the neighbourhood beyond `rings`.
    pub grown: usize,
    /// Only a lower degree could be fitted (a quadric gives extremality 0).
    pub reduced: usize,
    /// Nothing could be fitted (isolated vertex, no normal, degenerate neighbourhood): zeros.
    pub failed: usize,
}

/// The result of [`polynomial_curvature`].
#[derive(Clone, Debug, PartialEq)]
pub struct PolynomialCurvature {
    pub field: CurvatureField,
    pub stats: FitStats,
}

/// Errors of [`polynomial_curvature`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolynomialError {
    #[error(transparent)]
    Mesh(#[from] MeshInputError),
    #[error("invalid parameters: {0}")]
    Params(String),
}

/// Per-vertex result of the fit.
#[derive(Clone, Copy, Debug)]
struct VertexFit {
    k_max: f64,
    k_min: f64,
    t_max: V3,
    t_min: V3,
    normal: V3,
    e_max: f64,
    e_min: f64,
    status: Status,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Status {
    Full,
    Grown,
    Reduced,
    Failed,
}

impl VertexFit {
    fn failed(normal: V3) -> Self {
        VertexFit {
            k_max: 0.0,
            k_min: 0.0,
            t_max: [0.0; 3],
            t_min: [0.0; 3],
            normal,
            e_max: 0.0,
            e_min: 0.0,
            status: Status::Failed,
        }
    }
}

/// Most unknowns of a fit: 2 slopes, 3 quadratic, 4 cubic and 5 quartic coefficients.
const MAX_NU: usize = 14;

/// Unknowns of a fit of total degree `degree` (2, 3 or 4) with slopes.
fn unknowns(degree: u32) -> usize {
    match degree {
        2 => 5,
        3 => 9,
        _ => 14,
    }
}

/// Estimates curvature at every vertex of `mesh` by local polynomial fitting (see the module
/// docs).
pub fn polynomial_curvature(
    mesh: &TriMesh,
    params: &PolynomialParams,
    par: Par,
) -> Result<PolynomialCurvature, PolynomialError> {
    let issues = params.validate();
    if !issues.is_empty() {
        let text: Vec<String> = issues
            .iter()
            .map(|i| format!("{}: {}", i.field, i.message))
            .collect();
        return Err(PolynomialError::Params(text.join("; ")));
    }
    check_mesh(mesh)?;
    let n = mesh.n_vertices();
    let topo = mesh.topology();
    let initial = area_weighted_normals(mesh);
    let fits: Vec<VertexFit> = if params.use_normals {
        // Averaged face normals are only first-order accurate on irregular meshes, which
        // would spoil the adjacent-normal equations: a first pass fits a positions-only cubic
        // at every vertex for its normal, keeping the height sums it gathered (which the
        // second pass needs too, in the same frame) so that the second pass only adds the
        // neighbours' normals.
        let first: Vec<(V3, Option<Box<Heights>>)> = par.map_collect(n, |v| {
            with_scratch(|scratch| first_pass(v as u32, mesh, &initial, topo, params, scratch))
        });
        let normals: Vec<V3> = first.iter().map(|f| f.0).collect();
        par.map_collect(n, |v| {
            with_scratch(|scratch| {
                let heights = first[v].1.as_deref();
                second_pass(
                    v as u32, mesh, &initial, &normals, heights, topo, params, scratch,
                )
            })
        })
    } else {
        let input = FitInput {
            mesh,
            frame_normals: &initial,
            neighbour_normals: None,
            topo,
        };
        par.map_collect(n, |v| {
            with_scratch(|scratch| fit_vertex(v as u32, &input, params, false, scratch))
        })
    };

    let mut stats = FitStats::default();
    let mut field = CurvatureField {
        k_max: Vec::with_capacity(n),
        k_min: Vec::with_capacity(n),
        t_max: Vec::with_capacity(n),
        t_min: Vec::with_capacity(n),
        normal: Vec::with_capacity(n),
        e_max: Vec::with_capacity(n),
        e_min: Vec::with_capacity(n),
        method: "curvature.polynomial".to_string(),
    };
    for f in &fits {
        match f.status {
            Status::Full => {}
            Status::Grown => stats.grown += 1,
            Status::Reduced => stats.reduced += 1,
            Status::Failed => stats.failed += 1,
        }
        field.k_max.push(f.k_max);
        field.k_min.push(f.k_min);
        field.t_max.push(f.t_max);
        field.t_min.push(f.t_min);
        field.normal.push(f.normal);
        field.e_max.push(f.e_max);
        field.e_min.push(f.e_min);
    }
    if params.orient {
        orient_directions(mesh, &mut field);
    }
    Ok(PolynomialCurvature { field, stats })
}

/// Fewest neighbours for a fit of `nu` unknowns: about 1.5 equations per unknown.
fn min_neighbours(nu: usize, with_normals: bool) -> usize {
    let per = if with_normals { 3 } else { 1 };
    (3 * nu).div_ceil(2 * per).max(2)
}

/// The height sums of a vertex's first-pass fit, in its initial frame, and the rings gathered.
struct Heights {
    s: [f64; 45],
    z: [f64; 15],
    h2: f64,
    count: usize,
    rings: u32,
}

/// Rings around `v` until at least `need` neighbours (or `params.rings + 2` rings, or the
/// whole component); returns the number of rings gathered.
fn gather(
    v: u32,
    n_vertices: usize,
    topo: &crestflow_geom::Topology,
    rings: u32,
    need: usize,
    scratch: &mut crate::local::Scratch,
) -> u32 {
    let mut outer = scratch.start(topo, n_vertices, v);
    let mut got = 1;
    while got < rings {
        outer = scratch.grow(topo, outer);
        got += 1;
    }
    while scratch.ring.len() < need && got < rings + 2 {
        let before = scratch.ring.len();
        outer = scratch.grow(topo, outer);
        got += 1;
        if scratch.ring.len() == before {
            break;
        }
    }
    got
}

/// First pass: the normal of a positions-only cubic fit in the frame of the averaged normal,
/// and the height sums for the second pass (`None` where the plain fallbacks took over).
fn first_pass(
    v: u32,
    mesh: &TriMesh,
    initial: &[V3],
    topo: &crestflow_geom::Topology,
    params: &PolynomialParams,
    scratch: &mut crate::local::Scratch,
) -> (V3, Option<Box<Heights>>) {
    let n0 = initial[v as usize];
    if n0 == [0.0; 3] {
        return (n0, None);
    }
    let rings = gather(
        v,
        mesh.n_vertices(),
        topo,
        params.rings,
        min_neighbours(9, false),
        scratch,
    );
    let frame = Frame::new(mesh.positions[v as usize], n0);
    let mut acc = Moments::default();
    // Sums for the final degree (a superset of what the cubic needs: graded prefixes).
    match params.degree {
        3 => acc.add_positions::<3>(&frame, mesh, &scratch.ring),
        _ => acc.add_positions::<4>(&frame, mesh, &scratch.ring),
    }
    if scratch.ring.len() >= min_neighbours(9, false) {
        if let Some(fit) = solve_moments::<3>(&acc, &frame, false, true) {
            let heights = Heights {
                s: acc.s,
                z: acc.z,
                h2: acc.h2,
                count: acc.count,
                rings,
            };
            return (fit.normal, Some(Box::new(heights)));
        }
    }
    // Lower degrees or a larger neighbourhood, as a plain fit would do.
    let first = PolynomialParams {
        use_normals: false,
        degree: 3,
        ..params.clone()
    };
    let input = FitInput {
        mesh,
        frame_normals: initial,
        neighbour_normals: None,
        topo,
    };
    let fit = fit_vertex(v, &input, &first, true, scratch);
    if fit.status == Status::Failed || fit.status == Status::Reduced {
        (n0, None)
    } else {
        (fit.normal, None)
    }
}

/// Second pass: the full fit with the neighbours' (first-pass) normals, reusing the first
/// pass' height sums where there are any.
#[allow(clippy::too_many_arguments)]
fn second_pass(
    v: u32,
    mesh: &TriMesh,
    initial: &[V3],
    normals: &[V3],
    heights: Option<&Heights>,
    topo: &crestflow_geom::Topology,
    params: &PolynomialParams,
    scratch: &mut crate::local::Scratch,
) -> VertexFit {
    if let Some(h) = heights {
        gather(v, mesh.n_vertices(), topo, h.rings, 0, scratch);
        let frame = Frame::new(mesh.positions[v as usize], initial[v as usize]);
        let mut acc = Moments {
            s: h.s,
            z: h.z,
            h2: h.h2,
            count: h.count,
            rows: h.count,
            ..Moments::default()
        };
        let fit = match params.degree {
            3 => {
                acc.add_normals::<3>(&frame, mesh, normals, &scratch.ring);
                solve_moments::<3>(&acc, &frame, true, false)
            }
            _ => {
                acc.add_normals::<4>(&frame, mesh, normals, &scratch.ring);
                solve_moments::<4>(&acc, &frame, true, false)
            }
        };
        if let Some(mut fit) = fit {
            if h.rings > params.rings {
                fit.status = Status::Grown;
            }
            return fit;
        }
    }
    let input = FitInput {
        mesh,
        frame_normals: normals,
        neighbour_normals: Some(normals),
        topo,
    };
    fit_vertex(v, &input, params, false, scratch)
}

/// What every vertex's fit reads.
#[derive(Clone, Copy)]
struct FitInput<'a> {
    mesh: &'a TriMesh,
    /// Orient each vertex's local frame.
    frame_normals: &'a [V3],
    /// If given, add the adjacent-normal equations.
    neighbour_normals: Option<&'a [V3]>,
    topo: &'a crestflow_geom::Topology,
}

/// Fits vertex `v` with the fallbacks of the module docs. `frame_normals[v]` orients the local
/// frame; `neighbour_normals` (if any) add the adjacent-normal equations.
fn fit_vertex(
    v: u32,
    input: &FitInput,
    params: &PolynomialParams,
    normal_only: bool,
    scratch: &mut crate::local::Scratch,
) -> VertexFit {
    let FitInput {
        mesh,
        frame_normals,
        neighbour_normals,
        topo,
    } = *input;
    let n0 = frame_normals[v as usize];
    if n0 == [0.0; 3] {
        return VertexFit::failed(n0);
    }
    let mut outer = scratch.start(topo, mesh.n_vertices(), v);
    for _ in 1..params.rings {
        outer = scratch.grow(topo, outer);
    }
    let max_rings = params.rings + 2;
    let mut rings = params.rings;
    let nu = unknowns(params.degree);
    let with_normals = neighbour_normals.is_some();
    loop {
        if scratch.ring.len() >= min_neighbours(nu, with_normals) {
            if let Some(mut fit) = solve_local(
                v,
                mesh,
                n0,
                neighbour_normals,
                &scratch.ring,
                params.degree,
                normal_only,
            ) {
                if rings > params.rings {
                    fit.status = Status::Grown;
                }
                return fit;
            }
        }
        if rings >= max_rings {
            break;
        }
        let before = scratch.ring.len();
        outer = scratch.grow(topo, outer);
        rings += 1;
        if scratch.ring.len() == before {
            // The component has no more vertices: growing further cannot help.
            break;
        }
    }
    // Lower degrees on the largest neighbourhood gathered.
    for degree in (2..params.degree).rev() {
        if scratch.ring.len() >= min_neighbours(unknowns(degree), with_normals) {
            if let Some(mut fit) = solve_local(
                v,
                mesh,
                n0,
                neighbour_normals,
                &scratch.ring,
                degree,
                normal_only,
            ) {
                fit.status = Status::Reduced;
                return fit;
            }
        }
    }
    VertexFit::failed(n0)
}

/// The unknowns [a1, a2, w0, w1, w2, w3, w4, w5, w6, q0, q1, q2, q3, q4] as monomials
/// c x^a y^b of the height function
/// z = a1 x + a2 y + ½(w0 x² + 2 w1 xy + w2 y²) + ⅙(w3 x³ + 3 w4 x²y + 3 w5 xy² + w6 y³)
///   + (1/24)(q0 x⁴ + 4 q1 x³y + 6 q2 x²y² + 4 q3 xy³ + q4 y⁴): (a, b, c).
const MONOMIALS: [(usize, usize, f64); MAX_NU] = [
    (1, 0, 1.0),
    (0, 1, 1.0),
    (2, 0, 0.5),
    (1, 1, 1.0),
    (0, 2, 0.5),
    (3, 0, 1.0 / 6.0),
    (2, 1, 0.5),
    (1, 2, 0.5),
    (0, 3, 1.0 / 6.0),
    (4, 0, 1.0 / 24.0),
    (3, 1, 1.0 / 6.0),
    (2, 2, 0.25),
    (1, 3, 1.0 / 6.0),
    (0, 4, 1.0 / 24.0),
];

/// Least-squares fit of degree `degree` in the frame of vertex `v` (normal `n`); `None` when
/// the system is (nearly) singular.
fn solve_local(
    v: u32,
    mesh: &TriMesh,
    n: V3,
    neighbour_normals: Option<&[V3]>,
    ring: &[u32],
    degree: u32,
    normal_only: bool,
) -> Option<VertexFit> {
    // One copy per degree, so that the loop bounds below are constants.
    match degree {
        2 => solve_local_deg::<2>(v, mesh, n, neighbour_normals, ring, normal_only),
        3 => solve_local_deg::<3>(v, mesh, n, neighbour_normals, ring, normal_only),
        _ => solve_local_deg::<4>(v, mesh, n, neighbour_normals, ring, normal_only),
    }
}

/// Total degree of the monomial at each graded index.
const GRADED_DEGREE: [usize; 45] = {
    let mut out = [0usize; 45];
    let mut deg = 0;
    let mut k = 0;
    while deg <= 8 {
        let mut b = 0;
        while b <= deg {
            out[k] = deg;
            k += 1;
            b += 1;
        }
        deg += 1;
    }
    out
};

/// Power of y of the monomial at each graded index.
const GRADED_B: [usize; 45] = {
    let mut out = [0usize; 45];
    let mut deg = 0;
    let mut k = 0;
    while deg <= 8 {
        let mut b = 0;
        while b <= deg {
            out[k] = b;
            k += 1;
            b += 1;
        }
        deg += 1;
    }
    out
};

/// One entry of AᵀA as moments: c·S[s] + cx·T[x] + cy·T[y] (T: sums over neighbours with a
/// usable normal; index 45 holds zero for absent terms).
#[derive(Clone, Copy)]
struct Entry {
    c: f64,
    s: usize,
    cx: f64,
    x: usize,
    cy: f64,
    y: usize,
}

/// One entry of Aᵀb: c·Z[z] + cx·P[x] + cy·Q[y] (index 10 of P, Q holds zero).
#[derive(Clone, Copy)]
struct Rhs {
    c: f64,
    z: usize,
    cx: f64,
    x: usize,
    cy: f64,
    y: usize,
}

/// Index of x^a y^b in graded order (by total degree, then by b).
const fn graded_const(a: usize, b: usize) -> usize {
    let deg = a + b;
    deg * (deg + 1) / 2 + b
}

/// Where each entry of the normal equations comes from, for the unknowns in [`MONOMIALS`]
/// order (a fit of lower degree uses the leading block).
const ASSEMBLY: [[Entry; MAX_NU]; MAX_NU] = {
    let zero = Entry {
        c: 0.0,
        s: 45,
        cx: 0.0,
        x: 45,
        cy: 0.0,
        y: 45,
    };
    let mut out = [[zero; MAX_NU]; MAX_NU];
    let mut i = 0;
    while i < MAX_NU {
        let (ai, bi, ci) = MONOMIALS[i];
        let mut j = 0;
        while j < MAX_NU {
            let (aj, bj, cj) = MONOMIALS[j];
            let mut e = zero;
            e.c = ci * cj;
            e.s = graded_const(ai + aj, bi + bj);
            if ai > 0 && aj > 0 {
                e.cx = ci * cj * (ai * aj) as f64;
                e.x = graded_const(ai + aj - 2, bi + bj);
            }
            if bi > 0 && bj > 0 {
                e.cy = ci * cj * (bi * bj) as f64;
                e.y = graded_const(ai + aj, bi + bj - 2);
            }
            out[i][j] = e;
            j += 1;
        }
        i += 1;
    }
    out
};

/// Where each entry of the right-hand side comes from.
const RHS: [Rhs; MAX_NU] = {
    let zero = Rhs {
        c: 0.0,
        z: 0,
        cx: 0.0,
        x: 10,
        cy: 0.0,
        y: 10,
    };
    let mut out = [zero; MAX_NU];
    let mut i = 0;
    while i < MAX_NU {
        let (a, b, c) = MONOMIALS[i];
        let mut r = zero;
        r.c = c;
        r.z = graded_const(a, b);
        if a > 0 {
            r.cx = c * a as f64;
            r.x = graded_const(a - 1, b);
        }
        if b > 0 {
            r.cy = c * b as f64;
            r.y = graded_const(a, b - 1);
        }
        out[i] = r;
        i += 1;
    }
    out
};

/// Number of monomials of total degree ≤ `deg`.
#[inline]
const fn graded_count(deg: usize) -> usize {
    (deg + 1) * (deg + 2) / 2
}

fn solve_local_deg<const D: usize>(
    v: u32,
    mesh: &TriMesh,
    n: V3,
    neighbour_normals: Option<&[V3]>,
    ring: &[u32],
    normal_only: bool,
) -> Option<VertexFit> {
    let frame = Frame::new(mesh.positions[v as usize], n);
    let mut acc = Moments::default();
    acc.add_positions::<D>(&frame, mesh, ring);
    if let Some(normals) = neighbour_normals {
        acc.add_normals::<D>(&frame, mesh, normals, ring);
    }
    solve_moments::<D>(&acc, &frame, neighbour_normals.is_some(), normal_only)
}

/// A vertex's local frame: origin, tangents e1, e2 and normal n (e1 × e2 = n).
#[derive(Clone, Copy)]
struct Frame {
    p: V3,
    e1: V3,
    e2: V3,
    n: V3,
}

impl Frame {
    fn new(p: V3, n: V3) -> Self {
        let (e1, e2) = tangent_basis(n);
        Frame { p, e1, e2, n }
    }
}

/// Sums over a neighbourhood from which the normal equations are assembled. Monomials x^a y^b
/// are kept flat in graded order (total degree, then b), so that every accumulation is a
/// fixed-length loop over contiguous values; a lower degree uses a prefix. Sums are in mesh
/// units and rescaled by the neighbourhood's RMS distance h when solving.
#[derive(Clone, Copy)]
struct Moments {
    /// Σ x^a y^b over all neighbours (a + b ≤ 2 × degree).
    s: [f64; 45],
    /// Σ z x^a y^b (a + b ≤ degree).
    z: [f64; 15],
    /// Σ z_x x^a y^b and Σ z_y x^a y^b (a + b < degree), slopes from neighbour normals.
    px: [f64; 10],
    py: [f64; 10],
    /// Σ x^a y^b over neighbours without a usable normal (a + b ≤ 2 × degree − 2).
    bad: [f64; 45],
    /// Σ |q − p|², number of neighbours, of equations, of neighbours without usable normal.
    h2: f64,
    count: usize,
    rows: usize,
    n_bad: usize,
}

impl Default for Moments {
    fn default() -> Self {
        Moments {
            s: [0.0; 45],
            z: [0.0; 15],
            px: [0.0; 10],
            py: [0.0; 10],
            bad: [0.0; 45],
            h2: 0.0,
            count: 0,
            rows: 0,
            n_bad: 0,
        }
    }
}

/// The graded monomials of total degree ≤ M: powers x^0..x^M, y^0..y^M first, then the
/// products.
#[inline]
fn monomials<const M: usize>(x: f64, y: f64, mono: &mut [f64; 45]) {
    let mut xp = [1.0f64; 9];
    let mut yp = [1.0f64; 9];
    for k in 1..=M {
        xp[k] = xp[k - 1] * x;
        yp[k] = yp[k - 1] * y;
    }
    for k in 0..graded_count(M) {
        mono[k] = xp[GRADED_DEGREE[k] - GRADED_B[k]] * yp[GRADED_B[k]];
    }
}

/// [`monomials`] for a runtime degree bound known to be a small constant per call site.
#[inline]
fn monomials_upto(deg: usize, x: f64, y: f64, mono: &mut [f64; 45]) {
    match deg {
        0 => mono[0] = 1.0,
        1 => monomials::<1>(x, y, mono),
        2 => monomials::<2>(x, y, mono),
        3 => monomials::<3>(x, y, mono),
        4 => monomials::<4>(x, y, mono),
        6 => monomials::<6>(x, y, mono),
        _ => monomials::<8>(x, y, mono),
    }
}

impl Moments {
    /// Adds the height equations of `ring` for a fit of degree D.
    fn add_positions<const D: usize>(&mut self, f: &Frame, mesh: &TriMesh, ring: &[u32]) {
        let (n_s, n_z) = (graded_count(2 * D), graded_count(D));
        let mut mono = [0.0f64; 45];
        for &w in ring {
            let dv = vec3::sub(mesh.positions[w as usize], f.p);
            self.h2 += vec3::dot(dv, dv);
            let (x, y, z) = (vec3::dot(dv, f.e1), vec3::dot(dv, f.e2), vec3::dot(dv, f.n));
            monomials_upto(2 * D, x, y, &mut mono);
            for (sk, mk) in self.s[..n_s].iter_mut().zip(&mono) {
                *sk += mk;
            }
            for (zk, mk) in self.z[..n_z].iter_mut().zip(&mono) {
                *zk += z * mk;
            }
        }
        self.count += ring.len();
        self.rows += ring.len();
    }

    /// Adds the slope equations of the neighbours' normals (GI04) for a fit of degree D.
    fn add_normals<const D: usize>(
        &mut self,
        f: &Frame,
        mesh: &TriMesh,
        normals: &[V3],
        ring: &[u32],
    ) {
        let (n_p, n_u) = (graded_count(D - 1), graded_count(2 * D - 2));
        let mut mono = [0.0f64; 45];
        for &w in ring {
            let dv = vec3::sub(mesh.positions[w as usize], f.p);
            let (x, y) = (vec3::dot(dv, f.e1), vec3::dot(dv, f.e2));
            let nw = normals[w as usize];
            let (a, b, c) = (vec3::dot(nw, f.e1), vec3::dot(nw, f.e2), vec3::dot(nw, f.n));
            // A neighbour normal tilted by more than ~70° says nothing reliable about slopes.
            if c > 0.34 {
                monomials_upto(D - 1, x, y, &mut mono);
                let (gx, gy) = (-a / c, -b / c);
                for ((pk, qk), mk) in self.px[..n_p]
                    .iter_mut()
                    .zip(&mut self.py[..n_p])
                    .zip(&mono)
                {
                    *pk += gx * mk;
                    *qk += gy * mk;
                }
                self.rows += 2;
            } else {
                monomials_upto(2 * D - 2, x, y, &mut mono);
                self.n_bad += 1;
                for (bk, mk) in self.bad[..n_u].iter_mut().zip(&mono) {
                    *bk += mk;
                }
            }
        }
    }
}

/// Assembles and solves the normal equations of degree D from `acc`, then derives curvature,
/// directions and extremality (or only the normal).
fn solve_moments<const D: usize>(
    acc: &Moments,
    frame: &Frame,
    with_normals: bool,
    normal_only: bool,
) -> Option<VertexFit> {
    let degree = D as u32;
    let nu = unknowns(degree);
    let Frame { e1, e2, n, .. } = *frame;
    if acc.rows < nu || acc.count == 0 {
        return None;
    }
    let h = (acc.h2 / acc.count as f64).sqrt();
    if !(h > 0.0 && h.is_finite()) {
        return None;
    }
    let inv_h = 1.0 / h;
    let mut inv_pow = [1.0f64; 10];
    for k in 1..10 {
        inv_pow[k] = inv_pow[k - 1] * inv_h;
    }
    // Rescaled moments (x → x / h): the conditioning does not depend on the mesh scale.
    // Index 45 (and 10) stays zero: the tables point there for absent terms.
    let mut ss = [0.0f64; 46];
    let mut tt = [0.0f64; 46];
    for k in 0..graded_count(2 * D) {
        ss[k] = acc.s[k] * inv_pow[GRADED_DEGREE[k]];
    }
    if with_normals {
        // Sums over the neighbours whose normals gave slope equations.
        for k in 0..graded_count(2 * D - 2) {
            tt[k] = (acc.s[k] - acc.bad[k]) * inv_pow[GRADED_DEGREE[k]];
        }
    }
    let mut zz = [0.0f64; 15];
    for k in 0..graded_count(D) {
        zz[k] = acc.z[k] * inv_pow[GRADED_DEGREE[k] + 1];
    }
    let mut pp = [0.0f64; 11];
    let mut qq = [0.0f64; 11];
    if with_normals {
        for k in 0..graded_count(D - 1) {
            pp[k] = acc.px[k] * inv_pow[GRADED_DEGREE[k]];
            qq[k] = acc.py[k] * inv_pow[GRADED_DEGREE[k]];
        }
    }
    let mut ata = [[0.0f64; MAX_NU]; MAX_NU];
    let mut atb = [0.0f64; MAX_NU];
    for i in 0..nu {
        let tab = &ASSEMBLY[i];
        for j in i..nu {
            // Heights: m_i m_j; slopes: ∂x m_i ∂x m_j + ∂y m_i ∂y m_j.
            let e = &tab[j];
            ata[i][j] = e.c * ss[e.s] + e.cx * tt[e.x] + e.cy * tt[e.y];
        }
        let r = &RHS[i];
        atb[i] = r.c * zz[r.z] + r.cx * pp[r.x] + r.cy * qq[r.y];
    }
    let u = match D {
        2 => cholesky_solve::<5>(&mut ata, &mut atb)?,
        3 => cholesky_solve::<9>(&mut ata, &mut atb)?,
        _ => cholesky_solve::<14>(&mut ata, &mut atb)?,
    };

    // Back to mesh units: slopes unchanged, quadratic / h, cubic / h².
    let (a1, a2) = (u[0], u[1]);
    let normal = vec3::normalize(vec3::sub(
        n,
        vec3::add(vec3::scale(e1, a1), vec3::scale(e2, a2)),
    ));
    if normal_only {
        let mut fit = VertexFit::failed(normal);
        fit.status = Status::Full;
        return Some(fit);
    }
    let q = [u[2] * inv_h, u[3] * inv_h, u[4] * inv_h];
    let c = if degree >= 3 {
        let s = inv_h * inv_h;
        [u[5] * s, u[6] * s, u[7] * s, u[8] * s]
    } else {
        [0.0; 4]
    };

    // Curvature is positive where the surface bends away from the normal, i.e. the second
    // fundamental form of −z: II = −Hess z / √(1 + |∇z|²), I = Id + ∇z ∇zᵀ.
    let g2 = 1.0 + a1 * a1 + a2 * a2;
    let inv_w = 1.0 / g2.sqrt();
    let ii = [-q[0] * inv_w, -q[1] * inv_w, -q[2] * inv_w];
    let first = [1.0 + a1 * a1, a1 * a2, 1.0 + a2 * a2];
    let (k_max, v_max, k_min, v_min) = pencil_eigen2(ii, first);
    if !(k_max.is_finite() && k_min.is_finite()) {
        return None;
    }
    // Third directional derivative of z along (unit-length) v, and the slope along v.
    let cubic = |v: [f64; 2]| {
        let (x, y) = (v[0], v[1]);
        c[0] * x * x * x + 3.0 * c[1] * x * x * y + 3.0 * c[2] * x * y * y + c[3] * y * y * y
    };
    let slope = |v: [f64; 2]| a1 * v[0] + a2 * v[1];
    let e_max = -cubic(v_max) + 3.0 * k_max * k_max * slope(v_max);
    let e_min = -cubic(v_min) + 3.0 * k_min * k_min * slope(v_min);

    // Lift the parameter-plane directions onto the fitted surface's tangent plane.
    let lift = |v: [f64; 2]| {
        vec3::normalize(vec3::add(
            vec3::add(vec3::scale(e1, v[0]), vec3::scale(e2, v[1])),
            vec3::scale(n, slope(v)),
        ))
    };
    let t_max = lift(v_max);
    let t_min = vec3::cross(normal, t_max);
    // `lift(v_min)` equals `t_min` up to sign; keep the sign that matches v_min so that e_min
    // is the derivative along the returned direction.
    let t_min_sign = if vec3::dot(t_min, lift(v_min)) < 0.0 {
        -1.0
    } else {
        1.0
    };
    Some(VertexFit {
        k_max,
        k_min,
        t_max,
        t_min,
        normal,
        e_max,
        e_min: e_min * t_min_sign,
        status: Status::Full,
    })
}

/// Solves the symmetric positive-definite system given by its upper triangle, in place
/// (Cholesky). `None` when a pivot is not clearly positive (rank-deficient neighbourhood).
#[allow(clippy::needless_range_loop)] // the index arithmetic is the algorithm
fn cholesky_solve<const N: usize>(
    a: &mut [[f64; MAX_NU]; MAX_NU],
    b: &mut [f64; MAX_NU],
) -> Option<[f64; MAX_NU]> {
    let n = N;
    let mut max_diag = 0.0f64;
    for (i, row) in a.iter().enumerate().take(n) {
        max_diag = max_diag.max(row[i]);
    }
    let tol = 1e-11 * max_diag;
    // Factor A = Rᵀ R with R upper triangular, stored over A.
    for i in 0..n {
        let mut d = a[i][i];
        for k in 0..i {
            d -= a[k][i] * a[k][i];
        }
        // Written so that NaN also fails.
        if d.is_nan() || d <= tol {
            return None;
        }
        let r = d.sqrt();
        a[i][i] = r;
        let inv = 1.0 / r;
        for j in i + 1..n {
            let mut s = a[i][j];
            for k in 0..i {
                s -= a[k][i] * a[k][j];
            }
            a[i][j] = s * inv;
        }
    }
    // Rᵀ y = b
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= a[k][i] * b[k];
        }
        b[i] = s / a[i][i];
    }
    // R x = y
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= a[i][k] * b[k];
        }
        b[i] = s / a[i][i];
    }
    Some(*b)
}

/// The `curvature.polynomial` node.
pub struct PolynomialNode;

impl NodeKind for PolynomialNode {
    type Params = PolynomialParams;
    const KIND: &'static str = "curvature.polynomial";
    const VERSION: u32 = 1;
    const DOC: &'static str = "Principal curvatures, directions and extremality coefficients \
        by fitting a bivariate polynomial (cubic as in Yoshizawa, Belyaev, Seidel 2005, plus \
        slope and, by default, quartic terms) to each vertex's n-ring, positions and neighbour \
        normals (adjacent-normal cubic approximation of Goldfeather and Interrante 2004; \
        thesis §2.4). Directions are oriented consistently (§2.5.1.1 step 2). Vertices with \
        too few neighbours grow their ring, then fall back to lower degrees, then to zeros \
        (counted in a warning).";

    fn inputs() -> Vec<Port> {
        vec![Port::of::<TriMesh>("mesh", "the triangle mesh")]
    }
    fn outputs() -> Vec<Port> {
        vec![Port::of::<CurvatureField>(
            "field",
            "k_max, k_min, t_max, t_min, normal, e_max, e_min per vertex",
        )]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let mesh = inputs.get::<TriMesh>("mesh")?;
        ctx.check_cancelled()?;
        let out = polynomial_curvature(mesh, params, ctx.par).map_err(|e| match e {
            PolynomialError::Mesh(m) => NodeError::from_source(ErrorKind::InvalidInput, m),
            other => NodeError::from_source(ErrorKind::InvalidInput, other),
        })?;
        let s = out.stats;
        if s.grown + s.reduced + s.failed > 0 {
            ctx.warn(&format!(
                "{} vertices needed a larger neighbourhood, {} only got a lower-degree fit, \
                 {} could not be fitted (set to zero)",
                s.grown, s.reduced, s.failed
            ));
        }
        Ok(Outputs::new().with("field", out.field))
    }
}
