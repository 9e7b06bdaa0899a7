//! Triangular-solve benchmark: the sparse Cholesky solves of `SpdSolver` on the factor of
//! `L + M` (cotangent Laplacian plus lumped mass) of a mesh, one right-hand side and a
//! block of eight, on one thread; blocks of four on one thread and over the pool. Prints the fastest time and nanoseconds per factor value
//! (each value is read twice per solve: forward and backward).
//!
//! Usage: `cargo bench -p crestflow-nodes-spectral --bench solve -- [MESH | --sphere LEVEL]
//! [--repeats N] [--only 1|4|8]` (default: unit icosphere of level 6; give MESH as an absolute path, since
//! cargo runs benches in the crate's folder).

use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::shapes::sphere;
use crestflow_nodes_spectral::sparse::{laplacian_and_mass, CsrMatrix, LaplacianOptions};
use crestflow_nodes_spectral::SpdSolver;

fn main() {
    let mut repeats = 41usize;
    let mut level = 6u32;
    let mut path = None;
    let mut only = None;
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let value = |flag: &str, args: &mut dyn Iterator<Item = String>| {
        args.next()
            .unwrap_or_else(|| panic!("{flag} needs a value"))
    };
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--repeats" => repeats = value("--repeats", &mut args).parse().expect("--repeats N"),
            "--sphere" => {
                level = value("--sphere", &mut args)
                    .parse()
                    .expect("--sphere LEVEL")
            }
            "--only" => {
                only = Some(
                    value("--only", &mut args)
                        .parse::<usize>()
                        .expect("--only 1|4|8"),
                )
            }
            _ => path = Some(arg),
        }
    }
    let mesh = match &path {
        Some(p) => match load_mesh(p, &LoadOptions::default()) {
            Ok(loaded) => loaded.mesh,
            Err(e) => panic!("cannot load {p}: {e}"),
        },
        None => sphere(1.0, level).expect("sphere"),
    };
    let (l, mass) =
        laplacian_and_mass(&mesh, &LaplacianOptions::default(), Par::Seq).expect("laplacian");
    let a = l
        .add_scaled(1.0, &CsrMatrix::from_diagonal(&mass).expect("mass"), 1.0)
        .expect("L + M");
    // The factorisation: analysis plus values on the pool, and the values alone (same
    // pattern) on one thread and on the pool.
    let mut solver = SpdSolver::new(&a, Par::Rayon).expect("factor");
    let fastest_of = |runs: usize, f: &mut dyn FnMut()| {
        (0..runs)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let t_factor = fastest_of(5, &mut || {
        solver = SpdSolver::new(&a, Par::Rayon).expect("factor");
    });
    let t_numeric_seq = fastest_of(5, &mut || solver.refactor(&a, Par::Seq).expect("refactor"));
    let t_numeric = fastest_of(5, &mut || {
        solver.refactor(&a, Par::Rayon).expect("refactor")
    });
    let n = a.nrows();
    let nnz = solver.factor_nnz() as f64;
    let rhs: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1009) as f64 / 1009.0 - 0.5)
        .collect();
    // The fastest run of each width: the solves are bound by memory traffic, and other jobs
    // only add to it. `--only W` times width W alone.
    let timed = |w: usize| only.is_none_or(|o| o == w);
    let fastest = fastest_of;
    let mut b = rhs.clone();
    let t1 = timed(1).then(|| {
        fastest(repeats, &mut || {
            b.copy_from_slice(&rhs);
            solver.solve_in_place(&mut b).expect("solve");
        })
    });
    let check: f64 = b.iter().sum();
    let m = 8;
    let block: Vec<f64> = (0..m).flat_map(|_| rhs.iter().copied()).collect();
    let mut bb = block.clone();
    let t8 = timed(m).then(|| {
        fastest(repeats / 4 + 1, &mut || {
            bb.copy_from_slice(&block);
            solver.solve_many(&mut bb, m, Par::Seq).expect("solve");
        })
    });
    // The eigensolver's case: eight columns in groups over the rayon pool.
    let mut bp = block.clone();
    let t8p = timed(m).then(|| {
        fastest(repeats / 4 + 1, &mut || {
            bp.copy_from_slice(&block);
            solver.solve_many(&mut bp, m, Par::Rayon).expect("solve");
        })
    });
    // The eigensolver's case at k < 64 (blocks of four): one group, its elimination subtrees
    // over the rayon pool, against the same four columns on one thread.
    let four: Vec<f64> = block[..4 * n].to_vec();
    let mut b4 = four.clone();
    let t4 = timed(4).then(|| {
        fastest(repeats / 2 + 1, &mut || {
            b4.copy_from_slice(&four);
            solver.solve_many(&mut b4, 4, Par::Seq).expect("solve");
        })
    });
    let t4p = timed(4).then(|| {
        fastest(repeats / 2 + 1, &mut || {
            b4.copy_from_slice(&four);
            solver.solve_many(&mut b4, 4, Par::Rayon).expect("solve");
        })
    });
    // Milliseconds and nanoseconds per value (per value and column for the block).
    let figures = |t: Option<f64>, per: f64| match t {
        Some(t) => (format!("{:.3}", t * 1e3), format!("{:.3}", t * 1e9 / per)),
        None => ("null".to_string(), "null".to_string()),
    };
    let (one_ms, one_ns) = figures(t1, nnz);
    let (eight_ms, eight_ns) = figures(t8, nnz * m as f64);
    let (pool_ms, _) = figures(t8p, nnz * m as f64);
    let (four_ms, _) = figures(t4, nnz * 4.0);
    let (four_pool_ms, _) = figures(t4p, nnz * 4.0);
    println!(
        "{{\"n\": {n}, \"factor_values\": {nnz}, \"factor_ms\": {:.3}, \"numeric_one_thread_ms\": {:.3}, \"numeric_pool_ms\": {:.3}, \"one_ms\": {one_ms}, \"one_ns_per_value\": {one_ns}, \"eight_ms\": {eight_ms}, \"eight_ns_per_value_column\": {eight_ns}, \"eight_pool_ms\": {pool_ms}, \"four_ms\": {four_ms}, \"four_pool_ms\": {four_pool_ms}, \"checksum\": {check:.17e}}}",
        t_factor * 1e3,
        t_numeric_seq * 1e3,
        t_numeric * 1e3
    );
}
