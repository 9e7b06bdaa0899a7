//! Ridge tracing against curvature estimation on cgal_bunny00 (37k vertices), one thread and
//! all threads: `cargo bench -p crestflow-nodes-ridges`. Tracing should cost less than the
//! curvature it consumes.

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::{CurvatureField, TriMesh};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};

fn main() {
    divan::main();
}

fn bunny() -> (TriMesh, CurvatureField) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/meshes/organic/cgal_bunny00.off"
    );
    let mesh = load_mesh(path, &LoadOptions::default())
        .expect("bunny loads")
        .mesh;
    let field = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Seq)
        .expect("curvature")
        .field;
    (mesh, field)
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

#[divan::bench(args = [1, 2], sample_count = 10)]
fn trace_bunny(bencher: divan::Bencher, threads: usize) {
    let (mesh, field) = bunny();
    let params = TraceParams::default();
    let par = if threads == 1 { Par::Seq } else { Par::Rayon };
    let pool = pool(threads);
    bencher.bench_local(|| pool.install(|| trace(&mesh, &field, &params, par).expect("trace")));
}

#[divan::bench(args = [1, 2], sample_count = 10)]
fn curvature_bunny(bencher: divan::Bencher, threads: usize) {
    let (mesh, _) = bunny();
    let params = PolynomialParams::default();
    let par = if threads == 1 { Par::Seq } else { Par::Rayon };
    let pool = pool(threads);
    bencher.bench_local(|| {
        pool.install(|| polynomial_curvature(&mesh, &params, par).expect("curvature"))
    });
}
