//! `graphs/remesh.ron` runs as shipped (with the families it uses registered) on the fandisk:
//! ridges constrain the remeshing, and the quality report has the figures the issue asks for.
//! Also pipelines that fuzz runs (`bench/fuzz/run.py`) found to break the remesh.

use std::path::{Path, PathBuf};

use crestflow_flow::{load_file, run, Registry, RunOptions};

/// Runs shipped graph `name` with every node family it may use registered, `out` set to a
/// fresh temporary folder and the given parameters; returns that folder.
fn run_shipped(name: &str, sets: &[(&str, &str)]) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = std::env::temp_dir().join(format!(
        "crestflow-{}-{}",
        name.trim_end_matches(".ron"),
        std::process::id()
    ));
    run_graph(&root.join("graphs").join(name), &out, sets);
    out
}

/// Runs the graph file `graph` with every node family it may use registered, its `out`
/// parameter set to `out` and the given parameters, without the cache.
fn run_graph(graph: &Path, out: &Path, sets: &[(&str, &str)]) {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_ridges::register(&mut reg);
    crestflow_nodes_render::register(&mut reg);
    crestflow_nodes_eval::register(&mut reg);
    crestflow_nodes_remesh::register(&mut reg);
    crestflow_nodes_scale::register(&mut reg);
    let mut params = vec![("out".to_string(), out.display().to_string())];
    params.extend(sets.iter().map(|(k, v)| (k.to_string(), v.to_string())));
    let name = graph.display();
    let plan =
        load_file(graph, &reg, &params).unwrap_or_else(|e| panic!("{name} does not load: {e:?}"));
    let opts = RunOptions {
        use_cache: false,
        cache_dir: Some(out.join("cache")),
        ..Default::default()
    };
    run(&plan, &opts).unwrap_or_else(|e| panic!("{name} does not run: {e:?}"));
}

/// Report `name` written by a graph into `out`.
fn read(out: &Path, name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(out.join(name)).expect("report written");
    serde_json::from_str(&text).expect("report is JSON")
}

