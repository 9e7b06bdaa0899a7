//! The feature curve selection of thesis §4.3.3.3 as a binary linear program: one binary b_e per
//! feature edge, one binary b_v per extraordinary vertex in a vertex conflict, one pair variable
//! b_ij per combined term (smoothness, parallel/orthogonal), and the constraints
//!
//! - (4.3) b_ij ≤ b_i, b_ij ≤ b_j;
//! - (4.4) b_i + b_j ≤ 1 for conflicting edges;
//! - (4.5) b_u + b_v ≤ 1 for conflicting extraordinary vertices;
//! - (4.6)–(4.8) a removed vertex keeps at most two edges, linearised as
//!   Σ_{e∋v} b_e − (deg − 2) b_v ≤ 2 (deg ≥ 3), and b_e − b_v ≤ 0 at a valence-1 vertex (4.7);
//! - (4.9) a kept short edge keeps at least one other edge at its ends: b_s − Σ b_k ≤ 0;
//! - (4.10) b_c + b_i + b_j ≤ 2 for every edge e_c in conflict with a short edge (v_i, v_j) and
//!   every pair of edges e_i at v_i, e_j at v_j.
//!
//! The objective Σ w_e b_e + Σ c_ij b_ij is maximised (all coefficients ≥ 0).
//!
//! **Decomposition.** An edge that appears with a positive coefficient in no constraint (a *free*
//! edge) is 1 in some optimum: raising it never violates a constraint (it only appears on the
//! helping side of (4.9)) and never lowers the objective. Free edges are fixed to 1; their
//! combined terms with a constrained edge become linear bonuses of that edge. The remaining
//! variables split into components (union-find over the constraints and the combined terms
//! between constrained edges), which are independent problems, solved in parallel and
//! collected in component order.
//!
//! **Formulation.** Conflicting pairs (4.4), (4.5) are written as cliques of the conflict
//! graph (Σ b ≤ 1 over edges that all conflict with each other: the same binaries allowed,
//! a tighter relaxation), and a triple of (4.10) is left out when two of its edges conflict
//! already (the pair implies it) or when it was written before.
//!
//! **Small components.** Most components of a sparse network have a few dozen binaries at
//! most, and building and solving a model costs microlp 15–900 µs for each. A depth-first
//! branch and bound (`solve_search`: constraints checked as binaries are fixed, the
//! objective bounded by what the free binaries could still add) gets every component first,
//! for at most [`SEARCH_NODES`] nodes; the components it does not prove by then go to the
//! solver. On cgal_fandisk_large's sharp edges at 1 % it proves 156 of the 158 components
//! (1–58 binaries), in about 2.4 ms for all, where microlp took about 17 ms. Both are exact:
//! the objective is the same, though where two selections tie the two may return different
//! ones.
//!
//! **Hard components.** Under a time limit (and above [`EXACT_MAX_BINARIES`] binaries in any
//! case) a component gets [`WHOLE_TRY_S`] seconds whole; one the solver does not prove by
//! then (dense networks: sharp edges above a few degrees on a scanned mesh) is improved window
//! by window, each window a few dozen neighbouring binaries solved exactly with the rest fixed
//! (large-neighbourhood search, [`Method::Windows`]).

use std::collections::{BTreeMap, HashSet};

use crestflow_flow::Par;
use good_lp::{
    microlp, variable, Constraint, Expression, ProblemVariables, Solution, SolutionStatus,
    SolverModel, Variable, WithInitialSolution, WithTimeLimit,
};

/// A selection problem over the edges of a network.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Problem {
    pub n_vertices: usize,
    pub edges: Vec<[u32; 2]>,
    /// w(e) ≥ 0.
    pub weight: Vec<f64>,
    /// Edges that cannot be kept (long edges): b_e = 0.
    pub fixed_zero: Vec<bool>,
    /// Short edges (shorter than r_min).
    pub short: Vec<bool>,
    /// Conflicting edge pairs (4.4).
    pub edge_conflicts: Vec<(u32, u32)>,
    /// Conflicting extraordinary vertex pairs (4.5).
    pub vertex_conflicts: Vec<(u32, u32)>,
    /// Combined terms (i, j, coefficient ≥ 0), coefficient already multiplied by η.
    pub pairs: Vec<(u32, u32, f64)>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Var {
    Edge(u32),
    Vertex(u32),
}

/// Σ coef · var ≤ rhs.
#[derive(Clone, Debug, PartialEq)]
struct Lin {
    terms: Vec<(Var, f64)>,
    rhs: f64,
}

/// How to select.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The binary program, solved exactly per component: by a branch and bound where it
    /// proves the optimum within [`SEARCH_NODES`] nodes, else by good_lp (microlp or HiGHS).
    Ilp,
    /// Enumeration of every assignment per component (exact; for tests, ≤ 24 binaries).
    BruteForce,
    /// Heaviest edge first, kept if it conflicts with nothing kept (the baseline).
    Greedy,
    /// Greedy, then improved by exact solves of windows of `size` neighbouring binaries with
    /// the rest fixed (large-neighbourhood search; feasible, never worse than greedy, not
    /// proven optimal). What [`Method::Ilp`] goes on with on components it does not prove
    /// within [`WHOLE_TRY_S`] (under a time limit, or above [`EXACT_MAX_BINARIES`]).
    Windows { size: usize },
}

/// Which solver runs the exact binary programs of [`Method::Ilp`] and [`Method::Windows`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// microlp (pure Rust, always built).
    #[default]
    Microlp,
    /// HiGHS (C++, only with the `highs` build feature; otherwise selecting fails with
    /// [`SelectError::Unavailable`]). Run on one thread per component, with a relative and
    /// absolute gap of 0, so that "optimal" means proven optimal as with microlp.
    Highs,
}

impl Backend {
    /// Whether this build can run it.
    pub fn available(self) -> bool {
        match self {
            Backend::Microlp => true,
            Backend::Highs => cfg!(feature = "highs"),
        }
    }
}

/// Why a selection failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SelectError {
    #[error(
        "the solver failed on conflict component {component} ({binaries} binaries): {message}"
    )]
    Solver {
        component: usize,
        binaries: usize,
        message: String,
    },
    #[error(
        "conflict component {component} has {binaries} binaries; brute force takes at most 24"
    )]
    TooLarge { component: usize, binaries: usize },
    #[error(
        "the HiGHS solver is not in this build: rebuild with `--features highs` (needs cmake, \
         libclang and a C++ compiler)"
    )]
    Unavailable,
}

