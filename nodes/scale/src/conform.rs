//! `scale.conform`: adapts a feature curve network to a prescribed scale r_min (thesis §4.3,
//! Fig. 4.7; Gehre, Lim & Kobbelt 2016). Four steps are iterated until nothing changes:
//!
//! 1. **Resampling** ([`crate::resample`]): every arc with an edge outside
//!    S = [r_min, r_max] is resampled by a shortest path over dense samples; arcs that cannot
//!    be get a *short* or *long* special edge. Arcs whose edges are all in S are kept as they
//!    are, so a converged network is a fixed point.
//! 2. **Conflicts** ([`crate::conflicts`]): adjacent edges (and edges joined by a short edge)
//!    whose angle is not representable, non-adjacent edges closer than r_min without a
//!    triangulation (c)/(d) of Fig. 4.9, extraordinary vertices closer than r_min.
//! 3. **Selection** ([`crate::ilp`]): weights w(e) = w_κ · l · w_sym · w_loop (w_κ the
//!    sharpness and l the length of the input curve of e, w_loop = α_loop on closed loops,
//!    w_sym = 1: no symmetry input), smoothness pairs η_0 cos^p(2θ) for turning angles
//!    θ ≤ 45° and optional parallel/orthogonal pairs η_1 cos^{2p}(2θ); the binary program with
//!    constraints (4.3)–(4.10) solved exactly per conflict component, components in parallel
//!    (microlp; HiGHS with `solver: Highs` in builds with the `highs` feature).
//! 4. **Collapses**: short edges the selection drops are collapsed into their sharper end
//!    vertex; other dropped edges are removed.
//!
//! Lone edges (an arc of one edge whose ends belong to no other edge) are fixed to 0 in
//! step 3 unless `lone_edges: true`: the thesis's (4.9) drops such an arc only when it is
//! shorter than r_min. An edge left lone by the selection goes in the next iteration (the
//! program does not see that dropping a neighbour drops it too).
//!
//! Long edges are never kept, except special long edges (§4.3.3.2) with
//! `special_long_edges: true`: an arc of one edge between r_max and 2 r_min, which S can hold
//! neither as one edge nor as two (with r_max = 1.5 r_min, every arc from 1.5 to 2 r_min
//! long). The remesher splits such an edge in two, and the proximity tests treat its middle as
//! a vertex. Dropping them loses, e.g., the corners of a tunnel 1.7 r_min deep; keeping them
//! is off by default (docs/scale-remesh-log.md, section on version 32, has what it changes).
//!
//! The loop stops when an iteration removes, collapses and resamples nothing (or after
//! `max_iterations`); a final pass then removes, lightest first, any edge still violating a
//! condition of [`mod@crate::check`], so the output always passes `scale.check`
//! (`repaired_edges` counts those removals; 0 when the loop converged).

use serde::{Deserialize, Serialize};

use crestflow_flow::{
    check_range, Ctx, ErrorKind, Inputs, NodeError, NodeKind, Outputs, Par, ParamIssue, Port,
    Report, Validate,
};
use crestflow_geom::bvh::TriangleBvh;
use crestflow_geom::fcn::SurfacePoint;
use crestflow_geom::vec3;
use crestflow_geom::{CurveLabel, FeatureCurveNetwork, TriMesh};

use crate::conflicts::{angle, box_pairs, find_conflicts, incidence, Scale};
use crate::ilp::{self, Method, Problem, SelectError};
use crate::network::{Graph, NetworkError};
use crate::resample::{resample_arc, ArcPoint};

/// How the conflict-free subset is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Solver {
    /// The exact binary program per conflict component: a branch and bound for the
    /// components it proves quickly, good_lp + microlp for the others.
    #[default]
    Ilp,
    /// The same, with HiGHS for the components the branch and bound leaves (only in builds
    /// with the `highs` feature, which needs cmake and a C++ compiler; otherwise a parameter
    /// error).
    Highs,
    /// Heaviest edge first, kept if it conflicts with nothing kept (a baseline).
    Greedy,
}

