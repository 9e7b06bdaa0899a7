//! `graphs/co-completion.ron` runs as shipped (with this family and the ones it uses
//! registered) and reports the keys its header promises.
//!
//! On cgal_fandisk (6.5k vertices, a few seconds); the shipped default (the turbine) is
//! ignored: run it with
//!   cargo test -p crestflow-nodes-selection --test graph -- --ignored --nocapture

use std::path::PathBuf;

use crestflow_flow::{load_file, run, Registry, RunOptions};

fn run_graph(mesh: Option<&str>, tag: &str) -> serde_json::Value {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_ridges::register(&mut reg);
    crestflow_nodes_render::register(&mut reg);
    crestflow_nodes_symmetry::register(&mut reg);
    crestflow_nodes_selection::register(&mut reg);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let graph = root.join("graphs/co-completion.ron");
    let out = std::env::temp_dir().join(format!(
        "crestflow-co-completion-{tag}-{}",
        std::process::id()
    ));
    // Overrides are RON text: quoted strings.
    let mut set = vec![("out".to_string(), format!("\"{}\"", out.display()))];
    if let Some(m) = mesh {
        set.push((
            "mesh".to_string(),
            format!("\"{}\"", root.join("..").join(m).display()),
        ));
    }
    let plan =
        load_file(&graph, &reg, &set).unwrap_or_else(|e| panic!("graph does not load: {e:?}"));
    let opts = RunOptions {
        use_cache: false,
        cache_dir: Some(out.join("cache")),
        ..Default::default()
    };
    let t = std::time::Instant::now();
    run(&plan, &opts).unwrap_or_else(|e| panic!("graph does not run: {e:?}"));
    eprintln!("{tag}: graph ran in {:.1} s", t.elapsed().as_secs_f64());
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json written");
    let json: serde_json::Value = serde_json::from_str(&text).expect("report is JSON");
    let model: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("model.json")).expect("model.json written"),
    )
    .expect("model report is JSON");
    for key in [
        "curves_in",
        "curves_out",
        "templates",
        "noise_curves_removed",
    ] {
        assert!(json[key].as_f64().is_some(), "{key} missing: {json}");
    }
    for f in [
        "completed.png",
        "components.png",
        "input.png",
        "completed.ply",
        "templates.ply",
        "components.ply",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    eprintln!("{tag} report: {json}");
    eprintln!(
        "{tag} model: candidates {} kept {} assigned {} null {}",
        model["candidates"], model["kept"], model["curves_assigned"], model["curves_null"]
    );
    if let Some(obj) = model.as_object() {
        for (k, v) in obj {
            if k.starts_with("kept_") || k.starts_with("step_") {
                eprintln!("{tag} model {k} = {v}");
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    json
}

#[test]
fn co_completion_graph_runs_on_fandisk() {
    let json = run_graph(Some("shared/data/meshes/cad/cgal_fandisk.off"), "fandisk");
    let n_in = json["curves_in"].as_f64().unwrap();
    let removed = json["noise_curves_removed"].as_f64().unwrap();
    assert!(n_in > 0.0);
    assert!(removed <= n_in);
}

#[test]
#[ignore]
fn co_completion_graph_runs_as_shipped() {
    let json = run_graph(None, "default");
    assert!(json["curves_in"].as_f64().unwrap() > 0.0);
}
