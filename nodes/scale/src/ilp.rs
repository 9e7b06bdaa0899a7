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
//! case) a component gets a budget of the solver's work whole ([`WHOLE_WORK`]; a component
//! of more than [`WHOLE_MAX_ROWS`] rows none). One the solver does not prove by then (dense
//! networks: sharp edges above a few degrees on a scanned mesh) is improved window by window,
//! each window a few dozen neighbouring binaries solved exactly with the rest fixed
//! (large-neighbourhood search, [`Method::Windows`]). The budgets count the solver's pivots,
//! not seconds, so that the selection is the same on every machine. The time limit stays as
//! a safety net, and a component it cuts short is counted in [`Selection::out_of_time`].

use std::collections::{BTreeMap, HashSet};

use crestflow_flow::Par;

/// A selection problem over the edges of a network.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Problem {
    pub n_vertices: usize,
    pub edges: Vec<[u32; 2]>,
    /// w(e) ≥ 0.
    pub weight: Vec<f64>,
    /// Edges that cannot be kept (long edges; lone edges unless kept): b_e = 0.
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
    /// within [`WHOLE_WORK`] (under a time limit, or above [`EXACT_MAX_BINARIES`]).
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
    /// proven within [`WHOLE_WORK`]).
    pub unproven: usize,
    /// Components whose solve the time limit cut short: the only ones whose selection can
    /// depend on the machine's speed (the work budgets do not).
    pub out_of_time: usize,
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

/// The exact selection of one component within `limits`, and how the solve ended (the greedy
/// selection is the solver's start, so the result is never worse than it).
///
/// A component that [`solve_search`] proves within `search_nodes` nodes does not reach the
/// solver.
fn solve_ilp(
    pr: &Prepared,
    comp: &Component,
    ci: usize,
    backend: Backend,
    limits: Limits,
    search_nodes: usize,
) -> Result<(Vec<bool>, Ended), SelectError> {
    let start = solve_greedy(pr, comp);
    if let Some(x) = solve_search(pr, comp, &start, search_nodes) {
        return Ok((x, Ended::Proven));
    }
    solve_ilp_from(pr, comp, ci, backend, limits, start)
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

/// How an exact solve ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ended {
    /// Optimal, and proven so.
    Proven,
    /// The work budget ran out first: the best selection found, the same on any machine.
    Budget,
    /// The time limit ran out first: the best selection found, which depends on the machine.
    Time,
}

/// The limits of one exact solve: work (simplex pivots times rows of the program, the
/// budget that does not depend on the machine) and seconds (a safety net).
#[derive(Clone, Copy, Debug, Default)]
struct Limits {
    work: Option<u64>,
    seconds: Option<f64>,
    /// Rows above which the solver is not called (its root relaxation alone would take more
    /// than `work`): the start stays, as if the budget had run out.
    max_rows: Option<usize>,
}

/// A component's binary program for a solver: columns `0..binaries` are the component's
/// binaries, the others one y per combined term (0 ≤ y ≤ 1, y ≤ both ends, so that y is
/// min(b_i, b_j) at the optimum as its coefficient is positive); every row is Σ a·col ≤ rhs.
struct Model {
    objective: Vec<f64>,
    binaries: usize,
    rows: Vec<(Vec<(usize, f64)>, f64)>,
}

impl Model {
    fn new(pr: &Prepared, comp: &Component, loc: &BTreeMap<Var, usize>) -> Model {
        let n = comp.vars.len();
        let mut objective: Vec<f64> = comp
            .vars
            .iter()
            .map(|&v| match v {
                Var::Edge(e) => pr.lin[e as usize],
                Var::Vertex(_) => 0.0,
            })
            .collect();
        objective.extend(comp.pairs.iter().map(|&k| pr.pairs[k].2));
        let mut rows = Vec::new();
        let (cl, covered) = cliques(pr, comp, loc);
        for q in &cl {
            rows.push((q.iter().map(|&v| (v, 1.0)).collect(), 1.0));
        }
        for (t, &k) in comp.constraints.iter().enumerate() {
            if covered[t] {
                continue;
            }
            let c = &pr.constraints[k];
            // One term per binary (a solver may reject repeats).
            let mut terms: Vec<(usize, f64)> = c.terms.iter().map(|&(v, a)| (loc[&v], a)).collect();
            terms.sort_by_key(|&(col, _)| col);
            let mut merged: Vec<(usize, f64)> = Vec::with_capacity(terms.len());
            for (col, a) in terms {
                match merged.last_mut() {
                    Some(last) if last.0 == col => last.1 += a,
                    _ => merged.push((col, a)),
                }
            }
            rows.push((merged, c.rhs));
        }
        for (t, &k) in comp.pairs.iter().enumerate() {
            let (i, j, _) = pr.pairs[k];
            let y = n + t;
            rows.push((vec![(y, 1.0), (loc[&Var::Edge(i)], -1.0)], 0.0));
            rows.push((vec![(y, 1.0), (loc[&Var::Edge(j)], -1.0)], 0.0));
        }
        Model {
            objective,
            binaries: n,
            rows,
        }
    }