/// Parameters of `scale.conform`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConformParams {
    /// r_min: the target scale, as a fraction of the mesh's bounding-box diagonal when
    /// `relative` (default 0.01), else in mesh units.
    pub scale: f64,
    /// `scale` is relative to the bounding-box diagonal (default true).
    pub relative: bool,
    /// r_max / r_min, in [1.05, 4] (default 1.5, thesis §4.3.2.1).
    pub aspect: f64,
    /// α_loop, weight factor of edges on closed loops (default 100).
    pub alpha_loop: f64,
    /// η_0, weight of the smoothness pair terms (default 100).
    pub eta_smooth: f64,
    /// p, fall-off of the smoothness term cos^p(2θ) (default 2).
    pub p: f64,
    /// η_1, weight of the parallel/orthogonal pair terms (default 0; 10 for quad layouts).
    pub eta_parallel: f64,
    /// Radius of the parallel/orthogonal pairs, in units of r_max (default 1).
    pub parallel_radius: f64,
    /// Iterations of the four steps at most (default 20).
    pub max_iterations: u32,
    /// Start samples tried when resampling a closed loop (default 4).
    pub loop_starts: u32,
    /// `Ilp` (default, microlp), `Highs` (builds with the `highs` feature) or `Greedy`.
    pub solver: Solver,
    /// Time limit of the exact solver per conflict component and iteration, in seconds
    /// (default 60; 0 = none). With a limit, a component the solver does not prove optimal
    /// within a budget of work (5·10⁷ simplex pivots × rows, 1–6 s on two cores of 2026;
    /// without a limit, only components above 2000 binaries get this budget; a program of
    /// more than 10,000 rows gets none) is improved from the best selection found by exact
    /// solves of windows of 60 binaries. Such a component is never
    /// worse than greedy and is counted in `unproven_components`. The budgets count work, not
    /// seconds, so the result is the same on every machine. The time limit is a safety net:
    /// a component it cuts short is counted in `out_of_time_components`, and only then can
    /// the result depend on the machine's speed.
    pub time_limit_s: f64,
    /// Keep special long edges (thesis §4.3.3.2; default false): an arc of one edge between
    /// r_max and 2 r_min, which S can hold neither as one edge nor as two. Off, such arcs are
    /// dropped. `scale.check` must be given the same value.
    pub special_long_edges: bool,
    /// Keep lone edges (default false): an arc of one edge whose two ends belong to no other
    /// edge. Constraint (4.9) drops such an arc when it is shorter than r_min; off, it is
    /// dropped at any length, since at the scale it is a fragment shorter than two edges
    /// that pins two vertices of a remesh and gives it no curve to follow (of the 76 edges
    /// kept from the subdivided armadillo's sharp edges at 2 %, 55 were lone;
    /// docs/scale-remesh.md has what dropping them changes).
    pub lone_edges: bool,
}

impl Default for ConformParams {
    fn default() -> Self {
        ConformParams {
            scale: 0.01,
            relative: true,
            aspect: 1.5,
            alpha_loop: 100.0,
            eta_smooth: 100.0,
            p: 2.0,
            eta_parallel: 0.0,
            parallel_radius: 1.0,
            max_iterations: 20,
            loop_starts: 4,
            solver: Solver::Ilp,
            time_limit_s: 60.0,
            special_long_edges: false,
            lone_edges: false,
        }
    }
}

impl Validate for ConformParams {
    fn validate(&self) -> Vec<ParamIssue> {
        let mut v = Vec::new();
        check_range(&mut v, "scale", self.scale, 1e-12, 1e12);
        check_range(&mut v, "aspect", self.aspect, 1.05, 4.0);
        check_range(&mut v, "alpha_loop", self.alpha_loop, 0.0, 1e6);
        check_range(&mut v, "eta_smooth", self.eta_smooth, 0.0, 1e6);
        check_range(&mut v, "p", self.p, 0.0, 64.0);
        check_range(&mut v, "eta_parallel", self.eta_parallel, 0.0, 1e6);
        check_range(&mut v, "parallel_radius", self.parallel_radius, 0.0, 100.0);
        check_range(&mut v, "max_iterations", self.max_iterations, 1, 1000);
        check_range(&mut v, "loop_starts", self.loop_starts, 1, 64);
        check_range(&mut v, "time_limit_s", self.time_limit_s, 0.0, 1e6);
        if self.solver == Solver::Highs && !ilp::Backend::Highs.available() {
            v.push(ParamIssue::new(
                "solver",
                "Highs needs a build with `--features highs` (cmake, libclang and a C++ \
                 compiler); use Ilp (microlp) or Greedy",
            ));
        }
        v
    }
}

