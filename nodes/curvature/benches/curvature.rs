//! Speed of the two curvature estimators, in µs per vertex at 1 and 2 threads (median of 3
//! runs, derivatives and orientation included), printed as one JSON line per (mesh, method,
//! threads). `bench/curvature/run.sh` runs it next to libigl and prints the ratios.
//!
//! Usage (arguments after `--` of `cargo bench -p crestflow-nodes-curvature --bench curvature`):
//!   MESH.off ...                      time both methods on each OFF file
//!   --make-torus PATH N [SEED]        write an irregular torus (R = 1, r = 0.35, jitter 0.35)
//!                                     of about N vertices as OFF, then exit
//!   --accuracy N                      errors of both methods on that torus with N vertices

use std::io::Write;
use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::shapes::{analytic_curvature_field, AnalyticShape};
use crestflow_geom::TriMesh;
use crestflow_nodes_curvature::{
    polynomial_curvature, shape_operator_curvature, PolynomialParams, ShapeOperatorParams,
};

/// A timed computation on a mesh.
type Job<'a> = &'a (dyn Fn(&TriMesh) + Sync);

const TORUS: AnalyticShape = AnalyticShape::Torus {
    major: 1.0,
    minor: 0.35,
};

/// A minimal OFF reader for benchmark inputs (triangles only; polygons are fanned).
fn read_off(path: &str) -> Result<TriMesh, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut tokens = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or(""))
        .flat_map(|l| l.split_whitespace())
        .peekable();
    if tokens.peek().is_some_and(|t| t.ends_with("OFF")) {
        tokens.next();
    }
    let mut num = |what: &str| -> Result<f64, String> {
        tokens
            .next()
            .ok_or_else(|| format!("{path}: file ends before {what}"))?
            .parse::<f64>()
            .map_err(|e| format!("{path}: bad {what}: {e}"))
    };
    let nv = num("vertex count")? as usize;
    let nf = num("face count")? as usize;
    let _ne = num("edge count")?;
    let mut positions = Vec::with_capacity(nv);
    for _ in 0..nv {
        positions.push([num("x")?, num("y")?, num("z")?]);
    }
    let mut triangles = Vec::with_capacity(nf);
    for f in 0..nf {
        let k = num("face size")? as usize;
        let idx: Vec<u32> = (0..k)
            .map(|_| num("index").map(|x| x as u32))
            .collect::<Result<_, _>>()?;
        if idx.iter().any(|&i| i as usize >= nv) {
            return Err(format!("{path}: face {f} has an index out of range"));
        }
        for j in 1..k.saturating_sub(1) {
            triangles.push([idx[0], idx[j], idx[j + 1]]);
        }
    }
    Ok(TriMesh::new(positions, triangles))
}

fn write_off(path: &str, mesh: &TriMesh) -> std::io::Result<()> {
    if let Some(dir) = std::path::Path::new(path).parent() {
        std::fs::create_dir_all(dir)?;
    }
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(out, "OFF\n{} {} 0", mesh.n_vertices(), mesh.n_faces())?;
    for p in &mesh.positions {
        // 17 significant digits: the file round-trips the f64 positions exactly.
        writeln!(out, "{:.17e} {:.17e} {:.17e}", p[0], p[1], p[2])?;
    }
    for t in &mesh.triangles {
        writeln!(out, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    Ok(())
}

fn median_us_per_vertex(mesh: &TriMesh, threads: usize, f: Job) -> (f64, Vec<f64>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let mut runs = Vec::new();
    for _ in 0..3 {
        // A fresh mesh per run, so the (lazily built) connectivity is part of the timing.
        let m = mesh.clone();
        let t0 = Instant::now();
        pool.install(|| f(&m));
        runs.push(t0.elapsed().as_secs_f64() * 1e6 / mesh.n_vertices() as f64);
    }
    let mut sorted = runs.clone();
    sorted.sort_by(f64::total_cmp);
    (sorted[1], runs)
}

fn accuracy(n: usize) {
    let mesh = TORUS.mesh(n, 0.35, 1).expect("torus");
    let exact = analytic_curvature_field(&mesh, &TORUS);
    let poly = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon).expect("fit");
    let so =
        shape_operator_curvature(&mesh, &ShapeOperatorParams::default(), Par::Rayon).expect("so");
    for (name, f) in [
        ("curvature.polynomial", &poly.field),
        ("curvature.shape_operator", &so.field),
    ] {
        let rel = |k: &[f64], t: &[f64]| {
            let v: Vec<f64> = (0..k.len())
                .filter(|&i| t[i].abs() > 1e-6)
                .map(|i| (k[i] - t[i]).abs() / t[i].abs())
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        println!(
            "{{\"accuracy\": \"{name}\", \"mesh\": \"irregular torus R=1 r=0.35 jitter=0.35\", \"n_vertices\": {}, \"k_max_mean_rel\": {:.6e}, \"k_min_mean_rel\": {:.6e}}}",
            mesh.n_vertices(),
            rel(&f.k_max, &exact.k_max),
            rel(&f.k_min, &exact.k_min)
        );
    }
}

fn main() {
    // `cargo bench` passes `--bench`; ignore flags we do not know.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().map(String::as_str) == Some("--make-torus") {
        let path = args.get(1).expect("--make-torus PATH N");
        let n: usize = args
            .get(2)
            .and_then(|s| s.parse().ok())
            .expect("--make-torus PATH N");
        let seed: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
        let mesh = TORUS.mesh(n, 0.35, seed).expect("torus");
        write_off(path, &mesh).expect("write torus");
        eprintln!("wrote {path}: {} vertices", mesh.n_vertices());
        return;
    }
    if args.first().map(String::as_str) == Some("--accuracy") {
        let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(80_000);
        accuracy(n);
        return;
    }
    for path in &args {
        let mesh = match read_off(path) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("skipping {e}");
                continue;
            }
        };
        let poly = |m: &TriMesh| {
            polynomial_curvature(m, &PolynomialParams::default(), Par::Rayon).expect("polynomial");
        };
        let so = |m: &TriMesh| {
            shape_operator_curvature(m, &ShapeOperatorParams::default(), Par::Rayon)
                .expect("shape operator");
        };
        let methods: [(&str, Job); 2] = [
            ("curvature.polynomial", &poly),
            ("curvature.shape_operator", &so),
        ];
        // CURVATURE_BENCH_ONLY=polynomial|shape_operator and CURVATURE_BENCH_THREADS=1|2 narrow
        // the run (for profiling).
        let only = std::env::var("CURVATURE_BENCH_ONLY").unwrap_or_default();
        let threads_only: Option<usize> = std::env::var("CURVATURE_BENCH_THREADS")
            .ok()
            .and_then(|t| t.parse().ok());
        for (name, f) in methods {
            if !name.contains(only.as_str()) {
                continue;
            }
            for threads in [1, 2] {
                if threads_only.is_some_and(|t| t != threads) {
                    continue;
                }
                let (median, runs) = median_us_per_vertex(&mesh, threads, f);
                println!(
                    "{{\"mesh\": \"{path}\", \"n_vertices\": {}, \"method\": \"{name}\", \"threads\": {threads}, \"us_per_vertex\": {median:.4}, \"runs\": {runs:.4?}}}",
                    mesh.n_vertices()
                );
            }
        }
    }
}
