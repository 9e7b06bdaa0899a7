//! Remeshing speed and output for the peer comparison (`bench/remesh/run.sh`).
//!
//!   cargo bench -p crestflow-nodes-remesh --bench remesh -- OUT_DIR MESH... [--targets 1,2]
//!       [--feature-tolerance 0.002] [--boundary-tolerance 0.25] [--iterations 10] [--smoothing-steps 5]
//!       [--feature-grading 0] [--conforming [--sharp-angle 30]] [--lloyd] [--repeats 3]
//!       [--repair] [--special-long-edges] [--conform-ratio 1] [--save-curves]
//!
//! With `--conforming` (method `crestflow_conforming`) the features are not every sharp edge
//! but the scale-conforming subset of them: `remesh.sharp_edges` pruned at the target,
//! `scale.conform` at r_min = the target, then `remesh.isotropic` constrained by that network
//! only (its own sharp-edge detection off); the times cover all three steps. `--sharp-angle A`
//! sets the dihedral angle above which an edge is sharp there (dense networks at 5°–15°; the
//! method's name then ends in `_A`). With `--lloyd`
//! the remeshing runs with `relaxation: Lloyd` and the method's name ends in `_lloyd`; with
//! `--special-long-edges`, `scale.conform` keeps special long edges and the name ends in
//! `_long`. `--conform-ratio F` prunes and conforms at r_min = F × the target instead (the
//! remeshing target stays; the name ends in `_rminF`).
//! `--repair` loads the meshes as `io.load_mesh` does with `repair: true` (non-manifold edges
//! and vertices split, faces oriented coherently; `bench/remesh/corpus.sh`). With
//! `--conforming`, `--save-curves` also writes the scale-conforming network beside the output
//! (`….curves.obj`, for `bench/remesh/valence_by_distance.py`).
//!
//! For each mesh and target (percent of the bounding-box diagonal): the median of 3 runs
//! (`--repeats N`: N runs, e.g. for a profiler) of
//! `remesh.isotropic` (default parameters: 10 rounds, sharp edges > 30° kept) at 1 thread
//! (`Par::Seq`) and on the rayon pool, the remeshed mesh written to OUT_DIR as OBJ, and one
//! JSON line with the timings and the node's report.

use std::time::Instant;

use crestflow_flow::{Par, ReportValue};
use crestflow_geom::io::{load_mesh, save_curves_obj, save_mesh_obj, LoadOptions};
use crestflow_nodes_remesh::{
    isotropic, sharp_edges, IsotropicParams, Relaxation, SharpEdgesParams,
};
use crestflow_nodes_scale::{conform, ConformParams};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Removes `flag` and the value after it from `args`; the value, when it parses.
fn take_value<T: std::str::FromStr>(args: &mut Vec<String>, flag: &str) -> Option<T> {
    let i = args.iter().position(|a| a == flag)?;
    let value = args.get(i + 1).and_then(|t| t.parse().ok());
    args.drain(i..(i + 2).min(args.len()));
    value
}