/// Why `scale.conform` or `scale.check` could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScaleError {
    #[error("feature curves: {0}")]
    Network(#[from] NetworkError),
    #[error(
        "the mesh's bounding box has diagonal {diagonal}: a relative scale needs a mesh with \
         extent (or set relative: false)"
    )]
    NoExtent { diagonal: f64 },
    #[error("selection: {0}")]
    Select(#[from] SelectError),
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("the network is not scale conforming: {0}")]
    NotConforming(String),
    #[error(
        "r_min {r_min} is too small for curves of total length {length}: resampling would take \
         about {samples} dense samples (at most {max})"
    )]
    TooFine {
        r_min: f64,
        length: f64,
        samples: f64,
        max: f64,
    },
    #[error("cancelled")]
    Cancelled,
}

impl ScaleError {
    pub fn kind(&self) -> ErrorKind {
        match self {
            ScaleError::Select(_) => ErrorKind::NumericalFailure,
            ScaleError::Cancelled => ErrorKind::Cancelled,
            _ => ErrorKind::InvalidInput,
        }
    }
}

/// Dense samples the resampling may create over the whole network.
pub const MAX_SAMPLES: f64 = 2e7;

/// r_min in mesh units.
pub fn absolute_scale(mesh: &TriMesh, scale: f64, relative: bool) -> Result<f64, ScaleError> {
    if !relative {
        return Ok(scale);
    }
    let diagonal = mesh.bbox_diagonal();
    if !(diagonal.is_finite() && diagonal > 0.0) {
        return Err(ScaleError::NoExtent { diagonal });
    }
    Ok(scale * diagonal)
}

/// What `scale.conform` did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ConformStats {
    pub r_min: f64,
    pub r_max: f64,
    pub input_edges: usize,
    pub input_curves: usize,
    /// Edges after the first resampling (the first selection problem).
    pub resampled_edges: usize,
    pub output_edges: usize,
    pub output_curves: usize,
    pub iterations: usize,
    /// 1 when an iteration changed nothing before `max_iterations`.
    pub converged: bool,
    /// First iteration: conflicts, components, objective of the chosen solver and of the
    /// greedy baseline on the same problem, and the edges each keeps.
    pub first_edge_conflicts: usize,
    pub first_vertex_conflicts: usize,
    pub first_components: usize,
    pub first_largest_component: usize,
    pub first_objective: f64,
    pub first_kept: usize,
    /// The objectives without the part no choice changes (free edges): what the conflict
    /// components contribute.
    pub first_objective_components: f64,
    pub greedy_objective_components: f64,
    pub greedy_objective: f64,
    pub greedy_kept: usize,
    pub short_collapsed: usize,
    pub long_dropped: usize,
    /// Lone edges (an arc of one edge with two free ends) fixed to 0 (over all iterations).
    pub lone_dropped: usize,
    pub loops_dropped: usize,
    pub repaired_edges: usize,
    /// Components (over all iterations) whose optimum was not proven: improved by windows
    /// after [`crate::ilp::WHOLE_WORK`], or out of time.
    pub unproven_components: usize,
    /// Components (over all iterations) that the time limit cut short: while this is 0, the
    /// output does not depend on the machine.
    pub out_of_time_components: usize,
}

impl ConformStats {
    pub fn to_report(&self) -> Report {
        let mut r = Report::new();
        r.set("r_min", self.r_min)
            .set("r_max", self.r_max)
            .set("input_edges", self.input_edges)
            .set("input_curves", self.input_curves)
            .set("resampled_edges", self.resampled_edges)
            .set("output_edges", self.output_edges)
            .set("output_curves", self.output_curves)
            .set("iterations", self.iterations)
            .set("converged", self.converged as usize)
            .set("first_edge_conflicts", self.first_edge_conflicts)
            .set("first_vertex_conflicts", self.first_vertex_conflicts)
            .set("first_components", self.first_components)
            .set("first_largest_component", self.first_largest_component)
            .set("objective", self.first_objective)
            .set("kept", self.first_kept)
            .set("greedy_objective", self.greedy_objective)
            .set("objective_components", self.first_objective_components)
            .set(
                "greedy_objective_components",
                self.greedy_objective_components,
            )
            .set("greedy_kept", self.greedy_kept)
            .set("short_collapsed", self.short_collapsed)
            .set("long_dropped", self.long_dropped)
            .set("lone_dropped", self.lone_dropped)
            .set("loops_dropped", self.loops_dropped)
            .set("repaired_edges", self.repaired_edges)
            .set("unproven_components", self.unproven_components)
            .set("out_of_time_components", self.out_of_time_components);
        r
    }
}

