//! `graphs/symmetry.ron` runs as shipped (with this family and the ones it uses registered)
//! on the turbine, whose blades repeat under rotation.

use std::path::PathBuf;

use crestflow_flow::{load_file, run, Registry, RunOptions};

#[test]
fn symmetry_graph_runs_on_the_turbine() {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_ridges::register(&mut reg);
    crestflow_nodes_render::register(&mut reg);
    crestflow_nodes_symmetry::register(&mut reg);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let graph = root.join("graphs/symmetry.ron");
    let out = std::env::temp_dir().join(format!("crestflow-symmetry-graph-{}", std::process::id()));
    let plan = load_file(
        &graph,
        &reg,
        &[("out".to_string(), out.display().to_string())],
    )
    .unwrap_or_else(|e| panic!("graph does not load: {e:?}"));
    let opts = RunOptions {
        use_cache: false,
        cache_dir: Some(out.join("cache")),
        ..Default::default()
    };
    run(&plan, &opts).unwrap_or_else(|e| panic!("graph does not run: {e:?}"));
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json written");
    let json: serde_json::Value = serde_json::from_str(&text).expect("report is JSON");
    eprintln!("{json}");
    let n = json["orbits"].as_f64().expect("orbits count");
    assert!(n >= 1.0, "{json}");
    assert_eq!(json["orbit_0.kind"], "rotation", "{json}");
    assert!(out.join("render.png").exists());
    let ply = std::fs::read_to_string(out.join("orbit_curves.ply")).expect("orbit PLY written");
    assert!(ply.starts_with("ply\n") && ply.contains("property int group"));
    assert!(out.join("cluster_curves.ply").exists());
    let _ = std::fs::remove_dir_all(&out);
}
