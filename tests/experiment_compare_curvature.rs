//! The shipped experiment graphs/compare-curvature.experiment.ron: every run loads with the
//! real node kinds; run in full, its table is consistent with the cache sharing it relies on
//! and a second run is all cached.

use std::path::{Path, PathBuf};

use crestflow::experiment::{expand, run_experiment, Cell, Experiment, ExperimentOptions, Table};
use crestflow_flow::graph::Graph;

fn exp_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/compare-curvature.experiment.ron")
}

#[test]
fn every_run_of_the_shipped_experiment_loads() {
    let exp = Experiment::from_file(&exp_file()).expect("the experiment parses");
    assert_eq!(exp.inputs.len(), 3);
    assert!(exp.inputs.iter().all(|p| p.is_file()));
    let base = Graph::from_file(&exp.graph).expect("the base graph parses");
    let runs = expand(&exp, &base).expect("expands");
    // 3 meshes × 2 estimators × 3 jitters.
    assert_eq!(runs.len(), 18);
    let reg = crestflow::registry();
    for r in &runs {
        crestflow_flow::load(&r.graph, &reg, &r.overrides)
            .unwrap_or_else(|e| panic!("run {} does not load:\n{e}", r.id));
    }
    let kinds: Vec<&str> = runs
        .iter()
        .map(|r| r.graph.find("curv").unwrap().kind.as_str())
        .collect();
    assert_eq!(kinds[0], "curvature.polynomial");
    assert_eq!(kinds[3], "curvature.shape_operator");
}

fn num(t: &Table, row: usize, col: &str) -> f64 {
    match t.get(row, col) {
        Some(Cell::Num(x)) => *x,
        other => panic!("row {row} column {col}: {other:?}"),
    }
}

#[test]
fn shipped_experiment_runs_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let exp = Experiment::from_file(&exp_file()).unwrap();
    let opts = ExperimentOptions {
        cache: Some(dir.path().join("cache")),
        out: Some(dir.path().join("out")),
        ..Default::default()
    };
    let reg = crestflow::registry();
    let r = run_experiment(&reg, &exp, &opts, &mut |_, _| {}).expect("runs");
    assert_eq!(r.failed(), 0, "{:#?}", r.runs);
    let t = Table::new(&r.runs);
    for row in 0..18 {
        // Rows: input (3) × variant (2) × jitter (3).
        let (input_block, variant_block) = (row / 6, (row / 3) % 2);
        // The torus branch does not read the mesh: the same figures for every input.
        let same_torus = variant_block * 3 + row % 3;
        assert_eq!(
            num(&t, row, "torus_error.k_max.mean_rel"),
            num(&t, same_torus, "torus_error.k_max.mean_rel")
        );
        // The mesh branch does not depend on the torus' jitter.
        let same_mesh = input_block * 6 + variant_block * 3;
        assert_eq!(
            num(&t, row, "ridges.total_length"),
            num(&t, same_mesh, "ridges.total_length")
        );
        assert!(num(&t, row, "ridges.curves") >= 1.0);
        assert!(num(&t, row, "curv.ms") > 0.0, "row {row}: no compute time");
    }
    // On the regular torus both estimators are accurate (relative k_max error < 5 %).
    assert!(num(&t, 0, "torus_error.k_max.mean_rel") < 0.05);
    assert!(num(&t, 3, "torus_error.k_max.mean_rel") < 0.05);
    assert_eq!(r.plots.len(), 1);

    let r2 = run_experiment(&reg, &exp, &opts, &mut |_, _| {}).unwrap();
    assert!(r2.runs.iter().all(|x| x.ran == 0 && x.status == "ok"));
}