/// The scale-conforming network and stats.
#[derive(Clone, Debug, PartialEq)]
pub struct ConformOutput {
    pub network: FeatureCurveNetwork,
    pub stats: ConformStats,
}

/// Per input curve: w_κ · l (sharpness times length).
fn curve_weights(net: &FeatureCurveNetwork) -> Vec<f64> {
    (0..net.curves.len())
        .map(|c| net.curve_strength(c).abs() * net.curve_length(c))
        .collect()
}

/// Step 1 of Fig. 4.7: resamples the arcs with an edge outside S. Returns the new graph,
/// whether anything was resampled, and the number of loops dropped. New vertices go to the
/// closest point of the mesh to their sample: samples lie on the arc's chords, and
/// once short edges have been collapsed into long chords over a few iterations, chords of
/// chords left dense networks floating off the surface (the armadillo's sharp edges above 5°
/// at 2 %: 655 of 1038 output vertices more than 1 % of the diagonal away, up to 10 %).
fn resample(
    g: &Graph,
    s: &Scale,
    starts: usize,
    surface: &Surface<'_>,
    par: Par,
) -> (Graph, bool, usize) {
    let arcs = g.arcs();
    let len = |e: u32| {
        let [a, b] = g.edges[e as usize];
        vec3::dist(g.pos[a as usize], g.pos[b as usize])
    };
    let todo: Vec<bool> = arcs
        .iter()
        .map(|a| {
            // An arc that is one special long edge stays: no resampling holds it better.
            let special = a.edges.len() == 1 && s.is_special_long(len(a.edges[0]));
            !special && a.edges.iter().any(|&e| !s.in_range(len(e)))
        })
        .collect();
    let results = par.map_collect(arcs.len(), |k| {
        if !todo[k] {
            return None;
        }
        let a = &arcs[k];
        let pts: Vec<ArcPoint> = a
            .verts
            .iter()
            .map(|&v| ArcPoint {
                pos: g.pos[v as usize],
                strength: g.strength[v as usize],
                orig: v,
            })
            .collect();
        let src: Vec<u32> = a.edges.iter().map(|&e| g.src[e as usize]).collect();
        Some(resample_arc(&pts, &src, a.closed, s, starts))
    });
    let mut out = Graph {
        pos: g.pos.clone(),
        strength: g.strength.clone(),
        location: g.location.clone(),
        edges: Vec::new(),
        src: Vec::new(),
    };
    let mut changed = false;
    let mut loops_dropped = 0;
    let mut new_vertices: Vec<usize> = Vec::new();
    for (k, a) in arcs.iter().enumerate() {
        match &results[k] {
            None => {
                for &e in &a.edges {
                    out.edges.push(g.edges[e as usize]);
                    out.src.push(g.src[e as usize]);
                }
            }
            Some(None) => {
                changed = true;
                loops_dropped += 1;
            }
            Some(Some((sm, path))) => {
                changed = true;
                let mut ids = Vec::with_capacity(path.len());
                for (t, &i) in path.iter().enumerate() {
                    let end = t == 0 || (t + 1 == path.len() && !a.closed);
                    let id = match sm[i].orig {
                        Some(v) => v,
                        None => {
                            debug_assert!(!end);
                            out.pos.push(sm[i].pos);
                            out.strength.push(sm[i].strength);
                            out.location.push(SurfacePoint::Free);
                            new_vertices.push(out.pos.len() - 1);
                            (out.pos.len() - 1) as u32
                        }
                    };
                    ids.push(id);
                }
                let n_e = if a.closed { ids.len() } else { ids.len() - 1 };
                for t in 0..n_e {
                    let (x, y) = (ids[t], ids[(t + 1) % ids.len()]);
                    if x == y {
                        continue;
                    }
                    let i0 = path[t];
                    let i1 = if t + 1 < path.len() {
                        path[t + 1]
                    } else {
                        sm.len() - 1
                    };
                    out.edges.push([x, y]);
                    out.src.push(sm[(i0 + i1) / 2].src);
                }
            }
        }
    }
    if let Some(bvh) = (!new_vertices.is_empty()).then(|| surface.bvh()).flatten() {
        let closest = par.map_collect(new_vertices.len(), |k| {
            bvh.closest(out.pos[new_vertices[k]])
        });
        for (&v, c) in new_vertices.iter().zip(closest) {
            if c.face != u32::MAX {
                out.pos[v] = c.point;
                out.location[v] = SurfacePoint::Face {
                    f: c.face,
                    bary: c.bary,
                };
            }
        }
    }
    // Only a different edge set counts as a change (an arc shorter than r_min resamples to
    // the edge it already is).
    let sorted = |es: &[[u32; 2]]| {
        let mut v: Vec<(u32, u32)> = es.iter().map(|&[a, b]| (a.min(b), a.max(b))).collect();
        v.sort_unstable();
        v
    };
    changed = changed && sorted(&out.edges) != sorted(&g.edges);
    // Repeated edges (two arcs resampled onto the same pair of vertices) are kept once.
    let mut seen = std::collections::BTreeSet::new();
    let mut keep = Vec::new();
    for (e, &[a, b]) in out.edges.iter().enumerate() {
        if seen.insert((a.min(b), a.max(b))) {
            keep.push(e);
        }
    }
    if keep.len() != out.edges.len() {
        out.edges = keep.iter().map(|&e| out.edges[e]).collect();
        out.src = keep.iter().map(|&e| out.src[e]).collect();
    }
    (out.compact(), changed, loops_dropped)
}