/// The selected edges and what it took.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    pub keep: Vec<bool>,
    /// Kept extraordinary vertices (true for vertices without a vertex variable).
    pub keep_vertex: Vec<bool>,
    /// The objective Σ w_e b_e + Σ c_ij min(b_i, b_j).
    pub objective: f64,
    pub components: usize,
    /// Binaries (edge and vertex) of the largest component.
    pub largest_component: usize,
    /// Edges fixed to 1 because no constraint involves them.
    pub free_edges: usize,
    /// Components whose optimum was not proven: the solver ran out of time, or the component
    /// was solved by windows ([`Method::Windows`], and [`Method::Ilp`] on components not
    /// proven within [`WHOLE_TRY_S`]).
    pub unproven: usize,
    /// The part of `objective` that no choice changes: weights of the free edges and the
    /// combined terms between two free edges. `objective − fixed_objective` is what the
    /// conflict components contribute.
    pub fixed_objective: f64,
    /// Rows of the binary program (all components, after the free edges are fixed).
    pub constraints: usize,
}

struct Prepared {
    constraints: Vec<Lin>,
    constrained: Vec<bool>,
    /// Linear objective coefficient of each edge (weight + bonuses from free partners).
    lin: Vec<f64>,
    /// Combined terms between two constrained edges.
    pairs: Vec<(u32, u32, f64)>,
}

/// The graph of conflicting pairs (4.4) or (4.5), for lookups and the clique rows.
struct ConflictGraph<'a> {
    pairs: &'a [(u32, u32)],
    adj: BTreeMap<u32, Vec<u32>>,
}

impl<'a> ConflictGraph<'a> {
    fn new(pairs: &'a [(u32, u32)]) -> Self {
        let mut adj: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        for &(i, j) in pairs {
            if i != j {
                adj.entry(i).or_default().push(j);
                adj.entry(j).or_default().push(i);
            }
        }
        for list in adj.values_mut() {
            list.sort_unstable();
            list.dedup();
        }
        ConflictGraph { pairs, adj }
    }

    /// Whether `x` and `y` conflict.
    fn joined(&self, x: u32, y: u32) -> bool {
        self.adj
            .get(&x)
            .is_some_and(|list| list.binary_search(&y).is_ok())
    }

    /// Cliques that together cover every pair: each pair not covered yet, in order, grows into
    /// a clique by the common neighbours of its ends, lowest index first. One constraint
    /// Σ b ≤ 1 per clique allows the same binaries as one per pair, with fewer rows and a far
    /// tighter relaxation (pairs alone allow ½ everywhere), which is what the solver's bounds
    /// are made of. A pair (i, i) stays the row 2 b_i ≤ 1 it was.
    fn cliques(&self) -> Vec<Vec<u32>> {
        let mut covered: HashSet<(u32, u32)> = HashSet::new();
        let mut cliques = Vec::new();
        for &(i, j) in self.pairs {
            let (i, j) = (i.min(j), i.max(j));
            if !covered.insert((i, j)) {
                continue;
            }
            if i == j {
                cliques.push(vec![i, i]);
                continue;
            }
            let mut clique = vec![i, j];
            for &k in &self.adj[&i] {
                if k != j && clique.iter().all(|&m| self.joined(m, k)) {
                    clique.push(k);
                }
            }
            for (a, &x) in clique.iter().enumerate() {
                for &y in &clique[a + 1..] {
                    covered.insert((x.min(y), x.max(y)));
                }
            }
            cliques.push(clique);
        }
        cliques
    }
}

fn raw_constraints(p: &Problem) -> Vec<Lin> {
    let mut inc: Vec<Vec<u32>> = vec![Vec::new(); p.n_vertices];
    for (e, &[a, b]) in p.edges.iter().enumerate() {
        if p.fixed_zero[e] {
            continue;
        }
        inc[a as usize].push(e as u32);
        if a != b {
            inc[b as usize].push(e as u32);
        }
    }
    let live = |e: u32| !p.fixed_zero[e as usize];
    let mut cons: Vec<Lin> = Vec::new();
    // Triples of (4.10) already written, in ascending order.
    let mut triples: HashSet<[u32; 3]> = HashSet::new();
    let mut short_conf: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    let live_conflicts: Vec<(u32, u32)> = p
        .edge_conflicts
        .iter()
        .copied()
        .filter(|&(i, j)| live(i) && live(j))
        .collect();
    let conflicts = ConflictGraph::new(&live_conflicts);
    for clique in conflicts.cliques() {
        cons.push(Lin {
            terms: clique.iter().map(|&e| (Var::Edge(e), 1.0)).collect(),
            rhs: 1.0,
        });
    }
    for &(i, j) in &live_conflicts {
        if p.short[i as usize] {
            short_conf.entry(i).or_default().push(j);
        }
        if p.short[j as usize] {
            short_conf.entry(j).or_default().push(i);
        }
    }
    let mut vvars: Vec<u32> = Vec::new();
    for clique in ConflictGraph::new(&p.vertex_conflicts).cliques() {
        cons.push(Lin {
            terms: clique.iter().map(|&v| (Var::Vertex(v), 1.0)).collect(),
            rhs: 1.0,
        });
    }
    for &(u, v) in &p.vertex_conflicts {
        vvars.push(u);
        vvars.push(v);
    }
    vvars.sort_unstable();
    vvars.dedup();
    for &v in &vvars {
        let es = &inc[v as usize];
        let deg = es.len();
        if deg >= 3 {
            let mut terms: Vec<(Var, f64)> = es.iter().map(|&e| (Var::Edge(e), 1.0)).collect();
            terms.push((Var::Vertex(v), -((deg - 2) as f64)));
            cons.push(Lin { terms, rhs: 2.0 });
        } else if deg == 1 {
            cons.push(Lin {
                terms: vec![(Var::Edge(es[0]), 1.0), (Var::Vertex(v), -1.0)],
                rhs: 0.0,
            });
        }
    }
    for (s, &[a, b]) in p.edges.iter().enumerate() {
        if !p.short[s] || p.fixed_zero[s] {
            continue;
        }
        let s = s as u32;
        let mut terms = vec![(Var::Edge(s), 1.0)];
        for &k in inc[a as usize].iter().chain(&inc[b as usize]) {
            if k != s {
                terms.push((Var::Edge(k), -1.0));
            }
        }
        cons.push(Lin { terms, rhs: 0.0 });
        if let Some(cs) = short_conf.get(&s) {
            for &c in cs {
                for &ei in &inc[a as usize] {
                    for &ej in &inc[b as usize] {
                        if ei == s || ej == s || ei == ej || c == ei || c == ej {
                            continue;
                        }
                        // A triple two of whose edges conflict already is implied by that
                        // pair's constraint (4.4), for the binaries and for the relaxation;
                        // at vertices of high degree most triples are such, or repeats (one
                        // component of the armadillo's sharp edges above 10° at 2 % had
                        // 920k constraints, 91k without them, for 967 binaries).
                        if conflicts.joined(c, ei)
                            || conflicts.joined(c, ej)
                            || conflicts.joined(ei, ej)
                        {
                            continue;
                        }
                        let mut key = [c, ei, ej];
                        key.sort_unstable();
                        if !triples.insert(key) {
                            continue;
                        }
                        cons.push(Lin {
                            terms: vec![
                                (Var::Edge(c), 1.0),
                                (Var::Edge(ei), 1.0),
                                (Var::Edge(ej), 1.0),
                            ],
                            rhs: 2.0,
                        });
                    }
                }
            }
        }
    }
    cons
}

