//! The selection against brute-force enumeration, and the greedy baseline on instances where
//! its answer is known to be worse.

use crate::ilp::{
    brute_force_full, feasible_full, objective, select, select_searching, select_using,
    select_with, Backend, Budgets, Method, Problem, SEARCH_NODES,
};
use crestflow_flow::Par;

/// A small deterministic generator (64-bit LCG) so the instances are reproducible.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn unit(&mut self) -> f64 {
        self.next() as f64 / (1u64 << 31) as f64
    }
}

/// A random network problem: edges on a few vertices, random conflicts, some short and long
/// edges, vertex conflicts among vertices of valence 1 or ≥ 3, smoothness pairs at shared
/// vertices. At most 16 binaries in all.
fn random_problem(seed: u64) -> Problem {
    random_problem_sized(seed, 6, 9, 16)
}

/// [`random_problem`] with 4 to 3 + `more_vertices` vertices, 3 to 2 + `more_edges` edges and
/// at most `binaries` edge and vertex binaries.
fn random_problem_sized(
    seed: u64,
    more_vertices: u64,
    more_edges: u64,
    binaries: usize,
) -> Problem {
    let mut r = Lcg(seed);
    let nv = 4 + r.below(more_vertices) as usize;
    let ne = 3 + r.below(more_edges) as usize;
    let mut edges: Vec<[u32; 2]> = Vec::new();
    while edges.len() < ne {
        let a = r.below(nv as u64) as u32;
        let b = r.below(nv as u64) as u32;
        if a != b
            && !edges
                .iter()
                .any(|e| (e[0], e[1]) == (a, b) || (e[0], e[1]) == (b, a))
        {
            edges.push([a, b]);
        }
        if edges.len() * 2 >= nv * (nv - 1) {
            break;
        }
    }
    let ne = edges.len();
    let mut valence = vec![0; nv];
    for &[a, b] in &edges {
        valence[a as usize] += 1;
        valence[b as usize] += 1;
    }
    let extra: Vec<u32> = (0..nv as u32)
        .filter(|&v| valence[v as usize] == 1 || valence[v as usize] >= 3)
        .collect();
    let mut vertex_conflicts = Vec::new();
    for x in 0..extra.len() {
        for y in x + 1..extra.len() {
            if r.below(4) == 0 && ne + 2 * vertex_conflicts.len() + 2 <= binaries {
                vertex_conflicts.push((extra[x], extra[y]));
            }
        }
    }
    let mut edge_conflicts = Vec::new();
    for i in 0..ne as u32 {
        for j in i + 1..ne as u32 {
            if r.below(3) == 0 {
                edge_conflicts.push((i, j));
            }
        }
    }
    let mut pairs = Vec::new();
    for i in 0..ne {
        for j in i + 1..ne {
            let share = edges[i].iter().any(|v| edges[j].contains(v));
            if share && r.below(2) == 0 {
                pairs.push((i as u32, j as u32, 10.0 * r.unit()));
            }
        }
    }
    Problem {
        n_vertices: nv,
        edges,
        weight: (0..ne).map(|_| 0.1 + 5.0 * r.unit()).collect(),
        fixed_zero: (0..ne).map(|_| r.below(10) == 0).collect(),
        short: (0..ne).map(|_| r.below(4) == 0).collect(),
        edge_conflicts,
        vertex_conflicts,
        pairs,
    }
}

#[test]
fn ilp_matches_brute_force_on_random_instances() {
    let mut worse = 0;
    for seed in 0..100u64 {
        let p = random_problem(seed);
        let best = brute_force_full(&p).expect("at most 22 binaries");
        let ilp = select(&p, Method::Ilp, Par::Seq).unwrap();
        let bf = select(&p, Method::BruteForce, Par::Seq).unwrap();
        let greedy = select(&p, Method::Greedy, Par::Seq).unwrap();
        assert!(
            (ilp.objective - best).abs() <= 1e-6 * best.abs().max(1.0),
            "seed {seed}: ILP {} vs brute force {best}",
            ilp.objective
        );
        assert!((bf.objective - best).abs() <= 1e-6 * best.abs().max(1.0));
        for sel in [&ilp, &bf, &greedy] {
            assert!(
                feasible_full(&p, &sel.keep, &sel.keep_vertex),
                "seed {seed}"
            );
            assert!((objective(&p, &sel.keep) - sel.objective).abs() < 1e-9);
        }
        assert!(greedy.objective <= best + 1e-9);
        if greedy.objective < best - 1e-9 {
            worse += 1;
        }
    }
    // The instances are hard enough that the greedy baseline misses the optimum on some.
    assert!(worse > 0);
}