/// The mesh under the network, with its closest-point hierarchy built on first use (a
/// network whose arcs are all in scale never needs it).
struct Surface<'a> {
    mesh: &'a TriMesh,
    bvh: std::sync::OnceLock<Option<TriangleBvh>>,
    par: Par,
}

impl Surface<'_> {
    /// The hierarchy (none for a mesh without faces).
    fn bvh(&self) -> Option<&TriangleBvh> {
        self.bvh
            .get_or_init(|| {
                (self.mesh.n_faces() > 0)
                    .then(|| TriangleBvh::new_with(self.mesh, self.par == Par::Rayon))
            })
            .as_ref()
    }
}

/// The edges of `g` that are special long edges (thesis §4.3.3.2): an arc of a single edge
/// whose length lies between r_max and 2 r_min, which S cannot hold as one edge or as two.
/// They are kept like edges of S (the remesher splits them in two); other long edges never
/// are.
pub(crate) fn special_long_edges(g: &Graph, s: &Scale) -> Vec<bool> {
    let mut special = vec![false; g.edges.len()];
    // Off (the default), no arcs to walk: `build_problem` runs in every iteration.
    if !s.special_long {
        return special;
    }
    for a in g.arcs() {
        if let [e] = a.edges[..] {
            let [u, v] = g.edges[e as usize];
            special[e as usize] =
                !a.closed && s.is_special_long(vec3::dist(g.pos[u as usize], g.pos[v as usize]));
        }
    }
    special
}