    /// Every column's value for the binaries `x`.
    fn columns_of(
        &self,
        pr: &Prepared,
        comp: &Component,
        loc: &BTreeMap<Var, usize>,
        x: &[bool],
    ) -> Vec<f64> {
        let mut v: Vec<f64> = x.iter().map(|&b| b as u8 as f64).collect();
        v.extend(comp.pairs.iter().map(|&k| {
            let (i, j, _) = pr.pairs[k];
            (x[loc[&Var::Edge(i)]] && x[loc[&Var::Edge(j)]]) as u8 as f64
        }));
        v
    }
}

/// [`solve_ilp`] from the feasible selection `start`: microlp's warm start, and for both
/// back ends the result when the solver stops without a better one.
fn solve_ilp_from(
    pr: &Prepared,
    comp: &Component,
    ci: usize,
    backend: Backend,
    limits: Limits,
    start: Vec<bool>,
) -> Result<(Vec<bool>, Ended), SelectError> {
    let n = comp.vars.len();
    let loc = local(comp);
    let model = Model::new(pr, comp, &loc);
    if limits.max_rows.is_some_and(|m| model.rows.len() > m) {
        return Ok((start, Ended::Budget));
    }
    let solved = match backend {
        Backend::Microlp => {
            let warm = model.columns_of(pr, comp, &loc, &start);
            run_microlp(&model, &warm, limits)
        }
        #[cfg(feature = "highs")]
        Backend::Highs => run_highs(&model, limits),
        #[cfg(not(feature = "highs"))]
        Backend::Highs => return Err(SelectError::Unavailable),
    };
    let (x, ended) = match solved {
        Ok(r) => r,
        // A limited solve that fails keeps the start, as one that runs out of its budget.
        Err(_) if limits.work.is_some() || limits.seconds.is_some() => (None, Ended::Budget),
        Err(message) => {
            return Err(SelectError::Solver {
                component: ci,
                binaries: n,
                message,
            })
        }
    };
    // Out of nodes or time before the solver reported a selection: keep the start.
    let Some(x) = x else {
        return Ok((start, ended));
    };
    if !feasible(pr, comp, &loc, &x) {
        return Err(SelectError::Solver {
            component: ci,
            binaries: n,
            message: "the solver returned an infeasible assignment".into(),
        });
    }
    // Never worse than the start (a limited run may stop before improving on it).
    if comp_objective(pr, comp, &loc, &x) + 1e-9 < comp_objective(pr, comp, &loc, &start) {
        return Ok((start, ended));
    }
    Ok((x, ended))
}

