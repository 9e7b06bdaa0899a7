//! `graphs/curve-matching.ron` runs as shipped (with the families it uses registered) on two
//! cat poses and reports the accuracies the issue asks for.

use std::path::PathBuf;

use crestflow_flow::{load_file, run, Registry, RunOptions};

#[test]
fn curve_matching_graph_runs_on_two_cat_poses() {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_ridges::register(&mut reg);
    crestflow_nodes_descriptors::register(&mut reg);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let graph = root.join("graphs/curve-matching.ron");
    let out = std::env::temp_dir().join(format!("crestflow-curve-matching-{}", std::process::id()));
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
    let text = std::fs::read_to_string(out.join("report.json")).expect("report written");
    let r: serde_json::Value = serde_json::from_str(&text).expect("report is JSON");
    eprintln!("{r}");
    let num = |k: &str| {
        r[k].as_f64()
            .unwrap_or_else(|| panic!("{k} missing in {r}"))
    };
    // Same figures as tests/cat_poses.rs computes without the engine (cat-reference ->
    // cat-01): GICS Hungarian well above chance (1/79).
    assert!(num("accuracy.gics.hungarian") > 0.5);
    for k in [
        "accuracy.gics.nearest",
        "accuracy.hks.nearest",
        "accuracy.hks.hungarian",
    ] {
        let v = num(k);
        assert!((0.0..=1.0).contains(&v), "{k} = {v}");
    }
    assert!(out.join("roc_gics.png").exists());
    assert!(out.join("roc_hks.png").exists());
    // Set KEEP_OUT=1 to keep the report and ROC pictures for inspection.
    if std::env::var_os("KEEP_OUT").is_none() {
        let _ = std::fs::remove_dir_all(&out);
    }
}
