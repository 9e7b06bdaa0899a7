//! GICS benchmark: ridges and ravines of a mesh (cubic-fit curvature, default tracing), then
//! `descriptors.curve_gics` for all curves on one thread (`Par::Seq`) and on a 2-thread rayon
//! pool; median of repeats. Checks that both give the same bits.
//!
//! Usage: `cargo bench -p crestflow-nodes-descriptors --bench gics -- MESH [--repeats 3]`

use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_descriptors::{curve_gics, CurveGicsParams};
use crestflow_nodes_ridges::{trace, TraceParams};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut path = None;
    let mut repeats = 3usize;
    let mut i = 0;
    while i < args.len() {
        if args[i] == "--repeats" {
            repeats = args[i + 1].parse().expect("--repeats N");
            i += 2;
        } else {
            path = Some(args[i].clone());
            i += 1;
        }
    }
    let path = path.expect("usage: gics MESH");
    let mesh = load_mesh(&path, &LoadOptions::default())
        .expect("load")
        .mesh;
    let curv =
        polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon).expect("curvature");
    let net = trace(&mesh, &curv.field, &TraceParams::default(), Par::Rayon)
        .expect("trace")
        .network;
    let params = CurveGicsParams::default();
    // The factorisation inside curve_gics runs on one thread whatever the pool: time it alone.
    let t = Instant::now();
    crestflow_nodes_geodesic::HeatSolver::new(&mesh, params.time_factor, Par::Seq).expect("solver");
    let t_factor = t.elapsed().as_secs_f64();
    let run = |par: Par| {
        let mut times = Vec::new();
        let mut out = None;
        for _ in 0..repeats {
            let t = Instant::now();
            out = Some(curve_gics(&mesh, &net, &params, par).expect("gics"));
            times.push(t.elapsed().as_secs_f64());
        }
        (median(times), out.expect("repeats > 0"))
    };
    let (t1, a) = run(Par::Seq);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    let (t2, b) = pool.install(|| run(Par::Rayon));
    println!(
        "GICS {path}: n={} curves={} radii={}  1 thread {t1:.3} s  2 threads {t2:.3} s  speed-up {:.2}x  identical={}  (of which operators + factorisation {t_factor:.3} s)",
        mesh.n_vertices(),
        net.curves.len(),
        params.radii,
        t1 / t2,
        a == b
    );
}