/// Solves `model` with microlp from the column values `warm` (a feasible selection), within
/// `limits`: the selection found (`None` if a limit came before any) and how the solve ended.
/// microlp is called directly rather than through good_lp, whose wrapper offers only a time
/// limit: microlp's node limit and pivot count are what keep a limited solve the same on
/// every machine.
fn run_microlp(
    model: &Model,
    warm: &[f64],
    limits: Limits,
) -> Result<(Option<Vec<bool>>, Ended), String> {
    use microlp::{
        ComparisonOp, OptimizationDirection, ResumeOptions, SolveOptions, TerminationReason,
    };
    let mut p = microlp::Problem::new(OptimizationDirection::Maximize);
    let cols: Vec<microlp::Variable> = model
        .objective
        .iter()
        .enumerate()
        .map(|(c, &o)| {
            if c < model.binaries {
                p.add_binary_var(o)
            } else {
                p.add_var(o, (0.0, 1.0))
            }
        })
        .collect();
    for (terms, rhs) in &model.rows {
        p.add_constraint(
            terms.iter().map(|&(c, a)| (cols[c], a)),
            ComparisonOp::Le,
            *rhs,
        );
    }
    // The solver goes on a node at a time while the work done is below the budget: microlp
    // counts its pivots, and a pivot costs about as much as the rows it updates.
    let rows = model.rows.len().max(1) as u64;
    let work = |st: microlp::Stats| (st.lp_iterations + st.nodes_solved).saturating_mul(rows);
    let started = std::time::Instant::now();
    let time_left = || {
        limits
            .seconds
            .map(|t| seconds(t - started.elapsed().as_secs_f64()))
    };
    // Nodes until the budget is reached at the average work per node so far (at least one):
    // few resumes, and the last ones a node each.
    let next_nodes = |st: Option<microlp::Stats>| -> Option<u64> {
        let budget = limits.work?;
        let Some(st) = st else { return Some(1) };
        let per_node = (work(st) / st.nodes_solved.max(1)).max(1);
        Some((budget.saturating_sub(work(st)) / per_node).max(1))
    };
    let mut options = SolveOptions::default();
    options.node_limit = next_nodes(None);
    options.time_limit = time_left();
    options.warm_start = Some(cols.iter().copied().zip(warm.iter().copied()).collect());
    let mut out = p.solve_with(options).map_err(|e| e.to_string())?;
    while out.termination_reason() == TerminationReason::NodeLimit
        && limits.work.is_some_and(|w| work(out.stats()) < w)
    {
        let mut more = ResumeOptions::default();
        more.node_limit = next_nodes(Some(out.stats()));
        more.time_limit = time_left();
        out = out.resume_with(more).map_err(|e| e.to_string())?;
    }
    let ended = match out.termination_reason() {
        TerminationReason::ProvenOptimal => Ended::Proven,
        TerminationReason::TimeLimit => Ended::Time,
        _ => Ended::Budget,
    };
    let x = out.solution().map(|s| {
        cols[..model.binaries]
            .iter()
            .map(|&v| s.var_value(v) > 0.5)
            .collect()
    });
    Ok((x, ended))
}

/// A non-negative number of seconds as a duration (clamped; limits are validated finite).
fn seconds(s: f64) -> std::time::Duration {
    std::time::Duration::try_from_secs_f64(s.max(0.0)).unwrap_or(std::time::Duration::MAX)
}

/// Solves `model` with HiGHS (through good_lp) on one thread. One thread: components already
/// run in parallel, and HiGHS's own threads would make the search depend on the machine. Gaps
/// of 0: proven optimal, not within HiGHS's default 0.01 %. No warm start: with the greedy
/// selection as its start, HiGHS called a component of 70 binaries (cgal_bunny00 at 2 %)
/// optimal at that start, 1.5 % below microlp's optimum (right with presolve off, or without
/// the start; without it both solvers agree on all 342 components of bench/scale).
#[cfg(feature = "highs")]
fn run_highs(model: &Model, limits: Limits) -> Result<(Option<Vec<bool>>, Ended), String> {
    use good_lp::solvers::highs::{highs, HighsParallelType};
    use good_lp::{
        variable, Expression, ProblemVariables, Solution, SolutionStatus, SolverModel,
        WithTimeLimit,
    };
    let mut vars = ProblemVariables::new();
    let cols: Vec<good_lp::Variable> = (0..model.objective.len())
        .map(|c| {
            if c < model.binaries {
                vars.add(variable().binary())
            } else {
                vars.add(variable().min(0.0).max(1.0))
            }
        })
        .collect();
    let mut objective = Expression::from(0.0);
    for (&o, &v) in model.objective.iter().zip(&cols) {
        objective += o * v;
    }
    let mut problem = highs(vars.maximise(objective))
        .set_threads(1)
        .set_parallel(HighsParallelType::Off)
        .set_option("mip_rel_gap", 0.0)
        .set_option("mip_abs_gap", 1e-9);
    // HiGHS counts no pivots across its branch and bound: its budget is in nodes, at
    // [`HIGHS_PIVOTS_PER_NODE`] pivots each.
    if let Some(work) = limits.work {
        let rows = model.rows.len().max(1) as u64;
        let nodes = (work / rows / HIGHS_PIVOTS_PER_NODE).max(1);
        problem = problem.set_option("mip_max_nodes", nodes.min(i32::MAX as u64) as i32);
    }
    if let Some(t) = limits.seconds {
        problem = problem.with_time_limit(t);
    }
    for (terms, rhs) in &model.rows {
        let mut e = Expression::from(0.0);
        for &(c, a) in terms {
            e += a * cols[c];
        }
        problem = problem.with(e.leq(*rhs));
    }
    let started = std::time::Instant::now();
    // HiGHS reports one status for every limit: it was the time if that is used up.
    let limit_hit = || match limits.seconds {
        Some(t) if started.elapsed().as_secs_f64() >= t => Ended::Time,
        _ => Ended::Budget,
    };
    match problem.solve() {
        Ok(sol) => {
            // HiGHS reports "optimal" with the gap it closed, and good_lp calls any gap above
            // 0 a gap limit: here that means within the 1e-9 asked for, so proven.
            let ended = match sol.status() {
                SolutionStatus::Optimal | SolutionStatus::GapLimit => Ended::Proven,
                SolutionStatus::TimeLimit => limit_hit(),
            };
            let x = cols[..model.binaries]
                .iter()
                .map(|&v| sol.value(v) > 0.5)
                .collect();
            Ok((Some(x), ended))
        }
        // A limit came before any selection.
        Err(_) if limits.work.is_some() || limits.seconds.is_some() => Ok((None, limit_hit())),
        Err(e) => Err(e.to_string()),
    }
}