/// The selection problem of step 3 for graph `g`, the number of its vertex conflicts, and of
/// the lone edges it fixes to 0. Long edges (except special long ones) and, unless
/// `params.lone_edges`, lone edges are fixed to 0.
pub fn build_problem(
    g: &Graph,
    s: &Scale,
    cw: &[f64],
    params: &ConformParams,
    par: Par,
) -> (Problem, usize, usize) {
    let ne = g.edges.len();
    let len: Vec<f64> = g
        .edges
        .iter()
        .map(|&[a, b]| vec3::dist(g.pos[a as usize], g.pos[b as usize]))
        .collect();
    let conf = find_conflicts(s, &g.pos, &g.edges, par);
    let special = special_long_edges(g, s);
    let mut on_loop = vec![false; ne];
    for a in g.arcs() {
        if a.closed {
            for &e in &a.edges {
                on_loop[e as usize] = true;
            }
        }
    }
    let weight: Vec<f64> = (0..ne)
        .map(|e| {
            let base = cw.get(g.src[e] as usize).copied().unwrap_or(0.0);
            let loop_f = if on_loop[e] { params.alpha_loop } else { 1.0 };
            // A floor keeps every edge worth keeping when the input has no strengths.
            (base * loop_f).max(1e-9 * len[e].max(f64::MIN_POSITIVE))
        })
        .collect();
    let inc = incidence(g.pos.len(), &g.edges);
    // Lone: neither end belongs to another edge.
    let lone: Vec<bool> = g
        .edges
        .iter()
        .map(|&[a, b]| {
            !params.lone_edges && a != b && inc[a as usize].len() == 1 && inc[b as usize].len() == 1
        })
        .collect();
    let mut pairs = Vec::new();
    let quarter = std::f64::consts::FRAC_PI_4;
    if params.eta_smooth > 0.0 {
        for (v, es) in inc.iter().enumerate() {
            for x in 0..es.len() {
                for y in x + 1..es.len() {
                    let (i, j) = (es[x], es[y]);
                    let o = |e: u32| {
                        let [a, b] = g.edges[e as usize];
                        if a as usize == v {
                            b
                        } else {
                            a
                        }
                    };
                    let u = vec3::sub(g.pos[o(i) as usize], g.pos[v]);
                    let w = vec3::sub(g.pos[o(j) as usize], g.pos[v]);
                    let theta = std::f64::consts::PI - angle(u, w);
                    if theta <= quarter {
                        let c = params.eta_smooth * (2.0 * theta).cos().max(0.0).powf(params.p);
                        if c > 0.0 {
                            pairs.push((i.min(j), i.max(j), c));
                        }
                    }
                }
            }
        }
    }
    if params.eta_parallel > 0.0 {
        let boxes: Vec<_> = g
            .edges
            .iter()
            .map(|&[a, b]| {
                let (p, q) = (g.pos[a as usize], g.pos[b as usize]);
                (
                    [p[0].min(q[0]), p[1].min(q[1]), p[2].min(q[2])],
                    [p[0].max(q[0]), p[1].max(q[1]), p[2].max(q[2])],
                )
            })
            .collect();
        let radius = params.parallel_radius * s.r_max;
        for (i, j) in box_pairs(&boxes, radius, par) {
            let [a, b] = g.edges[i as usize];
            let [c, d] = g.edges[j as usize];
            if a == c || a == d || b == c || b == d {
                continue;
            }
            let (pa, pb, pc, pd) = (
                g.pos[a as usize],
                g.pos[b as usize],
                g.pos[c as usize],
                g.pos[d as usize],
            );
            if crate::conflicts::segment_distance(pa, pb, pc, pd) > radius {
                continue;
            }
            let theta = angle(vec3::sub(pb, pa), vec3::sub(pd, pc));
            let c = params.eta_parallel * (2.0 * theta).cos().abs().powf(2.0 * params.p);
            if c > 0.0 {
                pairs.push((i, j, c));
            }
        }
    }
    pairs.sort_by_key(|x| (x.0, x.1));
    let n_vc = conf.vertex_pairs.len();
    let long: Vec<bool> = (0..ne).map(|e| s.is_long(len[e]) && !special[e]).collect();
    let n_lone = (0..ne).filter(|&e| lone[e] && !long[e]).count();
    (
        Problem {
            n_vertices: g.pos.len(),
            edges: g.edges.clone(),
            weight,
            fixed_zero: (0..ne).map(|e| long[e] || lone[e]).collect(),
            short: len.iter().map(|&l| s.is_short(l)).collect(),
            edge_conflicts: conf.edge_pairs.iter().map(|&(i, j, _)| (i, j)).collect(),
            vertex_conflicts: conf.vertex_pairs,
            pairs,
        },
        n_vc,
        n_lone,
    )
}

/// Step 4: removes dropped edges and collapses dropped short edges into their sharper end.
/// Returns the new graph, the number of removed edges and of collapses.
fn apply(g: &Graph, p: &Problem, keep: &[bool]) -> (Graph, usize, usize) {
    let n = g.pos.len();
    let mut rep: Vec<u32> = (0..n as u32).collect();
    fn root(rep: &mut [u32], mut x: u32) -> u32 {
        while rep[x as usize] != x {
            rep[x as usize] = rep[rep[x as usize] as usize];
            x = rep[x as usize];
        }
        x
    }
    let mut collapsed = 0;
    for (e, &[a, b]) in g.edges.iter().enumerate() {
        if keep[e] || !p.short[e] || p.fixed_zero[e] {
            continue;
        }
        let (ra, rb) = (root(&mut rep, a), root(&mut rep, b));
        if ra == rb {
            continue;
        }
        let (sa, sb) = (g.strength[ra as usize], g.strength[rb as usize]);
        // The weaker vertex moves into the sharper one (ties: the lower index stays).
        let (stay, go) = if sa > sb || (sa == sb && ra < rb) {
            (ra, rb)
        } else {
            (rb, ra)
        };
        rep[go as usize] = stay;
        collapsed += 1;
    }
    let mut out = Graph {
        pos: g.pos.clone(),
        strength: g.strength.clone(),
        location: g.location.clone(),
        edges: Vec::new(),
        src: Vec::new(),
    };
    let mut seen = std::collections::BTreeSet::new();
    let mut removed = 0;
    for (e, &[a, b]) in g.edges.iter().enumerate() {
        if !keep[e] {
            removed += 1;
            continue;
        }
        let (ra, rb) = (root(&mut rep, a), root(&mut rep, b));
        if ra == rb || !seen.insert((ra.min(rb), ra.max(rb))) {
            removed += 1;
            continue;
        }
        out.edges.push([ra, rb]);
        out.src.push(g.src[e]);
    }
    (out.compact(), removed, collapsed)
}

