//! Eigenbasis benchmark: times `spectral.laplacian` and `spectral.eigenbasis` on a mesh for
//! several k (median of repeats) and prints one JSON object, which
//! `bench/spectral/run.sh` compares with scipy's `eigsh` (bench/spectral/peer_scipy.py).
//!
//! Usage: `cargo bench -p crestflow-nodes-spectral --bench eigen -- MESH [--ks 20,60,120]
//! [--repeats 3] [--block B] [--subspace M] [--tol T] [--inner-shift F] [--torus N OUT.off]` — with `--torus`, a jittered torus of about N
//! vertices is generated (crestflow_geom::shapes), written to OUT.off and used as MESH.

use std::io::Write;
use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::shapes::AnalyticShape;
use crestflow_geom::TriMesh;
use crestflow_nodes_spectral::{eigenbasis, laplacian, EigenbasisParams, LaplacianParams};

fn write_off(mesh: &TriMesh, path: &str) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "OFF\n{} {} 0", mesh.n_vertices(), mesh.n_faces())?;
    for p in &mesh.positions {
        writeln!(f, "{:.17e} {:.17e} {:.17e}", p[0], p[1], p[2])?;
    }
    for t in &mesh.triangles {
        writeln!(f, "3 {} {} {}", t[0], t[1], t[2])?;
    }
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut mesh_path = None;
    let mut ks = vec![20usize, 60, 120];
    let mut repeats = 3usize;
    let mut torus: Option<(usize, String)> = None;
    let mut base = EigenbasisParams::default();
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--ks" => {
                ks = args[i + 1]
                    .split(',')
                    .map(|s| s.parse())
                    .collect::<Result<_, _>>()?;
                i += 2;
            }
            "--repeats" => {
                repeats = args[i + 1].parse()?;
                i += 2;
            }
            "--block" => {
                base.block = args[i + 1].parse()?;
                i += 2;
            }
            "--subspace" => {
                base.subspace = args[i + 1].parse()?;
                i += 2;
            }
            "--tol" => {
                base.tol = args[i + 1].parse()?;
                i += 2;
            }
            "--inner-shift" => {
                base.inner_shift = args[i + 1].parse()?;
                i += 2;
            }
            "--torus" => {
                torus = Some((args[i + 1].parse()?, args[i + 2].clone()));
                i += 3;
            }
            other => {
                mesh_path = Some(other.to_string());
                i += 1;
            }
        }
    }
    let mesh = if let Some((n, out)) = &torus {
        let shape = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        let m = shape.mesh(*n, 0.2, 1)?;
        write_off(&m, out)?;
        mesh_path = Some(out.clone());
        m
    } else {
        let path = mesh_path.clone().ok_or("usage: eigen MESH [--ks ..]")?;
        crestflow_geom::io::load_mesh(&path, &Default::default())?.mesh
    };
    let t0 = Instant::now();
    let op = laplacian(&mesh, &LaplacianParams::default(), Par::Rayon)?;
    let build = t0.elapsed().as_secs_f64();
    let mut runs = Vec::new();
    for &k in &ks {
        let params = EigenbasisParams { k, ..base.clone() };
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..repeats {
            let t = Instant::now();
            let b = eigenbasis(&op, &params, Par::Rayon)?;
            times.push(t.elapsed().as_secs_f64());
            last = Some(b);
        }
        let b = last.ok_or("no run")?;
        let values: Vec<String> = b.values.iter().map(|v| format!("{v:.17e}")).collect();
        runs.push(format!(
            "\"k{k}\": {{\"time\": {:.6}, \"times\": {:?}, \"solves\": {}, \"max_rel_residual\": {:e}, \"max_M_orthonormality_err\": {:e}, \"values\": [{}]}}",
            median(times.clone()),
            times,
            b.solves,
            b.max_residual,
            b.max_orthonormality_error,
            values.join(", ")
        ));
    }
    println!(
        "{{\"mesh\": {:?}, \"n\": {}, \"faces\": {}, \"threads\": {}, \"build_time\": {:.6}, {}}}",
        mesh_path.unwrap_or_default(),
        mesh.n_vertices(),
        mesh.n_faces(),
        rayon::current_num_threads(),
        build,
        runs.join(", ")
    );
    Ok(())
}