fn main() {
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut targets = vec![1.0, 2.0];
    let d = IsotropicParams::default();
    let feature_tolerance =
        take_value(&mut args, "--feature-tolerance").unwrap_or(d.feature_tolerance);
    let boundary_tolerance =
        take_value(&mut args, "--boundary-tolerance").unwrap_or(d.boundary_tolerance);
    let iterations = take_value(&mut args, "--iterations").unwrap_or(d.iterations);
    let feature_grading = take_value(&mut args, "--feature-grading").unwrap_or(d.feature_grading);
    let sharp_angle: Option<f64> = take_value(&mut args, "--sharp-angle");
    let smoothing_steps = take_value(&mut args, "--smoothing-steps").unwrap_or(d.smoothing_steps);
    let repeats = take_value(&mut args, "--repeats").unwrap_or(3usize).max(1);
    let conform_ratio: f64 = take_value(&mut args, "--conform-ratio").unwrap_or(1.0);
    let conforming = args.iter().any(|a| a == "--conforming");
    args.retain(|a| a != "--conforming");
    let lloyd = args.iter().any(|a| a == "--lloyd");
    args.retain(|a| a != "--lloyd");
    let repair = args.iter().any(|a| a == "--repair");
    args.retain(|a| a != "--repair");
    let save_curves = args.iter().any(|a| a == "--save-curves");
    args.retain(|a| a != "--save-curves");
    let special_long = args.iter().any(|a| a == "--special-long-edges");
    args.retain(|a| a != "--special-long-edges");
    if let Some(list) = take_value::<String>(&mut args, "--targets") {
        targets = list.split(',').filter_map(|t| t.parse().ok()).collect();
    }
    if args.len() < 2 {
        eprintln!("usage: remesh OUT_DIR MESH... [--targets 1,2]");
        std::process::exit(2);
    }
    let out_dir = std::path::PathBuf::from(&args[0]);
    if let Err(e) = std::fs::create_dir_all(&out_dir) {
        eprintln!("cannot create {}: {e}", out_dir.display());
        std::process::exit(1);
    }
    for path in &args[1..] {
        let options = LoadOptions {
            repair,
            ..Default::default()
        };
        let mesh = match load_mesh(path, &options) {
            Ok(m) => m.mesh,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let stem = std::path::Path::new(path)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        for &pct in &targets {
            let params = IsotropicParams {
                target: pct / 100.0,
                feature_tolerance,
                boundary_tolerance,
                iterations,
                smoothing_steps,
                feature_grading,
                sharp_edges: !conforming,
                relaxation: if lloyd {
                    Relaxation::Lloyd
                } else {
                    Relaxation::Centroids
                },
                ..Default::default()
            };
            let sharp_params = SharpEdgesParams {
                prune_scale: conform_ratio * pct / 100.0,
                angle_deg: sharp_angle.unwrap_or(SharpEdgesParams::default().angle_deg),
                ..Default::default()
            };
            let conform_params = ConformParams {
                scale: conform_ratio * pct / 100.0,
                special_long_edges: special_long,
                ..Default::default()
            };
            let mut times = Vec::new();
            let mut out = None;
            let mut network = None;
            for par in [Par::Seq, Par::Rayon] {
                let mut runs = Vec::new();
                for _ in 0..repeats {
                    let t = Instant::now();
                    let r = if conforming {
                        sharp_edges(&mesh, &sharp_params)
                            .map_err(|e| e.to_string())
                            .and_then(|s| {
                                conform(&s.network, &mesh, &conform_params, par)
                                    .map_err(|e| e.to_string())
                            })
                            .and_then(|c| {
                                let r = isotropic(&mesh, Some(&c.network), &params, par)
                                    .map_err(|e| e.to_string());
                                network = Some(c.network);
                                r
                            })
                    } else {
                        isotropic(&mesh, None, &params, par).map_err(|e| e.to_string())
                    };
                    runs.push(t.elapsed().as_secs_f64());
                    match r {
                        Ok(o) => out = Some(o),
                        Err(e) => {
                            eprintln!("{path}: {e}");
                            std::process::exit(1);
                        }
                    }
                }
                times.push(median(runs));
            }
            let Some(out) = out else { continue };
            // A graded run is a method of its own in the comparison.
            let method = if conforming {
                "crestflow_conforming"
            } else if feature_grading > 0.0 {
                "crestflow_graded"
            } else {
                "crestflow"
            };
            let method = match sharp_angle {
                Some(a) if conforming => format!("{method}_{a}"),
                _ => method.to_string(),
            };
            let method = if lloyd {
                format!("{method}_lloyd")
            } else {
                method
            };
            let method = if special_long && conforming {
                format!("{method}_long")
            } else {
                method
            };
            let method = if conforming && conform_ratio != 1.0 {
                format!("{method}_rmin{conform_ratio}")
            } else {
                method
            };
            let file = out_dir.join(format!("{stem}.{method}_{pct}pct.obj"));
            if let Err(e) = save_mesh_obj(&file, &out.mesh, None) {
                eprintln!("{e}");
                std::process::exit(1);
            }
            if let (true, Some(net)) = (save_curves, &network) {
                let curves = out_dir.join(format!("{stem}.{method}_{pct}pct.curves.obj"));
                if let Err(e) = save_curves_obj(&curves, net) {
                    eprintln!("{e}");
                    std::process::exit(1);
                }
            }
            let report: Vec<String> = out
                .report
                .values
                .iter()
                .filter_map(|(k, v)| match v {
                    ReportValue::Num(x) => Some(format!("\"{k}\": {x}")),
                    ReportValue::Text(_) => None,
                })
                .collect();
            println!(
                "{{\"method\": \"{method}\", \"mesh\": \"{path}\", \"target_pct\": {pct}, \
                 \"time_1thread_s\": {:.6}, \"time_pool_s\": {:.6}, \
                 \"threads\": {}, \"output\": \"{}\", {}}}",
                times[0],
                times[1],
                rayon_threads(),
                file.display(),
                report.join(", ")
            );
        }
    }
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}