#[test]
fn parallel_equals_sequential() {
    for seed in 0..40u64 {
        let p = random_problem(seed);
        let a = select(&p, Method::Ilp, Par::Seq).unwrap();
        let b = select(&p, Method::Ilp, Par::Rayon).unwrap();
        assert_eq!(a, b);
    }
}

/// A chain of three edges where the middle one conflicts with both others: the greedy keeps the
/// heaviest (middle) edge, the optimum the two outer ones.
#[test]
fn greedy_is_beaten_on_a_conflict_chain() {
    let p = Problem {
        n_vertices: 6,
        edges: vec![[0, 1], [2, 3], [4, 5]],
        weight: vec![1.0, 1.5, 1.0],
        fixed_zero: vec![false; 3],
        short: vec![false; 3],
        edge_conflicts: vec![(0, 1), (1, 2)],
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let ilp = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert_eq!(ilp.keep, vec![true, false, true]);
    assert!((ilp.objective - 2.0).abs() < 1e-12);
    let greedy = select(&p, Method::Greedy, Par::Seq).unwrap();
    assert_eq!(greedy.keep, vec![false, true, false]);
    assert!((greedy.objective - 1.5).abs() < 1e-12);
    assert_eq!(ilp.components, 1);
}

/// Two T-junctions (vertices 1 and 4) closer than r_min: one of them must drop to two edges,
/// and the lightest of its three edges goes.
#[test]
fn vertex_conflict_downgrades_one_junction() {
    // Junction 1: edges 0 (0-1), 1 (1-2), 2 (1-3); junction 4: edges 3 (4-5), 4 (4-6), 5 (4-7).
    let p = Problem {
        n_vertices: 8,
        edges: vec![[0, 1], [1, 2], [1, 3], [4, 5], [4, 6], [4, 7]],
        weight: vec![5.0, 5.0, 0.5, 4.0, 4.0, 3.0],
        fixed_zero: vec![false; 6],
        short: vec![false; 6],
        edge_conflicts: vec![],
        vertex_conflicts: vec![(1, 4)],
        pairs: vec![],
    };
    let s = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert_eq!(s.keep, vec![true, true, false, true, true, true]);
    assert!(!s.keep_vertex[1] && s.keep_vertex[4]);
    assert!((s.objective - 21.0).abs() < 1e-12);
}

/// Edges in no constraint are fixed to 1 and the others split into independent components.
#[test]
fn free_edges_and_components() {
    let p = Problem {
        n_vertices: 12,
        edges: vec![[0, 1], [2, 3], [4, 5], [6, 7], [8, 9], [10, 11]],
        weight: vec![1.0; 6],
        fixed_zero: vec![false, false, false, false, false, true],
        short: vec![false; 6],
        edge_conflicts: vec![(0, 1), (2, 3)],
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let s = select(&p, Method::Ilp, Par::Rayon).unwrap();
    assert_eq!(s.components, 2);
    assert_eq!(s.free_edges, 1);
    assert!(s.keep[4] && !s.keep[5]);
    assert_eq!(s.keep[0] as u8 + s.keep[1] as u8, 1);
    assert!((s.objective - 3.0).abs() < 1e-12);
}

/// A kept short edge needs another kept edge at one of its ends (4.9); a short edge that
/// conflicts with e_c forbids keeping e_c together with both neighbours (4.10).
#[test]
fn short_edge_constraints() {
    // Isolated short edge: never kept, whatever its weight.
    let p = Problem {
        n_vertices: 2,
        edges: vec![[0, 1]],
        weight: vec![100.0],
        fixed_zero: vec![false],
        short: vec![true],
        edge_conflicts: vec![],
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let s = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert_eq!(s.keep, vec![false]);
    // Edges 0 (0-1), short 1 (1-2), 2 (2-3); edge 3 (4-5) conflicts with the short edge.
    let p = Problem {
        n_vertices: 6,
        edges: vec![[0, 1], [1, 2], [2, 3], [4, 5]],
        weight: vec![3.0, 0.1, 3.0, 2.0],
        fixed_zero: vec![false; 4],
        short: vec![false, true, false, false],
        edge_conflicts: vec![(1, 3)],
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let s = select(&p, Method::Ilp, Par::Seq).unwrap();
    // Keeping 0, 2, 3 would violate (4.10); the best is 0, 2 and the short edge (6.1) rather
    // than 3 with one of the neighbours (5).
    assert_eq!(s.keep, vec![true, true, true, false]);
    assert_eq!(Some(s.objective), brute_force_full(&p));
}

#[test]
fn brute_force_rejects_large_components() {
    let n = 30;
    let p = Problem {
        n_vertices: 2 * n,
        edges: (0..n as u32).map(|i| [2 * i, 2 * i + 1]).collect(),
        weight: vec![1.0; n],
        fixed_zero: vec![false; n],
        short: vec![false; n],
        edge_conflicts: (0..n as u32 - 1).map(|i| (i, i + 1)).collect(),
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let err = select(&p, Method::BruteForce, Par::Seq).unwrap_err();
    assert!(err.to_string().contains("30 binaries"), "{err}");
    // The ILP solves it: alternate edges, 15 of 30.
    let s = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert!((s.objective - 15.0).abs() < 1e-9);
}

/// With a time limit too short to prove anything the result is still feasible and at least as
/// good as greedy (the warm start).
#[test]
fn time_limited_solve_keeps_a_feasible_solution() {
    for seed in 0..30u64 {
        let p = random_problem(seed);
        let s = select_with(&p, Method::Ilp, Some(1e-12), Par::Seq).unwrap();
        let g = select(&p, Method::Greedy, Par::Seq).unwrap();
        assert!(feasible_full(&p, &s.keep, &s.keep_vertex), "seed {seed}");
        assert!(s.objective >= g.objective - 1e-9, "seed {seed}");
        assert!(s.unproven <= s.components);
    }
}

/// Windows as large as the component solve it whole: the brute-force optimum. Windows of three
/// binaries stay feasible, between greedy and the optimum, and beat greedy somewhere.
#[test]
fn windows_are_exact_when_they_cover_the_component_and_improve_greedy_when_small() {
    let mut improved = 0;
    for seed in 0..60u64 {
        let p = random_problem(seed);
        let best = brute_force_full(&p).expect("at most 22 binaries");
        let whole = select(&p, Method::Windows { size: 64 }, Par::Seq).unwrap();
        assert!(
            (whole.objective - best).abs() <= 1e-6 * best.abs().max(1.0),
            "seed {seed}: windows {} vs brute force {best}",
            whole.objective
        );
        let small = select(&p, Method::Windows { size: 3 }, Par::Seq).unwrap();
        let greedy = select(&p, Method::Greedy, Par::Seq).unwrap();
        assert!(
            feasible_full(&p, &small.keep, &small.keep_vertex),
            "seed {seed}"
        );
        assert!(small.objective >= greedy.objective - 1e-9, "seed {seed}");
        assert!(small.objective <= best + 1e-9, "seed {seed}");
        assert_eq!(small.unproven, small.components);
        if small.objective > greedy.objective + 1e-9 {
            improved += 1;
        }
    }
    assert!(improved > 0);
}

/// A path of `n` edges, each in conflict with its two neighbours, weighted 1, 1.5, 1, 1, 1.5,
/// 1, ... (greedy keeps the heavy middles: 1.5 per three edges; both 1s of a triple give 2),
/// and its optimum by the dynamic programme for the best independent set of a path.
fn conflict_path(n: usize) -> (Problem, f64) {
    let weight: Vec<f64> = (0..n).map(|e| if e % 3 == 1 { 1.5 } else { 1.0 }).collect();
    let (mut take, mut skip) = (0.0f64, 0.0f64);
    for &w in &weight {
        let t = skip + w;
        skip = skip.max(take);
        take = t;
    }
    let p = Problem {
        n_vertices: 2 * n,
        edges: (0..n as u32).map(|e| [2 * e, 2 * e + 1]).collect(),
        weight,
        fixed_zero: vec![false; n],
        short: vec![false; n],
        edge_conflicts: (0..n as u32 - 1).map(|e| (e, e + 1)).collect(),
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    (p, take.max(skip))
}

/// A path of 3000 conflicting edges (each with its two neighbours) whose weights make greedy
/// keep the heavy middle of every triple: one component above EXACT_MAX_BINARIES. Windows of
/// the default size get within 1 % of the optimum (the usual dynamic programme for the best
/// independent set of a path) from greedy's 86 %; the ILP method, given it whole first,
/// proves it.
#[test]
fn a_path_above_the_exact_limit_is_solved_by_windows_near_the_optimum_and_whole_exactly() {
    let n = 3000usize;
    assert!(n > crate::ilp::EXACT_MAX_BINARIES);
    let (p, best) = conflict_path(n);
    let greedy = select(&p, Method::Greedy, Par::Seq).unwrap();
    assert!((greedy.objective - 1.5 * (n / 3) as f64).abs() < 1e-9);
    let windows = select(
        &p,
        Method::Windows {
            size: crate::ilp::WINDOW,
        },
        Par::Seq,
    )
    .unwrap();
    assert_eq!(windows.components, 1);
    assert_eq!(windows.largest_component, n);
    assert_eq!(windows.unproven, 1);
    assert!(feasible_full(&p, &windows.keep, &windows.keep_vertex));
    assert!(
        windows.objective >= 0.99 * best,
        "windows {} vs optimum {best} (greedy {})",
        windows.objective,
        greedy.objective
    );
    let rayon = select(
        &p,
        Method::Windows {
            size: crate::ilp::WINDOW,
        },
        Par::Rayon,
    )
    .unwrap();
    assert_eq!(windows, rayon);
    let ilp = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert_eq!(ilp.unproven, 0);
    assert!(
        (ilp.objective - best).abs() < 1e-9,
        "{} vs {best}",
        ilp.objective
    );
}

/// Without the `highs` build feature, asking for HiGHS is an error that says how to get it
/// (greedy needs no solver and still runs).
#[cfg(not(feature = "highs"))]
#[test]
fn highs_without_the_feature_is_a_clear_error() {
    let p = random_problem(3);
    assert!(!Backend::Highs.available());
    let err = select_using(&p, Method::Ilp, Backend::Highs, None, Par::Seq).unwrap_err();
    assert_eq!(err, crate::ilp::SelectError::Unavailable);
    assert!(err.to_string().contains("--features highs"), "{err}");
    let err = select_using(
        &p,
        Method::Windows { size: 4 },
        Backend::Highs,
        None,
        Par::Seq,
    );
    assert_eq!(err.unwrap_err(), crate::ilp::SelectError::Unavailable);
    let greedy = select_using(&p, Method::Greedy, Backend::Highs, None, Par::Seq).unwrap();
    assert_eq!(greedy, select(&p, Method::Greedy, Par::Seq).unwrap());
}

/// HiGHS reaches the brute-force optimum on the same 100 instances as microlp, with the same
/// bits on one thread and on the pool, and proves the 3000-edge path (where its windows also
/// reach the optimum of the path's dynamic programme).
#[cfg(feature = "highs")]
#[test]
fn highs_matches_brute_force_and_solves_the_long_path() {
    assert!(Backend::Highs.available());
    for seed in 0..100u64 {
        let p = random_problem(seed);
        let best = brute_force_full(&p).expect("at most 22 binaries");
        let h = select_using(&p, Method::Ilp, Backend::Highs, None, Par::Seq).unwrap();
        assert!(
            (h.objective - best).abs() <= 1e-6 * best.abs().max(1.0),
            "seed {seed}: HiGHS {} vs brute force {best}",
            h.objective
        );
        assert!(feasible_full(&p, &h.keep, &h.keep_vertex), "seed {seed}");
        assert_eq!(h.unproven, 0);
        let r = select_using(&p, Method::Ilp, Backend::Highs, None, Par::Rayon).unwrap();
        assert_eq!(h, r, "seed {seed}");
    }
    let (p, best) = conflict_path(3000);
    let whole = select_using(&p, Method::Ilp, Backend::Highs, None, Par::Seq).unwrap();
    assert_eq!(whole.unproven, 0);
    assert!((whole.objective - best).abs() < 1e-9, "{}", whole.objective);
    let size = crate::ilp::WINDOW;
    let w = select_using(&p, Method::Windows { size }, Backend::Highs, None, Par::Seq).unwrap();
    assert!(feasible_full(&p, &w.keep, &w.keep_vertex));
    assert!(w.objective >= 0.99 * best, "{}", w.objective);
}

/// Six edges that all conflict with each other are one row (a clique), not fifteen pairs,
/// and the program still keeps the heaviest alone.
#[test]
fn mutually_conflicting_edges_are_one_clique_row() {
    let n = 6u32;
    let mut edge_conflicts = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            edge_conflicts.push((i, j));
        }
    }
    let p = Problem {
        n_vertices: 2 * n as usize,
        edges: (0..n).map(|e| [2 * e, 2 * e + 1]).collect(),
        weight: (1..=n).map(f64::from).collect(),
        fixed_zero: vec![false; n as usize],
        short: vec![false; n as usize],
        edge_conflicts,
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let s = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert_eq!(s.constraints, 1);
    assert_eq!(s.objective, 6.0);
    assert_eq!(s.keep, [false, false, false, false, false, true]);
}

/// A short edge s = (0, 1) with edges e1, e2 at 0 and e3, e4 at 1, and an edge c in conflict
/// with s, e1 and e2: the four triples c + e_i + e_j ≤ 2 of (4.10) are implied by the pairs
/// c + e1 ≤ 1, c + e2 ≤ 1 and are not written. Rows: three pairs and the short edge's
/// (4.9) (eight with the triples). Keeping c (weight 10) drops s, e1 and e2: objective 12.
#[test]
fn triples_implied_by_a_conflicting_pair_are_not_written() {
    let (s, e1, e2, e3, e4, c) = (0u32, 1, 2, 3, 4, 5);
    let p = Problem {
        n_vertices: 8,
        edges: vec![[0, 1], [0, 2], [0, 3], [1, 4], [1, 5], [6, 7]],
        weight: vec![1.0, 1.0, 1.0, 1.0, 1.0, 10.0],
        fixed_zero: vec![false; 6],
        short: vec![true, false, false, false, false, false],
        edge_conflicts: vec![(s, c), (c, e1), (c, e2)],
        vertex_conflicts: vec![],
        pairs: vec![],
    };
    let sel = select(&p, Method::Ilp, Par::Seq).unwrap();
    assert_eq!(sel.constraints, 4);
    assert_eq!(sel.objective, 12.0);
    assert_eq!(sel.keep, [false, false, false, true, true, true]);
    assert!([e3, e4].iter().all(|&e| sel.keep[e as usize]));
    assert_eq!(sel.objective, brute_force_full(&p).unwrap());
}

/// The branch and bound that takes components before the solver reaches the solver's optimum
/// (microlp with the search turned off) and proves it: on the small random instances and on
/// larger ones of up to 60 binaries, with short edges (4.9), vertex binaries and combined
/// terms, one thread and the pool alike.
#[test]
fn search_matches_the_solver_on_random_instances() {
    let mut larger = 0;
    for seed in 0..160u64 {
        let p = if seed < 80 {
            random_problem(seed)
        } else {
            random_problem_sized(seed, 16, 38, 60)
        };
        let solver = select_searching(
            &p,
            Method::Ilp,
            Backend::Microlp,
            None,
            Par::Seq,
            searching(0),
        )
        .unwrap();
        let searched = select_searching(
            &p,
            Method::Ilp,
            Backend::Microlp,
            None,
            Par::Seq,
            searching(SEARCH_NODES),
        )
        .unwrap();
        assert!(
            (searched.objective - solver.objective).abs() <= 1e-9 * solver.objective.max(1.0),
            "seed {seed}: search {} vs solver {}",
            searched.objective,
            solver.objective
        );
        assert!(feasible_full(&p, &searched.keep, &searched.keep_vertex));
        assert_eq!(searched.unproven, 0);
        let pool = select_searching(
            &p,
            Method::Ilp,
            Backend::Microlp,
            None,
            Par::Rayon,
            searching(SEARCH_NODES),
        )
        .unwrap();
        assert_eq!(searched, pool, "seed {seed}");
        if searched.largest_component > 20 {
            larger += 1;
        }
    }
    // The larger instances do reach components the small ones do not have.
    assert!(
        larger >= 20,
        "{larger} instances with a component above 20 binaries"
    );
}

/// The default budgets with `nodes` of the search.
fn searching(nodes: usize) -> Budgets {
    Budgets {
        search: nodes,
        ..Budgets::DEFAULT
    }
}

/// A component the search cannot prove within its node budget goes to the solver: a path of
/// 300 conflicting edges with a budget of 50 nodes still gets the path's optimum (its dynamic
/// programme), as it does with the default budget.
#[test]
fn a_component_beyond_the_search_budget_goes_to_the_solver() {
    let (p, best) = conflict_path(300);
    for budget in [50, SEARCH_NODES] {
        let s = select_searching(
            &p,
            Method::Ilp,
            Backend::Microlp,
            None,
            Par::Seq,
            searching(budget),
        )
        .unwrap();
        assert_eq!(s.unproven, 0);
        assert!(
            (s.objective - best).abs() < 1e-9,
            "budget {budget}: {} vs {best}",
            s.objective
        );
    }
}

/// Under a time limit, the components go to the solver with budgets of work, not seconds:
/// with budgets of 0 (no search; the solver stops after its root relaxation and one node, in
/// windows likewise), the components that does not settle stay unproven and go on with
/// windows. The
/// selection is then feasible, never below greedy, and the same on one thread and on the
/// pool, whatever the time limit (a minute, a day) as long as it is not reached. A limit of 0
/// seconds cuts at least those components short, and says so.
#[test]
fn work_budgets_give_the_same_selection_whatever_the_time_limit() {
    let none = Budgets {
        search: 0,
        whole: 0,
        whole_max_rows: usize::MAX,
        window: 0,
    };
    let mut unproven = 0;
    for seed in 0..40u64 {
        let p = random_problem_sized(seed, 16, 38, 60);
        let run = |limit: f64, par: Par| {
            select_searching(&p, Method::Ilp, Backend::Microlp, Some(limit), par, none).unwrap()
        };
        let minute = run(60.0, Par::Seq);
        assert_eq!(minute.out_of_time, 0, "seed {seed}");
        assert!(feasible_full(&p, &minute.keep, &minute.keep_vertex));
        let greedy = select(&p, Method::Greedy, Par::Seq).unwrap();
        assert!(minute.objective >= greedy.objective - 1e-9, "seed {seed}");
        assert_eq!(minute, run(86400.0, Par::Seq), "seed {seed}");
        assert_eq!(minute, run(60.0, Par::Rayon), "seed {seed}");
        let exact = select(&p, Method::Ilp, Par::Seq).unwrap();
        assert!(minute.objective <= exact.objective + 1e-9, "seed {seed}");
        let cut = run(0.0, Par::Seq);
        assert!(cut.out_of_time >= minute.unproven, "seed {seed}");
        assert!(feasible_full(&p, &cut.keep, &cut.keep_vertex));
        unproven += minute.unproven;
    }
    // The budgets do stop the solver: components its first node leaves open.
    assert!(unproven >= 5, "{unproven} unproven components");
}

/// A component whose program has more rows than `whole_max_rows` is not given to the solver
/// whole (its root relaxation alone could take longer than the budget): it goes to windows
/// at once, and stays unproven. With the default limit, the same 300-edge path is proven.
#[test]
fn a_component_with_too_many_rows_goes_to_windows_at_once() {
    let (p, best) = conflict_path(300);
    let run = |whole_max_rows: usize| {
        let budgets = Budgets {
            search: 0,
            whole_max_rows,
            ..Budgets::DEFAULT
        };
        select_searching(
            &p,
            Method::Ilp,
            Backend::Microlp,
            Some(60.0),
            Par::Seq,
            budgets,
        )
        .unwrap()
    };
    let windows = run(10);
    assert_eq!((windows.unproven, windows.out_of_time), (1, 0));
    assert!(feasible_full(&p, &windows.keep, &windows.keep_vertex));
    assert!(
        windows.objective >= 0.99 * best,
        "{} vs {best}",
        windows.objective
    );
    let whole = run(crate::ilp::WHOLE_MAX_ROWS);
    assert_eq!(whole.unproven, 0);
    assert!(
        (whole.objective - best).abs() < 1e-9,
        "{} vs {best}",
        whole.objective
    );
}
