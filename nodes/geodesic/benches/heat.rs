//! Heat-method benchmark: times the precomputation (operators and both factorisations) and
//! the per-source solve (one source: the first three calls after the construction, and the
//! steady state of back-to-back calls; a batch of 16 as one block), median of repeats, and
//! the error against the great-circle distance when the mesh is a unit sphere. Prints one
//! JSON object that `bench/geodesic/run.sh` compares with potpourri3d (bench/geodesic/peer.py).
//!
//! Usage: `cargo bench -p crestflow-nodes-geodesic --bench heat -- MESH [--repeats 5]
//! [--sphere LEVEL OUT.off]` — with `--sphere`, a unit icosphere is written to OUT.off and used.

use std::io::Write;
use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_geom::shapes::sphere;
use crestflow_geom::TriMesh;
use crestflow_nodes_geodesic::{HeatSolver, HeatSource};

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

/// The vertex of smallest `p · (1, 0.31, 0.17)` (the peer script's choice).
fn pick_source(mesh: &TriMesh) -> u32 {
    let mut best = (f64::INFINITY, 0u32);
    for (i, p) in mesh.positions.iter().enumerate() {
        let s = p[0] + 0.31 * p[1] + 0.17 * p[2];
        if s < best.0 {
            best = (s, i as u32);
        }
    }
    best.1
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut mesh_path = None;
    let mut repeats = 5usize;
    let mut sphere_level = None;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--repeats" => {
                repeats = args[i + 1].parse().expect("--repeats N");
                i += 2;
            }
            "--sphere" => {
                sphere_level = Some(args[i + 1].parse::<u32>().expect("--sphere LEVEL OUT.off"));
                mesh_path = Some(args[i + 2].clone());
                i += 3;
            }
            other => {
                mesh_path = Some(other.to_string());
                i += 1;
            }
        }
    }
    let path = mesh_path.expect("usage: heat MESH | --sphere LEVEL OUT.off");
    let mesh = if let Some(level) = sphere_level {
        let m = sphere(1.0, level).expect("sphere");
        write_off(&m, &path).expect("write sphere");
        m
    } else {
        load_mesh(&path, &LoadOptions::default())
            .expect("load mesh")
            .mesh
    };
    let par = Par::Rayon;
    let mut t_pre = Vec::new();
    let mut solver = None;
    for _ in 0..repeats {
        let t = Instant::now();
        solver = Some(HeatSolver::new(&mesh, 1.0, par).expect("heat solver"));
        t_pre.push(t.elapsed().as_secs_f64());
    }
    let solver = solver.expect("repeats > 0");
    let src = pick_source(&mesh);
    let single = HeatSource::vertices(&[src]);
    // The first three calls after the construction (a cold start: caches and the second
    // core not yet busy), then the steady state of back-to-back calls after fifty more.
    let mut t_cold = Vec::new();
    let mut t_one = Vec::new();
    let mut field = None;
    for k in 0..53 + repeats.max(3) {
        let t = Instant::now();
        field = Some(solver.distance(&single, par).expect("solve"));
        let dt = t.elapsed().as_secs_f64();
        if k < 3 {
            t_cold.push(dt);
        } else if k >= 53 {
            t_one.push(dt);
        }
    }
    let field = field.expect("repeats > 0");
    let n = mesh.n_vertices() as u32;
    let batch: Vec<HeatSource> = (0..16)
        .map(|k| HeatSource::vertices(&[(k * 7919) % n]))
        .collect();
    let mut t_batch = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        solver.distances(&batch, par).expect("batch");
        t_batch.push(t.elapsed().as_secs_f64() / 16.0);
    }
    let mut err = String::from("null");
    if sphere_level.is_some() {
        let p0 = mesh.positions[src as usize];
        let exact: Vec<f64> = mesh
            .positions
            .iter()
            .map(|p| {
                (p[0] * p0[0] + p[1] * p0[1] + p[2] * p0[2])
                    .clamp(-1.0, 1.0)
                    .acos()
            })
            .collect();
        let m = exact.iter().cloned().fold(0.0, f64::max);
        let (mut sum_abs, mut max_abs, mut sum_rel, mut cnt) = (0.0, 0.0f64, 0.0, 0usize);
        for (d, r) in field.values.iter().zip(&exact) {
            let e = (d - r).abs();
            sum_abs += e;
            max_abs = max_abs.max(e);
            if *r > 0.01 * m {
                sum_rel += e / r;
                cnt += 1;
            }
        }
        err = format!(
            "{{\"mean_abs_err_rel\": {:.6e}, \"max_abs_err_rel\": {:.6e}, \"mean_rel_err\": {:.6e}}}",
            sum_abs / exact.len() as f64 / m,
            max_abs / m,
            sum_rel / cnt as f64
        );
    }
    println!(
        "{{\"mesh\": \"{}\", \"n\": {}, \"threads\": {}, \"source\": {}, \"precompute\": {:.6}, \"solve_one\": {:.6}, \"solve_one_cold\": {:.6}, \"solve_batched_per_source\": {:.6}, \"error\": {}}}",
        std::fs::canonicalize(&path).map(|p| p.display().to_string()).unwrap_or(path.clone()),
        mesh.n_vertices(),
        rayon::current_num_threads(),
        src,
        median(t_pre),
        median(t_one),
        median(t_cold),
        median(t_batch),
        err
    );
}
