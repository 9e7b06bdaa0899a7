//! `scale.conform` on real meshes, for `bench/scale/run.sh`.
//!
//!   cargo bench -p crestflow-nodes-scale --bench scale -- MESH... [--scales 0.5,1,2] [--highs]
//!
//! `--highs` runs the exact selection with HiGHS instead of microlp (build with
//! `--features highs`).
//! For each mesh: principal curvatures (`curvature.polynomial`, 2 rings) and ridges
//! (`ridges.trace`, min_strength 1.0 as in graphs/scale-remesh.ron), then for each scale
//! (percent of the bounding-box diagonal) `scale.conform` with the exact selection and with the
//! greedy baseline, each timed (median of 3 runs, rayon pool) and checked with `scale.check`.
//! Prints one JSON line per mesh and scale.

use std::time::Instant;

use crestflow_flow::Par;
use crestflow_geom::io::{load_mesh, LoadOptions};
use crestflow_nodes_curvature::{polynomial_curvature, PolynomialParams};
use crestflow_nodes_ridges::{trace, TraceParams};
use crestflow_nodes_scale::{check, conform, CheckParams, ConformOutput, ConformParams, Solver};

fn timed(f: impl Fn() -> ConformOutput) -> (ConformOutput, f64) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..3 {
        let t = Instant::now();
        out = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    (out.expect("three runs"), times[1])
}

fn main() {
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut scales = vec![0.5, 1.0, 2.0];
    if let Some(i) = args.iter().position(|a| a == "--scales") {
        if i + 1 < args.len() {
            scales = args[i + 1]
                .split(',')
                .filter_map(|t| t.parse().ok())
                .collect();
            args.drain(i..i + 2);
        }
    }
    let solver = match args.iter().position(|a| a == "--highs") {
        Some(i) => {
            args.remove(i);
            Solver::Highs
        }
        None => Solver::Ilp,
    };
    if args.is_empty() {
        eprintln!("usage: scale MESH... [--scales 0.5,1,2] [--highs]");
        std::process::exit(2);
    }
    for path in &args {
        let mesh = match load_mesh(path, &LoadOptions::default()) {
            Ok(m) => m.mesh,
            Err(e) => {
                eprintln!("{path}: {e}");
                std::process::exit(1);
            }
        };
        let stem = std::path::Path::new(path)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let t = Instant::now();
        let curv = polynomial_curvature(&mesh, &PolynomialParams::default(), Par::Rayon)
            .expect("curvature");
        let ridges = trace(
            &mesh,
            &curv.field,
            &TraceParams {
                min_strength: 1.0,
                ..Default::default()
            },
            Par::Rayon,
        )
        .expect("ridges");
        let prep = t.elapsed().as_secs_f64();
        for &pct in &scales {
            let params = ConformParams {
                scale: pct / 100.0,
                solver,
                ..Default::default()
            };
            let greedy_params = ConformParams {
                solver: Solver::Greedy,
                ..params.clone()
            };
            let (ilp, t_ilp) =
                timed(|| conform(&ridges.network, &mesh, &params, Par::Rayon).expect("conform"));
            let (gr, t_gr) = timed(|| {
                conform(&ridges.network, &mesh, &greedy_params, Par::Rayon).expect("conform")
            });
            let seq = conform(&ridges.network, &mesh, &params, Par::Seq).expect("conform");
            let cp = CheckParams {
                scale: pct / 100.0,
                ..Default::default()
            };
            let c_ilp = check(&ilp.network, &mesh, &cp, Par::Rayon).expect("check");
            let c_gr = check(&gr.network, &mesh, &cp, Par::Rayon).expect("check");
            let c_in = check(&ridges.network, &mesh, &cp, Par::Rayon).expect("check");
            let s = &ilp.stats;
            println!(
                "{{\"mesh\":\"{stem}\",\"solver\":\"{solver:?}\",\"scale_pct\":{pct},\"vertices\":{},\"prep_s\":{prep:.3},\
                 \"input_edges\":{},\"input_violations\":{},\"resampled_edges\":{},\
                 \"conflicts\":{},\"vertex_conflicts\":{},\"components\":{},\
                 \"largest_component\":{},\"objective_ilp\":{:.3},\"objective_greedy\":{:.3},\
                 \"kept_ilp\":{},\"kept_greedy\":{},\"output_edges\":{},\"output_edges_greedy\":{},\
                 \"iterations\":{},\"converged\":{},\"repaired\":{},\"repaired_greedy\":{},\
                 \"violations\":{},\"violations_greedy\":{},\"seq_equals_par\":{},\
                 \"objective_components_ilp\":{:.3},\"objective_components_greedy\":{:.3},\
                 \"unproven\":{},\"out_of_time\":{},\"conform_s\":{t_ilp:.4},\"conform_greedy_s\":{t_gr:.4}}}",
                mesh.n_vertices(),
                s.input_edges,
                c_in.violations(),
                s.resampled_edges,
                s.first_edge_conflicts,
                s.first_vertex_conflicts,
                s.first_components,
                s.first_largest_component,
                s.first_objective,
                s.greedy_objective,
                s.first_kept,
                s.greedy_kept,
                s.output_edges,
                gr.stats.output_edges,
                s.iterations,
                s.converged,
                s.repaired_edges,
                gr.stats.repaired_edges,
                c_ilp.violations(),
                c_gr.violations(),
                seq == ilp,
                s.first_objective_components,
                s.greedy_objective_components,
                s.unproven_components,
                s.out_of_time_components,
            );
        }
    }
}