/// [`Method::Ilp`] gives a component with more binaries than this at most
/// [`WHOLE_WORK`] whole even without a time limit (with one, every component); unless the
/// solver proves it optimal by then, windows of [`WINDOW`] binaries ([`Method::Windows`]) go
/// on from the best selection found. Size alone does not tell: the armadillo's ridges at 1 %
/// and 2 % made components of 2416 and 3178 binaries that the solver proved in well under a
/// second, while its sharp edges above 15° / 10° / 5° at 2 % (5168 / 13659 / 18210 binaries)
/// are not proven in a minute.
pub const EXACT_MAX_BINARIES: usize = 2000;

/// Work (simplex pivots times rows of the program) the solver is given for a component whole
/// under a time limit, and for one above [`EXACT_MAX_BINARIES`] binaries without one. A budget
/// of work, unlike one of seconds, ends at the same selection on every machine. On a
/// two-core machine of 2026 this is 1–6 s: the pivot-rows of microlp took 23–113 ns on the
/// hard components of the corpus and of dense networks (5168 binaries on the armadillo's sharp
/// edges above 15° at 2 %: 23 ns; 2100 on trimesh_cycloidal's sharp edges at 2 %: 113 ns).
/// Smaller components can be as hard: one of 310 binaries (trimesh_cycloidal at 2 %) took
/// 4.5·10⁷ of this work, 5 s, to prove.
pub const WHOLE_WORK: u64 = 50_000_000;

/// Rows of a component's program above which [`Method::Ilp`] does not give it to the solver
/// whole but goes to windows at once. The solver's root relaxation cannot be stopped by a
/// budget of work, and it took about rows / 2 pivots (0.4–0.8 × rows on the components
/// below), so above this many rows it alone would cost more than [`WHOLE_WORK`]. The root
/// took 2100 binaries and 11,526 rows (trimesh_cycloidal's sharp edges at 2 %) 9692 pivots
/// and 11 s; 5168 binaries and 25,682 rows (armadillo_sub1's sharp edges above 15° at 2 %)
/// 9855 pivots and 6 s; 13,659 binaries and 117,158 rows (above 10°) more than a minute.
pub const WHOLE_MAX_ROWS: usize = 10_000;

/// Work of the solver per window (after [`SEARCH_NODES`] of the search).
pub const WINDOW_WORK: u64 = 10_000_000;

/// Pivots per node of HiGHS's branch and bound, to turn a work budget into the node limit
/// HiGHS takes: microlp took 39–530 per node on the components of [`WHOLE_WORK`]'s docs.
#[cfg(feature = "highs")]
const HIGHS_PIVOTS_PER_NODE: u64 = 100;

/// Binaries per window when [`Method::Ilp`] goes on with windows ([`WHOLE_WORK`]):
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
/// Every window gets `budgets.window` of the solver's work ([`WINDOW_WORK`]). `time_limit`
/// (for the whole component) is a safety net: no window starts once it is used up, and a
/// window solve stops at what is left of it. The second value tells whether that happened;
/// only then does the result depend on the machine.
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
    budgets: Budgets,
) -> (Vec<bool>, bool) {
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
    let mut out_of_time = false;
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
                        return (x, true);
                    }
                    Some(l)
                }
                None => None,
            };
            let limits = Limits {
                work: Some(budgets.window),
                seconds: left,
                max_rows: None,
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
                    limits,
                    budgets.search,
                )
            });
            for (t, (y, timed_out)) in found.into_iter().enumerate() {
                out_of_time |= timed_out;
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
    (x, out_of_time)
}