fn prepare(p: &Problem) -> Prepared {
    let ne = p.edges.len();
    let live = |e: u32| !p.fixed_zero[e as usize];
    let cons = raw_constraints(p);
    let mut constrained = vec![false; ne];
    for c in &cons {
        for &(v, k) in &c.terms {
            if let Var::Edge(e) = v {
                if k > 0.0 {
                    constrained[e as usize] = true;
                }
            }
        }
    }
    // Substitute free edges (1).
    let mut out: Vec<Lin> = Vec::new();
    for c in cons {
        let mut rhs = c.rhs;
        let mut terms = Vec::new();
        for (v, k) in c.terms {
            match v {
                Var::Edge(e) if !constrained[e as usize] => rhs -= k,
                _ => terms.push((v, k)),
            }
        }
        if terms.iter().any(|&(_, k)| k > 0.0) {
            out.push(Lin { terms, rhs });
        }
    }
    let mut lin: Vec<f64> = (0..ne)
        .map(|e| if p.fixed_zero[e] { 0.0 } else { p.weight[e] })
        .collect();
    let mut pairs = Vec::new();
    for &(i, j, c) in &p.pairs {
        if !live(i) || !live(j) || c <= 0.0 {
            continue;
        }
        match (constrained[i as usize], constrained[j as usize]) {
            (true, true) => pairs.push((i, j, c)),
            (true, false) => lin[i as usize] += c,
            (false, true) => lin[j as usize] += c,
            (false, false) => {}
        }
    }
    Prepared {
        constraints: out,
        constrained,
        lin,
        pairs,
    }
}

struct Component {
    vars: Vec<Var>,
    constraints: Vec<usize>,
    pairs: Vec<usize>,
}

fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