/// Removes, lightest first, edges that still violate a condition of scale conformity, until
/// none does. Returns the graph and the number of removed edges.
fn repair(mut g: Graph, s: &Scale, cw: &[f64], params: &ConformParams, par: Par) -> (Graph, usize) {
    let mut removed = 0;
    loop {
        let (p, _, _) = build_problem(&g, s, cw, params, par);
        let ne = g.edges.len();
        let mut drop: Vec<bool> = (0..ne).map(|e| p.short[e] || p.fixed_zero[e]).collect();
        let mut any = drop.iter().any(|&d| d);
        if !any {
            for &(i, j) in &p.edge_conflicts {
                let (i, j) = (i as usize, j as usize);
                if drop[i] || drop[j] {
                    continue;
                }
                let lose = if p.weight[i] < p.weight[j] || (p.weight[i] == p.weight[j] && i > j) {
                    i
                } else {
                    j
                };
                drop[lose] = true;
                any = true;
            }
        }
        if !any && !p.vertex_conflicts.is_empty() {
            let inc = incidence(g.pos.len(), &g.edges);
            for &(u, v) in &p.vertex_conflicts {
                let cand = inc[u as usize].iter().chain(&inc[v as usize]);
                if let Some(&e) = cand.min_by(|&&a, &&b| {
                    p.weight[a as usize]
                        .total_cmp(&p.weight[b as usize])
                        .then(a.cmp(&b))
                }) {
                    if !drop[e as usize] {
                        drop[e as usize] = true;
                        any = true;
                    }
                }
            }
        }
        if !any {
            return (g, removed);
        }
        removed += drop.iter().filter(|&&d| d).count();
        let keep: Vec<bool> = drop.iter().map(|&d| !d).collect();
        let no_short = Problem {
            short: vec![false; ne],
            ..p
        };
        g = apply(&g, &no_short, &keep).0;
    }
}

