//! Speed of `smooth.laplacian`, in seconds per iteration (median of 3 runs), printed as one
//! JSON line per (mesh, method, threads). `bench/smooth/run.sh` runs it next to pymeshlab and
//! libigl on the same (noisy) files and prints the ratios.
//!
//! Usage (arguments after `--` of `cargo bench -p crestflow-nodes-smooth --bench smooth`):
//!   MESH ...                    time every method on each mesh file (OFF, OBJ, PLY, STL)
//!   --make-torus PATH N         write an irregular torus (R = 1, r = 0.35, jitter 0.35) of
//!                               about N vertices as OFF, then exit
//!
//! Methods: `uniform_explicit` and `cotan_explicit` (10 steps, λ = 0.5, weights recomputed
//! every step for cotan), `cotan_implicit_1` (one implicit step, t = 1 mean edge length²,
//! including building L and M, the symbolic analysis and the factorisation: libigl's unit of
//! work), `cotan_implicit_10` (10 steps re-weighted on the moving mesh: numeric
//! refactorisation only), `cotan_implicit_frozen_10` (10 steps, one factorisation).

use std::io::Write;
use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::shapes::torus;
use crestflow_geom::TriMesh;
use crestflow_nodes_smooth::{laplacian_smooth, LaplacianParams, Step, Weights};

fn write_off(path: &str, mesh: &TriMesh) -> std::io::Result<()> {
    if let Some(dir) = std::path::Path::new(path).parent() {
        std::fs::create_dir_all(dir)?;
    }
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(out, "OFF\n{} {} 0", mesh.n_vertices(), mesh.n_faces())?;
    for p in &mesh.positions {
        writeln!(out, "{:.17e} {:.17e} {:.17e}", p[0], p[1], p[2])?;
    }
    for t in &mesh.triangles {
        writeln!(out, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    Ok(())
}

fn median3(mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..3)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[1]
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().map(String::as_str) == Some("--make-torus") {
        let (Some(path), Some(n)) = (
            args.get(1),
            args.get(2).and_then(|s| s.parse::<usize>().ok()),
        ) else {
            eprintln!("usage: --make-torus PATH N");
            std::process::exit(2);
        };
        let n_v = ((n as f64 * 0.35).sqrt().round() as usize).max(3);
        let n_u = (n / n_v).max(3);
        let mesh = match torus(1.0, 0.35, n_u, n_v, 0.35, 1) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        if let Err(e) = write_off(path, &mesh) {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
        return;
    }
    let pool2 = rayon::ThreadPoolBuilder::new().num_threads(2).build();
    for path in &args {
        let mesh = match load_mesh(path, &LoadOptions::default()) {
            Ok(m) => m.mesh,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let methods: [(&str, Weights, Step, u32, bool); 5] = [
            (
                "uniform_explicit",
                Weights::Uniform,
                Step::Explicit,
                10,
                true,
            ),
            ("cotan_explicit", Weights::Cotan, Step::Explicit, 10, true),
            ("cotan_implicit_1", Weights::Cotan, Step::Implicit, 1, true),
            (
                "cotan_implicit_10",
                Weights::Cotan,
                Step::Implicit,
                10,
                true,
            ),
            (
                "cotan_implicit_frozen_10",
                Weights::Cotan,
                Step::Implicit,
                10,
                false,
            ),
        ];
        for (name, weights, step, iterations, update_weights) in methods {
            let params = LaplacianParams {
                weights,
                step,
                iterations,
                update_weights,
                lambda: 0.5,
                time_step: 1.0,
                ..Default::default()
            };
            for threads in [1usize, 2] {
                let mut job = || {
                    let par = if threads == 1 { Par::Seq } else { Par::Rayon };
                    if let Err(e) = laplacian_smooth(&mesh, None, &params, par) {
                        eprintln!("{path}: {name}: {e}");
                        std::process::exit(1);
                    }
                };
                let secs = match (&pool2, threads) {
                    (Ok(pool), 2) => pool.install(|| median3(&mut job)),
                    _ => median3(&mut job),
                };
                println!(
                    "{{\"impl\": \"crestflow\", \"mesh\": \"{}\", \"n_vertices\": {}, \"method\": \"{name}\", \
                     \"threads\": {threads}, \"iterations\": {iterations}, \"s_per_iter\": {:.6e}}}",
                    path.rsplit('/').next().unwrap_or(path),
                    mesh.n_vertices(),
                    secs / iterations as f64
                );
            }
        }
    }
}
