//! The feature-curve pipeline on one mesh through the pure functions: load, polynomial
//! curvature, ridge tracing, render. Prints counts, lengths and timings.
//!
//! ```text
//! cargo run --release -p crestflow-nodes-ridges --example feature_curves -- \
//!     ../shared/data/meshes/cad/cgal_fandisk.off docs/fandisk.png az=30 el=20 up=Y
//! ```

use std::path::Path;
use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_render::{render, write_png, RenderParams, UpAxis};
use crestflow_nodes_ridges::{trace, TraceParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        return Err("usage: feature_curves MESH OUT.png [az=30] [el=20] [up=Y] [w=1024] [h=768] [threads=all|1] \
                    [strength=..] [cyclide=..] [length=..]"
            .into());
    }
    // Options as key=value after the two paths.
    let opt = |key: &str| {
        args[2..]
            .iter()
            .find_map(|a| a.strip_prefix(&format!("{key}=")).map(str::to_string))
    };
    let num = |key: &str, default: f64| -> Result<f64, Box<dyn std::error::Error>> {
        Ok(match opt(key) {
            Some(s) => s.parse()?,
            None => default,
        })
    };
    let up = match opt("up").as_deref() {
        Some("X") => UpAxis::X,
        Some("Z") => UpAxis::Z,
        _ => UpAxis::Y,
    };
    let par = if opt("threads").as_deref() == Some("1") {
        Par::Seq
    } else {
        Par::Rayon
    };
    let defaults = TraceParams::default();
    let trace_params = TraceParams {
        min_strength: num("strength", defaults.min_strength)?,
        min_cyclideness: num("cyclide", defaults.min_cyclideness)?,
        min_length: num("length", defaults.min_length)?,
        ..defaults
    };

    let t0 = Instant::now();
    let loaded = load_mesh(&args[0], &LoadOptions::default())?;
    let mesh = loaded.mesh;
    let t_load = t0.elapsed();
    let nv = mesh.n_vertices() as f64;

    let t1 = Instant::now();
    let curv = polynomial_curvature(&mesh, &PolynomialParams::default(), par)?;
    let t_curv = t1.elapsed();

    let t2 = Instant::now();
    let traced = trace(&mesh, &curv.field, &trace_params, par)?;
    let t_trace = t2.elapsed();

    let t3 = Instant::now();
    let params = RenderParams {
        azimuth: num("az", 30.0)?,
        elevation: num("el", 20.0)?,
        up,
        width: num("w", 1024.0)? as u32,
        height: num("h", 768.0)? as u32,
        ..RenderParams::default()
    };
    let img = render(
        &mesh,
        Some(&traced.network),
        Some(&curv.field),
        &params,
        Par::Rayon,
    )?;
    write_png(&img.image, Path::new(&args[1]))?;
    let t_render = t3.elapsed();

    let s = &traced.stats;
    println!(
        "{}: {} vertices; curves {} (ridges {}, ravines {}), total length {:.4} (bbox diagonal {:.4}); \
         load {:.1} ms, curvature {:.1} ms ({:.2} us/vertex), trace {:.1} ms ({:.2} us/vertex), render {:.1} ms",
        args[0],
        mesh.n_vertices(),
        s.ridges + s.ravines,
        s.ridges,
        s.ravines,
        s.ridge_length + s.ravine_length,
        mesh.bbox_diagonal(),
        t_load.as_secs_f64() * 1e3,
        t_curv.as_secs_f64() * 1e3,
        t_curv.as_secs_f64() * 1e6 / nv,
        t_trace.as_secs_f64() * 1e3,
        t_trace.as_secs_f64() * 1e6 / nv,
        t_render.as_secs_f64() * 1e3,
    );
    println!("  {s:?}");
    Ok(())
}