/// Adapts `net` on `mesh` to the scale of `params`, reporting progress through `keep_going`
/// (which returns false to cancel).
pub fn conform_with(
    net: &FeatureCurveNetwork,
    mesh: &TriMesh,
    params: &ConformParams,
    par: Par,
    keep_going: &mut dyn FnMut(f32) -> bool,
) -> Result<ConformOutput, ScaleError> {
    let issues = params.validate();
    if let Some(i) = issues.first() {
        return Err(ScaleError::Params(format!("{}: {}", i.field, i.message)));
    }
    let r_min = absolute_scale(mesh, params.scale, params.relative)?;
    let s = Scale::new(r_min, params.aspect).with_special_long(params.special_long_edges);
    let mut g = Graph::from_network(net, true)?;
    let length: f64 = g
        .edges
        .iter()
        .map(|&[a, b]| vec3::dist(g.pos[a as usize], g.pos[b as usize]))
        .sum();
    let samples = length / crate::resample::sample_spacing(&s);
    if samples > MAX_SAMPLES {
        return Err(ScaleError::TooFine {
            r_min,
            length,
            samples,
            max: MAX_SAMPLES,
        });
    }
    let cw = curve_weights(net);
    let labels: Vec<CurveLabel> = net.curves.iter().map(|c| c.label).collect();
    let mut stats = ConformStats {
        r_min: s.r_min,
        r_max: s.r_max,
        input_edges: g.edges.len(),
        input_curves: net.curves.len(),
        ..Default::default()
    };
    let surface = Surface {
        mesh,
        bvh: std::sync::OnceLock::new(),
        par,
    };
    let (method, backend) = match params.solver {
        Solver::Ilp => (Method::Ilp, ilp::Backend::Microlp),
        Solver::Highs => (Method::Ilp, ilp::Backend::Highs),
        Solver::Greedy => (Method::Greedy, ilp::Backend::Microlp),
    };
    for it in 0..params.max_iterations as usize {
        if !keep_going(it as f32 / params.max_iterations as f32) {
            return Err(ScaleError::Cancelled);
        }
        let (g1, resampled, dropped) = resample(&g, &s, params.loop_starts as usize, &surface, par);
        stats.loops_dropped += dropped;
        let (p, n_vc, n_lone) = build_problem(&g1, &s, &cw, params, par);
        let limit = (params.time_limit_s > 0.0).then_some(params.time_limit_s);
        let sel = ilp::select_using(&p, method, backend, limit, par)?;
        stats.unproven_components += sel.unproven;
        stats.out_of_time_components += sel.out_of_time;
        if it == 0 {
            let greedy = ilp::select(&p, Method::Greedy, par)?;
            stats.resampled_edges = g1.edges.len();
            stats.first_edge_conflicts = p.edge_conflicts.len();
            stats.first_vertex_conflicts = n_vc;
            stats.first_components = sel.components;
            stats.first_largest_component = sel.largest_component;
            stats.first_objective = sel.objective;
            stats.first_kept = sel.keep.iter().filter(|&&k| k).count();
            stats.greedy_objective = greedy.objective;
            stats.first_objective_components = sel.objective - sel.fixed_objective;
            stats.greedy_objective_components = greedy.objective - greedy.fixed_objective;
            stats.greedy_kept = greedy.keep.iter().filter(|&&k| k).count();
        }
        stats.lone_dropped += n_lone;
        stats.long_dropped += p.fixed_zero.iter().filter(|&&f| f).count() - n_lone;
        let (g2, removed, collapsed) = apply(&g1, &p, &sel.keep);
        stats.short_collapsed += collapsed;
        stats.iterations = it + 1;
        g = g2;
        if !resampled && removed == 0 && collapsed == 0 {
            stats.converged = true;
            break;
        }
    }
    let (g, repaired) = repair(g, &s, &cw, params, par);
    stats.repaired_edges = repaired;
    keep_going(1.0);
    let network = g.to_network(&labels);
    stats.output_edges = g.edges.len();
    stats.output_curves = network.curves.len();
    Ok(ConformOutput { network, stats })
}

/// [`conform_with`] without progress reporting.
pub fn conform(
    net: &FeatureCurveNetwork,
    mesh: &TriMesh,
    params: &ConformParams,
    par: Par,
) -> Result<ConformOutput, ScaleError> {
    conform_with(net, mesh, params, par, &mut |_| true)
}

/// The `scale.conform` node.
pub struct ConformNode;

impl NodeKind for ConformNode {
    type Params = ConformParams;
    const KIND: &'static str = "scale.conform";
    const VERSION: u32 = 9;
    const DOC: &'static str = "Adapts a feature curve network to a prescribed scale r_min: arcs \
        resampled into edges of length in [r_min, r_max], edge and vertex conflicts detected, \
        the best conflict-free subset selected by an exact binary linear program (weights \
        w_κ·l·w_loop, smoothness pairs), short edges collapsed, iterated until stable. \
        Thesis §4.3 (Fig. 4.7, constraints 4.3-4.10); Gehre, Lim & Kobbelt 2016.";

    fn inputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("curves", "the feature curves to adapt"),
            Port::of::<TriMesh>("mesh", "the mesh they lie on (sets the relative scale)"),
        ]
    }
    fn outputs() -> Vec<Port> {
        vec![
            Port::of::<FeatureCurveNetwork>("network", "the scale-conforming network"),
            Port::of::<Report>("report", "edge counts, conflicts, objective vs greedy"),
        ]
    }
    fn run(params: &Self::Params, inputs: &Inputs, ctx: &Ctx) -> Result<Outputs, NodeError> {
        let net = inputs.get::<FeatureCurveNetwork>("curves")?;
        let mesh = inputs.get::<TriMesh>("mesh")?;
        let out = conform_with(net, mesh, params, ctx.par, &mut |f| {
            ctx.progress(f);
            !ctx.cancel.is_cancelled()
        })
        .map_err(|e| NodeError::from_source(e.kind(), e))?;
        Ok(Outputs::new()
            .with("network", out.network)
            .with("report", out.stats.to_report()))
    }
}