#[test]
fn remesh_graph_runs_on_the_fandisk() {
    let out = run_shipped("remesh.ron", &[("scale", "0.02")]);
    let read = |name: &str| read(&out, name);
    let q = read("quality.json");
    let r = read("remesh.json");
    eprintln!("{q}\n{r}");
    assert!(
        r["feature_edges_from_curves"].as_f64().unwrap() > 0.0,
        "{r}"
    );
    assert!(r["feature_edges_out"].as_f64().unwrap() > 0.0, "{r}");
    let h = q["hausdorff_rel"].as_f64().unwrap();
    // Chord error at 2 % of the diagonal stays a fraction of the target length.
    assert!(h > 0.0 && h < 0.25 * 0.02, "{q}");
    assert!(q["min_angle_deg"].as_f64().unwrap() > 0.0);
    assert!(q["valence6_share"].as_f64().unwrap() > 0.5, "{q}");
    assert!(out.join("render.png").exists());
    assert!(out.join("mesh.ply").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// The goals of the remeshing (issue 7: min angle ≥ 30°), and what this graph gives on the
/// fandisk at 2 % (valence 6 0.804, Hausdorff 0.00447 of the diagonal when measured), with
/// room for other rounding: the unconstrained remesh is 0.008–0.011 from the input, so a
/// Hausdorff below 0.006 means the creases are followed.
const MIN_ANGLE_CAD: f64 = 30.0;
const VALENCE6_CAD: f64 = 0.78;
const HAUSDORFF_CAD: f64 = 0.006;

/// `graphs/scale-remesh-cad.ron`: the sharp edges of the fandisk, made scale
/// conforming at 2 %, constrain the remeshing. The network passes the check, and the remesh
/// keeps well-shaped triangles along it while following the part's creases.
#[test]
fn scale_remesh_cad_graph_runs_on_the_fandisk() {
    let out = run_shipped("scale-remesh-cad.ron", &[]);
    let read = |name: &str| read(&out, name);
    let (s, c, k, q) = (
        read("sharp.json"),
        read("conform.json"),
        read("check.json"),
        read("quality.json"),
    );
    eprintln!("{s}\n{c}\n{k}\n{q}");
    // The small fandisk's creases are clean lines: nothing below 2 % to prune.
    assert_eq!(s["sharp_edges"].as_f64(), Some(722.0), "{s}");
    assert_eq!(s["pruned_edges"].as_f64(), Some(0.0), "{s}");
    assert_eq!(k["violations"].as_f64(), Some(0.0), "{k}");
    assert!(c["output_edges"].as_f64().unwrap() > 0.0, "{c}");
    let min_angle = q["min_angle_deg"].as_f64().unwrap();
    assert!(min_angle >= MIN_ANGLE_CAD, "{q}");
    assert!(q["valence6_share"].as_f64().unwrap() > VALENCE6_CAD, "{q}");
    let h = q["hausdorff_rel"].as_f64().unwrap();
    assert!(h > 0.0 && h < HAUSDORFF_CAD, "{q}");
    assert!(out.join("render.png").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// `relaxation` takes `Centroids` or `Lloyd`; anything else is a parameter error on its line.
#[test]
fn relaxation_names_are_checked_when_the_graph_loads() {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_remesh::register(&mut reg);
    let dir = std::env::temp_dir().join(format!("crestflow-relaxation-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let graph = |relaxation: &str| {
        format!(
            "Graph(nodes: {{\n  \"load\": (kind: \"io.load_mesh\", params: (path: \"m.off\")),\n  \
             \"remesh\": (kind: \"remesh.isotropic\",\n    params: (relaxation: {relaxation}),\n    \
             inputs: {{ \"mesh\": \"load.mesh\" }}),\n}})\n"
        )
    };
    let good = dir.join("good.ron");
    std::fs::write(&good, graph("Lloyd")).unwrap();
    assert!(load_file(&good, &reg, &[]).is_ok());
    let bad = dir.join("bad.ron");
    std::fs::write(&bad, graph("Voronoi")).unwrap();
    let e = match load_file(&bad, &reg, &[]) {
        Ok(_) => panic!("a graph with `relaxation: Voronoi` loaded"),
        Err(e) => e,
    };
    assert_eq!(e.diagnostics.len(), 1, "{e:?}");
    let d = &e.diagnostics[0];
    assert_eq!(d.line, 4, "{d:?}");
    assert!(d.message.contains("Voronoi"), "{d:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ridges of `data/cgal_fandisk.off` (`ridges.trace` at min_strength 0.5) conformed at 0.5 %
/// and remeshed with `remesh` (the parameters of `remesh.isotropic`, RON): the quality report
/// of the remesh. The pipeline of the fuzz runs (`bench/fuzz/run.py`).
fn fandisk_ridges_remeshed(name: &str, remesh: &str) -> serde_json::Value {
    let out = std::env::temp_dir().join(format!("crestflow-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&out).unwrap();
    let graph = out.join("g.ron");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mesh = root.join("data/cgal_fandisk.off");
    let text = format!(
        r#"Graph(params: {{"mesh": "{}", "out": "out"}}, nodes: {{
 "load": (kind: "io.load_mesh", params: (path: "$mesh")),
 "curv": (kind: "curvature.polynomial", params: (rings: 2, degree: 4),
          inputs: {{"mesh": "load.mesh"}}),
 "ridges": (kind: "ridges.trace", params: (min_strength: 0.5),
            inputs: {{"mesh": "load.mesh", "curvature": "curv.field"}}),
 "conform": (kind: "scale.conform", params: (scale: 0.005),
             inputs: {{"curves": "ridges.network", "mesh": "load.mesh"}}),
 "remesh": (kind: "remesh.isotropic", params: ({remesh}),
            inputs: {{"mesh": "load.mesh", "curves": "conform.network"}}),
 "quality": (kind: "eval.mesh_quality", inputs: {{"mesh": "remesh.mesh"}}),
 "save": (kind: "io.save_report", params: (path: "$out/quality.json"),
          inputs: {{"report": "quality.report"}}),
}})"#,
        mesh.display()
    );
    std::fs::write(&graph, text).unwrap();
    run_graph(&graph, &out, &[]);
    let q = read(&out, "quality.json");
    let _ = std::fs::remove_dir_all(&out);
    q
}

#[test]
fn chain_vertices_between_two_corners_at_one_end_stay_off_them() {
    // A target of twice the diagonal, a corner wherever a feature turns by more than 1° and
    // no relaxation: nearly every feature vertex is a corner, and a chain vertex is left
    // between two corners that both stand for the same end of its chain (one of them is not
    // an end of it). The final slide to the middle between them put it on top of one: an
    // edge of length 0 and two triangles of 0° (a fuzz run).
    let q = fandisk_ridges_remeshed(
        "two-corners",
        "target: 2.0, corner_angle_deg: 1.0, smoothing_steps: 0, boundary_tolerance: 0.0",
    );
    let lo = q["min_angle_deg"].as_f64().unwrap();
    assert!(lo > 1.0, "smallest angle {lo}°");
}
