//! Embedding the engine: load a pipeline from RON text, run it on a thread pool with an event
//! channel, and read typed output values. Run from the repository root:
//!
//! `cargo run --example embed_engine`

use std::path::Path;

use crestflow_flow::{load, run, Event, Graph, RunOptions};
use crestflow_geom::curvature::CurvatureField;

const PIPELINE: &str = r#"Graph(
    params: { "mesh": "../shared/data/meshes/cad/cgal_pinion.off" },
    nodes: {
        "load": (kind: "io.load_mesh", params: (path: "$mesh")),
        "curv": (kind: "curvature.polynomial", params: (rings: 2), inputs: { "mesh": "load.mesh" }),
    },
)"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Relative paths in the graph resolve against this folder (the repository root here).
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let graph = Graph::from_ron(PIPELINE, None, root)?;
    let registry = crestflow::registry();
    let plan = load(&graph, &registry, &[])?;

    // Events arrive on a crossbeam channel while the run goes on.
    let (tx, rx) = crossbeam_channel::unbounded();
    let cache = std::env::temp_dir().join("crestflow-example-cache");
    let opts = RunOptions {
        threads: 2,
        cache_dir: Some(cache),
        events: Some(tx),
        graph_id: Some("embed_engine".into()),
        ..Default::default()
    };
    let summary = std::thread::scope(|s| {
        let h = s.spawn(|| run(&plan, &opts));
        for e in rx.iter() {
            if let Event::NodeFinished {
                node, status, ms, ..
            } = &e
            {
                println!("{node}: {} in {ms:.1} ms", status.as_str());
            }
            if matches!(e, Event::RunFinished { .. }) {
                break;
            }
        }
        h.join().expect("the executor thread")
    })?;

    if !summary.ok() {
        for f in summary.failures() {
            eprintln!("{} failed: {:?}", f.name, f.error);
        }
        std::process::exit(1);
    }
    let field = summary
        .node("curv")
        .ok_or("no node curv")?
        .get::<CurvatureField>("field")?;
    let n = field.len();
    let mean: f64 = (0..n).map(|v| field.mean(v)).sum::<f64>() / n as f64;
    println!("{n} vertices, average mean curvature {mean:.4}");
    Ok(())
}
