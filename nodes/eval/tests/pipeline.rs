//! The evaluation as a pipeline: an analytic shape, both curvature estimators, their errors
//! graded by `eval.curvature_error`, run through the engine from a RON graph.

use crestflow_flow::{load, run, Graph, Registry, Report, RunOptions};

const GRAPH: &str = r#"
Graph(
    nodes: {
        "shape": (kind: "shapes.analytic",
                  params: (shape: Torus(major: 1.0, minor: 0.35), vertices: 6000, jitter: JITTER, seed: 3)),
        "poly":  (kind: "curvature.polynomial", params: (), inputs: { "mesh": "shape.mesh" }),
        "so":    (kind: "curvature.shape_operator", params: (), inputs: { "mesh": "shape.mesh" }),
        "err_poly": (kind: "eval.curvature_error", params: (shape: Torus(major: 1.0, minor: 0.35)),
                     inputs: { "mesh": "shape.mesh", "curvature": "poly.field" }),
        "err_so":   (kind: "eval.curvature_error", params: (shape: Torus(major: 1.0, minor: 0.35)),
                     inputs: { "mesh": "shape.mesh", "curvature": "so.field" }),
    },
)
"#;

fn registry() -> Registry {
    let mut reg = Registry::new();
    crestflow_nodes_shapes::register(&mut reg);
    crestflow_nodes_curvature::register(&mut reg);
    crestflow_nodes_eval::register(&mut reg);
    reg
}

#[test]
fn analytic_torus_pipeline_grades_both_estimators() {
    let dir = tempfile::tempdir().unwrap();
    let graph = Graph::from_ron(&GRAPH.replace("JITTER", "0.35"), None, dir.path()).unwrap();
    let reg = registry();
    let plan = load(&graph, &reg, &[]).unwrap();
    let opts = RunOptions {
        cache_dir: Some(dir.path().join("cache")),
        ..Default::default()
    };
    let summary = run(&plan, &opts).unwrap();
    assert!(summary.ok(), "{:?}", summary.failures().collect::<Vec<_>>());
    let report = |node: &str| -> Report {
        (*summary.node(node).unwrap().get::<Report>("report").unwrap()).clone()
    };
    let (p, s) = (report("err_poly"), report("err_so"));
    let kp = p.num("k_max.mean_rel").unwrap();
    let ks = s.num("k_max.mean_rel").unwrap();
    assert!(kp < 5e-3, "polynomial k_max.mean_rel {kp}");
    assert!(
        ks > 3.0 * kp && ks < 0.1,
        "shape operator k_max.mean_rel {ks}"
    );
    assert_eq!(p.text("method"), Some("curvature.polynomial"));
    assert_eq!(s.text("method"), Some("curvature.shape_operator"));

    // Same graph with a regular torus: the shape operator's error drops (regular sampling).
    let graph = Graph::from_ron(&GRAPH.replace("JITTER", "0.0"), None, dir.path()).unwrap();
    let plan = load(&graph, &reg, &[]).unwrap();
    let summary = run(&plan, &opts).unwrap();
    assert!(summary.ok());
    let s_regular = (*summary
        .node("err_so")
        .unwrap()
        .get::<Report>("report")
        .unwrap())
    .clone();
    assert!(s_regular.num("k_max.mean_rel").unwrap() < ks / 3.0);
}
