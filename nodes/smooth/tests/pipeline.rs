//! `graphs/smooth.ron` through the engine on the bundled fandisk.

use std::path::Path;

use crestflow_flow::{load_file, run, Registry, Report, RunOptions};
use crestflow_geom::io::{load_mesh, LoadOptions};

fn registry() -> Registry {
    let mut reg = Registry::new();
    crestflow_nodes_io::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_ridges::register(&mut reg);
    crestflow_nodes_smooth::register(&mut reg);
    crestflow_nodes_eval::register(&mut reg);
    crestflow_nodes_render::register(&mut reg);
    reg
}

#[test]
fn smooth_graph_runs_on_the_fandisk() {
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../graphs/smooth.ron");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let reg = registry();
    let plan = load_file(
        &graph,
        &reg,
        &[("out".to_string(), out.display().to_string())],
    )
    .unwrap();
    let opts = RunOptions {
        cache_dir: Some(dir.path().join("cache")),
        ..Default::default()
    };
    let summary = run(&plan, &opts).unwrap();
    assert!(summary.ok(), "{:?}", summary.failures().collect::<Vec<_>>());
    let report = |node: &str| -> Report {
        (*summary.node(node).unwrap().get::<Report>("report").unwrap()).clone()
    };
    let dist = report("distance");
    let smooth = report("smooth");
    // The curves hold a good share of the fandisk's vertices; the rest moved, but the
    // smoothed surface stays within 5 % of the diagonal of the input.
    let fixed = smooth.num("fixed_by_curves").unwrap();
    assert!(fixed > 500.0 && fixed < 6475.0, "fixed {fixed}");
    let h = dist.num("hausdorff_rel").unwrap();
    let m = dist.num("mean_rel").unwrap();
    assert!(h > 0.0 && h < 0.05, "hausdorff {h}");
    assert!(m > 0.0 && m < h, "mean {m}");
    for f in [
        "smoothed.ply",
        "curves.ply",
        "render.png",
        "distance.json",
        "smooth.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let back = load_mesh(out.join("smoothed.ply"), &LoadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.n_vertices(), 6475);
}