fn components(p: &Problem, pr: &Prepared) -> Vec<Component> {
    let ne = p.edges.len();
    let idx = |v: Var| match v {
        Var::Edge(e) => e as usize,
        Var::Vertex(u) => ne + u as usize,
    };
    let mut parent: Vec<usize> = (0..ne + p.n_vertices).collect();
    let union = |parent: &mut Vec<usize>, a: usize, b: usize| {
        let (ra, rb) = (find(parent, a), find(parent, b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    };
    let mut used = vec![false; ne + p.n_vertices];
    for c in &pr.constraints {
        let first = idx(c.terms[0].0);
        for &(v, _) in &c.terms {
            used[idx(v)] = true;
            union(&mut parent, first, idx(v));
        }
    }
    for &(i, j, _) in &pr.pairs {
        union(&mut parent, i as usize, j as usize);
    }
    let mut by_root: BTreeMap<usize, Component> = BTreeMap::new();
    for (x, &u) in used.iter().enumerate() {
        if !u {
            continue;
        }
        let r = find(&mut parent, x);
        let v = if x < ne {
            Var::Edge(x as u32)
        } else {
            Var::Vertex((x - ne) as u32)
        };
        by_root
            .entry(r)
            .or_insert_with(|| Component {
                vars: Vec::new(),
                constraints: Vec::new(),
                pairs: Vec::new(),
            })
            .vars
            .push(v);
    }
    for (k, c) in pr.constraints.iter().enumerate() {
        let r = find(&mut parent, idx(c.terms[0].0));
        if let Some(comp) = by_root.get_mut(&r) {
            comp.constraints.push(k);
        }
    }
    for (k, &(i, _, _)) in pr.pairs.iter().enumerate() {
        let r = find(&mut parent, i as usize);
        if let Some(comp) = by_root.get_mut(&r) {
            comp.pairs.push(k);
        }
    }
    by_root.into_values().collect()
}

/// Local index of each variable of a component.
fn local(comp: &Component) -> BTreeMap<Var, usize> {
    comp.vars.iter().enumerate().map(|(k, &v)| (v, k)).collect()
}

fn feasible(pr: &Prepared, comp: &Component, loc: &BTreeMap<Var, usize>, x: &[bool]) -> bool {
    comp.constraints.iter().all(|&k| {
        let c = &pr.constraints[k];
        let lhs: f64 = c
            .terms
            .iter()
            .map(|&(v, a)| if x[loc[&v]] { a } else { 0.0 })
            .sum();
        lhs <= c.rhs + 1e-9
    })
}

fn comp_objective(pr: &Prepared, comp: &Component, loc: &BTreeMap<Var, usize>, x: &[bool]) -> f64 {
    let mut f = 0.0;
    for (k, &v) in comp.vars.iter().enumerate() {
        if let Var::Edge(e) = v {
            if x[k] {
                f += pr.lin[e as usize];
            }
        }
    }
    for &k in &comp.pairs {
        let (i, j, c) = pr.pairs[k];
        if x[loc[&Var::Edge(i)]] && x[loc[&Var::Edge(j)]] {
            f += c;
        }
    }
    f
}

fn solve_brute(pr: &Prepared, comp: &Component) -> Vec<bool> {
    let n = comp.vars.len();
    let loc = local(comp);
    let mut best = vec![false; n];
    let mut best_f = f64::NEG_INFINITY;
    let mut x = vec![false; n];
    for mask in 0u64..(1u64 << n) {
        for (k, xk) in x.iter_mut().enumerate() {
            *xk = mask >> k & 1 == 1;
        }
        if !feasible(pr, comp, &loc, &x) {
            continue;
        }
        let f = comp_objective(pr, comp, &loc, &x);
        if f > best_f + 1e-9 {
            best_f = f;
            best.clone_from(&x);
        }
    }
    best
}

/// Clique inequalities implied by the pairwise conflicts (4.4)/(4.5) of a component: for each
/// variable, a clique of the conflict graph grown greedily from it (neighbours in index order).
/// They cut off fractional LP points (½ on every variable of a dense conflict cluster) without
/// changing the integer solutions. Returns the cliques (≥ 3 variables, local indices) and, for
/// each pairwise constraint, whether a clique covers it.
fn cliques(
    pr: &Prepared,
    comp: &Component,
    loc: &BTreeMap<Var, usize>,
) -> (Vec<Vec<usize>>, Vec<bool>) {
    let n = comp.vars.len();
    let is_pair = |k: usize| {
        let c = &pr.constraints[k];
        c.terms.len() == 2 && c.rhs == 1.0 && c.terms.iter().all(|&(_, a)| a == 1.0)
    };
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &k in &comp.constraints {
        if is_pair(k) {
            let c = &pr.constraints[k];
            let (a, b) = (loc[&c.terms[0].0], loc[&c.terms[1].0]);
            adj[a].push(b);
            adj[b].push(a);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    let mut set = std::collections::BTreeSet::new();
    for i in 0..n {
        if adj[i].len() < 2 {
            continue;
        }
        let mut q = vec![i];
        for &j in &adj[i] {
            if q.iter().all(|&m| adj[j].binary_search(&m).is_ok()) {
                q.push(j);
            }
        }
        if q.len() >= 3 {
            q.sort_unstable();
            set.insert(q);
        }
    }
    let cl: Vec<Vec<usize>> = set.into_iter().collect();
    let mut member: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (c, q) in cl.iter().enumerate() {
        for &v in q {
            member[v].push(c);
        }
    }
    let covered = comp
        .constraints
        .iter()
        .map(|&k| {
            if !is_pair(k) {
                return false;
            }
            let c = &pr.constraints[k];
            let (a, b) = (loc[&c.terms[0].0], loc[&c.terms[1].0]);
            member[a].iter().any(|x| member[b].contains(x))
        })
        .collect();
    (cl, covered)
}

/// The exact selection of one component. Returns the assignment and whether the solver proved
/// it optimal (false only when `time_limit` ran out; the greedy solution is the warm start,
/// so the result is never worse than it).
///
/// A component that [`solve_search`] proves within `search_nodes` nodes does not reach the
/// solver.
fn solve_ilp(
    pr: &Prepared,
    comp: &Component,
    ci: usize,
    backend: Backend,
    time_limit: Option<f64>,
    search_nodes: usize,
) -> Result<(Vec<bool>, bool), SelectError> {
    let start = solve_greedy(pr, comp);
    if let Some(x) = solve_search(pr, comp, &start, search_nodes) {
        return Ok((x, true));
    }
    solve_ilp_from(pr, comp, ci, backend, time_limit, start)
}

/// Nodes the branch and bound (`solve_search`) visits at most before it leaves a component
/// to the solver: about 0.4 ms of search (the two components of cgal_fandisk_large's sharp
/// edges at 1 % that reach it, of 26 and 58 binaries, took 0.35–0.40 ms before going to
/// microlp).
pub const SEARCH_NODES: usize = 20_000;

/// The exact selection of one component by depth-first branch and bound, when it takes at
/// most `budget` nodes (else `None`). Binaries are fixed in order of their objective
/// coefficient (edges, heaviest first, then vertices), 1 before 0. A branch ends when a
/// constraint can no longer hold (its fixed part plus the negative coefficients still free
/// exceeds the right-hand side) or when everything still free could not lift the objective
/// above the best selection so far (`start`, a feasible one, to begin with). The answer is
/// `start` if nothing beats it, else the first selection in that order with the highest
/// objective: the same at any thread count.
fn solve_search(
    pr: &Prepared,
    comp: &Component,
    start: &[bool],
    budget: usize,
) -> Option<Vec<bool>> {
    let n = comp.vars.len();
    let loc = local(comp);
    let gain = |k: usize| match comp.vars[k] {
        Var::Edge(e) => pr.lin[e as usize],
        Var::Vertex(_) => 0.0,
    };
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        let edge = |k: usize| matches!(comp.vars[k], Var::Edge(_));
        edge(b)
            .cmp(&edge(a))
            .then(gain(b).total_cmp(&gain(a)))
            .then(a.cmp(&b))
    });
    let mut rank = vec![0; n];
    for (r, &k) in order.iter().enumerate() {
        rank[k] = r;
    }
    // Constraints over positions in `order`; each position's rows and coefficients.
    let rhs: Vec<f64> = comp
        .constraints
        .iter()
        .map(|&c| pr.constraints[c].rhs)
        .collect();
    let mut rows_of: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    // The smallest value each row's free part can still take (its negative coefficients).
    let mut free_min = vec![0.0; rhs.len()];
    for (r, &c) in comp.constraints.iter().enumerate() {
        for &(v, a) in &pr.constraints[c].terms {
            rows_of[rank[loc[&v]]].push((r, a));
            free_min[r] += a.min(0.0);
        }
    }
    // Combined terms count at their later end: what setting position t to 1 adds is its
    // gain plus the terms with an earlier end already 1.
    let mut terms_of: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for &k in &comp.pairs {
        let (i, j, c) = pr.pairs[k];
        let (ri, rj) = (rank[loc[&Var::Edge(i)]], rank[loc[&Var::Edge(j)]]);
        terms_of[ri.max(rj)].push((ri.min(rj), c));
    }
    // The most positions t.. can still add.
    let mut rest = vec![0.0; n + 1];
    for t in (0..n).rev() {
        let most = gain(order[t]).max(0.0) + terms_of[t].iter().map(|&(_, c)| c).sum::<f64>();
        rest[t] = rest[t + 1] + most;
    }
    // What position t set to 1 adds, given the earlier positions of `x`.
    let added = |t: usize, x: &[bool]| -> f64 {
        gain(order[t])
            + terms_of[t]
                .iter()
                .filter(|&&(u, _)| x[u])
                .map(|&(_, c)| c)
                .sum::<f64>()
    };
    let mut best = comp_objective(pr, comp, &loc, start);
    let mut best_x: Option<Vec<bool>> = None;
    let mut x = vec![false; n];
    let mut fixed = vec![0.0; rhs.len()];
    let mut nodes = 0usize;
    // Explicit stack of (position, value so far, next choice): 2 = try 1, 1 = try 0, 0 = done.
    let mut stack: Vec<(usize, f64, u8)> = vec![(0, 0.0, 2)];
    // Undoes position t's effect on the rows (it was fixed to x[t]).
    let unfix = |t: usize, x: &[bool], fixed: &mut [f64], free_min: &mut [f64]| {
        for &(r, a) in &rows_of[t] {
            if x[t] {
                fixed[r] -= a;
            }
            free_min[r] += a.min(0.0);
        }
    };
    while let Some(top) = stack.last_mut() {
        let (t, f, choice) = *top;
        if choice == 0 {
            stack.pop();
            if t > 0 {
                unfix(t - 1, &x, &mut fixed, &mut free_min);
                x[t - 1] = false;
            }
            continue;
        }
        top.2 -= 1;
        if t == n {
            top.2 = 0;
            if f > best + 1e-9 {
                best = f;
                best_x = Some(x.clone());
            }
            continue;
        }
        if f + rest[t] <= best + 1e-9 {
            top.2 = 0;
            continue;
        }
        nodes += 1;
        if nodes > budget {
            return None;
        }
        let one = choice == 2;
        // Fix position t, and check its rows.
        x[t] = one;
        let mut ok = true;
        for &(r, a) in &rows_of[t] {
            free_min[r] -= a.min(0.0);
            if one {
                fixed[r] += a;
            }
            if fixed[r] + free_min[r] > rhs[r] + 1e-9 {
                ok = false;
            }
        }
        if !ok {
            unfix(t, &x, &mut fixed, &mut free_min);
            x[t] = false;
            continue;
        }
        let add = if one { added(t, &x) } else { 0.0 };
        stack.push((t + 1, f + add, 2));
    }
    let mut out = start.to_vec();
    if let Some(bx) = best_x {
        for (t, &k) in order.iter().enumerate() {
            out[k] = bx[t];
        }
    }
    Some(out)
}

/// [`solve_ilp`] from the feasible selection `start`: microlp's warm start, and for both
/// back ends the result when the solver stops without a better one.
fn solve_ilp_from(
    pr: &Prepared,
    comp: &Component,
    ci: usize,
    backend: Backend,
    time_limit: Option<f64>,
    start: Vec<bool>,
) -> Result<(Vec<bool>, bool), SelectError> {
    let n = comp.vars.len();
    let loc = local(comp);
    let mut vars = ProblemVariables::new();
    let xs: Vec<Variable> = (0..n).map(|_| vars.add(variable().binary())).collect();
    let ys: Vec<Variable> = comp
        .pairs
        .iter()
        .map(|_| vars.add(variable().min(0.0).max(1.0)))
        .collect();
    let mut obj = Expression::from(0.0);
    for (k, &v) in comp.vars.iter().enumerate() {
        if let Var::Edge(e) = v {
            obj += pr.lin[e as usize] * xs[k];
        }
    }
    for (y, &k) in ys.iter().zip(&comp.pairs) {
        obj += pr.pairs[k].2 * *y;
    }
    let mut init: Vec<(Variable, f64)> = xs
        .iter()
        .zip(&start)
        .map(|(&x, &b)| (x, b as u8 as f64))
        .collect();
    for (y, &k) in ys.iter().zip(&comp.pairs) {
        let (i, j, _) = pr.pairs[k];
        let on = start[loc[&Var::Edge(i)]] && start[loc[&Var::Edge(j)]];
        init.push((*y, on as u8 as f64));
    }
    let mut cons: Vec<Constraint> = Vec::new();
    let (cl, covered) = cliques(pr, comp, &loc);
    for q in &cl {
        let mut e = Expression::from(0.0);
        for &v in q {
            e += xs[v];
        }
        cons.push(e.leq(1.0));
    }
    for (t, &k) in comp.constraints.iter().enumerate() {
        if covered[t] {
            continue;
        }
        let c = &pr.constraints[k];
        let mut e = Expression::from(0.0);
        for &(v, a) in &c.terms {
            e += a * xs[loc[&v]];
        }
        cons.push(e.leq(c.rhs));
    }
    for (y, &k) in ys.iter().zip(&comp.pairs) {
        let (i, j, _) = pr.pairs[k];
        cons.push(Expression::from(*y).leq(xs[loc[&Var::Edge(i)]]));
        cons.push(Expression::from(*y).leq(xs[loc[&Var::Edge(j)]]));
    }
    let problem = vars.maximise(obj);
    let solved = match backend {
        Backend::Microlp => run_model(problem.using(microlp), Some(init), time_limit, cons, &xs)
            .map(|(x, status)| (x, matches!(status, SolutionStatus::Optimal))),
        #[cfg(feature = "highs")]
        Backend::Highs => {
            // One thread: components already run in parallel, and HiGHS's own threads would
            // make the search depend on the machine. Gaps of 0: proven optimal, not within
            // HiGHS's default 0.01 %. No warm start: with the greedy selection as its start,
            // HiGHS called a component of 70 binaries (cgal_bunny00 at 2 %) optimal at that
            // start, 1.5 % below microlp's optimum (right with presolve off, or without the
            // start; without it both solvers agree on all 342 components of bench/scale).
            let model = good_lp::solvers::highs::highs(problem)
                .set_threads(1)
                .set_parallel(good_lp::solvers::highs::HighsParallelType::Off)
                .set_option("mip_rel_gap", 0.0)
                .set_option("mip_abs_gap", 1e-9);
            // HiGHS reports "optimal" with the gap it closed, and good_lp calls any gap above
            // 0 a gap limit: here that means within the 1e-9 asked for, so proven.
            run_model(model, None, time_limit, cons, &xs).map(|(x, status)| {
                (
                    x,
                    matches!(status, SolutionStatus::Optimal | SolutionStatus::GapLimit),
                )
            })
        }
        #[cfg(not(feature = "highs"))]
        Backend::Highs => return Err(SelectError::Unavailable),
    };
    let (x, proven) = match solved {
        Ok(r) => r,
        // Out of time before the solver reported a solution: keep the warm start.
        Err(_) if time_limit.is_some() => return Ok((start, false)),
        Err(e) => {
            return Err(SelectError::Solver {
                component: ci,
                binaries: n,
                message: e.to_string(),
            })
        }
    };
    if !feasible(pr, comp, &loc, &x) {
        return Err(SelectError::Solver {
            component: ci,
            binaries: n,
            message: "the solver returned an infeasible assignment".into(),
        });
    }
    // Never worse than the warm start (a time-limited run may stop before improving on it).
    if comp_objective(pr, comp, &loc, &x) + 1e-9 < comp_objective(pr, comp, &loc, &start) {
        return Ok((start, proven));
    }
    Ok((x, proven))
}

/// Solves `model` (from the warm start `init`, if any) under `cons`; the binaries `xs`
/// rounded, and the solver's status.
fn run_model<M>(
    model: M,
    init: Option<Vec<(Variable, f64)>>,
    time_limit: Option<f64>,
    cons: Vec<Constraint>,
    xs: &[Variable],
) -> Result<(Vec<bool>, SolutionStatus), M::Error>
where
    M: SolverModel + WithInitialSolution + WithTimeLimit,
{
    let mut model = model;
    if let Some(init) = init {
        model = model.with_initial_solution(init);
    }
    if let Some(t) = time_limit {
        model = model.with_time_limit(t);
    }
    for c in cons {
        model = model.with(c);
    }
    let sol = model.solve()?;
    Ok((
        xs.iter().map(|&v| sol.value(v) > 0.5).collect(),
        sol.status(),
    ))
}

/// [`Method::Ilp`] gives a component with more binaries than this at most
/// [`WHOLE_TRY_S`] seconds whole even without a time limit (with one, every component);
/// unless the solver proves it optimal by then, the rest of the time limit goes to windows of
/// [`WINDOW`] binaries ([`Method::Windows`]) from the best selection found. Size alone does
/// not tell: the armadillo's ridges at 1 % and 2 % make components of 2416 and 3178 binaries
/// that the solver proves in well under a second, while its sharp edges above 15° / 10° / 5°
/// at 2 % (5168 / 13659 / 18210 binaries) ran out of five seconds per iteration with little
/// or nothing over greedy.
pub const EXACT_MAX_BINARIES: usize = 2000;

/// Seconds a component is given whole under a time limit (or the limit, if shorter), and
/// one above [`EXACT_MAX_BINARIES`] binaries without one. Smaller components can be as hard:
/// on the armadillo's sharp edges above 15° at 2 %, one of 928 binaries took microlp 49 s to
/// prove, and its selection after 5 s was already the optimal one; above 10°, one of 967
/// binaries was not proven in a minute.
pub const WHOLE_TRY_S: f64 = 5.0;

/// Binaries per window when [`Method::Ilp`] goes on with windows ([`WHOLE_TRY_S`]):
/// on the armadillo's sharp edges above 5° at 2 % (18k binaries, a minute's limit), windows
/// of 30 / 60 / 120 / 300 binaries reached objectives 1.75 / 2.13 / 1.71 / 1.03 times greedy's
/// (larger windows take longer each and were still in their first pass at the limit).
pub const WINDOW: usize = 60;

/// Passes over a component's windows at most (each pass grows its windows from the other end
/// of the variable order, so that their borders move). The passes stop earlier when one
/// improves nothing: on the armadillo's sharp edges above 10° and 5° at 2 %, within eight
/// passes, at objectives 0.8 % and 1.4 % above those of four passes.
const WINDOW_PASSES: usize = 16;

/// A large component, solved by windows (large-neighbourhood search): from `start` (a
/// feasible selection; greedy's when `None`), each window of up to `size` neighbouring
/// binaries (grown breadth-first over shared constraints and combined terms) is solved
/// exactly with everything else fixed, and taken where it raises the objective; passes repeat
/// until one improves nothing. Feasible and never worse than the start; not proven optimal.
/// Every window gets what is left of `time_limit` (for the whole component), and no window
/// starts once it is used up; while that does not happen, the result does not depend on the
/// machine.
///
/// Windows that share no constraint and no combined term do not read each other's binaries,
/// so a window only waits for the earlier windows it touches: those of one *level* (one more
/// than the highest level of the earlier windows it touches) are solved in parallel, which
/// gives the selection solving them one after the other gives, at any thread count.
#[allow(clippy::too_many_arguments)]
fn solve_windows(
    pr: &Prepared,
    comp: &Component,
    ci: usize,
    size: usize,
    backend: Backend,
    time_limit: Option<f64>,
    start: Option<Vec<bool>>,
    par: Par,
    search_nodes: usize,
) -> Vec<bool> {
    let size = size.max(1);
    let started = std::time::Instant::now();
    let n = comp.vars.len();
    let loc = local(comp);
    let mut x = start.unwrap_or_else(|| solve_greedy(pr, comp));
    let mut cons_of: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &k in &comp.constraints {
        let ls: Vec<usize> = pr.constraints[k]
            .terms
            .iter()
            .map(|&(v, _)| loc[&v])
            .collect();
        for &a in &ls {
            cons_of[a].push(k);
            adj[a].extend(ls.iter().copied().filter(|&b| b != a));
        }
    }
    let mut pairs_of: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &k in &comp.pairs {
        let (i, j, _) = pr.pairs[k];
        let (a, b) = (loc[&Var::Edge(i)], loc[&Var::Edge(j)]);
        pairs_of[a].push(k);
        pairs_of[b].push(k);
        adj[a].push(b);
        adj[b].push(a);
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    for pass in 0..WINDOW_PASSES {
        // The pass's windows: a partition of the binaries grown from seeds in order (from the
        // other end in odd passes); it does not depend on the selection.
        let mut taken = vec![false; n];
        let mut windows: Vec<Vec<usize>> = Vec::new();
        for i in 0..n {
            let seed = if pass % 2 == 0 { i } else { n - 1 - i };
            if taken[seed] {
                continue;
            }
            let mut window = vec![seed];
            taken[seed] = true;
            let mut head = 0;
            while head < window.len() && window.len() < size {
                for &b in &adj[window[head]] {
                    if !taken[b] && window.len() < size {
                        taken[b] = true;
                        window.push(b);
                    }
                }
                head += 1;
            }
            windows.push(window);
        }
        let mut owner = vec![usize::MAX; n];
        for (k, w) in windows.iter().enumerate() {
            for &a in w {
                owner[a] = k;
            }
        }
        let mut levels: Vec<Vec<usize>> = Vec::new();
        let mut level = vec![0usize; windows.len()];
        for k in 0..windows.len() {
            let l = windows[k]
                .iter()
                .flat_map(|&a| adj[a].iter().map(|&b| owner[b]))
                .filter(|&j| j < k)
                .map(|j| level[j] + 1)
                .max()
                .unwrap_or(0);
            level[k] = l;
            if levels.len() <= l {
                levels.resize(l + 1, Vec::new());
            }
            levels[l].push(k);
        }
        let mut improved = false;
        for ks in &levels {
            let left = match time_limit {
                Some(t) => {
                    let l = t - started.elapsed().as_secs_f64();
                    if l <= 0.0 {
                        return x;
                    }
                    Some(l)
                }
                None => None,
            };
            let found = par.map_collect(ks.len(), |t| {
                improve_window(
                    pr,
                    comp,
                    ci,
                    &loc,
                    &cons_of,
                    &pairs_of,
                    &windows[ks[t]],
                    &x,
                    backend,
                    left,
                    search_nodes,
                )
            });
            for (t, y) in found.into_iter().enumerate() {
                if let Some(y) = y {
                    for (w, &a) in windows[ks[t]].iter().enumerate() {
                        x[a] = y[w];
                    }
                    improved = true;
                }
            }
        }
        if !improved {
            break;
        }
    }
    x
}

/// Solves the binaries of `window` (local indices) exactly with the others fixed at `x`;
/// returns the window's new binaries if they raise the objective.
#[allow(clippy::too_many_arguments)]
fn improve_window(
    pr: &Prepared,
    comp: &Component,
    ci: usize,
    loc: &BTreeMap<Var, usize>,
    cons_of: &[Vec<usize>],
    pairs_of: &[Vec<usize>],
    window: &[usize],
    x: &[bool],
    backend: Backend,
    time_limit: Option<f64>,
    search_nodes: usize,
) -> Option<Vec<bool>> {
    // The window's binaries renumbered 0.. as a problem of its own: edges keep their linear
    // coefficient plus the combined terms with partners fixed at 1 outside the window;
    // constraints move the fixed binaries' part to the right-hand side.
    let mut slot = vec![usize::MAX; x.len()];
    for (w, &a) in window.iter().enumerate() {
        slot[a] = w;
    }
    let sub_var = |a: usize| match comp.vars[a] {
        Var::Edge(_) => Var::Edge(slot[a] as u32),
        Var::Vertex(_) => Var::Vertex(slot[a] as u32),
    };
    let mut lin = vec![0.0; window.len()];
    let mut pairs = Vec::new();
    for (w, &a) in window.iter().enumerate() {
        if let Var::Edge(e) = comp.vars[a] {
            lin[w] = pr.lin[e as usize];
        }
        for &k in &pairs_of[a] {
            let (i, j, c) = pr.pairs[k];
            let (pa, pb) = (loc[&Var::Edge(i)], loc[&Var::Edge(j)]);
            let other = if pa == a { pb } else { pa };
            if slot[other] == usize::MAX {
                if x[other] {
                    lin[w] += c;
                }
            } else if pa == a {
                // Inside the window: once, from its first end.
                pairs.push((slot[pa] as u32, slot[pb] as u32, c));
            }
        }
    }
    let mut ks: Vec<usize> = window
        .iter()
        .flat_map(|&a| cons_of[a].iter().copied())
        .collect();
    ks.sort_unstable();
    ks.dedup();
    let constraints: Vec<Lin> = ks
        .iter()
        .map(|&k| {
            let c = &pr.constraints[k];
            let mut rhs = c.rhs;
            let mut terms = Vec::new();
            for &(v, a) in &c.terms {
                let l = loc[&v];
                if slot[l] == usize::MAX {
                    if x[l] {
                        rhs -= a;
                    }
                } else {
                    terms.push((sub_var(l), a));
                }
            }
            Lin { terms, rhs }
        })
        .collect();
    let sub_vars: Vec<Var> = window.iter().map(|&a| sub_var(a)).collect();
    let start: Vec<bool> = window.iter().map(|&a| x[a]).collect();
    let sub = Prepared {
        constraints,
        constrained: Vec::new(),
        lin,
        pairs,
    };
    let sub_comp = Component {
        vars: sub_vars,
        constraints: (0..sub.constraints.len()).collect(),
        pairs: (0..sub.pairs.len()).collect(),
    };
    let sub_loc = local(&sub_comp);
    let before = comp_objective(&sub, &sub_comp, &sub_loc, &start);
    // A window the solver fails on keeps its part of the (feasible) selection.
    let y = match solve_search(&sub, &sub_comp, &start, search_nodes) {
        Some(y) => y,
        None => {
            solve_ilp_from(&sub, &sub_comp, ci, backend, time_limit, start)
                .ok()?
                .0
        }
    };
    (comp_objective(&sub, &sub_comp, &sub_loc, &y) > before + 1e-9).then_some(y)
}

fn solve_greedy(pr: &Prepared, comp: &Component) -> Vec<bool> {
    let n = comp.vars.len();
    let loc = local(comp);
    let mut order: Vec<usize> = (0..n)
        .filter(|&k| matches!(comp.vars[k], Var::Edge(_)))
        .collect();
    let w = |k: usize| match comp.vars[k] {
        Var::Edge(e) => pr.lin[e as usize],
        Var::Vertex(_) => 0.0,
    };
    order.sort_by(|&a, &b| w(b).total_cmp(&w(a)).then(a.cmp(&b)));
    // Constraints with a negative edge coefficient (4.9) are restored at the end; vertex
    // variables are raised to 1 exactly when a degree constraint needs them.
    let mut cons_of: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &k in &comp.constraints {
        let c = &pr.constraints[k];
        if c.terms
            .iter()
            .any(|&(v, a)| matches!(v, Var::Edge(_)) && a < 0.0)
        {
            continue;
        }
        for &(v, _) in &c.terms {
            cons_of[loc[&v]].push(k);
        }
    }
    let lhs = |k: usize, x: &[bool]| -> f64 {
        pr.constraints[k]
            .terms
            .iter()
            .map(|&(v, a)| if x[loc[&v]] { a } else { 0.0 })
            .sum()
    };
    let mut x = vec![false; n];
    for &k in &order {
        x[k] = true;
        let mut raised: Vec<usize> = Vec::new();
        let mut ok = true;
        for &c in &cons_of[k] {
            if lhs(c, &x) <= pr.constraints[c].rhs + 1e-9 {
                continue;
            }
            for &(v, a) in &pr.constraints[c].terms {
                let l = loc[&v];
                if matches!(v, Var::Vertex(_)) && a < 0.0 && !x[l] {
                    x[l] = true;
                    raised.push(l);
                }
            }
            if lhs(c, &x) > pr.constraints[c].rhs + 1e-9 {
                ok = false;
                break;
            }
        }
        if ok {
            ok = raised.iter().all(|&l| {
                cons_of[l]
                    .iter()
                    .all(|&c| lhs(c, &x) <= pr.constraints[c].rhs + 1e-9)
            });
        }
        if !ok {
            x[k] = false;
            for l in raised {
                x[l] = false;
            }
        }
    }
    // Drop kept short edges left without a neighbour (4.9) until none is.
    loop {
        let mut changed = false;
        for &k in &comp.constraints {
            if lhs(k, &x) > pr.constraints[k].rhs + 1e-9 {
                for &(v, a) in &pr.constraints[k].terms {
                    if a > 0.0 && x[loc[&v]] && matches!(v, Var::Edge(_)) {
                        x[loc[&v]] = false;
                        changed = true;
                        break;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    x
}

/// The objective of an edge selection on the full problem.
pub fn objective(p: &Problem, keep: &[bool]) -> f64 {
    let mut f: f64 = (0..p.edges.len())
        .filter(|&e| keep[e] && !p.fixed_zero[e])
        .map(|e| p.weight[e])
        .sum();
    for &(i, j, c) in &p.pairs {
        if keep[i as usize] && keep[j as usize] {
            f += c;
        }
    }
    f
}

/// Solves the selection problem `p` with `method`, component by component.
pub fn select(p: &Problem, method: Method, par: Par) -> Result<Selection, SelectError> {
    select_with(p, method, None, par)
}

/// [`select`] with a time limit (seconds) per component for [`Method::Ilp`]: a component
/// whose search runs out of time keeps the best solution found (at least the greedy one) and
/// is counted in [`Selection::unproven`].
pub fn select_with(
    p: &Problem,
    method: Method,
    time_limit: Option<f64>,
    par: Par,
) -> Result<Selection, SelectError> {
    select_using(p, method, Backend::Microlp, time_limit, par)
}

/// [`select_with`] with the exact programs run by `backend`.
pub fn select_using(
    p: &Problem,
    method: Method,
    backend: Backend,
    time_limit: Option<f64>,
    par: Par,
) -> Result<Selection, SelectError> {
    select_searching(p, method, backend, time_limit, par, SEARCH_NODES)
}

/// [`select_using`] with components given to [`solve_search`] for at most `search_nodes`
/// nodes before the solver (0: every component to the solver, as tests of the solver want).
pub(crate) fn select_searching(
    p: &Problem,
    method: Method,
    backend: Backend,
    time_limit: Option<f64>,
    par: Par,
    search_nodes: usize,
) -> Result<Selection, SelectError> {
    if matches!(method, Method::Ilp | Method::Windows { .. }) && !backend.available() {
        return Err(SelectError::Unavailable);
    }
    let pr = prepare(p);
    let comps = components(p, &pr);
    let sols: Vec<Result<(Vec<bool>, bool), SelectError>> = par.map_collect(comps.len(), |ci| {
        let comp = &comps[ci];
        match method {
            Method::Ilp if time_limit.is_some() || comp.vars.len() > EXACT_MAX_BINARIES => {
                let started = std::time::Instant::now();
                let whole = time_limit.map_or(WHOLE_TRY_S, |t| t.min(WHOLE_TRY_S));
                let (x, proven) = solve_ilp(&pr, comp, ci, backend, Some(whole), search_nodes)?;
                if proven {
                    return Ok((x, true));
                }
                let left = time_limit.map(|t| (t - started.elapsed().as_secs_f64()).max(0.0));
                if left == Some(0.0) {
                    return Ok((x, false));
                }
                Ok((
                    solve_windows(
                        &pr,
                        comp,
                        ci,
                        WINDOW,
                        backend,
                        left,
                        Some(x),
                        par,
                        search_nodes,
                    ),
                    false,
                ))
            }
            Method::Windows { size } => Ok((
                solve_windows(
                    &pr,
                    comp,
                    ci,
                    size,
                    backend,
                    time_limit,
                    None,
                    par,
                    search_nodes,
                ),
                false,
            )),
            Method::Ilp => solve_ilp(&pr, comp, ci, backend, time_limit, search_nodes),
            Method::BruteForce => {
                if comp.vars.len() > 24 {
                    Err(SelectError::TooLarge {
                        component: ci,
                        binaries: comp.vars.len(),
                    })
                } else {
                    Ok((solve_brute(&pr, comp), true))
                }
            }
            Method::Greedy => Ok((solve_greedy(&pr, comp), false)),
        }
    });
    let ne = p.edges.len();
    let mut keep: Vec<bool> = (0..ne)
        .map(|e| !p.fixed_zero[e] && !pr.constrained[e])
        .collect();
    let free_edges = keep.iter().filter(|&&k| k).count();
    let mut keep_vertex = vec![true; p.n_vertices];
    let mut largest = 0;
    let mut unproven = 0;
    for (comp, sol) in comps.iter().zip(sols) {
        let (x, proven) = sol?;
        if matches!(method, Method::Ilp | Method::Windows { .. }) && !proven {
            unproven += 1;
        }
        largest = largest.max(comp.vars.len());
        for (k, &v) in comp.vars.iter().enumerate() {
            match v {
                Var::Edge(e) => keep[e as usize] = x[k],
                Var::Vertex(u) => keep_vertex[u as usize] = x[k],
            }
        }
    }
    let objective = objective(p, &keep);
    let free: Vec<bool> = (0..ne)
        .map(|e| !p.fixed_zero[e] && !pr.constrained[e])
        .collect();
    let fixed_objective = self::objective(p, &free);
    Ok(Selection {
        keep,
        keep_vertex,
        objective,
        components: comps.len(),
        largest_component: largest,
        free_edges,
        unproven,
        fixed_objective,
        constraints: pr.constraints.len(),
    })
}

/// The optimum of `p` by enumerating every assignment of all its edge and vertex binaries at
/// once, with no decomposition and no free-edge fixing (for tests; at most 22 binaries).
pub fn brute_force_full(p: &Problem) -> Option<f64> {
    let cons = raw_constraints(p);
    let ne = p.edges.len();
    let mut vv: Vec<u32> = p
        .vertex_conflicts
        .iter()
        .flat_map(|&(u, v)| [u, v])
        .collect();
    vv.sort_unstable();
    vv.dedup();
    let n = ne + vv.len();
    if n > 22 {
        return None;
    }
    let mut best = f64::NEG_INFINITY;
    let mut keep = vec![false; ne];
    for mask in 0u64..(1u64 << n) {
        for (e, k) in keep.iter_mut().enumerate() {
            *k = mask >> e & 1 == 1;
        }
        if (0..ne).any(|e| keep[e] && p.fixed_zero[e]) {
            continue;
        }
        let val = |v: Var| match v {
            Var::Edge(e) => keep[e as usize],
            Var::Vertex(u) => {
                let k = vv.binary_search(&u).expect("vertex variable");
                mask >> (ne + k) & 1 == 1
            }
        };
        let ok = cons.iter().all(|c| {
            let lhs: f64 = c
                .terms
                .iter()
                .map(|&(v, a)| if val(v) { a } else { 0.0 })
                .sum();
            lhs <= c.rhs + 1e-9
        });
        if ok {
            best = best.max(objective(p, &keep));
        }
    }
    Some(best)
}

/// Whether the edge selection `keep` with the vertex labels `keep_vertex` satisfies every
/// constraint (4.4)–(4.10) of `p` (for tests).
pub fn feasible_full(p: &Problem, keep: &[bool], keep_vertex: &[bool]) -> bool {
    if (0..p.edges.len()).any(|e| keep[e] && p.fixed_zero[e]) {
        return false;
    }
    raw_constraints(p).iter().all(|c| {
        let lhs: f64 = c
            .terms
            .iter()
            .map(|&(v, a)| {
                let on = match v {
                    Var::Edge(e) => keep[e as usize],
                    Var::Vertex(u) => keep_vertex[u as usize],
                };
                if on {
                    a
                } else {
                    0.0
                }
            })
            .sum();
        lhs <= c.rhs + 1e-9
    })
}