/// Solves the binaries of `window` (local indices) exactly with the others fixed at `x`;
/// returns the window's new binaries if they raise the objective, and whether the solver ran
/// out of time.
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
    limits: Limits,
    search_nodes: usize,
) -> (Option<Vec<bool>>, bool) {
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
    let (y, ended) = match solve_search(&sub, &sub_comp, &start, search_nodes) {
        Some(y) => (y, Ended::Proven),
        None => match solve_ilp_from(&sub, &sub_comp, ci, backend, limits, start) {
            Ok(r) => r,
            Err(_) => return (None, false),
        },
    };
    let better = comp_objective(&sub, &sub_comp, &sub_loc, &y) > before + 1e-9;
    (better.then_some(y), ended == Ended::Time)
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

/// [`select`] with a time limit (seconds) per component for [`Method::Ilp`]: every
/// component then gets work budgets ([`WHOLE_WORK`], then windows), and one not proven
/// within them keeps the best selection found (at least the greedy one) and is counted in
/// [`Selection::unproven`]. The time limit is a safety net on top (see
/// [`Selection::out_of_time`]).
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
    select_searching(p, method, backend, time_limit, par, Budgets::DEFAULT)
}

/// The work budgets of [`Method::Ilp`] and [`Method::Windows`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Budgets {
    /// Nodes of [`solve_search`] per component or window before the solver (0: every
    /// component to the solver, as tests of the solver want).
    pub search: usize,
    /// The solver's work for a component whole ([`WHOLE_WORK`]).
    pub whole: u64,
    /// Rows of a component above which it goes to windows at once ([`WHOLE_MAX_ROWS`]).
    pub whole_max_rows: usize,
    /// The solver's work per window ([`WINDOW_WORK`]).
    pub window: u64,
}

impl Budgets {
    pub const DEFAULT: Budgets = Budgets {
        search: SEARCH_NODES,
        whole: WHOLE_WORK,
        whole_max_rows: WHOLE_MAX_ROWS,
        window: WINDOW_WORK,
    };
}

/// [`select_using`] with other budgets (tests).
pub(crate) fn select_searching(
    p: &Problem,
    method: Method,
    backend: Backend,
    time_limit: Option<f64>,
    par: Par,
    budgets: Budgets,
) -> Result<Selection, SelectError> {
    if matches!(method, Method::Ilp | Method::Windows { .. }) && !backend.available() {
        return Err(SelectError::Unavailable);
    }
    let pr = prepare(p);
    let comps = components(p, &pr);
    // Each component's selection, and how its solve ended (`Nodes` also for greedy and for
    // windows, which prove nothing).
    let sols: Vec<Result<(Vec<bool>, Ended), SelectError>> = par.map_collect(comps.len(), |ci| {
        let comp = &comps[ci];
        let windows = |time_limit: Option<f64>, size: usize, start: Option<Vec<bool>>| {
            let (x, out_of_time) = solve_windows(
                &pr, comp, ci, size, backend, time_limit, start, par, budgets,
            );
            (
                x,
                if out_of_time {
                    Ended::Time
                } else {
                    Ended::Budget
                },
            )
        };
        match method {
            Method::Ilp if time_limit.is_some() || comp.vars.len() > EXACT_MAX_BINARIES => {
                let started = std::time::Instant::now();
                let limits = Limits {
                    work: Some(budgets.whole),
                    seconds: time_limit,
                    max_rows: Some(budgets.whole_max_rows),
                };
                let (x, ended) = solve_ilp(&pr, comp, ci, backend, limits, budgets.search)?;
                if ended != Ended::Budget {
                    return Ok((x, ended));
                }
                let left = time_limit.map(|t| (t - started.elapsed().as_secs_f64()).max(0.0));
                if left == Some(0.0) {
                    return Ok((x, Ended::Time));
                }
                Ok(windows(left, WINDOW, Some(x)))
            }
            Method::Windows { size } => Ok(windows(time_limit, size, None)),
            Method::Ilp => solve_ilp(&pr, comp, ci, backend, Limits::default(), budgets.search),
            Method::BruteForce => {
                if comp.vars.len() > 24 {
                    Err(SelectError::TooLarge {
                        component: ci,
                        binaries: comp.vars.len(),
                    })
                } else {
                    Ok((solve_brute(&pr, comp), Ended::Proven))
                }
            }
            Method::Greedy => Ok((solve_greedy(&pr, comp), Ended::Budget)),
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
    let mut out_of_time = 0;
    for (comp, sol) in comps.iter().zip(sols) {
        let (x, ended) = sol?;
        if matches!(method, Method::Ilp | Method::Windows { .. }) && ended != Ended::Proven {
            unproven += 1;
        }
        if ended == Ended::Time {
            out_of_time += 1;
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
        out_of_time,
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
