//! Time of the symmetry chain (symmetry.blast + cluster + orbits; curvature and ridges are
//! computed once beforehand and not timed) at 1 and 2 threads, on cgal_turbine and on a
//! ~100k-vertex plate carrying a 5 × 5 grid of bumps.
//!
//!   cargo bench -p crestflow-nodes-symmetry --bench chain

use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::{FeatureCurveNetwork, TriMesh};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_symmetry::{
    blast, cluster, orbits, BlastParams, ClusterParams, OrbitParams, Orbits,
};

fn bump(x: f64, y: f64) -> f64 {
    let arm1 = (-(x * x / (1.5 * 1.5) + y * y / (0.35 * 0.35))).exp();
    let (s, c) = 60f64.to_radians().sin_cos();
    let (du, dv) = (x - 0.9, y - 0.8);
    let (p, q) = (c * du + s * dv, -s * du + c * dv);
    0.5 * (arm1 + 0.8 * (-(p * p / 0.81 + q * q / 0.09)).exp())
}

/// 316 × 316 vertices (~100k), spacing 0.1, bumps every 6 units.
fn big_plate() -> TriMesh {
    let n = 316;
    let a = 0.1;
    let mut pos = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f64 * a - 3.0, j as f64 * a - 3.0);
            let mut z = 0.0;
            for bi in 0..5 {
                for bj in 0..5 {
                    z += bump(x - 6.0 * bi as f64, y - 6.0 * bj as f64);
                }
            }
            pos.push([x, y, z]);
        }
    }
    let mut tris = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = (j * n + i) as u32;
            let m = n as u32;
            tris.push([v, v + 1, v + m + 1]);
            tris.push([v, v + m + 1, v + m]);
        }
    }
    TriMesh::new(pos, tris)
}

/// The chain, and the seconds spent in blast, cluster and orbits.
fn chain(net: &FeatureCurveNetwork, mesh: &TriMesh, par: Par) -> (Orbits, [f64; 3]) {
    let t0 = Instant::now();
    let m = blast(net, mesh, &BlastParams::default(), par).expect("blast");
    let t1 = Instant::now();
    let c = cluster(&m, &ClusterParams::default(), par).expect("cluster");
    let t2 = Instant::now();
    let o = orbits(&c, &OrbitParams::default(), par).expect("orbits");
    let t3 = Instant::now();
    (
        o,
        [
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            (t3 - t2).as_secs_f64(),
        ],
    )
}

fn bench(name: &str, mesh: &TriMesh) {
    let field = polynomial_curvature(mesh, &PolynomialParams::default(), Par::Rayon)
        .expect("curvature")
        .field;
    let net = trace(mesh, &field, &TraceParams::default(), Par::Rayon)
        .expect("ridges")
        .network;
    let mut results = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        let mut best = f64::INFINITY;
        let mut stages = [0.0; 3];
        let mut out = None;
        for _ in 0..3 {
            let t0 = Instant::now();
            let (o, st) = pool.install(|| chain(&net, mesh, Par::Rayon));
            let t = t0.elapsed().as_secs_f64();
            if t < best {
                best = t;
                stages = st;
            }
            out = Some(o);
        }
        println!(
            "  {name}, {threads} thread(s): blast {:.3} s, cluster {:.3} s, orbits {:.3} s",
            stages[0], stages[1], stages[2]
        );
        results.push((threads, best, out));
    }
    let o = results[0].2.as_ref().map(|o| o.orbits.len()).unwrap_or(0);
    println!(
        "{name}: {} vertices, {} curves, {} orbits; chain 1 thread {:.3} s, 2 threads {:.3} s (speed-up {:.2})",
        mesh.n_vertices(),
        net.curves.len(),
        o,
        results[0].1,
        results[1].1,
        results[0].1 / results[1].1
    );
    assert_eq!(
        results[0].2, results[1].2,
        "thread count changed the result"
    );
}

fn main() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/meshes/cad/cgal_turbine.off"
    );
    match load_mesh(path, &LoadOptions::default()) {
        Ok(m) => bench("cgal_turbine", &m.mesh),
        Err(e) => println!("cgal_turbine: cannot load ({e})"),
    }
    bench("plate_5x5_bumps", &big_plate());
}
